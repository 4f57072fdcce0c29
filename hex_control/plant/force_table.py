"""Force table, rotational compliance, stiction, runout and force sensor (seed 002 section 7.2).

- Position loop (7.3): X/X_c = b1 b2/((s + b1)(s + b2)), b1 = 2 pi 9 Hz, b2 = 2 pi 40 Hz,
  or the third-order model of (7.2) that Appendix B derives from the motor, amplifier
  and LVDT constants (:func:`appendix_b_position_loop`); either is discretized exactly
  (zero-order hold) at the internal step.
- Stiction: the DC motor hesitates on direction reversal, equivalent to about 4.8 N of
  normal force (Fig. 7-5). Modelled as a play (backlash) operator on the command of width
  stiction_n / K_x: the servo follows a command only once it has moved that far the other way.
- Compliance (7.1): K_x = K_theta / R^2 (the cell's 6e5 N mm/rad and 85 mm: 83 N/mm); the
  normal force is K_x (x - x_contact) in contact and zero once contact is lost (8.1).
- Disk runout (7.3): a force K_x * runout * sin(phase) while in contact, the phase advancing
  at the disk rotation frequency; the air motor slows under load (eq. 4.8, omega = omega_0 -
  beta R F_t), here linearly in the normal force, so 50 Hz idle falls towards 20 Hz.
- Force sensor (7.2): a 2-pole low-pass (30 Hz, damping 0.707) plus white noise.
Units: mm, N, s. Deterministic for a given seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hex_control.config import cell_default
from hex_control.control.discretize import controller_canonical, zero_order_hold


@dataclass(frozen=True)
class ForceTableParameters:
    pole1_hz: float = 9.0
    pole2_hz: float = 40.0
    # the disk's mount and radius: the cell's (config/cell.yaml disk.spring_n_mm_rad, process.disk_radius_mm)
    rotational_stiffness_n_mm_rad: float = field(default_factory=cell_default("disk.spring_n_mm_rad"))
    disk_radius_mm: float = field(default_factory=cell_default("process.disk_radius_mm"))
    stiction_n: float = 4.8
    runout_mm: float = 0.0
    disk_frequency_hz: float = 35.0  # at zero force
    disk_slowdown_hz_per_n: float = 0.0  # air motor droop; the frequency never goes below 5 Hz
    sensor_cutoff_hz: float = 30.0
    sensor_damping: float = 0.707
    sensor_noise_n: float = 0.0
    contact_mm: float = field(default_factory=cell_default("table.contact_mm"))  # where the disk touches the work
    position_loop: str = "two_pole"  # "two_pole" (eq. 7.3) or "third_order" (eq. 7.2, App. B)

    @property
    def stiffness_n_per_mm(self) -> float:
        """K_x = K_theta / R^2 (N/mm, eq. 7.1b)."""
        return self.rotational_stiffness_n_mm_rad / self.disk_radius_mm**2


def appendix_b_position_loop(inertia_in_lb_s_per_krpm: float = 9.313e-3, friction_in_lb_per_krpm: float = 0.063,
                             amplifier_a_per_v: float = 36.7, torque_in_lb_per_a: float = 0.363,
                             tachometer_v_per_krpm: float = 3.09, *, r28: float = 1.00, r53: float = 0.806,
                             lvdt_v_per_in: float = 41.878, pitch_rev_per_in: float = 5.0,
                             pole_rad_s: float = 1100.0, zero_rad_s: float = 5000.0):
    """(num, den) of X/X_c, eq. 7.2, from the block diagram of Fig. B-7 (Appendix B.4).

    x = [1/(c s)] [K_T/(J_2 s + B_2)] [(s/z_a + 1)/(s/p_a + 1)] K_3 e,
    e = R28 x_c - R53 D_T w - D_L x,  w = c s x,  c = 60 p / 1e3 kRPM per in/s,
    with x_c in the LVDT's units (x_c = D_L x at rest) so the DC gain is one. The printed
    closed form (B.4) has typesetting slips (B_2 for 1, a missing c), so it is re-derived;
    B_2 is not given for the loaded table, so the motor's B_1 stands in (it is dominated by
    the tachometer term). With the thesis's p_a = 1100 rad/s and z_a = 5000 rad/s the poles
    are 9.0 Hz (real) and a pair at 313 Hz (damping 0.47): the 9 Hz pole of eq. 7.3."""
    c = 60.0 * pitch_rev_per_in / 1e3
    gain = amplifier_a_per_v * torque_in_lb_per_a
    numerator = gain * np.array([1.0 / zero_rad_s, 1.0])
    plant = c * np.polymul([1.0, 0.0], np.polymul([inertia_in_lb_s_per_krpm, friction_in_lb_per_krpm],
                                                  [1.0 / pole_rad_s, 1.0]))
    feedback = np.polymul(numerator, [r53 * tachometer_v_per_krpm * c, lvdt_v_per_in])
    den = np.polyadd(plant, feedback)
    num = r28 * lvdt_v_per_in * numerator
    return num / den[0], den / den[0]


def position_loop(kind: str, pole1_hz: float = 9.0, pole2_hz: float = 40.0):
    """(num, den) of the table's position loop X/X_c: "two_pole" (7.3) or "third_order" (7.2)."""
    if kind == "two_pole":
        b1, b2 = 2 * math.pi * pole1_hz, 2 * math.pi * pole2_hz
        return np.array([b1 * b2]), np.polymul([1.0, b1], [1.0, b2])
    if kind == "third_order":
        return appendix_b_position_loop()
    raise ValueError(f"position_loop must be 'two_pole' or 'third_order', got {kind!r}")


