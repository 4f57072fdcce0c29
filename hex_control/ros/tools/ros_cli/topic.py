"""``hexctl topic list|info|echo|hz|pub``: rclpy's graph API finds topics, their types and
endpoints, the generated classes' own introspection (:mod:`hex_control.ros.infra.messages`)
prints and fills messages.

Echo and hz subscribe as ros2cli does: first wait for the topic's publishers, then take
their QoS (best effort if one of them is, transient local only if all are, so a latched
topic's last message arrives). Choosing before the publishers are discovered subscribed
volatile to latched topics and waited forever. ``--timeout`` bounds everything up to the
first message: discovery, matching, the message itself.
"""

from __future__ import annotations

import math
import sys
import time

import rclpy
import yaml
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from hex_control.ros.infra.messages import fill_message, get_field, message_class, to_primitive
from hex_control.ros.tools.ros_cli import daemon
from hex_control.ros.tools.ros_cli.common import (
    VerbError,
    absolute,
    cli_node,
    hidden,
    qos_from_options,
    settle_graph,
    spin_for,
    yaml_mapping,
)

#: when the publishers found first are all transient local, wait this long (s) for more of
#: them before subscribing so: a volatile one found later would not match the subscription
MORE_PUBLISHERS_S = 0.1


def _publishers(node, topic: str, end: float, timeout_s: float) -> list:
    """The topic's publishers' endpoint information, as soon as there are some; VerbError
    (2) at ``end``."""
    while not (publishers := node.get_publishers_info_by_topic(topic)):
        if time.monotonic() >= end:
            raise VerbError(f"no publisher of {topic} within {timeout_s:g} s "
                            "(is it running, with the same ROS_DOMAIN_ID? hexctl topic list)")
        spin_for(node, 0.02)
    settled = time.monotonic() + MORE_PUBLISHERS_S
    while publishers_qos(publishers).durability == DurabilityPolicy.TRANSIENT_LOCAL \
            and time.monotonic() < min(settled, end):
        spin_for(node, 0.02)
        more = node.get_publishers_info_by_topic(topic)
        if len(more) != len(publishers):
            publishers, settled = more, time.monotonic() + MORE_PUBLISHERS_S
    return publishers


def publishers_qos(publishers, depth: int = 100) -> QoSProfile:
    """A subscription profile every one of ``publishers`` (endpoint infos) matches and that
    gets a latched publisher's stored messages: best effort if any publisher is, transient
    local if all are (ros2cli's rule)."""
    qos = QoSProfile(depth=depth)
    if any(p.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers):
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    if publishers and all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers):
        qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return qos


def _subscribe_class_and_qos(node, topic: str, end: float, timeout_s: float, durability=None, *, reliability=None,
                             depth=None):
    publishers = _publishers(node, topic, end, timeout_s)
    type_name = publishers[0].topic_type
    try:
        cls = message_class(type_name)
    except ValueError as exc:
        raise VerbError(f"{topic}: {exc}") from None
    return cls, qos_from_options(durability, reliability, depth, publishers_qos(publishers))


def _subscriptions(node, topic: str) -> list:
    """The topic's subscriptions but this verb's and the daemon's (it holds latched topics)."""
    own = node.get_fully_qualified_name()
    return [s for s in node.get_subscriptions_info_by_topic(topic)
            if f"{s.node_namespace.rstrip('/')}/{s.node_name}" != own and s.node_name != daemon.NODE_NAME]


def topic_list(show_types: bool, wait_s: float, include_hidden: bool = False) -> int:
    """Every topic (``show_types``: with its publishers and subscriptions counted), once this
    verb's own discovery has settled (without -t, hexctl asks the daemon first:
    :func:`.daemon.list_verb`)."""
    with cli_node("hexctl_topic_list") as node:
        settle_graph(node, wait_s)
        for name, types in sorted(node.get_topic_names_and_types()):
            if hidden(name) and not include_hidden:
                continue
            if show_types:
                pubs, subs = node.count_publishers(name), len(_subscriptions(node, name))
                print(f"{name} [{', '.join(types)}] publishers: {pubs}, subscribers: {subs}")
            else:
                print(name)
    return 0


def _duration(value) -> str:
    """A QoS duration as ros2cli prints it: unset (0) and DDS's infinity (about 68 years
    and more) as Infinite."""
    return "Infinite" if value.nanoseconds == 0 or value.nanoseconds > 10**18 else f"{value.nanoseconds} nanoseconds"


def _endpoint_lines(info) -> list[str]:
    qos = info.qos_profile
    return [f"Node name: {info.node_name}", f"Node namespace: {info.node_namespace}",
            f"Topic type: {info.topic_type}", f"Endpoint type: {info.endpoint_type.name}",
            f"GID: {'.'.join(f'{b:02x}' for b in info.endpoint_gid)}",
            "QoS profile:", f"  Reliability: {qos.reliability.name}",
            f"  History (Depth): {qos.history.name} ({qos.depth})", f"  Durability: {qos.durability.name}",
            f"  Lifespan: {_duration(qos.lifespan)}", f"  Deadline: {_duration(qos.deadline)}",
            f"  Liveliness: {qos.liveliness.name}",
            f"  Liveliness lease duration: {_duration(qos.liveliness_lease_duration)}"]


