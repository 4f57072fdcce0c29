"""Stability of milling by semi-discretization (Insperger & Stepan, Int. J. Numer. Meth.
Engng 61 (2004) 117-141; Semi-Discretization for Time-Delay Systems, Springer 2011):
the standard exact-in-the-limit method for the time-periodic, delayed milling model, used
here to check the time-domain model and to draw the lobes.

At a constant speed the model is x' = A x + B F(t), F = a_p k_d K(t) (w(t) - w(t - tau)),
w = C x, with the period T = tau = 60 / (n z) of the directional matrix
K(t) = sum_l g_l(t) [-cos - mu sin; sin - mu cos](phi_l) [sin, cos](phi_l) (eq. 11-12
linearized about the cut, g_l = 1 while tooth l is in the immersion). T is cut into
``intervals`` steps; over each, K is its average and the delayed deflection the mean of the
two stored samples around t - tau (zeroth order). The period's map of
[x, w_-1, ..., w_-k] has spectral radius < 1 exactly when the cut is stable.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.linalg import expm

from hex_control.seeds.milling.cutting import Cut
from hex_control.seeds.milling.tool_beam import ToolModes


def _modal_system(modes: ToolModes):
    m = modes.omega_rad_s.size
    a_plane = np.zeros((2 * m, 2 * m))
    a_plane[:m, m:] = np.eye(m)
    a_plane[m:, :m] = -np.diag(modes.omega_rad_s ** 2)
    a_plane[m:, m:] = -np.diag(2 * modes.damping * modes.omega_rad_s)
    a = np.kron(np.eye(2), a_plane)  # state [eta_x, eta_x', eta_y, eta_y']
    b = np.zeros((4 * m, 2))
    b[m:2 * m, 0] = modes.tip_shape
    b[3 * m:, 1] = modes.tip_shape
    c = np.zeros((2, 4 * m))
    c[0, :m] = modes.tip_shape
    c[1, 2 * m:3 * m] = modes.tip_shape
    return a, b, c


def directional_matrix(cut: Cut, spindle_angle_rad: np.ndarray) -> np.ndarray:
    """K(t) (2x2 per angle, dimensionless) of the linearized eq. 11-12, summed over the teeth."""
    angles = np.asarray(spindle_angle_rad, float)[:, None] + 2 * math.pi * np.arange(cut.teeth) / cut.teeth
    phi = np.mod(angles, 2 * math.pi)
    g = ((phi >= cut.start_rad) & (phi <= cut.exit_rad)).astype(float)
    s, c, mu = np.sin(phi), np.cos(phi), cut.force_ratio
    force_x, force_y = -c - mu * s, s - mu * c
    return np.stack([np.stack([np.sum(g * force_x * s, 1), np.sum(g * force_x * c, 1)], -1),
                     np.stack([np.sum(g * force_y * s, 1), np.sum(g * force_y * c, 1)], -1)], -2)


def spectral_radius(modes: ToolModes, cut: Cut, speed_rpm: float, intervals: int = 40,
                    subsamples: int = 8) -> float:
    """|largest Floquet multiplier| of the cut at a constant speed: < 1 stable."""
    a, b, c = _modal_system(modes)
    n, k = a.shape[0], intervals
    period = cut.tooth_period_s(speed_rpm)
    dt = period / k
    omega = 2 * math.pi * speed_rpm / 60
    size = n + 2 * k
    monodromy = np.eye(size)
    gain = cut.depth_m * cut.cutting_pressure_pa
    for i in range(k):
        sample_angles = omega * dt * (i + (np.arange(subsamples) + 0.5) / subsamples)
        kbar = gain * directional_matrix(cut, sample_angles).mean(axis=0)
        a_i = a + b @ kbar @ c
        # [[A_i, B K], [0, 0]] exponential gives exp(A_i dt) and the held input's response
        block = np.zeros((n + 2, n + 2))
        block[:n, :n], block[:n, n:] = a_i, -b @ kbar
        e = expm(block * dt)
        step = np.zeros((size, size))
        step[:n, :n] = e[:n, :n]
        # delayed deflection: mean of w_{i-k} and w_{i-k+1}, the last two stored blocks
        step[:n, n + 2 * (k - 2):n + 2 * (k - 1)] = 0.5 * e[:n, n:]
        step[:n, n + 2 * (k - 1):] = 0.5 * e[:n, n:]
        step[n:n + 2, :n] = c  # newest stored sample: w_i
        step[n + 2:, n:n + 2 * (k - 1)] = np.eye(2 * (k - 1))
        monodromy = step @ monodromy
    return float(np.max(np.abs(np.linalg.eigvals(monodromy))))


def critical_depth(modes: ToolModes, cut: Cut, speed_rpm: float, low_m: float, high_m: float,
                   *, tolerance_m: float = 1e-7, intervals: int = 40) -> float:
    """The depth of cut a_p (m) where the cut turns unstable at ``speed_rpm``, by bisection
    between a stable ``low_m`` and an unstable ``high_m``."""
    def radius(depth):
        return spectral_radius(modes, replace(cut, depth_m=depth), speed_rpm, intervals)

    if radius(low_m) >= 1 or radius(high_m) <= 1:
        raise ValueError(f"need a stable low_m and an unstable high_m at {speed_rpm} rev/min")
    while high_m - low_m > tolerance_m:
        middle = 0.5 * (low_m + high_m)
        low_m, high_m = (middle, high_m) if radius(middle) < 1 else (low_m, middle)
    return 0.5 * (low_m + high_m)
