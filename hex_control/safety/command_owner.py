"""Who may command an input: the publishers of the nodes configured for it.

An industrial cell's drive takes commands from one master. DDS lets any process on the
domain publish on any topic; without DDS security (absent from these wheels,
docs/graph.md "Threat model") a subscriber can still refuse all but the publishers of
the nodes it is configured to obey, told apart by the GID each message carries in its
message info and the node name discovery gives for that GID:

- Configured (the default of every command input in the graph the project starts): a
  publisher is obeyed when its node's fully qualified name is one of ``owner_nodes``
  (e.g. ``("/cell2/plant", "/cell2/pass_planner")``). A restarted owner is obeyed at once
  (same name, new GID: counted in ``takeovers``); nobody else is, whether it spoke first,
  alone, or after the owner left.
- First heard (``owner_nodes`` empty; for hand use only): the first publisher heard owns
  the input; a publisher of the owner's node takes over, and so does any publisher once the
  owner's is gone from the graph.

A publisher discovery has not yet named is ``UNKNOWN``: the caller holds its messages and
asks again (a latched command must not be lost because it beat the graph's news of its
sender), and refuses them if the name never comes.

The ROS graph is behind two callables, so the rule is testable without ROS:
``node_of(gid)`` gives a publisher's fully qualified node name (None while discovery has
not told us) and ``publishing(gid)`` whether that publisher is still on the topic.
"""

from __future__ import annotations

import enum
from typing import Callable, Iterable, Optional

_KEPT_NAMES = 256  # GIDs whose node name is remembered (a name never changes for a GID)


class Verdict(enum.Enum):
    ADMIT = "admit"
    REFUSE = "refuse"
    UNKNOWN = "unknown"  # discovery has not named the publisher yet


class CommandOwner:
    """Admit the messages of the configured nodes' publishers (GIDs as bytes)."""

    def __init__(self, node_of: Callable[[bytes], Optional[str]], publishing: Callable[[bytes], bool],
                 owner_nodes: str | Iterable[str] = ()):
        names = (owner_nodes,) if isinstance(owner_nodes, str) else tuple(owner_nodes)
        names = tuple(name for name in names if name)
        for name in names:
            if not name.startswith("/"):
                raise ValueError(f"owner node must be a fully qualified name like /force_controller, got {name!r}")
        self._node_of, self._publishing = node_of, publishing
        self.owner_nodes = names  # configured; empty = first heard
        self.owner_node: Optional[str] = names[0] if len(names) == 1 else None  # first heard: once known
        self.owner_gid: Optional[bytes] = None  # the latest admitted publisher
        self.takeovers = 0  # admitted publisher changes after the first
        self.last_refused: Optional[str] = None  # the node name of the latest refused publisher
        self._names: dict[bytes, str] = {}

    def _name(self, gid: bytes) -> Optional[str]:
        name = self._names.get(gid)
        if name is None:
            name = self._node_of(gid)
            if name is not None:
                if len(self._names) >= _KEPT_NAMES:
                    del self._names[next(iter(self._names))]
                self._names[gid] = name
        return name

    def _take(self, gid: bytes) -> Verdict:
        if self.owner_gid is not None and gid != self.owner_gid:
            self.takeovers += 1
        self.owner_gid = gid
        return Verdict.ADMIT

    def verdict(self, gid: bytes) -> Verdict:
        """May this publisher's message command the input now?"""
        if gid == self.owner_gid:
            return Verdict.ADMIT
        if self.owner_nodes:
            node = self._name(gid)
            if node is None:
                return Verdict.UNKNOWN
            if node in self.owner_nodes:
                return self._take(gid)
            self.last_refused = node
            return Verdict.REFUSE
        return self._first_heard(gid)

    def _first_heard(self, gid: bytes) -> Verdict:
        if self.owner_gid is None:
            return self._take(gid)
        if self.owner_node is None:
            self.owner_node = self._name(self.owner_gid)
        node = self._name(gid)
        if (node is not None and node == self.owner_node) or not self._publishing(self.owner_gid):
            self.owner_node = node
            return self._take(gid)
        self.last_refused = node
        return Verdict.UNKNOWN if node is None else Verdict.REFUSE

    def node_name(self, gid: bytes) -> Optional[str]:
        """The fully qualified node name of a publisher, None while discovery has not told it."""
        return self._name(gid)

    def admit(self, gid: bytes) -> bool:
        """True only for an admitted publisher (an unnamed one is not, yet)."""
        return self.verdict(gid) is Verdict.ADMIT


def resolve_owner_nodes(owner_nodes: str | Iterable[str] | None, namespace: str) -> tuple[str, ...] | None:
    """Fully qualified owner names: a relative name (``plant``) is resolved in ``namespace``
    (``/cell2`` -> ``/cell2/plant``), an absolute one kept; a comma-separated string is
    several names; '' is () (first heard); None stays None (no ownership check)."""
    if owner_nodes is None:
        return None
    names = owner_nodes.split(",") if isinstance(owner_nodes, str) else list(owner_nodes)
    base = namespace.rstrip("/")
    resolved = []
    for name in (n.strip() for n in names):
        if not name:
            continue
        if any(part == "" for part in name.strip("/").split("/")) or name.startswith("~"):
            raise ValueError(f"owner node {name!r} is not a node name")
        resolved.append(name if name.startswith("/") else f"{base}/{name}")
    return tuple(resolved)


class OwnedInput:
    """One input's gate: messages of admitted publishers pass in order, others are refused,
    and those of a publisher not yet named by discovery wait (at most ``hold_s`` of the
    caller's clock, ``depth`` of them per publisher, ``publishers`` publishers) until it is.

    ``offer`` and ``retry`` return the ``(gid, message)`` pairs to deliver now and how many
    were refused (a message pushed out of a full wait is refused too: it was never admitted)."""

    def __init__(self, owner: CommandOwner, hold_s: float = 5.0, depth: int = 16, publishers: int = 8):
        if hold_s <= 0 or depth < 1 or publishers < 1:
            raise ValueError(f"hold_s {hold_s} must be > 0, depth {depth} and publishers {publishers} >= 1")
        self.owner, self.hold_s, self.depth, self.publishers = owner, hold_s, depth, publishers
        self._waiting: dict[bytes, tuple[float, list]] = {}  # gid -> (first wait s, messages)

    @property
    def waiting(self) -> int:
        return sum(len(messages) for _, messages in self._waiting.values())

    def offer(self, gid: bytes, message, now_s: float) -> tuple[list, int]:
        verdict = self.owner.verdict(gid)
        since, held = self._waiting.pop(gid, (now_s, []))
        held.append(message)
        if verdict is Verdict.ADMIT:
            return [(gid, m) for m in held], 0
        if verdict is Verdict.REFUSE:
            return [], len(held)
        refused = max(0, len(held) - self.depth)
        self._waiting[gid] = (since, held[refused:])
        if len(self._waiting) > self.publishers:  # a flood of unnamed publishers: the oldest wait goes
            refused += len(self._waiting.pop(next(iter(self._waiting)))[1])
        return [], refused

    def retry(self, now_s: float) -> tuple[list, int]:
        """Ask again for the waiting publishers (discovery may have named them)."""
        deliver, refused = [], 0
        for gid, (since, held) in list(self._waiting.items()):
            verdict = self.owner.verdict(gid)
            if verdict is Verdict.UNKNOWN and now_s - since < self.hold_s:
                continue
            del self._waiting[gid]
            if verdict is Verdict.ADMIT:
                deliver.extend((gid, m) for m in held)
            else:
                refused += len(held)
        return deliver, refused
