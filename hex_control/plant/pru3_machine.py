"""The 3-PRU head as the plant's machine: the rigid-body dynamics of seed 001 section 2.2
under the head's own slider drives, with the structural mode of :mod:`hex_control.plant.machine`.

The drives take slider-length commands c (what /plant/strut_command carries) and push the
sliders with forces tau through one of two laws (seed 001 section 3):

    lspd: tau = K_p (c - L) - K_v L' + b(q, q')      link-space PD, bias compensated
    ctc:  tau = A(q) q''_c + b(q, q'),  J q''_c + J' q' = w_s^2 (c - L) - 2 zeta_s w_s L'

with A = J^-T M and b = J^-T h (:func:`~hex_control.kinematics.pru3_dynamics.actuator_dynamics`).
The computed torque makes every slider the generic second-order servo exactly; the PD
leaves the platform's configuration-dependent inertia and its coupling between sliders
to the feedback, so its response changes across the workspace. K_p and K_v default to
the servo frequency and damping on the sliders' effective mass at the home pose.

Integration: one dynamics evaluation costs about a millisecond, so M, h, J and J' q' are
evaluated once per ``refresh_s`` (the control period) at the current state and held over
it; with them held the closed loop is linear, and it is stepped exactly (matrix
exponential) at the internal step. The state itself -- q, q', the mode -- is carried
exactly across refreshes, so holding only delays the configuration dependence by at most
one period (tested against adaptive integration of the unheld dynamics).

On a feed stage (``feed_stroke_mm``) a fourth joint, the stage, follows its command
through the generic second-order servo; it is stiff across the bead and does not drive
the mode.

Units: lengths and commands in m at the interface (as the generic machine), mm inside;
q = (z mm, alpha rad, beta rad); forces in N; deflection in mm; time in s.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from hex_control.kinematics.pru3 import HOME_Q, Pru3Geometry, forward_kinematics, inverse_kinematics, velocity_jacobian
from hex_control.kinematics.pru3_dynamics import KG_MM_S2_PER_N, Pru3Inertia, generalized_dynamics
from hex_control.plant.machine import Machine, MachineParameters

PRU3_SLIDER_DRIVES = ("lspd", "ctc")


def effective_slider_mass_kg(geometry: Pru3Geometry, inertia: Pru3Inertia, q=HOME_Q) -> float:
    """Mean diagonal of the link-space inertia J^-T M J^-1 (kg) at q."""
    m_gen, _, jac = generalized_dynamics(geometry, inertia, q, np.zeros(3))
    inverse = np.linalg.inv(jac[0])
    return float(np.trace(inverse.T @ m_gen[0] @ inverse) / 3)


class Pru3Machine:
    """Same interface as :class:`~hex_control.plant.machine.Machine`: three sliders, then
    the feed stage if the geometry has one. ``parameters`` describe the sliders' servo."""

    def __init__(self, geometry: Pru3Geometry = Pru3Geometry(), inertia: Pru3Inertia = Pru3Inertia(),
                 parameters: MachineParameters = MachineParameters(struts=3, participation=1 / 3),
                 step_s: float = 1e-3, *, drive: str = "lspd", refresh_s: float = 0.005,
                 gains_n_per_mm: tuple[float, float] | None = None):
        if parameters.struts != 3:
            raise ValueError("the 3-PRU has three sliders")
        if drive not in PRU3_SLIDER_DRIVES:
            raise ValueError(f"drive must be one of {PRU3_SLIDER_DRIVES}, got {drive!r}")
        self.refresh_steps = round(refresh_s / step_s)
        if not (step_s > 0 and self.refresh_steps >= 1 and abs(self.refresh_steps * step_s - refresh_s) < 1e-9):
            raise ValueError("refresh_s must be a whole number (>= 1) of step_s > 0")
        self.geometry, self.inertia, self.step_s, self.drive = geometry, inertia, step_s, drive
        self.feed = None if geometry.feed_stroke_mm is None else \
            Machine(replace(parameters, struts=1, participation=0.0), step_s)
        self.p = replace(parameters, struts=len(geometry.joint_names))
        self.servo_w = 2 * math.pi * parameters.servo_frequency_hz
        if gains_n_per_mm is None:
            mass = effective_slider_mass_kg(geometry, inertia) / KG_MM_S2_PER_N  # N s^2/mm
            gains_n_per_mm = (mass * self.servo_w**2, 2 * parameters.servo_damping * self.servo_w * mass)
        self.kp_n_per_mm, self.kv_n_s_per_mm = (float(g) for g in gains_n_per_mm)
        self.reset(np.append(inverse_kinematics(geometry, HOME_Q).lengths_mm[0] / 1000.0, [0.0] * (self.p.struts - 3)))

    def reset(self, lengths_m) -> None:
        """At rest at these joint positions (m)."""
        lengths = self._joints(lengths_m)
        if self.feed is not None:
            self.feed.reset(lengths[3:])
        self.q, _ = forward_kinematics(self.geometry, lengths[:3] * 1000.0, HOME_Q, tolerance_mm=1e-9)
        self.q_dot = np.zeros(3)
        self.mode = np.zeros(2)  # y (mm), y' (mm/s)
        self.time_s, self._held = 0.0, 0
        self._refresh()

    def _joints(self, values_m) -> np.ndarray:
        values = np.asarray(values_m, float).reshape(-1)
        if values.shape != (self.p.struts,) or not np.all(np.isfinite(values)):
            raise ValueError(f"need {self.p.struts} finite joint positions (m)")
        return values

    def check_command(self, lengths_m) -> None:
        """Raise ValueError unless these joint positions (m) are in stroke and place the
        platform within its tilt limits (:meth:`Pru3Geometry.check_joint_positions_mm`,
        solved from the pose now)."""
        self.geometry.check_joint_positions_mm(self._joints(lengths_m) * 1000.0, self.pose_q)

    @property
    def lengths_m(self) -> np.ndarray:
        sliders = (self._lengths0 + self._jac @ self._dq) / 1000.0
        return sliders if self.feed is None else np.append(sliders, self.feed.lengths_m)

    @property
    def speeds_m_s(self) -> np.ndarray:
        sliders = self._jac @ self.q_dot / 1000.0
        return sliders if self.feed is None else np.append(sliders, self.feed.speeds_m_s)

    @property
    def deflection_mm(self) -> float:
        return float(self.mode[0])

    @property
    def pose_q(self) -> np.ndarray:
        """(z mm, alpha rad, beta rad) now."""
        return self.q + self._dq

    def step(self, commands_m) -> None:
        commands = self._joints(commands_m)
        if self.feed is not None:
            self.feed.step(commands[3:])
        commands = commands[:3]
        if self._held == self.refresh_steps:
            self.q, self._held = self.q + self._dq, 0
            self._refresh()
        state = np.concatenate([self._dq, self.q_dot, self.mode])
        state = self._ad @ state + self._bd @ np.append(commands * 1000.0, 1.0)
        self._dq, self.q_dot, self.mode = state[:3], state[3:6], state[6:]
        self._held += 1
        self.time_s += self.step_s

    def advance(self, commands_m, steps: int) -> None:
        """``steps`` internal steps holding ``commands_m`` (as many calls of :meth:`step`)."""
        for _ in range(steps):
            self.step(commands_m)

    def _refresh(self) -> None:
        """Evaluate the dynamics at (q, q') and discretize the held closed loop."""
        q, q_dot = self.q, self.q_dot
        eps = 1e-5  # J' q' by a central difference of J along q'
        around = np.stack([q, q + eps * q_dot, q - eps * q_dot])
        pose = inverse_kinematics(self.geometry, around)
        if not pose.reachable[0]:
            raise FloatingPointError(f"the 3-PRU left its workspace at q = {q}")
        jacs = velocity_jacobian(self.geometry, around, pose)
        jac, jdq = jacs[0], (jacs[1] - jacs[2]) @ q_dot / (2 * eps)
        self._lengths0, self._jac, self._dq = pose.lengths_mm[0], jac, np.zeros(3)
        # q'' = F s + G [c; 1] with s = [dq, q'], L = L0 + J dq, L' = J q'
        if self.drive == "ctc":
            w, z = self.servo_w, self.p.servo_damping  # J^-1 [-w^2 J, -2 zeta w J] = [-w^2, -2 zeta w]
            f = np.hstack([-w**2 * np.eye(3), -2 * z * w * np.eye(3)])
            g = np.linalg.solve(jac, np.hstack([w**2 * np.eye(3), (-w**2 * self._lengths0 - jdq)[:, None]]))
        else:  # M q'' = 1000 J^T tau - h, and the drive's bias term J^-T h / 1000 cancels h
            m_gen, _, _ = generalized_dynamics(self.geometry, self.inertia, q, q_dot)
            drive = KG_MM_S2_PER_N * np.linalg.solve(m_gen[0], jac.T)  # q'' per N of slider force
            f = drive @ np.hstack([-self.kp_n_per_mm * jac, -self.kv_n_s_per_mm * jac])
            g = drive @ np.hstack([self.kp_n_per_mm * np.eye(3), (-self.kp_n_per_mm * self._lengths0)[:, None]])
        # the mode: y'' = -w_m^2 y - 2 zeta_m w_m y' - p sum(L''), L'' = J q'' + J' q'
        wm, zm, part = 2 * math.pi * self.p.mode_frequency_hz, self.p.mode_damping, self.p.participation
        a = np.zeros((8, 8))
        b = np.zeros((8, 4))
        a[:3, 3:6] = np.eye(3)
        a[3:6, :6], b[3:6] = f, g
        a[6, 7] = 1.0
        a[7, 6:] = (-wm**2, -2 * zm * wm)
        a[7, :6] = -part * (jac @ f).sum(axis=0)
        b[7] = -part * (jac @ g).sum(axis=0)
        b[7, 3] -= part * jdq.sum()
        block = np.zeros((12, 12))
        block[:8, :8], block[:8, 8:] = a * self.step_s, b * self.step_s
        discrete = _exponential(block)
        self._ad, self._bd = discrete[:8, :8], discrete[:8, 8:]


def _exponential(block: np.ndarray, terms: int = 12) -> np.ndarray:
    """exp(block) by scaling and squaring a Taylor series: for these small matrices many
    times cheaper than scipy's Pade expm (called once per control period)."""
    squarings = max(0, math.ceil(math.log2(max(np.linalg.norm(block, 1), 1e-300))) + 1)
    scaled = block / 2.0**squarings
    total = term = np.eye(len(block))
    for k in range(1, terms):
        term = term @ scaled / k
        total = total + term
    for _ in range(squarings):
        total = total @ total
    return total
