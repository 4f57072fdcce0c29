"""What every ``hexctl`` ROS verb shares: a short-lived node whose Ctrl-C ends the verb
quietly, QoS from the command line, ros2cli-style YAML arguments, and exit codes.

Exit codes: 0 done; 1 the graph said no (a service failed, a goal was rejected or
aborted); 2 bad input or nothing to talk to within the timeout; 130 interrupted.
"""

from __future__ import annotations

import importlib
import re
import time
from contextlib import contextmanager

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from hex_control.ros.infra.messages import fill_message
from hex_control.ros.tools.ros_cli.daemon import VerbError, hidden  # noqa: F401 - re-exported (.daemon: no rclpy)

DURABILITY = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL}
RELIABILITY = {"reliable": ReliabilityPolicy.RELIABLE, "best_effort": ReliabilityPolicy.BEST_EFFORT}


@contextmanager
def cli_node(name: str):
    """A node for one verb. Ctrl-C shuts rclpy down; the verb's spin then ends with
    ExternalShutdownException, which ends the verb (no traceback)."""
    rclpy.init(args=None)
    node = rclpy.create_node(name, start_parameter_services=False)
    try:
        yield node
    except (ExternalShutdownException, KeyboardInterrupt):
        raise VerbError("interrupted", 130) from None
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def spin_for(node, seconds: float) -> None:
    end = time.monotonic() + seconds
    while rclpy.ok() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=min(0.05, max(end - time.monotonic(), 0.0)))


#: a graph listing waits at least this long (s): Fast DDS announces each participant again
#: every 3 s (leaseDuration_announcementperiod), and one that does not answer a new
#: participant's start-up announcements at once is found by its next one (measured here:
#: participants found 0.1 to 4.2 s after start-up, most at once, some 3 s after the rest;
#: at 3.0 s a suite run beside a loaded machine missed one participant in 20 listings), so
#: the announcement period plus the latest seen past it, with a margin
MIN_DISCOVERY_S = 4.5
#: ... and until nothing new has been discovered for this long (s) ...
GRAPH_QUIET_S = 0.6
#: ... or this share of the time discovery took until its last change, if longer: how long
#: discovery takes depends on the load (at a load of 20 on 2 cores, three participants were
#: found together 1.6 to 2.6 s after start-up)
GRAPH_QUIET_SHARE = 1.0
#: a node seen without endpoints counts as still being discovered for at most this long (s)
#: (a node can have none: rosout disabled)
INCOMPLETE_NODE_S = 3.0


def graph_snapshot(node) -> tuple[tuple, bool]:
    """(what discovery has found so far: the nodes with the topics and services of each, and
    every topic's and service's name and types; whether every node found has endpoints).
    A node seen without any (its participant is known, its endpoints are not yet) makes
    the snapshot incomplete: every rclpy/rclcpp node publishes /rosout."""
    nodes, complete = [], True
    for name, namespace in sorted(node.get_node_names_and_namespaces()):
        try:
            entry = (namespace, name) + tuple(
                tuple(sorted(n for n, _ in query(name, namespace)))
                for query in (node.get_publisher_names_and_types_by_node,
                              node.get_subscriber_names_and_types_by_node,
                              node.get_service_names_and_types_by_node))
        except Exception:  # noqa: BLE001 - gone between two calls (rclpy's NodeNameNonExistentError)
            complete = False
            continue
        complete = complete and bool(entry[2])
        nodes.append(entry)
    topics = tuple(sorted((n, tuple(types)) for n, types in node.get_topic_names_and_types()))
    services = tuple(sorted((n, tuple(types)) for n, types in node.get_service_names_and_types()))
    return (tuple(nodes), topics, services), complete


