"""Deliberately wrong variants of seed 004's methods. The tests run them through the checks
that stand for the seed and assert the checks reject them: a check that passes these
would not be testing the seed's method."""

from __future__ import annotations

from hex_control.seeds.milling.optimal_speed import OptimalLinearSpeed
from hex_control.seeds.milling.programmes import TriangularSpeed
from hex_control.seeds.mobile_platform.control import EnergyIndexController


class MaximumAcceleration(OptimalLinearSpeed):
    """Eq. 18 replaced by 'always the maximum acceleration' (eq. 10's limit every period)."""

    def command_rpm(self, simulator) -> float:
        return self.limit_rpm


class ReversedEq18(OptimalLinearSpeed):
    """Eq. 18 with its sign turned: the speed change that feeds energy in."""

    def command_rpm(self, simulator) -> float:
        return -super().command_rpm(simulator)


def plain_ramp(low_rpm: float, high_rpm: float, acceleration_rpm_s: float) -> TriangularSpeed:
    """Eq. 18 replaced by a plain ramp at the spindle's acceleration, down in the same time."""
    rise_s = (high_rpm - low_rpm) / acceleration_rpm_s
    return TriangularSpeed(low_rpm, high_rpm, rise_s, rise_s)


def z04_fast_rise(low_rpm: float, high_rpm: float) -> TriangularSpeed:
    """Z04 with a 0.25 s rise instead of the seed's 0.4 s."""
    return TriangularSpeed(low_rpm, high_rpm, 0.25, 0.4)


def z05_as_z04(low_rpm: float, high_rpm: float) -> TriangularSpeed:
    """Z05 built with Z04's 0.4 s times."""
    return TriangularSpeed(low_rpm, high_rpm, 0.4, 0.4)


class EnergyIndexWithoutHalf(EnergyIndexController):
    """Eq. 21 without the 1/2 of (R + R^T)^-1 = (2 r)^-1: twice the seed's feedback for q1/r."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.feedback = 2 * self.feedback