def _discrete(a, b, dt):
    ad, bd = zero_order_hold(a, np.asarray(b, float).reshape(-1, 1), dt)
    return ad, bd[:, 0]


class ForceTable:
    """One internal step at a time: ``step(command_mm)``; read ``force_n`` / ``measured_n``."""

    def __init__(self, parameters: ForceTableParameters = ForceTableParameters(), step_s: float = 1e-3,
                 seed: int = 0):
        if not step_s > 0:
            raise ValueError("step_s must be > 0")
        self.p, self.step_s = parameters, step_s
        loop = position_loop(parameters.position_loop, parameters.pole1_hz, parameters.pole2_hz)
        a, b, c = controller_canonical(*loop)
        self._table = _discrete(a, b[:, 0], step_s)
        self._output = c
        self._rest = -np.linalg.solve(a, b[:, 0])  # state at rest per mm of command (unit DC gain)
        w = 2 * math.pi * parameters.sensor_cutoff_hz
        self._sensor = _discrete([[0, 1], [-w * w, -2 * parameters.sensor_damping * w]], [0, w * w], step_s)
        self._rng = np.random.default_rng(seed)
        self._stiffness = parameters.stiffness_n_per_mm  # K_x, and the stiction's play in table mm
        self._play = parameters.stiction_n / self._stiffness
        self.surface_mm = None  # the work's table position when something else sets it (the grinding cell)
        self.reset()

    def reset(self, position_mm: float = 0.0) -> None:
        self.time_s = 0.0
        self.disk_phase_rad = 0.0
        self._x = self._rest * position_mm
        self._servo_command = position_mm
        self.force_n = self._force(position_mm)
        self._s = np.array([self.force_n, 0.0])
        self.measured_n = self.force_n

    @property
    def position_mm(self) -> float:
        return float(self._output @ self._x)

    @property
    def disk_frequency_hz(self) -> float:
        return max(self.p.disk_frequency_hz - self.p.disk_slowdown_hz_per_n * self.force_n, 5.0)

    def _force(self, position_mm: float) -> float:
        depth = position_mm - (self.p.contact_mm if self.surface_mm is None else self.surface_mm)
        if depth <= 0:
            return 0.0
        k = self.p.stiffness_n_per_mm
        runout = k * self.p.runout_mm * math.sin(self.disk_phase_rad)
        return max(k * depth + runout, 0.0)

    def step(self, command_mm: float) -> None:
        self.advance(command_mm, 1)

    def advance(self, command_mm: float, steps: int) -> None:
        """``steps`` internal steps holding ``command_mm``: the same operations, in the same
        order, as ``steps`` calls of :meth:`step` (bit for bit), without their per-call cost
        (the plant runs five a control period); the sensor noise drawn at once, which draws
        the same numbers."""
        if not math.isfinite(command_mm):
            raise ValueError("the table command must be finite")
        p, k, play = self.p, self._stiffness, self._play
        ad, bd = self._table
        sd, sb = self._sensor
        output, dt = self._output, self.step_s
        contact = p.contact_mm if self.surface_mm is None else self.surface_mm
        runout_n = k * p.runout_mm  # (k * runout) * sin: as _force groups it
        noise = self._rng.normal(0.0, p.sensor_noise_n, steps).tolist() if p.sensor_noise_n > 0 else None
        servo, x, sensed = self._servo_command, self._x, self._s
        time_s, phase, force = self.time_s, self.disk_phase_rad, self.force_n
        for step in range(steps):
            gap = command_mm - servo
            if abs(gap) > play:
                servo = command_mm - math.copysign(play, gap)
            x = ad @ x + bd * servo
            time_s += dt
            frequency = max(p.disk_frequency_hz - p.disk_slowdown_hz_per_n * force, 5.0)
            phase = (phase + 2 * math.pi * frequency * dt) % (2 * math.pi)
            depth = float(output @ x) - contact
            force = max(k * depth + runout_n * math.sin(phase), 0.0) if depth > 0 else 0.0
            sensed = sd @ sensed + sb * force
            measured = float(sensed[0]) + (noise[step] if noise is not None else 0.0)
        self._servo_command, self._x, self._s = servo, x, sensed
        self.time_s, self.disk_phase_rad, self.force_n, self.measured_n = time_s, phase, force, measured


def simulate_force_loop(table: ForceTable, controller, setpoint, control_period_s: float, duration_s: float):
    """Sampled-data loop: every control period the controller (a force law, see
    :mod:`hex_control.control.force_law`) reads the measured force and sets the table
    command, held between samples. ``setpoint(t)`` gives the desired force.
    Returns dict of arrays at the control instants: time, setpoint, force, measured, command."""
    substeps = round(control_period_s / table.step_s)
    if abs(substeps * table.step_s - control_period_s) > 1e-12 or substeps < 1:
        raise ValueError("the control period must be a whole number of internal steps")
    samples = int(round(duration_s / control_period_s))
    log = {name: np.empty(samples) for name in ("time", "setpoint", "force", "measured", "command")}
    for k in range(samples):
        t = k * control_period_s
        desired = setpoint(t)
        command = controller.command(desired, table.measured_n)
        log["time"][k], log["setpoint"][k], log["force"][k] = t, desired, table.force_n
        log["measured"][k], log["command"][k] = table.measured_n, command
        table.advance(command, substeps)
    return log
