"""Who may command the plant: one publisher owns each command input at a time.

An industrial cell's drive takes commands from one master. DDS lets any process on the
domain publish on ``/plant/force_axis_command``; without DDS security (absent from these
wheels, docs/graph.md "Threat model") the plant can still refuse all but one publisher, told
apart by the GID each message carries in its message info:

- The owner is the first publisher heard, or, if one is configured, the first publisher
  of the node with that fully qualified name (e.g. ``/force_controller``).
- A publisher of the owner's node takes over (the owner restarted: same name, new GID).
- So does any publisher once the owner's is gone from the graph (stopped for good; a
  killed process lingers until DDS's liveliness lease expires).
- Every other publisher's messages are refused; the caller counts them.

The ROS graph is behind two callables, so the rule is testable without ROS:
``node_of(gid)`` gives a publisher's fully qualified node name (None while discovery has
not told us) and ``publishing(gid)`` whether that publisher is still on the topic.
"""

from __future__ import annotations

from typing import Callable, Optional


class CommandOwner:
    """Admit the messages of one publisher (GIDs as bytes)."""

    def __init__(self, node_of: Callable[[bytes], Optional[str]], publishing: Callable[[bytes], bool],
                 owner_node: str = ""):
        if owner_node and not owner_node.startswith("/"):
            raise ValueError(f"owner node must be a fully qualified name like /force_controller, got {owner_node!r}")
        self._node_of, self._publishing = node_of, publishing
        self.owner_node = owner_node or None  # known once configured or first asked
        self._configured = bool(owner_node)
        self.owner_gid: Optional[bytes] = None
        self.takeovers = 0  # owner changes after the first

    def admit(self, gid: bytes) -> bool:
        """May this publisher's message command the plant?"""
        if gid == self.owner_gid:
            return True
        if self.owner_gid is None and not self._configured:
            self.owner_gid = gid
            return True
        node = self._node_of(gid)
        if self.owner_node is None and self.owner_gid is not None:
            self.owner_node = self._node_of(self.owner_gid)
        same_node = node is not None and node == self.owner_node
        owner_gone = self.owner_gid is not None and not self._publishing(self.owner_gid)
        if same_node or (owner_gone and not self._configured):
            if self.owner_gid is not None:
                self.takeovers += 1
            self.owner_gid = gid
            if not self._configured:
                self.owner_node = node
            return True
        return False
