"""Periodic ``/diagnostics`` publishing with named counters and faults, for every node.

Published on the steady wall clock, so a node whose sim clock stands still (the plant died,
or holds between passes) still reports; a node on sim time with no ``/clock`` publisher
left says so (ERROR) -- within CLOCK_WATCH_LEASE_S of the publisher's death if it offers
DDS liveliness (:data:`CLOCK_QOS`), at once in the report that follows. The graph alone
learns of a killed process only when its participant's lease (20 s) runs out: the pass
planner said "no /clock publisher" 30 s after the plant was killed. /clock messages stop
while the plant holds between passes, so their age says nothing.

The level is the worst of the faults raised and not yet cleared: each fault has a name and
clears by itself when its cause does (``clear``) or, for an event such as a rejected input,
``hold_s`` after it last happened.
"""

from __future__ import annotations

import time
from collections import Counter

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.duration import Duration
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import LivelinessPolicy, QoSProfile
from rosgraph_msgs.msg import Clock

from hex_control.ros.infra.runtime import wall_timer

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR

#: a /clock publisher's promise (s): its process asserts it is alive every 2/3 of this
#: (rmw_fastrtps), without a message; a clock source publishes /clock with CLOCK_QOS
CLOCK_LEASE_S = 0.4
#: a node on sim time counts the clock publisher lost after this long without an assertion
#: (s): its lease, plus a margin for a publisher process stalled by a loaded machine; the
#: report follows at once (within 2 s of the death, issue 40)
CLOCK_WATCH_LEASE_S = 1.2
CLOCK_QOS = QoSProfile(depth=10, liveliness=LivelinessPolicy.AUTOMATIC,
                       liveliness_lease_duration=Duration(nanoseconds=int(CLOCK_LEASE_S * 1e9)))
_CLOCK_WATCH_QOS = QoSProfile(depth=1, liveliness=LivelinessPolicy.AUTOMATIC,
                              liveliness_lease_duration=Duration(nanoseconds=int(CLOCK_WATCH_LEASE_S * 1e9)))


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
        self._clock_liveliness = (0, 0)  # /clock publishers with a lease: alive, not alive
        self._clock_watch = None

    def count(self, name: str, increment: int = 1) -> None:
        self.counters[name] += increment

    def set(self, name: str, value) -> None:
        self.values[name] = str(value)

    def _on_clock_liveliness(self, info) -> None:
        was, self._clock_liveliness = self._clock_liveliness[0], (info.alive_count, info.not_alive_count)
        if was > 0 and info.alive_count == 0:
            self.publish()  # now, not at the next period: within 2 s of the publisher's death

    def _watch_clock(self) -> None:
        """Subscribe to /clock's liveliness once a publisher offers a lease: one without does
        not match this reader (its node would log the incompatible QoS), the graph alone
        watches it."""
        if self._clock_watch is not None:
            return
        leases = [p.qos_profile.liveliness_lease_duration.nanoseconds
                  for p in self._node.get_publishers_info_by_topic("clock")]
        if any(0 < lease <= _CLOCK_WATCH_QOS.liveliness_lease_duration.nanoseconds for lease in leases):
            self._clock_watch = self._node.create_subscription(
                Clock, "/clock", lambda _msg: None, _CLOCK_WATCH_QOS, raw=True,
                event_callbacks=SubscriptionEventCallbacks(liveliness=self._on_clock_liveliness,
                                                           incompatible_qos=lambda _event: None))

    def _check_clock(self) -> None:
        if not self._node.get_parameter("use_sim_time").value:
            return
        self._watch_clock()
        publishers = self._node.count_publishers("clock")
        alive, not_alive = self._clock_liveliness
        self.values["clock_publishers_alive"] = str(alive)  # (those with a lease)
        if publishers == 0:
            self.fault("clock", "no /clock publisher: sim time stands still", ERROR)
        elif alive == 0 and not_alive >= publishers:  # every publisher the graph still shows has lost its lease
            self.fault("clock", f"/clock publisher lost (silent for {CLOCK_WATCH_LEASE_S:g} s): sim time stands "
                                "still", ERROR)
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
