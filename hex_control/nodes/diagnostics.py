"""Periodic ``/diagnostics`` publishing with named counters, for every node."""

from __future__ import annotations

from collections import Counter

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from hex_control.nodes.runtime import wall_timer


class Diagnostics:
    """One DiagnosticStatus per node on ``/diagnostics``, published every ``period_s``.

    Counters (``count('rejected_nonfinite')``) and values (``set('model_a', 0.9)``)
    become KeyValue pairs; ``warn(text)`` raises the level to WARN until ``ok()``.
    """

    def __init__(self, node, period_s: float = 1.0, hardware_id: str = "hex_control"):
        self._node = node
        self._publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._hardware_id = hardware_id
        self.counters: Counter[str] = Counter()
        self.values: dict[str, str] = {}
        self._level = DiagnosticStatus.OK
        self._message = "ok"
        self._timer = wall_timer(node, period_s, self.publish)

    def count(self, name: str, increment: int = 1) -> None:
        self.counters[name] += increment

    def set(self, name: str, value) -> None:
        self.values[name] = str(value)

    def warn(self, message: str) -> None:
        self._level = DiagnosticStatus.WARN
        self._message = message

    def ok(self, message: str = "ok") -> None:
        self._level = DiagnosticStatus.OK
        self._message = message

    def status(self) -> DiagnosticStatus:
        status = DiagnosticStatus()
        status.level = self._level
        status.name = self._node.get_fully_qualified_name()
        status.message = self._message
        status.hardware_id = self._hardware_id
        pairs = {**{k: str(v) for k, v in sorted(self.counters.items())}, **self.values}
        status.values = [KeyValue(key=k, value=v) for k, v in pairs.items()]
        return status

    def publish(self) -> None:
        array = DiagnosticArray()
        array.header.stamp = self._node.get_clock().now().to_msg()
        array.status = [self.status()]
        self._publisher.publish(array)
