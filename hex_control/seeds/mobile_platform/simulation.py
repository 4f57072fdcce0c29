"""The platform on its path under a controller: the plant integrated by fourth-order
Runge-Kutta on the Appell-Gibbs equations (model.py) with the voltages held over each
sampling period, and the figures the seed compares (Fig. 8, 10-11). SI units."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.seeds.mobile_platform.control import PlatformState
from hex_control.seeds.mobile_platform.model import (
    PlatformParameters,
    appell_gibbs_accelerations,
    lagrange_accelerations,
    required_friction,
)
from hex_control.seeds.mobile_platform.odometry import EncoderOdometry
from hex_control.seeds.mobile_platform.path import DesiredMotion


@dataclass(frozen=True)
class PlatformRecord:
    """At each sampling instant: time_s (T,), states (T, 5) = x_A, y_A, beta, v, w; point H
    (T, 2); voltages (T, 2); the friction the worse wheel needs (T,)."""

    time_s: np.ndarray
    states: np.ndarray
    point_h_m: np.ndarray
    voltages_v: np.ndarray
    required_friction: np.ndarray


def _derivative(p: PlatformParameters, state, voltages):
    """State (x_A, y_A, beta, v, w, theta_1, theta_2)'s rates by Appell-Gibbs."""
    _, _, beta, v, w, _, _ = state
    rates = p.wheel_rates(v, w)
    v_dot, w_dot = appell_gibbs_accelerations(p, v, w, p.motor_torques(voltages, rates))
    return (v * math.cos(beta), v * math.sin(beta), w, v_dot, w_dot, *rates)


def _lagrange_derivative(p: PlatformParameters, state, voltages):
    _, _, beta, v, w, _, _ = state
    rates = p.wheel_rates(v, w)
    q_ddot, _ = lagrange_accelerations(p, beta, [v * math.cos(beta), v * math.sin(beta), w, *rates],
                                       p.motor_torques(voltages, rates))
    return (v * math.cos(beta), v * math.sin(beta), w, q_ddot[0] * math.cos(beta) + q_ddot[1] * math.sin(beta),
            q_ddot[2], *rates)


def _rk4_step(p: PlatformParameters, state: tuple, voltages, h: float, derivative=_derivative) -> tuple:
    k1 = derivative(p, state, voltages)
    k2 = derivative(p, tuple(s + 0.5 * h * k for s, k in zip(state, k1)), voltages)
    k3 = derivative(p, tuple(s + 0.5 * h * k for s, k in zip(state, k2)), voltages)
    k4 = derivative(p, tuple(s + h * k for s, k in zip(state, k3)), voltages)
    return tuple(s + h / 6 * (a + 2 * b + 2 * c + d) for s, a, b, c, d in zip(state, k1, k2, k3, k4))


def simulate_platform(plant: PlatformParameters, controller, desired: DesiredMotion, period_s: float,
                      substeps: int = 4, *, with_friction: bool = True, lagrange: bool = False,
                      encoder_counts_per_rev: int = 0) -> PlatformRecord:
    """Run the whole desired motion from rest with H at the path's start; the controller is
    called once per period with the true state, or with ``encoder_counts_per_rev`` > 0 with
    the encoders' odometry (odometry.py). ``with_friction=False`` leaves out the friction the wheels need
    (NaN; the constraint forces cost a linear solve per period, which tuning can skip);
    ``lagrange`` integrates Lagrange's form instead of Appell-Gibbs' (the same motion, slower)."""
    derivative = _lagrange_derivative if lagrange else _derivative
    steps = int(round(desired.time_s[-1] / period_s))
    h = period_s / substeps
    state = (-plant.point_h_ahead_m, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    odometry = (EncoderOdometry(plant, encoder_counts_per_rev, period_s, PlatformState(*state[:5]))
                if encoder_counts_per_rev else None)
    times, states, points, voltages, friction = [], [], [], [], []
    for k in range(steps):
        t = k * period_s
        now = PlatformState(*state[:5])
        seen = odometry.measure(state[5:]) if odometry else now
        u = np.asarray(controller.voltages(t, seen, desired.at(t)), float)
        times.append(t)
        states.append(state[:5])
        points.append(now.point_h(plant.point_h_ahead_m))
        voltages.append(u)
        if with_friction:
            rates = plant.wheel_rates(state[3], state[4])
            q_dot = [state[3] * math.cos(state[2]), state[3] * math.sin(state[2]), state[4], *rates]
            _, multipliers = lagrange_accelerations(plant, state[2], q_dot, plant.motor_torques(u, rates))
            friction.append(required_friction(plant, multipliers))
        else:
            friction.append(math.nan)
        for _ in range(substeps):
            state = _rk4_step(plant, state, u, h, derivative)
    return PlatformRecord(np.array(times), np.array(states), np.array(points), np.array(voltages),
                          np.array(friction))


def path_distance(path_m: np.ndarray, points_m: np.ndarray) -> np.ndarray:
    """Each point's distance (m) to the polyline path_m (nearest segment)."""
    a, b = path_m[:-1], path_m[1:]
    ab = b - a
    t = np.clip(np.einsum("pij,ij->pi", points_m[:, None, :] - a[None], ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    nearest = a[None] + t[..., None] * ab[None]
    return np.min(np.linalg.norm(points_m[:, None, :] - nearest, axis=2), axis=1)


@dataclass(frozen=True)
class TrackingFigures:
    """position error |H - H_bar(t)| (m): ITAE (m s^2), max; path error (distance to the
    path, m): max, RMS; final position error (m) once stopped; heading error beta - beta_bar
    (rad): max, final; the worst required friction coefficient."""

    itae_m_s2: float
    max_position_error_m: float
    max_path_error_m: float
    rms_path_error_m: float
    final_position_error_m: float
    max_heading_error_rad: float
    final_heading_error_rad: float
    max_required_friction: float


def tracking_figures(record: PlatformRecord, desired: DesiredMotion) -> TrackingFigures:
    wanted = np.column_stack([np.interp(record.time_s, desired.time_s, desired.position_m[:, i]) for i in (0, 1)])
    error = np.linalg.norm(record.point_h_m - wanted, axis=1)
    dt = record.time_s[1] - record.time_s[0]
    heading_error = record.states[:, 2] - np.interp(record.time_s, desired.time_s, desired.heading_rad)
    path_error = path_distance(desired.path_m, record.point_h_m[::5])
    return TrackingFigures(float(np.sum(error * record.time_s) * dt), float(error.max()), float(path_error.max()),
                           float(np.sqrt(np.mean(path_error ** 2))), float(error[-1]),
                           float(np.abs(heading_error).max()), float(abs(heading_error[-1])),
                           float(record.required_friction.max()))
