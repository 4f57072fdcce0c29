"""Timing of a sampled control loop run over a transport: command latency and missed cycles."""

from __future__ import annotations

import numpy as np


class LoopTiming:
    """``sent(t)`` when a measurement goes out, ``answered(t)`` when its command arrives,
    ``cycle()`` at every control period; times in s on one monotonic clock."""

    def __init__(self, keep: int = 100_000):
        self.keep = keep
        self.latencies_s: list[float] = []
        self.cycles = 0
        self.missed = 0
        self._pending = None

    @property
    def pending_since_s(self) -> float | None:
        """When the unanswered measurement went out, or None."""
        return self._pending

    def sent(self, time_s: float) -> None:
        self._pending = time_s

    def answered(self, time_s: float) -> bool:
        """True if this answers the last measurement (a late or repeated answer does not)."""
        if self._pending is None:
            return False
        if len(self.latencies_s) < self.keep:
            self.latencies_s.append(time_s - self._pending)
        self._pending = None
        return True

    def cycle(self) -> None:
        """A control period ends: if the last measurement is still unanswered, it is missed."""
        self.cycles += 1
        if self._pending is not None:
            self.missed += 1

    @property
    def missed_fraction(self) -> float:
        return self.missed / self.cycles if self.cycles else 0.0

    def latency_percentiles_ms(self, percentiles=(50, 99)) -> list[float]:
        if not self.latencies_s:
            return [float("nan")] * len(percentiles)
        return [float(v) * 1e3 for v in np.percentile(self.latencies_s, percentiles)]
