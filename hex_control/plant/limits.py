"""Limits the plant enforces itself, whoever commands it: the machine's strokes and the force
table's travel, as ros2_control enforces joint limits below every controller, and the
amplifier's overload trip (issue 21: a 50 m strut command used to drive every strut to
50 m; 1000 mm on the force axis gave 7.9e4 N against F_max 60 N).

- Strokes: every joint command within the machine file's limits, as the machine checks
  them (``check_joint_positions_mm`` of its geometry: a hexapod's strut strokes; the 3-PRU
  head's sliders, feed stage and tilt). A command outside is refused, not clamped:
  clamping one strut of six moves the platform somewhere nobody asked.
- Speed and acceleration: every joint's command (a Stewart machine's struts; the 3-PRU
  head's sliders and feed stage), one control period at a time, within the machine file's
  limits (``joint_speed_max_mm_s`` and ``joint_acceleration_max_mm_s2`` of the geometry;
  :class:`StrutRateLimiter`; ros2_control's joint limiter does the same below every
  controller). A path within them passes unchanged; a jump is turned into a time-optimal
  move onto it, all joints scaled by one factor.
- Travel: the force-axis command is clamped to the table's end stops (one axis: the stop is
  where the table would go anyway).
- Overload: a true normal force above ``overload_n`` retracts the table to its stop and
  holds it there until the command itself asks for no force (at or behind the work's
  contact), the reset an operator gives an amplifier fault.

Units: strut lengths m (the machine files give mm), table positions mm, force N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hex_control.config import cell_configuration


@dataclass
class ForceAxisLimits:
    """The table's travel (mm) and the overload trip: ``command_mm`` turns what a controller
    asked into what the table's servo gets, given the true force (N) the period before."""

    travel_mm: tuple[float, float] = (-5.0, 2.0)
    overload_n: float = field(default_factory=lambda: cell_configuration().overload_n)  # N: the cell's trip
    contact_mm: float = 0.0
    tripped: bool = False
    clamped: int = 0  # commands beyond the travel
    trips: int = 0

    def __post_init__(self):
        low, high = self.travel_mm
        if not (math.isfinite(low) and math.isfinite(high) and low < self.contact_mm < high):
            raise ValueError(f"the table's travel {self.travel_mm} mm must be finite and hold the contact "
                             f"{self.contact_mm} mm")
        if not (math.isfinite(self.overload_n) and self.overload_n > 0):
            raise ValueError(f"overload_n must be finite and > 0, got {self.overload_n!r}")

    def command_mm(self, commanded_mm: float, force_n: float) -> float:
        low, high = self.travel_mm
        if force_n > self.overload_n and not self.tripped:
            self.tripped, self.trips = True, self.trips + 1
        if self.tripped:
            if commanded_mm > self.contact_mm:
                return low
            self.tripped = False  # the controller has backed off: the fault is reset
        if not low <= commanded_mm <= high:
            self.clamped += 1
            return min(max(commanded_mm, low), high)
        return commanded_mm


@dataclass
class StrutRateLimiter:
    """Joint commands (m) within a speed (m/s) and an acceleration (m/s^2) limit, one for
    all joints or one per joint, updated once a control period: the command follows the
    target's own speed plus, towards the gap it was left behind, the speed from which it
    can brake onto it at half the acceleration (sqrt(a e): a period's lag then never
    overshoots), or the whole gap where that is less; the change of speed and then the
    speed are scaled down, all joints by one factor (the one the tightest joint needs), so
    the platform keeps its direction."""

    speed_max_m_s: float | np.ndarray
    acceleration_max_m_s2: float | np.ndarray
    limited: int = 0  # periods in which a limit acted

    def __post_init__(self):
        speed, acceleration = (np.asarray(v, float) for v in (self.speed_max_m_s, self.acceleration_max_m_s2))
        if not (speed.size and acceleration.size and np.all(np.isfinite(speed)) and np.all(speed > 0)
                and np.all(np.isfinite(acceleration)) and np.all(acceleration > 0)):
            raise ValueError(f"joint limits need finite speeds > 0 and accelerations > 0, got "
                             f"{self.speed_max_m_s!r} m/s, {self.acceleration_max_m_s2!r} m/s^2")
        self.speed_max_m_s, self.acceleration_max_m_s2 = speed, acceleration
        self.command_m = self.target_m = self.speed_m_s = None

    def reset(self, lengths_m) -> None:
        """At rest at ``lengths_m``."""
        self.command_m = [float(v) for v in np.asarray(lengths_m, float).reshape(-1)]
        self.target_m, self.speed_m_s = list(self.command_m), [0.0] * len(self.command_m)
        n = len(self.command_m)
        self._speed_max = np.broadcast_to(self.speed_max_m_s, (n,)).tolist()
        self._acceleration_max = np.broadcast_to(self.acceleration_max_m_s2, (n,)).tolist()

    def command(self, target_m, period_s: float) -> np.ndarray:
        """The strut commands (m) for the next ``period_s`` towards ``target_m``. In plain
        floats over the few joints (numpy's per-call cost was most of it); each operation as
        the array version did it, element by element, so the same bits."""
        target = np.asarray(target_m, float).tolist()
        behind = [t - c for t, c in zip(self.target_m, self.command_m)]  # the gap left last period (0 while tracking)
        target_speed = [(t - t0) / period_s for t, t0 in zip(target, self.target_m)]
        # the joint that must brake first sets the pace of all
        pace = min(1.0 / period_s, _least_ratio(self._acceleration_max, behind) ** 0.5) if any(behind) else 0.0
        change = [ts + b * pace - v for ts, b, v in zip(target_speed, behind, self.speed_m_s)]
        scale_a = min(1.0, _least_ratio([a * period_s for a in self._acceleration_max], change))
        speed = [v + scale_a * c for v, c in zip(self.speed_m_s, change)]
        scale_v = min(1.0, _least_ratio(self._speed_max, speed))
        self.limited += scale_a < 1.0 or scale_v < 1.0
        self.speed_m_s = [scale_v * v for v in speed]
        self.command_m = [c + v * period_s for c, v in zip(self.command_m, self.speed_m_s)]
        self.target_m = target
        return np.array(self.command_m)


def _least_ratio(limit, value) -> float:
    """min over joints of limit / |value| (inf where no joint moves); ``limit`` one per joint."""
    return min((bound / abs(v) for bound, v in zip(limit, value) if v != 0.0), default=math.inf)
