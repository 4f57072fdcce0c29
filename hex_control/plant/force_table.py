"""Force table, rotational compliance, stiction, runout and force sensor (seed 002 section 7.2).

- Position loop (7.3): X/X_c = b1 b2/((s + b1)(s + b2)), b1 = 2 pi 9 Hz, b2 = 2 pi 40 Hz,
  discretized exactly (zero-order hold) at the internal step.
- Stiction: the DC motor hesitates on direction reversal, equivalent to about 4.8 N of
  normal force (Fig. 7-5). Modelled as a play (backlash) operator on the command of width
  stiction_n / K_x: the servo follows a command only once it has moved that far the other way.
- Compliance (7.1): K_x = K_theta / R^2 (K_theta = 6e5 N mm/rad, R = 85 mm: 83 N/mm); the
  normal force is K_x (x - x_contact) in contact and zero once contact is lost (8.1).
- Disk runout (7.3): a force K_x * runout * sin(2 pi f_disk t) while in contact.
- Force sensor (7.2): a 2-pole low-pass (30 Hz, damping 0.707) plus white noise.
Units: mm, N, s. Deterministic for a given seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import cont2discrete


@dataclass(frozen=True)
class ForceTableParameters:
    pole1_hz: float = 9.0
    pole2_hz: float = 40.0
    rotational_stiffness_n_mm_rad: float = 6e5
    disk_radius_mm: float = 85.0
    stiction_n: float = 4.8
    runout_mm: float = 0.0
    disk_frequency_hz: float = 35.0
    sensor_cutoff_hz: float = 30.0
    sensor_damping: float = 0.707
    sensor_noise_n: float = 0.0
    contact_mm: float = 0.0  # table position where the disk touches the work

    @property
    def stiffness_n_mm(self) -> float:
        """K_x = K_theta / R^2 (eq. 7.1b)."""
        return self.rotational_stiffness_n_mm_rad / self.disk_radius_mm**2


def _discrete(a, b, dt):
    ad, bd, *_ = cont2discrete((np.asarray(a, float), np.asarray(b, float).reshape(-1, 1),
                                np.eye(len(a)), np.zeros((len(a), 1))), dt, method="zoh")
    return ad, bd[:, 0]


class ForceTable:
    """One internal step at a time: ``step(command_mm)``; read ``force_n`` / ``measured_n``."""

    def __init__(self, parameters: ForceTableParameters = ForceTableParameters(), step_s: float = 1e-3,
                 seed: int = 0):
        if not step_s > 0:
            raise ValueError("step_s must be > 0")
        self.p, self.step_s = parameters, step_s
        b1, b2 = 2 * math.pi * parameters.pole1_hz, 2 * math.pi * parameters.pole2_hz
        # x'' + (b1 + b2) x' + b1 b2 x = b1 b2 u
        self._table = _discrete([[0, 1], [-b1 * b2, -(b1 + b2)]], [0, b1 * b2], step_s)
        w = 2 * math.pi * parameters.sensor_cutoff_hz
        self._sensor = _discrete([[0, 1], [-w * w, -2 * parameters.sensor_damping * w]], [0, w * w], step_s)
        self._rng = np.random.default_rng(seed)
        self.reset()

    def reset(self, position_mm: float = 0.0) -> None:
        self.time_s = 0.0
        self._x = np.array([position_mm, 0.0])
        self._servo_command = position_mm
        self.force_n = self._force(position_mm)
        self._s = np.array([self.force_n, 0.0])
        self.measured_n = self.force_n

    @property
    def position_mm(self) -> float:
        return float(self._x[0])

    def _force(self, position_mm: float) -> float:
        depth = position_mm - self.p.contact_mm
        if depth <= 0:
            return 0.0
        k = self.p.stiffness_n_mm
        runout = k * self.p.runout_mm * math.sin(2 * math.pi * self.p.disk_frequency_hz * self.time_s)
        return max(k * depth + runout, 0.0)

    def step(self, command_mm: float) -> None:
        if not math.isfinite(command_mm):
            raise ValueError("the table command must be finite")
        play = self.p.stiction_n / self.p.stiffness_n_mm
        gap = command_mm - self._servo_command
        if abs(gap) > play:
            self._servo_command = command_mm - math.copysign(play, gap)
        ad, bd = self._table
        self._x = ad @ self._x + bd * self._servo_command
        self.time_s += self.step_s
        self.force_n = self._force(self._x[0])
        sd, sb = self._sensor
        self._s = sd @ self._s + sb * self.force_n
        noise = self._rng.normal(0.0, self.p.sensor_noise_n) if self.p.sensor_noise_n > 0 else 0.0
        self.measured_n = float(self._s[0]) + noise


def simulate_force_loop(table: ForceTable, controller, setpoint, control_period_s: float, duration_s: float):
    """Sampled-data loop: every control period the controller reads the measured force and
    sets the table command, held between samples. ``setpoint(t)`` gives the desired force.
    Returns dict of arrays at the control instants: time, setpoint, force, measured, command."""
    substeps = round(control_period_s / table.step_s)
    if abs(substeps * table.step_s - control_period_s) > 1e-12 or substeps < 1:
        raise ValueError("the control period must be a whole number of internal steps")
    samples = int(round(duration_s / control_period_s))
    log = {name: np.empty(samples) for name in ("time", "setpoint", "force", "measured", "command")}
    for k in range(samples):
        t = k * control_period_s
        desired = setpoint(t)
        command = controller.step(desired - table.measured_n)
        log["time"][k], log["setpoint"][k], log["force"][k] = t, desired, table.force_n
        log["measured"][k], log["command"][k] = table.measured_n, command
        for _ in range(substeps):
            table.step(command)
    return log
