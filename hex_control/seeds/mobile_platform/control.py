"""Controllers of the platform's two drives (seed 004 section 4): the optimal control at the
energy performance index (eq. 19-21) and the two-PID reference.

Both share the outer, kinematic loop of eq. 19: H's desired velocity plus the correcting
velocity (H_bar - H) / (k Delta t), turned into the platform's speed and turn rate by
inverse kinematics of H (v = cos b x' + sin b y', w = (-sin b x' + cos b y') / d) and into
wheel rates. They differ in how they drive the wheels to those rates:

- energy index (eq. 21): with q' the wheel rates, M* the platform's mass matrix in them,
  and the drives' linear model M* q'' = -L* q' + B_u U, the command over one sampling
  period Delta t is u = -(R + R^T)^-1 G^T (M*^T Q1^T + Q1 M*) (q' - q_bar' - q_hat'),
  G = int_0^Delta e^(A s) ds B. Eq. 21 is a variation about the desired motion (eq. 7: the
  control does not change the desired trajectory), so the voltage is U = U_0 + u with U_0
  the model's voltage for the desired motion itself (inertia, the a-offset's terms, back
  EMF; no friction: the model does not know it). Q1 = q1 I and R = r I: only q1 / r matters,
  and (R + R^T)^-1 (M*^T Q1^T + Q1 M*) = (q1 / r) M*: the 1/2 of (R + R^T)^-1 = (2 r)^-1
  cancels the 2 of the symmetrized M*, so the feedback is (q1 / r) G^T M*.
- two PIDs: one on the speed error, one on the turn-rate error, U_1,2 = U_v -/+ U_w, with
  the derivative filtered and the integrators held while a drive saturates.

Voltages are limited to +-U_max (eq. 10). SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from hex_control.seeds.mobile_platform.model import PlatformParameters


@dataclass(frozen=True)
class PlatformState:
    """x_A, y_A (m), beta (rad), v (m/s), w (rad/s)."""

    x_m: float
    y_m: float
    beta_rad: float
    v_m_s: float
    w_rad_s: float

    def point_h(self, d_m: float) -> np.ndarray:
        return np.array([self.x_m + d_m * math.cos(self.beta_rad), self.y_m + d_m * math.sin(self.beta_rad)])


def commanded_motion(model: PlatformParameters, state: PlatformState, desired, k: float, period_s: float):
    """(v, w) that move H at its desired velocity plus eq. 19's correction."""
    h_bar, h_bar_dot = desired[0], desired[1]
    correction = (h_bar - state.point_h(model.point_h_ahead_m)) / (k * period_s)  # eq. 19
    hx, hy = h_bar_dot + correction
    s, c = math.sin(state.beta_rad), math.cos(state.beta_rad)
    return c * hx + s * hy, (-s * hx + c * hy) / model.point_h_ahead_m


def wheel_rate_matrix(model: PlatformParameters) -> np.ndarray:
    """J with (v, w) = J (theta_1', theta_2')."""
    r, b = model.wheel_radius_m, model.half_track_m
    return np.array([[r / 2, r / 2], [-r / (2 * b), r / (2 * b)]])


class EnergyIndexController:
    def __init__(self, model: PlatformParameters, gain: float, k: float, period_s: float):
        """gain: q1 / r of eq. 21 (V^2 s / (kg m^2)); k: eq. 19's scaling."""
        if not (gain > 0 and k > 0 and period_s > 0):
            raise ValueError("gain, k and period_s must be > 0")
        self.model, self.gain, self.k, self.period_s = model, gain, k, period_s
        j = wheel_rate_matrix(model)
        self.mass = j.T @ np.diag(model.quasi_mass) @ j  # M* in wheel rates
        drive = model.gear_ratio * model.torque_constant_n_m_a / model.armature_resistance_ohm
        self.drive_n_m_v = drive
        a = -np.linalg.solve(self.mass, drive * model.gear_ratio * model.torque_constant_n_m_a * np.eye(2))
        b = np.linalg.solve(self.mass, drive * np.eye(2))
        block = np.zeros((4, 4))
        block[:2, :2], block[:2, 2:] = a, b
        g = expm(block * period_s)[:2, 2:]  # int_0^Delta e^(A s) ds B
        r_matrix, q1_matrix = np.eye(2), gain * np.eye(2)  # R = r I with r = 1, Q1 = (q1 / r) I
        self.feedback = np.linalg.solve(r_matrix + r_matrix.T,  # (R + R^T)^-1 G^T (M*^T Q1^T + Q1 M*)
                                        g.T @ (self.mass.T @ q1_matrix.T + q1_matrix @ self.mass))
        self.inverse_rates = np.linalg.inv(j)

    def desired_voltage(self, v: float, w: float, accelerations) -> np.ndarray:
        """U_0: the model's voltages for the desired motion (v, w, v', w')."""
        m = self.model
        ma = m.mass_kg * m.mass_ahead_m
        m_v, m_w = m.quasi_mass
        force = m_v * accelerations[0] - ma * w * w
        moment = m_w * accelerations[1] + ma * v * w
        r, b = m.wheel_radius_m, m.half_track_m
        torques = np.array([r / 2 * (force - moment / b), r / 2 * (force + moment / b)])
        rates = self.inverse_rates @ (v, w)
        return torques / self.drive_n_m_v + m.gear_ratio * m.torque_constant_n_m_a * rates

    def voltages(self, time_s: float, state: PlatformState, desired) -> np.ndarray:
        v_cmd, w_cmd = commanded_motion(self.model, state, desired, self.k, self.period_s)
        error = self.inverse_rates @ (state.v_m_s - v_cmd, state.w_rad_s - w_cmd)  # q' - q_bar' - q_hat'
        u = -self.feedback @ error  # eq. 21
        limit = self.model.voltage_limit_v
        return np.clip(self.desired_voltage(desired[3], desired[4], desired[5]) + u, -limit, limit)  # eq. 10


class TwoPidController:
    def __init__(self, model: PlatformParameters, speed_gains, turn_gains, k: float, *, period_s: float,
                 derivative_filter_s: float = 0.05):
        """speed_gains, turn_gains: (kp, ki, kd) in V per (m/s) and V per (rad/s)."""
        if not (k > 0 and period_s > 0) or min(*speed_gains, *turn_gains) < 0:
            raise ValueError("gains must be >= 0, k and period_s > 0")
        self.model, self.k, self.period_s = model, k, period_s
        self.gains = (tuple(speed_gains), tuple(turn_gains))
        self.alpha = period_s / (derivative_filter_s + period_s)
        self.integral = [0.0, 0.0]
        self.derivative = [0.0, 0.0]
        self.previous = [None, None]
        self.saturated = False

    def voltages(self, time_s: float, state: PlatformState, desired) -> np.ndarray:
        v_cmd, w_cmd = commanded_motion(self.model, state, desired, self.k, self.period_s)
        out = []
        for i, (error, (kp, ki, kd)) in enumerate(zip((v_cmd - state.v_m_s, w_cmd - state.w_rad_s), self.gains)):
            if not self.saturated:
                self.integral[i] += error * self.period_s
            if self.previous[i] is not None:
                raw = (error - self.previous[i]) / self.period_s
                self.derivative[i] += self.alpha * (raw - self.derivative[i])
            self.previous[i] = error
            out.append(kp * error + ki * self.integral[i] + kd * self.derivative[i])
        u_v, u_w = out
        wanted = np.array([u_v - u_w, u_v + u_w])
        limit = self.model.voltage_limit_v
        self.saturated = bool(np.any(np.abs(wanted) > limit))
        return np.clip(wanted, -limit, limit)
