"""``hexctl topic list|echo|hz|pub``: rclpy's graph API finds topics and their types, the
generated classes' own introspection (:mod:`hex_control.nodes.messages`) prints and fills
messages. Echo matches the publishers' QoS (latched ones too) unless told otherwise.
"""

from __future__ import annotations

import math
import sys
import time

import rclpy
import yaml
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from hex_control.nodes.messages import fill_message, get_field, message_class, to_primitive
from hex_control.nodes.ros_cli.common import VerbError, absolute, cli_node, qos_from_options, spin_for, yaml_mapping


def _topic_type(node, topic: str, timeout_s: float) -> str:
    end = time.monotonic() + timeout_s
    while True:
        types = dict(node.get_topic_names_and_types()).get(topic)
        if types:
            return types[0]
        if time.monotonic() >= end:
            raise VerbError(f"topic {topic!r} not found within {timeout_s:g} s "
                            "(is the publisher running, with the same ROS_DOMAIN_ID?)")
        spin_for(node, 0.1)


def _subscription_qos(node, topic: str) -> QoSProfile:
    """A profile compatible with every current publisher (latched ones included)."""
    qos = QoSProfile(depth=100)
    publishers = node.get_publishers_info_by_topic(topic)
    if any(p.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers):
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    if publishers and all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers):
        qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return qos


def topic_list(show_types: bool, wait_s: float) -> int:
    with cli_node("hexctl_topic_list") as node:
        spin_for(node, wait_s)  # let discovery fill the graph
        for name, types in sorted(node.get_topic_names_and_types()):
            if show_types:
                pubs, subs = node.count_publishers(name), node.count_subscribers(name)
                print(f"{name} [{', '.join(types)}] publishers: {pubs}, subscribers: {subs}")
            else:
                print(name)
    return 0


def topic_echo(topic: str, once: bool, count: int, field: str, timeout_s: float, durability=None, reliability=None,
               depth=None) -> int:
    topic = absolute(topic)
    with cli_node("hexctl_topic_echo") as node:
        cls = message_class(_topic_type(node, topic, timeout_s))
        qos = qos_from_options(durability, reliability, depth, _subscription_qos(node, topic))
        received = []

        def on_message(msg):
            value = get_field(msg, field) if field else msg
            print(yaml.safe_dump(to_primitive(value), sort_keys=False, default_flow_style=False).rstrip())
            print("---", flush=True)
            received.append(1)

        node.create_subscription(cls, topic, on_message, qos)
        limit = 1 if once else count
        while rclpy.ok() and (limit <= 0 or len(received) < limit):
            rclpy.spin_once(node, timeout_sec=0.1)
    return 0


def topic_hz(topic: str, window: int, duration_s: float, timeout_s: float) -> int:
    topic = absolute(topic)
    with cli_node("hexctl_topic_hz") as node:
        cls = message_class(_topic_type(node, topic, timeout_s))
        arrivals: list[float] = []
        node.create_subscription(cls, topic, lambda _m: arrivals.append(time.monotonic()),
                                 _subscription_qos(node, topic))
        # the window starts at the first message: discovery on a busy machine takes its own time
        subscribed, start = time.monotonic(), None
        while rclpy.ok() and (duration_s <= 0 or start is None or time.monotonic() - start < duration_s):
            rclpy.spin_once(node, timeout_sec=0.05)
            if start is None:
                if arrivals:
                    start = arrivals[0]
                    next_report = start + 1.0
                elif time.monotonic() - subscribed > timeout_s:
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


def topic_pub(topic: str, type_name: str, values: str, rate_hz: float, times: int, wait_s: float,
              durability=None, reliability=None, depth=None) -> int:
    topic = absolute(topic)
    cls = message_class(type_name)
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
