"""Subscriptions that read each message's info: the publisher's GID and sequence number.

- Lost messages: a gap in one publisher's sequence numbers is messages dropped on the way
  (a KEEP_LAST queue overflowed under a flood), counted as ``lost_<name>``.
- Authority by configuration (:mod:`hex_control.safety.command_owner`): with owners given,
  only their publishers' messages reach the callback; the others are counted as
  ``foreign_<name>`` and named in a WARN for ``FOREIGN_WARN_S``. A message whose publisher
  discovery has not named yet waits (wall time) until it is, so a latched command that beat
  the news of its sender is not lost.
"""

from __future__ import annotations

import inspect
import time

from rclpy.qos import DurabilityPolicy

from hex_control.ros.infra.runtime import wall_timer
from hex_control.safety.command_owner import CommandOwner, OwnedInput, resolve_owner_nodes

_KEPT_PUBLISHERS = 64  # sequence numbers remembered for this many publishers, the latest heard
FOREIGN_WARN_S = 10.0  # a refused publisher keeps the WARN this long (wall s) after its last message
_RETRY_S = 0.05  # how often (wall s) messages of a publisher not yet named are offered again


class _WithMessageInfo:
    """A callback rclpy hands the message info to, on either executor.

    rclpy picks the calling convention from the callback's signature: two parameters get
    ``(msg, info)``. The SingleThreadedExecutor then calls ``callback(msg, info)``, but the
    EventsExecutor of these wheels calls ``callback((msg, info))`` (events_executor.cpp,
    HandleSubscriptionReady), which a plain two-argument function cannot take."""

    __signature__ = inspect.Signature([inspect.Parameter(name, inspect.Parameter.POSITIONAL_ONLY)
                                       for name in ("msg", "info")])

    def __init__(self, callback):
        self._callback = callback

    def __call__(self, *args):
        msg, info = args if len(args) == 2 else args[0]
        self._callback(msg, info)


class LostMessages:
    """Messages a subscription never got, from the gaps in each publisher's sequence numbers."""

    def __init__(self):
        self._last: dict[bytes, int] = {}  # publisher GID -> its latest sequence number

    def lost(self, gid: bytes, sequence: int | None) -> int:
        if sequence is None:
            return 0
        last = self._last.pop(gid, None)
        self._last[gid] = sequence
        if len(self._last) > _KEPT_PUBLISHERS:
            del self._last[next(iter(self._last))]
        return 0 if last is None or sequence <= last else sequence - last - 1


def full_name(info) -> str:
    """The fully qualified node name of an endpoint's info (``/cell2/plant``)."""
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


def owner_publishes(node, topic: str, owner_node: str, *, latched: bool = False) -> bool:
    """Does ``owner_node`` (resolved as ``info_subscription``'s owners are) publish ``topic``
    (with ``latched``, keeping its last message for late joiners: what a transient-local
    reader matches)? Liveness by the graph that another process on the topic cannot fake."""
    [owner] = resolve_owner_nodes(owner_node, node.get_namespace())
    return any(full_name(info) == owner
               and (not latched or info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL)
               for info in node.get_publishers_info_by_topic(node.resolve_topic_name(topic)))


def foreign_publishers(node, topic: str, owner_node: str) -> list[str]:
    """The publishers of ``topic`` besides ``owner_node`` (resolved as ``info_subscription``'s
    owners are), by the names discovery gives them (one not yet named is left out)."""
    [owner] = resolve_owner_nodes(owner_node, node.get_namespace())
    return sorted({full_name(info) for info in node.get_publishers_info_by_topic(node.resolve_topic_name(topic))
                   if not info.node_name.startswith("_")} - {owner})


