"""What the controller sees: the state estimated from the wheels' encoders (seed 004
section 4: "a state vector for the needs of motion control is estimated in indirect way,
with the use of odometers' techniques and encoders' measurements").

Each period the encoders give whole counts. The increments of the two wheels, turned into
arc lengths, move the pose estimate by dead reckoning: a straight chord at the mean of
the old and new headings. The speed and turn rate are the increments over the period,
so they are quantized to one count per period. SI units."""

from __future__ import annotations

import math

from hex_control.seeds.mobile_platform.control import PlatformState
from hex_control.seeds.mobile_platform.model import PlatformParameters


class EncoderOdometry:
    def __init__(self, model: PlatformParameters, counts_per_wheel_rev: int, period_s: float,
                 start: PlatformState):
        if counts_per_wheel_rev < 1 or not period_s > 0:
            raise ValueError("counts_per_wheel_rev must be >= 1 and period_s > 0")
        self.model, self.period_s = model, period_s
        self.rad_per_count = 2 * math.pi / counts_per_wheel_rev
        self.counts = (0, 0)
        self.x, self.y, self.beta = start.x_m, start.y_m, start.beta_rad

    def measure(self, wheel_angles_rad) -> PlatformState:
        counts = tuple(math.floor(angle / self.rad_per_count) for angle in wheel_angles_rad)
        left, right = ((new - old) * self.rad_per_count * self.model.wheel_radius_m
                       for new, old in zip(counts, self.counts))
        self.counts = counts
        distance, turn = (left + right) / 2, (right - left) / (2 * self.model.half_track_m)
        middle = self.beta + turn / 2
        self.x += distance * math.cos(middle)
        self.y += distance * math.sin(middle)
        self.beta += turn
        return PlatformState(self.x, self.y, self.beta, distance / self.period_s, turn / self.period_s)
