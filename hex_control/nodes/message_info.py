"""Subscriptions that read each message's info: the publisher's GID and sequence number.

- Lost messages: a gap in one publisher's sequence numbers is messages dropped on the way
  (a KEEP_LAST queue overflowed under a flood), counted as ``lost_<name>``.
- Command ownership (:mod:`hex_control.plant.command_owner`): with an owner given, only
  one publisher's messages reach the callback; the others are counted as ``foreign_<name>``.
"""

from __future__ import annotations

import inspect

from hex_control.plant.command_owner import CommandOwner

_KEPT_PUBLISHERS = 64  # sequence numbers remembered for this many publishers, the latest heard


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


def info_subscription(node, msg_type, topic: str, callback, qos, diagnostics, name: str,
                      owner_node: str | None = None) -> CommandOwner | None:
    """Subscribe ``callback(msg)`` to ``topic``, counting lost messages in ``diagnostics``; with
    ``owner_node`` ('' = the first publisher heard, or a node's fully qualified name) only
    the owner's messages are delivered. Returns the CommandOwner, or None without one."""

    def endpoints():
        return {bytes(info.endpoint_gid): info for info in node.get_publishers_info_by_topic(subscription.topic_name)}

    def node_of(gid: bytes):
        info = endpoints().get(gid)
        if info is None or info.node_name.startswith("_"):  # not yet told by discovery
            return None
        return info.node_namespace.rstrip("/") + "/" + info.node_name

    owner = None if owner_node is None else CommandOwner(node_of, lambda gid: gid in endpoints(), owner_node)
    gaps = LostMessages()

    def on_message(msg, info):
        publisher = info.get("publisher_gid")
        if publisher is None:  # this middleware cannot tell publishers apart
            callback(msg)
            return
        gid = bytes(publisher["data"])
        lost = gaps.lost(gid, info.get("publication_sequence_number"))
        if lost:
            diagnostics.count(f"lost_{name}", lost)
        if owner is None or owner.admit(gid):
            callback(msg)
        else:
            diagnostics.count(f"foreign_{name}")

    subscription = node.create_subscription(msg_type, topic, _WithMessageInfo(on_message), qos)
    return owner
