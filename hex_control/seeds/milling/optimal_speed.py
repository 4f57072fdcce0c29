"""Optimal-linear spindle-speed control, seed 004 eq. 15-18 with the limitation of section 3.

The speed enters the cut through the delay tau = 60/(n z): a change dn moves the surface the
previous tooth left by w'(t - tau) tau/n dn, so the cutting force gains
dF = B_u dn with B_u = -a_p k_d K(t) w'(t - tau) tau / n (eq. 16; K(t) the teeth's directional
matrix of the linearized eq. 11-12, as in semi_discretization). In the mass-normalized modal
coordinates of the tool (M = I, K = Omega^2) the energy-index command (18) over one control
period Delta is

    u = dn = -R^-1 G^T [Q1 eta' ; Q2 Omega^2 (eta - eta_bar)],   G = int_0^Delta e^(A s) ds [0; phi] B_u,

eta_bar the static deflection under the mean cutting force (eq. 4), each plane summed, and
|u| limited to the spindle's acceleration times Delta (eq. 10). Applied alone the speed
climbs without end (the seed says so): once it reaches n_max it ramps down linearly to n0
over fall_s, and the optimal command resumes (the optimal-linear programme).

K* of eq. 18 is eq. 14's: the tool's Omega^2 plus the cut's proportional feedback, the
cutting stiffness -phi phi^T (x) a_p k_d K(t) coupling the two planes (with
``cutting_stiffness=False``, the tool's alone). At the case's depth the cut's term is about
5 % of the tool's tip stiffness; eq. 18 uses its symmetric part, and eta_bar = K*^-1 f0.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

from hex_control.seeds.milling.cutting import Cut, cutting_force
from hex_control.seeds.milling.semi_discretization import directional_matrix
from hex_control.seeds.milling.tool_beam import ToolModes


def mean_cutting_force(cut: Cut, samples: int = 720) -> np.ndarray:
    """f0 (N, (x, y)): the static cutting force averaged over a revolution, tool at rest."""
    pitch = 2 * math.pi / cut.teeth
    angles = np.linspace(0, 2 * math.pi, samples, endpoint=False)
    return np.mean([cutting_force(cut, [a + pitch * l for l in range(cut.teeth)], (0.0, 0.0), (0.0, 0.0))
                    for a in angles], axis=0)


class OptimalLinearSpeed:
    """A spindle programme (``speed_rpm(time_s, simulator)``) driven by eq. 18."""

    def __init__(self, modes: ToolModes, cut: Cut, nominal_rpm: float, max_rpm: float, *, fall_s: float,
                 acceleration_rpm_s: float, q1: float = 1.0, q2: float = 1.0, r: float = 1e-12,
                 control_period_s: float = 1e-3, cutting_stiffness: bool = True):
        if not (0 < nominal_rpm < max_rpm and fall_s > 0 and acceleration_rpm_s > 0 and r > 0
                and control_period_s > 0):
            raise ValueError("need 0 < nominal_rpm < max_rpm and positive fall_s, acceleration_rpm_s, r, "
                             "control_period_s")
        self.cut, self.n0, self.n_max = cut, nominal_rpm, max_rpm
        self.fall_rpm_s = (max_rpm - nominal_rpm) / fall_s
        self.limit_rpm = acceleration_rpm_s * control_period_s  # U of eq. 10, per control period
        self.q1, self.q2, self.r, self.period_s = q1, q2, r, control_period_s
        m = modes.omega_rad_s.size
        self.m, self.omega2 = m, modes.omega_rad_s ** 2
        a = np.zeros((2 * m, 2 * m))
        a[:m, m:] = np.eye(m)
        a[m:, :m] = -np.diag(self.omega2)
        a[m:, m:] = -np.diag(2 * modes.damping * modes.omega_rad_s)
        block = np.zeros((4 * m, 4 * m))  # int_0^Delta e^(A s) ds from [[A, I], [0, 0]]
        block[:2 * m, :2 * m], block[:2 * m, 2 * m:] = a, np.eye(2 * m)
        integral = expm(block * control_period_s)[:2 * m, 2 * m:]
        self.g = integral @ np.concatenate([np.zeros(m), modes.tip_shape])  # per unit tip force
        self.shape, self.f0 = modes.tip_shape, mean_cutting_force(cut)
        self.eta_bar = np.outer(modes.tip_shape / self.omega2, self.f0)  # (m, 2), the tool's K alone
        self.cutting_stiffness = cutting_stiffness
        self.speed, self.falling, self.next_control_s, self.last_time_s = nominal_rpm, False, 0.0, 0.0
        self.commands: list[tuple[float, float]] = []  # (time_s, u rev/min) of every control step

    @property
    def initial_rpm(self) -> float:
        return self.n0

    def command_rpm(self, simulator) -> float:
        """u = dn of eq. 18 (rev/min), limited by eq. 10."""
        x, m = simulator.modal_state, self.m
        kbar = directional_matrix(self.cut, [simulator.tooth_angles_rad[0]])[0]
        velocity_term = self.q1 * (self.g[m:] @ x[m:])  # per plane (x, y)
        if self.cutting_stiffness:  # K* = Omega^2 - phi phi^T (x) a_p k_d K(t) (eq. 14)
            cutting = self.cut.depth_m * self.cut.cutting_pressure_pa * kbar
            k_star = (np.kron(np.eye(2), np.diag(self.omega2))
                      - np.kron(cutting, np.outer(self.shape, self.shape)))  # [eta_x; eta_y] ordering
            eta_bar = np.linalg.solve(k_star, np.kron(self.f0, self.shape)).reshape(2, m).T
            error = (x[:m] - eta_bar).T.reshape(-1)
            position_term = self.q2 * (np.kron(np.eye(2), self.g[:m]) @ (0.5 * (k_star + k_star.T) @ error))
        else:
            position_term = self.q2 * (self.g[:m] @ (self.omega2[:, None] * (x[:m] - self.eta_bar)))
        weights = velocity_term + position_term
        b_u = (-self.cut.depth_m * self.cut.cutting_pressure_pa * simulator.delay_s / self.speed
               * kbar @ np.asarray(simulator.delayed_velocity_m_s))
        u = -float(b_u @ weights) / self.r
        return min(max(u, -self.limit_rpm), self.limit_rpm)

    def speed_rpm(self, time_s: float, simulator) -> float:
        dt, self.last_time_s = time_s - self.last_time_s, time_s
        if self.falling:
            self.speed -= self.fall_rpm_s * dt
            if self.speed <= self.n0:
                self.speed, self.falling = self.n0, False
        elif time_s >= self.next_control_s:
            self.next_control_s += self.period_s
            u = self.command_rpm(simulator)
            self.commands.append((time_s, u))
            self.speed = max(self.n0, self.speed + u)
            if self.speed >= self.n_max:
                self.speed, self.falling = self.n_max, True
        return self.speed