def settle_graph(node, max_wait_s: float, quiet_s: float = GRAPH_QUIET_S) -> None:
    """Spin until discovery has settled: MIN_DISCOVERY_S passed, the graph unchanged
    (:func:`graph_snapshot`) for ``quiet_s`` or GRAPH_QUIET_SHARE of the time until its last
    change, whichever is longer, and complete (or incomplete for longer than
    INCOMPLETE_NODE_S); at most ``max_wait_s``. A fixed wait either wastes time or cuts
    discovery short (a 1 s wait listed 2, 15 and 23 of 29 topics on a loaded machine)."""
    start = time.monotonic()
    end = start + max_wait_s
    last, changed, incomplete_since = None, start, None
    while rclpy.ok():
        now = time.monotonic()
        current, complete = graph_snapshot(node)
        if complete:
            incomplete_since = None
        elif incomplete_since is None:
            incomplete_since = now
        waiting_for_endpoints = incomplete_since is not None and now - incomplete_since < INCOMPLETE_NODE_S
        if current != last or waiting_for_endpoints:
            last, changed = current, now
        elif now - start >= MIN_DISCOVERY_S and now - changed >= max(quiet_s, GRAPH_QUIET_SHARE * (changed - start)):
            return
        if now >= end:
            return
        rclpy.spin_once(node, timeout_sec=min(0.1, max(end - now, 0.0)))


def spin_until(node, condition, timeout_s: float, what: str):
    """Spin until ``condition()`` is truthy; VerbError (2) after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while not (value := condition()):
        if time.monotonic() >= end:
            raise VerbError(f"no {what} within {timeout_s:g} s (is it running, with the same ROS_DOMAIN_ID?)")
        rclpy.spin_once(node, timeout_sec=0.05)
    return value


def qos_from_options(durability: str | None, reliability: str | None, depth: int | None,
                     default: QoSProfile | None = None) -> QoSProfile:
    """``default`` (or depth 10, reliable, volatile) with the options given on top."""
    qos = default or QoSProfile(depth=10)
    if durability is not None:
        qos.durability = DURABILITY[durability]
    if reliability is not None:
        qos.reliability = RELIABILITY[reliability]
    if depth is not None:
        if depth < 1:
            raise VerbError(f"--qos-depth must be >= 1, got {depth}")
        qos.depth = depth
    return qos


def yaml_mapping(text: str, what: str) -> dict:
    """A ros2cli-style YAML argument (``'{data: 1.5}'``, ``'data: 1.5'``), as a dict."""
    try:
        value = yaml.safe_load(text) if text.strip() else {}
    except yaml.YAMLError as exc:
        raise VerbError(f"{what} is not YAML: {exc}".splitlines()[0]) from None
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise VerbError(f"{what} must be a YAML mapping of fields, got {text!r}")
    return value


def interface_class(type_name: str, kind: str, part: str):
    """The class of a ``pkg/<kind>/Name`` (or ``pkg/Name``) interface, ``kind`` "srv" or
    "action", checked to have ``part`` (Request, Goal)."""
    parts = re.split(r"[/.]", type_name.strip())
    if len(parts) == 2:
        parts = [parts[0], kind, parts[1]]
    try:
        cls = getattr(importlib.import_module(f"{parts[0]}.{parts[1]}"), parts[2])
    except (ImportError, AttributeError, IndexError):
        raise VerbError(f"unknown {kind} type {type_name!r} (want pkg/{kind}/Name)") from None
    if not hasattr(cls, part):
        raise VerbError(f"{type_name!r} is no {kind} type (it has no {part})")
    return cls


def interface_message(type_name: str, kind: str, part: str, values: str):
    """(the interface class, its ``part`` filled from the YAML ``values``)."""
    cls = interface_class(type_name, kind, part)
    try:
        return cls, fill_message(getattr(cls, part)(), yaml_mapping(values, f"the {part.lower()}"))
    except (TypeError, ValueError, AssertionError) as exc:
        raise VerbError(f"cannot build the {part.lower()} of {type_name} from {values!r}: {exc}") from None


def absolute(name: str) -> str:
    return name if name.startswith("/") else "/" + name
