"""ROS parameters declared from a table: one descriptor per parameter, with its meaning,
its unit (in the name or the description), its range and, for a string, its choices.

rclpy enforces a descriptor's range when a parameter is declared and whenever it is set,
so ``rate_hz:=0.0`` is refused at start-up with one line (:func:`run_node` prints it)
instead of a ZeroDivisionError later. Read-only is the default: a parameter that the node
reads once at start-up must say so, and only those that the node re-reads live are
declared ``read_only=False``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor


class ParameterError(ValueError):
    """A parameter's value is not one its node can run with."""


@dataclass(frozen=True)
class ParameterSpec:
    """A parameter: its default, what it means (with its unit when the name has none), the
    closed range [low, high] a number must lie in, the strings a string may be."""

    default: object
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    read_only: bool = True

    def descriptor(self) -> ParameterDescriptor:
        descriptor = ParameterDescriptor(description=self.description, read_only=self.read_only)
        if self.choices:
            descriptor.additional_constraints = "one of: " + ", ".join(self.choices)
        if self.low is not None or self.high is not None:
            if isinstance(self.default, bool) or not isinstance(self.default, (int, float)):
                raise TypeError(f"a range needs a number, not {self.default!r}")
            if isinstance(self.default, int):
                descriptor.integer_range = [IntegerRange(
                    from_value=int(-2**63 if self.low is None else self.low),
                    to_value=int(2**63 - 1 if self.high is None else self.high), step=1)]
            else:
                descriptor.floating_point_range = [FloatingPointRange(
                    from_value=-1e308 if self.low is None else float(self.low),
                    to_value=1e308 if self.high is None else float(self.high), step=0.0)]
        return descriptor


def declare_parameters(node, specs: Mapping[str, ParameterSpec]) -> None:
    """Declare every parameter of ``specs`` on ``node``; ParameterError (or rclpy's
    InvalidParameterValueException for a value out of range) names the first bad one."""
    for name, spec in specs.items():
        node.declare_parameter(name, spec.default, spec.descriptor())
        value = node.get_parameter(name).value
        if spec.choices and value not in spec.choices:
            raise ParameterError(f"{name} must be one of {', '.join(spec.choices)}; got {value!r}")
