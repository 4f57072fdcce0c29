"""Spindle-speed programmes (rev/min against s; each has ``initial_rpm`` and
``speed_rpm(time_s, simulator)``): the constant references and the seed's
triangular programmes Z04 and Z05 (seed 004 section 3: speed switching every 0.4 s and
0.5 s, rising and falling between the two reference speeds)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ConstantSpeed:
    rpm: float

    @property
    def initial_rpm(self) -> float:
        return self.rpm

    def speed_rpm(self, time_s: float, _simulator=None) -> float:
        return self.rpm


@dataclass(frozen=True)
class TriangularSpeed:
    """Repeating triangle from low_rpm up to high_rpm in rise_s and back in fall_s."""

    low_rpm: float
    high_rpm: float
    rise_s: float
    fall_s: float

    def __post_init__(self):
        if not (0 < self.low_rpm < self.high_rpm and self.rise_s > 0 and self.fall_s > 0):
            raise ValueError("need 0 < low_rpm < high_rpm and positive rise_s, fall_s")

    @property
    def initial_rpm(self) -> float:
        return self.low_rpm

    def speed_rpm(self, time_s: float, _simulator=None) -> float:
        phase = time_s % (self.rise_s + self.fall_s)
        span = self.high_rpm - self.low_rpm
        if phase < self.rise_s:
            return self.low_rpm + span * phase / self.rise_s
        return self.high_rpm - span * (phase - self.rise_s) / self.fall_s


def seed_programmes(low_rpm: float = 15000.0, high_rpm: float = 16500.0) -> dict:
    """The seed's four: constant 15 000 and 16 500 rev/min, Z04 and Z05."""
    return {"constant 15000": ConstantSpeed(low_rpm), "constant 16500": ConstantSpeed(high_rpm),
            "Z04": TriangularSpeed(low_rpm, high_rpm, 0.4, 0.4), "Z05": TriangularSpeed(low_rpm, high_rpm, 0.5, 0.5)}
