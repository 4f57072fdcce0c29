"""``hexctl param list|get|set|describe|dump`` against a running node's parameter services.

Requests are resent while unanswered: a Fast DDS service drops a response whose client
has not matched yet (hex_control.nodes.action_probe), and reading or setting a parameter
twice does no harm.
"""

from __future__ import annotations

import time

import yaml
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient

from hex_control.nodes.ros_cli.common import VerbError, cli_node, spin_until

RESEND_S = 2.0
_TYPES = {value: name.removeprefix("PARAMETER_").lower() for name, value in vars(ParameterType).items()
          if name.startswith("PARAMETER_")}


def answer(node, send, timeout_s: float, what: str):
    """``send()``'s future's result, sending again every RESEND_S until ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while True:
        future = send()
        try:
            spin_until(node, future.done, min(RESEND_S, max(end - time.monotonic(), 0.05)), what)
            return future.result()
        except VerbError:
            if time.monotonic() >= end:
                raise


def _client(node, target: str, timeout_s: float) -> AsyncParameterClient:
    client = AsyncParameterClient(node, target)
    spin_until(node, lambda: client.services_are_ready(), timeout_s, f"parameter services of {target}")
    return client


def param_list(target: str, timeout_s: float) -> int:
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        result = answer(node, lambda: client.list_parameters(), timeout_s, f"answer from {target}")
        for name in sorted(result.result.names):
            print(f"  {name}")
    return 0


def _values(node, client, target, names, timeout_s):
    result = answer(node, lambda: client.get_parameters(names), timeout_s, f"answer from {target}")
    return result.values


def param_get(target: str, name: str, timeout_s: float) -> int:
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        [value] = _values(node, client, target, [name], timeout_s)
        if value.type == ParameterType.PARAMETER_NOT_SET:
            raise VerbError(f"{target} has no parameter {name!r}", 1)
        print(f"{_TYPES[value.type].capitalize()} value is: {parameter_value_to_python(value)}")
    return 0


def param_set(target: str, name: str, text: str, timeout_s: float) -> int:
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        value = text
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        try:
            parameter = Parameter(name, value=value)
        except (TypeError, ValueError) as exc:
            raise VerbError(f"{text!r} is no parameter value: {exc}") from None
        result = answer(node, lambda: client.set_parameters([parameter]), timeout_s, f"answer from {target}")
        [outcome] = result.results
        if not outcome.successful:
            raise VerbError(f"Setting parameter failed: {outcome.reason}", 1)
        print("Set parameter successful")
    return 0


def param_describe(target: str, name: str, timeout_s: float) -> int:
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        result = answer(node, lambda: client.describe_parameters([name]), timeout_s, f"answer from {target}")
        [descriptor] = result.descriptors
        if descriptor.type == ParameterType.PARAMETER_NOT_SET:
            raise VerbError(f"{target} has no parameter {name!r}", 1)
        print(f"Parameter name: {descriptor.name}\n  Type: {_TYPES[descriptor.type]}")
        if descriptor.description:
            print(f"  Description: {descriptor.description}")
        for kind in ("floating_point_range", "integer_range"):
            for bounds in getattr(descriptor, kind):
                print(f"  Range: {bounds.from_value} .. {bounds.to_value}" + (f", step {bounds.step}"
                                                                               if bounds.step else ""))
        if descriptor.read_only:
            print("  Read only: true")
    return 0


def param_dump(target: str, timeout_s: float) -> int:
    """The node's parameters as a parameter file (``--params-file`` takes it back)."""
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        names = sorted(answer(node, lambda: client.list_parameters(), timeout_s, f"answer from {target}")
                       .result.names)
        values = _values(node, client, target, names, timeout_s)
        parameters = {name: parameter_value_to_python(value) for name, value in zip(names, values)}
        print(yaml.safe_dump({target: {"ros__parameters": parameters}}, sort_keys=False).rstrip())
    return 0
