"""Touch-down: bringing the force table from its retracted stop to the work before a pass.

A planned pass starts with the disk on the work at the bead's start (seed 002 6.6: the
simulated pass begins in contact), so its force trajectory asks for force from its first
samples. A force loop started from the retracted stop finds no force to close on: the PI
integrates the whole desired force while the table travels the gap (2 mm at the shipped
limits: 0.15-0.3 s, 2-5 mm of bead at the demo's feeds), the start of the bead is left
standing and the wound-up integrator overshoots when contact comes. The thesis located the
grinder against the work before grinding by touching it to a fiducial point (8.3 item 3);
here the controller does the same in time: while the machine descends onto the start it
moves the table at ``speed_mm_s`` to ``standoff_mm`` short of the table position where the
disk meets the work (``contact_mm``), to arrive ``settle_s`` before the pass starts, so the
force loop closes from there at once (a guarded move: it stops where force is felt).

Units: mm (table position), s, N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class TouchDown:
    """The move: where (``contact_mm`` - ``standoff_mm``), how fast, how early, and the force
    (``felt_n``) that means the work is already touching."""

    contact_mm: float = 0.0
    standoff_mm: float = 0.1
    speed_mm_s: float = 10.0
    settle_s: float = 0.1
    felt_n: float = 2.0

    def __post_init__(self):
        values = (self.contact_mm, self.standoff_mm, self.speed_mm_s, self.settle_s, self.felt_n)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            raise ValueError(f"touch-down: every figure must be a finite number, got {values}")
        if not (self.standoff_mm >= 0 and self.speed_mm_s > 0 and self.settle_s >= 0 and self.felt_n > 0):
            raise ValueError("touch-down: need standoff_mm >= 0, speed_mm_s > 0, settle_s >= 0, felt_n > 0")

    @property
    def target_mm(self) -> float:
        return self.contact_mm - self.standoff_mm

    def command_mm(self, held_mm: float, time_to_start_s: float, measured_n: float, period_s: float) -> float:
        """The table command one control period on, from the command ``held_mm``, with the
        pass starting in ``time_to_start_s``: held until the move, started just in time,
        reaches the target ``settle_s`` before the start; held wherever force is felt."""
        target = self.target_mm
        gap = target - held_mm
        if measured_n >= self.felt_n and gap > 0:
            return held_mm  # touching already: go no further towards the work
        step = self.speed_mm_s * period_s
        if abs(gap) <= step:
            return target
        if time_to_start_s - self.settle_s > abs(gap) / self.speed_mm_s:
            return held_mm  # not yet: the table stays retracted while the machine descends
        return held_mm + math.copysign(step, gap)
