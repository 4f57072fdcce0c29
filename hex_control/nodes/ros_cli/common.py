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

from hex_control.nodes.messages import fill_message

DURABILITY = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL}
RELIABILITY = {"reliable": ReliabilityPolicy.RELIABLE, "best_effort": ReliabilityPolicy.BEST_EFFORT}


class VerbError(Exception):
    """A verb that cannot go on: its message is printed as one line, with ``code``."""

    def __init__(self, message: str, code: int = 2):
        super().__init__(message)
        self.code = code


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