def input_topic_name(topic: str, relative_to: str, namespace: str) -> str:
    """The name to subscribe ``topic`` by: as given (ROS resolves a relative name in the node's
    ``namespace``), or with ``relative_to`` 'parent' a relative name made absolute in the
    namespace that holds ``namespace`` (/cell2/load_predictor -> /cell2/<topic>; the root's
    parent is the root). ValueError for a private (~) name there: it has no parent reading."""
    if relative_to == "node" or topic.startswith("/"):
        return topic
    if relative_to != "parent":
        raise ValueError(f"input_namespace {relative_to!r} is not 'node' or 'parent'")
    if topic.startswith("~"):
        raise ValueError(f"input_topic {topic!r} is private to the node: input_namespace 'parent' cannot place it")
    return namespace.rstrip("/").rpartition("/")[0] + "/" + topic


def info_subscription(node, msg_type, topic: str, callback, qos, *, diagnostics, name: str,
                      owner_node: str | tuple[str, ...] | None = None,
                      with_source: bool = False, wait_depth: int = 16) -> CommandOwner | None:
    """Subscribe ``callback(msg)`` to ``topic``, counting lost messages in ``diagnostics``.

    ``owner_node``: None = every publisher; '' = the first publisher heard (hand use);
    otherwise the node name(s) whose publishers alone are obeyed, relative names (``plant``)
    resolved in this node's namespace, several as a tuple or comma-separated.
    ``with_source`` (with owners): ``callback(msg, source)``, source the sender's node name,
    relative to this node's namespace when inside it (``pass_planner``). ``wait_depth``:
    messages per publisher held until discovery names it (a late joiner of a kept topic
    receives its whole history at once). Returns the CommandOwner, or None without one."""

    def endpoints():
        return {bytes(info.endpoint_gid): info for info in node.get_publishers_info_by_topic(subscription.topic_name)}

    def node_of(gid: bytes):
        info = endpoints().get(gid)
        if info is None or info.node_name.startswith("_"):  # not yet told by discovery
            return None
        return full_name(info)

    owners = resolve_owner_nodes(owner_node, node.get_namespace())
    if with_source and owners is None:
        raise ValueError(f"{topic}: the source of a message is known only with owners")
    owner = None if owners is None else CommandOwner(node_of, lambda gid: gid in endpoints(), owners)
    gate = None if owner is None else OwnedInput(owner, depth=wait_depth)
    gaps = LostMessages()

    def settle(deliver: list, refused: int) -> None:
        if refused:
            diagnostics.count(f"foreign_{name}", refused)
            sender = owner.last_refused or "an unnamed publisher"
            obeyed = ", ".join(owner.owner_nodes) or owner.owner_node or "the first publisher"
            diagnostics.fault(f"foreign_{name}", f"{name} from {sender} refused (obeys {obeyed})",
                              hold_s=FOREIGN_WARN_S)
        for gid, msg in deliver:
            if with_source:
                callback(msg, source(gid))
            else:
                callback(msg)

    def source(gid: bytes) -> str | None:
        full = owner.node_name(gid)
        base = node.get_namespace().rstrip("/") + "/"
        return full[len(base):] if full is not None and full.startswith(base) else full

    def on_message(msg, info):
        publisher = info.get("publisher_gid")
        if publisher is None:  # this middleware cannot tell publishers apart
            callback(msg)
            return
        gid = bytes(publisher["data"])
        lost = gaps.lost(gid, info.get("publication_sequence_number"))
        if lost:
            diagnostics.count(f"lost_{name}", lost)
        if gate is None:
            callback(msg)
        else:
            settle(*gate.offer(gid, msg, time.monotonic()))
            if gate.waiting:
                retry_timer.reset()

    def retry():
        settle(*gate.retry(time.monotonic()))
        if not gate.waiting:
            retry_timer.cancel()

    subscription = node.create_subscription(msg_type, topic, _WithMessageInfo(on_message), qos)
    if gate is not None:  # runs only while a message waits for its publisher's name
        retry_timer = wall_timer(node, _RETRY_S, retry)
        retry_timer.cancel()
    return owner
