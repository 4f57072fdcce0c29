"""Time-domain simulation of milling with regeneration, seed 004 eq. 14-15: the tool's
modal model (tool_beam) under the cutting forces of eq. 11-13 at the tip, with the delay
following the instantaneous spindle speed.

The delay of eq. 16 is found, not approximated: the previous tooth was where this one is
now when the spindle angle was theta(t) - 2 pi / z, so tau solves
int_{t - tau}^t 2 pi n(s) / 60 ds = 2 pi / z, and the surface it left is the tip
deflection at that instant (linear interpolation in the stored history). Each step holds
the force over the step and advances the modes exactly (zero-order hold, one matrix
exponential). SI units; spindle speed in rev/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from hex_control.seeds.milling.cutting import Cut, cutting_force
from hex_control.seeds.milling.tool_beam import ToolModes


@dataclass(frozen=True)
class MillingRecord:
    """time_s (T,), deflection_m (T, 2) of the tip in (x, y), speed_rpm (T,), force_n (T, 2)."""

    time_s: np.ndarray
    deflection_m: np.ndarray
    speed_rpm: np.ndarray
    force_n: np.ndarray

    @property
    def step_s(self) -> float:
        return float(self.time_s[1] - self.time_s[0])


def modal_step_matrices(modes: ToolModes, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(Ad, Bd): [eta; eta'] <- Ad [eta; eta'] + Bd F over one step with F held (Van Loan)."""
    m = modes.omega_rad_s.size
    a = np.zeros((2 * m, 2 * m))
    a[:m, m:] = np.eye(m)
    a[m:, :m] = -np.diag(modes.omega_rad_s ** 2)
    a[m:, m:] = -np.diag(2 * modes.damping * modes.omega_rad_s)
    block = np.zeros((2 * m + 1, 2 * m + 1))
    block[:2 * m, :2 * m] = a
    block[m:2 * m, 2 * m] = modes.tip_shape
    exponential = expm(block * step_s)
    return exponential[:2 * m, :2 * m], exponential[:2 * m, 2 * m:]


class MillingSimulator:
    """One cut: call ``run(programme, duration_s)``. ``programme.speed_rpm(time_s, simulator)``
    gives the spindle speed for the next step; a controller reads the simulator's state
    (``modal_state``, ``delay_s``, ``delayed_velocity_m_s``, ``tooth_angles_rad``)."""

    def __init__(self, modes: ToolModes, cut: Cut, step_s: float = 2e-5):
        if not step_s > 0:
            raise ValueError("step_s must be > 0")
        self.modes, self.cut, self.step_s = modes, cut, step_s
        self.ad, self.bd = modal_step_matrices(modes, step_s)
        self.pitch_rad = 2 * math.pi / cut.teeth
        self.modal_state = np.zeros((2 * modes.omega_rad_s.size, 2))  # [eta; eta'] x (x, y) planes
        self.delay_s = math.nan
        self.delayed_velocity_m_s = (0.0, 0.0)
        self.tooth_angles_rad = [0.0] * cut.teeth

    def run(self, programme, duration_s: float) -> MillingRecord:
        steps = int(round(duration_s / self.step_s))
        if steps < 2:
            raise ValueError("duration_s must cover at least two steps")
        dt, pitch, shape, cut = self.step_s, self.pitch_rad, self.modes.tip_shape, self.cut
        m = shape.size
        offsets = [pitch * l for l in range(cut.teeth)]
        n0 = programme.initial_rpm
        # Before the cut the spindle turned at n0 with the tool at rest: the history the
        # first tooth period needs is a straight angle ramp at zero deflection.
        lead = int(math.ceil(60.0 / (n0 * cut.teeth) / dt)) + 2
        angle = [-(lead - i) * 2 * math.pi * n0 / 60.0 * dt for i in range(lead)] + [0.0]
        tip_x, tip_y = [0.0] * (lead + 1), [0.0] * (lead + 1)
        speed, force = np.zeros(steps), np.zeros((steps, 2))
        j = 0  # angle[j] <= angle now - pitch < angle[j + 1]
        x = self.modal_state
        for k in range(steps):
            i = lead + k
            target = angle[i] - pitch
            while angle[j + 1] <= target:
                j += 1
            frac = (target - angle[j]) / (angle[j + 1] - angle[j])
            delayed = (tip_x[j] + frac * (tip_x[j + 1] - tip_x[j]), tip_y[j] + frac * (tip_y[j + 1] - tip_y[j]))
            self.delay_s = (i - j - frac) * dt
            self.delayed_velocity_m_s = ((tip_x[j + 1] - tip_x[j]) / dt, (tip_y[j + 1] - tip_y[j]) / dt)
            self.tooth_angles_rad = [angle[i] + o for o in offsets]
            n = programme.speed_rpm(k * dt, self)
            f = cutting_force(cut, self.tooth_angles_rad, (tip_x[i], tip_y[i]), delayed)
            x = self.ad @ x + self.bd * f
            self.modal_state = x
            speed[k], force[k] = n, f
            angle.append(angle[i] + 2 * math.pi * n / 60.0 * dt)
            wx, wy = shape @ x[:m]
            tip_x.append(wx)
            tip_y.append(wy)
        deflection = np.column_stack([tip_x[lead + 1:], tip_y[lead + 1:]])
        return MillingRecord(np.arange(steps) * dt, deflection, speed, force)