def topic_info(topic: str, verbose: bool, wait_s: float) -> int:
    """``ros2 topic info [-v]``: the type and the endpoints' counts; with ``verbose`` each
    publisher and subscription with its node and QoS."""
    topic = absolute(topic)
    with cli_node("hexctl_topic_info") as node:
        settle_graph(node, wait_s)
        types = dict(node.get_topic_names_and_types()).get(topic)
        if not types:
            raise VerbError(f"unknown topic {topic} (hexctl topic list)")
        publishers = node.get_publishers_info_by_topic(topic)
        subscriptions = _subscriptions(node, topic)
        print(f"Type: {', '.join(types)}\n")
        for title, endpoints in (("Publisher", publishers), ("Subscription", subscriptions)):
            print(f"{title} count: {len(endpoints)}\n")
            if verbose:
                for info in endpoints:
                    print("\n".join(_endpoint_lines(info)) + "\n")
    return 0


def message_yaml(msg, field: str) -> str:
    """``field`` of ``msg`` ('' the whole message) as echo prints it: YAML, a lone value without
    YAML's end-of-document marker (as ros2 topic echo prints it)."""
    text = yaml.safe_dump(to_primitive(get_field(msg, field)), sort_keys=False, default_flow_style=False)
    return text.removesuffix("\n...\n").rstrip()


def _print_message(msg, field: str) -> None:
    print(message_yaml(msg, field))
    print("---", flush=True)


def topic_echo(topic: str, once: bool, count: int, field: str, timeout_s: float, *, durability=None, reliability=None,
               depth=None) -> int:
    """Print messages from a node of its own (hexctl asks the daemon first:
    :func:`.daemon.echo_verb`); ``timeout_s`` bounds the wait for the first one (discovery
    included): none by then is exit 2."""
    topic = absolute(topic)
    end = time.monotonic() + timeout_s
    if depth is not None and depth < 1:
        raise VerbError(f"--qos-depth must be >= 1, got {depth}")
    limit = 1 if once else count
    with cli_node("hexctl_topic_echo") as node:
        cls, qos = _subscribe_class_and_qos(node, topic, end, timeout_s, durability, reliability=reliability,
                                            depth=depth)
        received = []

        def on_message(msg):
            _print_message(msg, field)
            received.append(1)

        node.create_subscription(cls, topic, on_message, qos)
        while rclpy.ok() and (limit <= 0 or len(received) < limit):
            if not received and time.monotonic() >= end:
                raise VerbError(f"no message on {topic} within {timeout_s:g} s")
            rclpy.spin_once(node, timeout_sec=0.05)
    return 0


def topic_hz(topic: str, window: int, duration_s: float, timeout_s: float) -> int:
    topic = absolute(topic)
    end = time.monotonic() + timeout_s
    with cli_node("hexctl_topic_hz") as node:
        cls, qos = _subscribe_class_and_qos(node, topic, end, timeout_s)
        arrivals: list[float] = []
        node.create_subscription(cls, topic, lambda _m: arrivals.append(time.monotonic()), qos)
        # the window starts at the first message: discovery on a busy machine takes its own time
        start = None
        while rclpy.ok() and (duration_s <= 0 or start is None or time.monotonic() - start < duration_s):
            rclpy.spin_once(node, timeout_sec=0.05)
            if start is None:
                if arrivals:
                    start = arrivals[0]
                    next_report = start + 1.0
                elif time.monotonic() > end:
                    raise VerbError(f"no message on {topic} within {timeout_s:g} s")
                continue
            if time.monotonic() >= next_report:
                next_report += 1.0
                recent = arrivals[-window:]
                if len(recent) < 2:
                    print("no new messages", flush=True)
                    continue
                periods = [b - a for a, b in zip(recent, recent[1:])]
                mean = sum(periods) / len(periods)
                std = math.sqrt(sum((p - mean) ** 2 for p in periods) / len(periods))
                print(f"average rate: {1.0 / mean:.3f} Hz\n"
                      f"\tmin: {min(periods):.4f} s max: {max(periods):.4f} s "
                      f"std dev: {std:.5f} s window: {len(recent)}", flush=True)
    return 0


def topic_pub(topic: str, type_name: str, values: str, rate_hz: float, times: int, *, wait_s: float,
              durability=None, reliability=None, depth=None) -> int:
    topic = absolute(topic)
    try:
        cls = message_class(type_name)
    except ValueError as exc:
        raise VerbError(str(exc)) from None
    try:
        msg = fill_message(cls(), yaml_mapping(values, "the message"))
    except (TypeError, ValueError, AssertionError) as exc:
        raise VerbError(f"cannot build {type_name} from {values!r}: {exc}") from None
    qos = qos_from_options(durability, reliability, depth)
    with cli_node("hexctl_topic_pub") as node:
        publisher = node.create_publisher(cls, topic, qos)
        end = time.monotonic() + wait_s  # let subscribers match this writer first
        while publisher.get_subscription_count() == 0 and time.monotonic() < end:
            spin_for(node, 0.05)
        if publisher.get_subscription_count():
            # this writer can see a reader before the reader sees it: samples sent in between are lost
            spin_for(node, 0.5)
        else:
            print(f"hexctl: no subscriber on {topic} after {wait_s:g} s; publishing anyway", file=sys.stderr)
        sent = 0
        while rclpy.ok() and (times <= 0 or sent < times):
            publisher.publish(msg)
            sent += 1
            print(f"publishing #{sent}: {to_primitive(msg)}", flush=True)
            if times <= 0 or sent < times:
                spin_for(node, 1.0 / rate_hz)
        spin_for(node, 0.2)  # let the last message leave before shutdown
    return 0
