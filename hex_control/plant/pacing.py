"""Pacing a simulation to the wall clock: how many control periods are due at a given time.

A timer that fires late (a busy machine, a slow callback) skips its missed ticks; a plant
that stands in for hardware must not, since the machine it stands in for keeps moving. The
pacer owes one period per ``period_s / real_time_factor`` of wall time since the start, so a
late tick steps the periods it missed. When the simulation falls further behind than
``max_lag_periods`` it gives the excess up (the run is then slower than real time) and
counts it, rather than stepping ever-longer bursts.
"""

from __future__ import annotations

import math


class RealTimePacer:
    """Periods due on a monotonic wall clock (s); ``due(now)`` takes them."""

    def __init__(self, period_s: float, real_time_factor: float = 1.0, max_lag_periods: int = 20):
        if not (period_s > 0 and real_time_factor > 0 and max_lag_periods >= 1):
            raise ValueError("period_s and real_time_factor must be positive, max_lag_periods at least 1")
        self.wall_period_s = period_s / real_time_factor
        self.max_lag_periods = int(max_lag_periods)
        self.start_s: float | None = None
        self.stepped = 0  # periods handed out
        self.late_ticks = 0  # ticks that owed more than one period
        self.dropped = 0  # periods given up because the simulation fell too far behind

    def due(self, now_s: float) -> int:
        """Periods to step now: 1 on a tick that is on time, more after a late one, 0 early."""
        if self.start_s is None:
            self.start_s = now_s - self.wall_period_s  # the first tick steps one period
        owed = math.floor((now_s - self.start_s) / self.wall_period_s + 1e-9) - self.stepped - self.dropped
        if owed > self.max_lag_periods:
            self.dropped += owed - self.max_lag_periods
            owed = self.max_lag_periods
        owed = max(owed, 0)
        self.late_ticks += owed > 1
        self.stepped += owed
        return owed

    def lag_s(self, now_s: float) -> float:
        """Wall time (s) by which the simulation trails real time, given-up periods included."""
        if self.start_s is None:
            return 0.0
        return max(now_s - self.start_s - self.stepped * self.wall_period_s, 0.0)
