"""A whole strut trajectory held by the plant, the way ros2_control's joint trajectory
controller holds one (DESIGN.md 4.1): handed over before the motion starts, sampled by
the hardware loop at each control period.

Units: s (plant time) and m (strut lengths).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StrutTrajectory:
    """Strut lengths ``lengths_m`` (n, struts) at plant times ``start_s + time_s``."""

    start_s: float
    time_s: np.ndarray  # from start_s, strictly increasing, the first >= 0
    lengths_m: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.time_s, float)
        q = np.asarray(self.lengths_m, float)
        if t.ndim != 1 or t.size == 0 or q.ndim != 2 or q.shape[0] != t.size:
            raise ValueError(f"need n times and n x struts lengths, got {t.shape} and {q.shape}")
        if not (np.isfinite(self.start_s) and self.start_s >= 0 and np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
            raise ValueError("start, times and lengths must be finite, the start >= 0")
        if t[0] < 0 or np.any(np.diff(t) <= 0):
            raise ValueError("times from start must be >= 0 and strictly increasing")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "lengths_m", q)

    @property
    def end_s(self) -> float:
        return self.start_s + float(self.time_s[-1])

    def at(self, plant_time_s: float) -> np.ndarray:
        """Lengths at a plant time, linear between points, held before the first and after the last."""
        t = plant_time_s - self.start_s
        times = self.time_s
        if t <= times[0]:
            return self.lengths_m[0]
        if t >= times[-1]:
            return self.lengths_m[-1]
        k = int(np.searchsorted(times, t, side="right")) - 1
        f = (t - times[k]) / (times[k + 1] - times[k])
        return self.lengths_m[k] + f * (self.lengths_m[k + 1] - self.lengths_m[k])
