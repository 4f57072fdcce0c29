"""Limits the plant enforces itself, whoever commands it: the machine's strokes and the force
table's travel, as ros2_control enforces joint limits below every controller, and the
amplifier's overload trip (issue 21: a 50 m strut command used to drive every strut to
50 m; 1000 mm on the force axis gave 7.9e4 N against F_max 60 N).

- Strokes: a Stewart machine's strut lengths within the machine file's
  ``strut_length_mm`` (the 3-PRU head checks its sliders, feed stage and tilt in
  :meth:`hex_control.plant.pru3_machine.Pru3Machine.check_command`). A command outside is
  refused, not clamped: clamping one strut of six moves the platform somewhere nobody asked.
- Travel: the force-axis command is clamped to the table's end stops (one axis: the stop is
  where the table would go anyway).
- Overload: a true normal force above ``overload_n`` retracts the table to its stop and
  holds it there until the command itself asks for no force (at or behind the work's
  contact), the reset an operator gives an amplifier fault.

Units: strut lengths m (the machine files give mm), table positions mm, force N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def check_strokes(lengths_m, low_mm: float, high_mm: float) -> None:
    """Raise ValueError unless every strut length (m) is within [low_mm, high_mm]."""
    lengths_mm = np.asarray(lengths_m, float) * 1000.0
    outside = np.flatnonzero(~((lengths_mm >= low_mm) & (lengths_mm <= high_mm)))
    if outside.size:
        i = int(outside[0])
        raise ValueError(f"strut {i} at {lengths_mm[i]:.1f} mm is outside its stroke {low_mm:g}..{high_mm:g} mm")


@dataclass
class ForceAxisLimits:
    """The table's travel (mm) and the overload trip: ``command_mm`` turns what a controller
    asked into what the table's servo gets, given the true force (N) the period before."""

    travel_mm: tuple[float, float] = (-5.0, 2.0)
    overload_n: float = 150.0
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
