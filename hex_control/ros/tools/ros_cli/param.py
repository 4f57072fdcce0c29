"""``hexctl param list|get|set|describe|dump|load`` against a running node's parameter services.
A parameter the node does not declare is one line and exit 2, as a node that is not there.

Requests are resent while unanswered: a Fast DDS service drops a response whose client
has not matched yet (hex_control.ros.infra.action_probe), and reading or setting a parameter
twice does no harm.
"""

from __future__ import annotations

import sys
import time

import yaml
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter, parameter_dict_from_yaml_file, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient

from hex_control.ros.tools.ros_cli.common import VerbError, cli_node, spin_until

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


def _declared(node, client, target: str, timeout_s: float) -> list[str]:
    return sorted(answer(node, lambda: client.list_parameters(), timeout_s, f"answer from {target}").result.names)


def _check_declared(node, client, target: str, names, timeout_s: float) -> None:
    """VerbError (2) naming the ones of ``names`` the node does not declare (its services
    answer a request with one such name with nothing at all)."""
    unknown = sorted(set(names) - set(_declared(node, client, target, timeout_s)))
    if unknown:
        raise VerbError(f"{target} has no parameter {', '.join(unknown)} (hexctl param list {target})")


def param_list(target: str, timeout_s: float) -> int:
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        for name in _declared(node, client, target, timeout_s):
            print(f"  {name}")
    return 0


def _values(node, client, target, names, timeout_s):
    values = answer(node, lambda: client.get_parameters(names), timeout_s, f"answer from {target}").values
    if len(values) != len(names):
        _check_declared(node, client, target, names, timeout_s)
        raise VerbError(f"{target} answered {len(values)} values for {len(names)} parameters", 1)
    return values


def param_get(target: str, name: str, timeout_s: float) -> int:
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        [value] = _values(node, client, target, [name], timeout_s)
        if value.type == ParameterType.PARAMETER_NOT_SET:
            print("Parameter not set.")
            return 0
        print(f"{_TYPES[value.type].capitalize()} value is: {parameter_value_to_python(value)}")
    return 0


def _parse_value(text: str):
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text


def _set(node, client, target: str, parameters: list, timeout_s: float) -> bool:
    """Set ``parameters`` (rclpy Parameters) one by one, print each outcome; True if all were."""
    result = answer(node, lambda: client.set_parameters(parameters), timeout_s, f"answer from {target}")
    ok = True
    for parameter, outcome in zip(parameters, result.results):
        prefix = f"Set parameter {parameter.name} "
        if outcome.successful:
            print(prefix + "successful")
        else:
            ok = False
            print(f"{prefix}failed: {outcome.reason}", file=sys.stderr)
    return ok


def param_set(target: str, name: str, text: str, timeout_s: float) -> int:
    value = _parse_value(text)
    try:
        parameter = Parameter(name, value=value)
    except (TypeError, ValueError) as exc:
        raise VerbError(f"{text!r} is no parameter value: {exc}") from None
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        _check_declared(node, client, target, [name], timeout_s)
        result = answer(node, lambda: client.set_parameters([parameter]), timeout_s, f"answer from {target}")
        [outcome] = result.results
        if not outcome.successful:
            raise VerbError(f"Setting parameter failed: {outcome.reason}", 1)
        print("Set parameter successful")
    return 0


def _same(a, b) -> bool:
    """Equal values of the same parameter type (an array as any sequence)."""
    if isinstance(a, (str, bytes)) or isinstance(b, (str, bytes)) or not hasattr(a, "__len__") \
            or not hasattr(b, "__len__"):
        return type(a) is type(b) and a == b
    return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))


def param_load(target: str, path: str, timeout_s: float, use_wildcard: bool = True) -> int:
    """``ros2 param load``: set the parameters a parameter file (``hexctl param dump``'s, or
    a launch one) gives ``target`` (its full name, its name, or ``/**`` with ``use_wildcard``).
    Exit 1 if the node refused one of them, 2 if the file names one it does not declare."""
    try:
        messages = parameter_dict_from_yaml_file(path, use_wildcard, [target])
    except FileNotFoundError:
        raise VerbError(f"no parameter file {path}") from None
    except (RuntimeError, AttributeError, TypeError, yaml.YAMLError) as exc:
        raise VerbError(f"{path}: not a parameter file for {target}: {str(exc).splitlines()[0]}") from None
    parameters = [Parameter.from_parameter_msg(m) for m in messages.values()]
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        names = [p.name for p in parameters]
        _check_declared(node, client, target, names, timeout_s)
        # a value the node has already is not set again: a dump loaded back holds the
        # read-only parameters too, which refuse any set
        current = [parameter_value_to_python(v) for v in _values(node, client, target, names, timeout_s)]
        changed = []
        for parameter, now in zip(parameters, current):
            if _same(parameter.value, now):
                print(f"Parameter {parameter.name} unchanged")
            else:
                changed.append(parameter)
        if changed and not _set(node, client, target, changed, timeout_s):
            raise VerbError(f"{target} refused some parameters of {path}", 1)
    return 0


def param_describe(target: str, names, timeout_s: float) -> int:
    """``ros2 param describe NODE NAME...``: type, description, ranges, the declared choices
    (``additional_constraints``: "one of: ..."), read-only."""
    names = [names] if isinstance(names, str) else list(names)
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        descriptors = answer(node, lambda: client.describe_parameters(names), timeout_s,
                             f"answer from {target}").descriptors
        if len(descriptors) != len(names):
            _check_declared(node, client, target, names, timeout_s)
        for descriptor in descriptors:
            print(f"Parameter name: {descriptor.name}\n  Type: {_TYPES[descriptor.type]}")
            if descriptor.description:
                print(f"  Description: {descriptor.description}")
            for kind in ("floating_point_range", "integer_range"):
                for bounds in getattr(descriptor, kind):
                    print(f"  Range: {bounds.from_value} .. {bounds.to_value}"
                          + (f", step {bounds.step}" if bounds.step else ""))
            if descriptor.additional_constraints:
                print(f"  Constraints: {descriptor.additional_constraints}")
            if descriptor.read_only:
                print("  Read only: true")
    return 0


def param_dump(target: str, timeout_s: float) -> int:
    """The node's parameters as a parameter file (``--params-file`` and ``param load`` take it back)."""
    with cli_node("hexctl_param") as node:
        client = _client(node, target, timeout_s)
        names = _declared(node, client, target, timeout_s)
        values = _values(node, client, target, names, timeout_s)
        parameters = {name: parameter_value_to_python(value) for name, value in zip(names, values)}
        print(yaml.safe_dump({target: {"ros__parameters": parameters}}, sort_keys=False).rstrip())
    return 0
