"""Periodic ``/diagnostics`` publishing with named counters and faults, for every node.

Published on the steady wall clock, so a node whose sim clock stands still (the plant died,
or holds between passes) still reports; a node on sim time with no ``/clock`` publisher
left says so (ERROR). The level is the worst of the faults raised and not yet cleared: each
fault has a name and clears by itself when its cause does (``clear``) or, for an event such
as a rejected input, ``hold_s`` after it last happened.
"""

from __future__ import annotations

import time
from collections import Counter

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from hex_control.ros.infra.runtime import wall_timer

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


class Health:
    """The faults a node has now: ``fault(name, message)`` until ``clear(name)``, or for
    ``hold_s`` (wall s) after the last ``fault``; ``summary()`` gives the level and message."""

    def __init__(self, clock=time.monotonic):
        self._clock = clock
        self._faults: dict[str, tuple[bytes, str, float | None]] = {}  # name -> level, message, until s
        self.state = "ok"  # the message while nothing is wrong

    def fault(self, name: str, message: str, level: bytes = WARN, hold_s: float | None = None) -> None:
        self._faults.pop(name, None)  # the latest last: messages in the order things went wrong
        self._faults[name] = (level, message, None if hold_s is None else self._clock() + hold_s)

    def clear(self, name: str) -> None:
        self._faults.pop(name, None)

    def active(self, name: str) -> bool:
        self._expire()
        return name in self._faults

    def _expire(self) -> None:
        now = self._clock()
        for name in [n for n, (_, _, until) in self._faults.items() if until is not None and until <= now]:
            del self._faults[name]

    def summary(self) -> tuple[bytes, str]:
        self._expire()
        if not self._faults:
            return OK, self.state
        levels = [level for level, _, _ in self._faults.values()]
        return max(levels, key=ord), "; ".join(message for _, message, _ in self._faults.values())


class Diagnostics(Health):
    """One DiagnosticStatus per node on ``/diagnostics``, published every ``period_s`` of wall time.

    Counters (``count('rejected_nonfinite')``) and values (``set('model_a', 0.9)``) become
    KeyValue pairs; faults set the level (:class:`Health`).
    """

    def __init__(self, node, period_s: float = 1.0, hardware_id: str = "hex_control"):
        super().__init__()
        self._node = node
        self._publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._hardware_id = hardware_id
        self.counters: Counter[str] = Counter()
        self.values: dict[str, str] = {}
        self._timer = wall_timer(node, period_s, self.publish)

    def count(self, name: str, increment: int = 1) -> None:
        self.counters[name] += increment

    def set(self, name: str, value) -> None:
        self.values[name] = str(value)

    def _check_clock(self) -> None:
        if not self._node.get_parameter("use_sim_time").value:
            return
        if self._node.count_publishers("clock") == 0:
            self.fault("clock", "no /clock publisher: sim time stands still", ERROR)
        else:
            self.clear("clock")

    def status(self) -> DiagnosticStatus:
        self._check_clock()
        status = DiagnosticStatus()
        status.level, status.message = self.summary()
        status.name = self._node.get_fully_qualified_name()
        status.hardware_id = self._hardware_id
        pairs = {**{k: str(v) for k, v in sorted(self.counters.items())}, **self.values}
        status.values = [KeyValue(key=k, value=v) for k, v in pairs.items()]
        return status

    def publish(self) -> None:
        array = DiagnosticArray()
        array.header.stamp = self._node.get_clock().now().to_msg()
        array.status = [self.status()]
        self._publisher.publish(array)
