"""Stability lobes of milling by the zero-order approximation (Altintas & Budak 1995,
CIRP Annals 44/1; Altintas, Manufacturing Automation, 2nd ed. 2012, section 3.6): the
machining engineer's standard tool, computed here independently of the time-domain model
as its check.

Tooth angle phi is measured from the y axis, clockwise; the x axis is the feed direction.
The average directional coefficients over the immersion [phi_st, phi_ex] (alpha, eq. 3.58
there), the tip receptances G_xx = G_yy = G (round tool, no cross terms), and

    det(I + Lambda alpha G(i w_c)) = 0,    Lambda = Lambda_R + i Lambda_I,
    a_lim = -2 pi Lambda_R (1 + kappa^2) / (N k_d),   kappa = Lambda_I / Lambda_R,
    epsilon = pi - 2 atan(kappa),   T = (epsilon + 2 k pi) / w_c,   n = 60 / (N T).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def directional_coefficients(force_ratio: float, start_rad: float, exit_rad: float) -> np.ndarray:
    """Alpha (2x2, dimensionless) of the zero-order approximation; force_ratio = mu, the
    radial-to-tangential cutting force ratio of eq. 12."""
    kr = force_ratio

    def primitive(p):
        return 0.5 * np.array([[math.cos(2 * p) - 2 * kr * p + kr * math.sin(2 * p),
                                -math.sin(2 * p) - 2 * p + kr * math.cos(2 * p)],
                               [-math.sin(2 * p) + 2 * p + kr * math.cos(2 * p),
                                -math.cos(2 * p) - 2 * kr * p - kr * math.sin(2 * p)]])

    return primitive(exit_rad) - primitive(start_rad)


@dataclass(frozen=True)
class Lobe:
    """One lobe number k, parametrized by the chatter frequency."""

    lobe: int
    chatter_hz: np.ndarray
    speed_rpm: np.ndarray
    depth_limit_m: np.ndarray


def stability_lobes(tip_frf, teeth: int, cutting_pressure_pa: float, force_ratio: float,
                    start_rad: float, *, exit_rad: float, chatter_hz: np.ndarray, lobes=range(6)) -> list[Lobe]:
    """The lobes k in ``lobes`` over the candidate chatter frequencies (Hz); tip_frf(w) is the
    tip receptance (m/N) at angular frequency w (rad/s). Frequencies where no eigenvalue gives
    a positive depth are dropped."""
    alpha = directional_coefficients(force_ratio, start_rad, exit_rad)
    frequencies = np.asarray(chatter_hz, float)
    g = tip_frf(2 * math.pi * frequencies)
    # det(I + Lambda alpha G) = 0 <=> Lambda = -1/mu with mu an eigenvalue of alpha G
    mu = np.linalg.eigvals(alpha[None, :, :] * g[:, None, None])
    lam = -1 / mu
    depth = -2 * math.pi * lam.real * (1 + (lam.imag / lam.real) ** 2) / (teeth * cutting_pressure_pa)
    depth = np.where(depth > 0, depth, np.inf)
    pick = np.argmin(depth, axis=1)
    rows = np.arange(frequencies.size)
    depth, lam = depth[rows, pick], lam[rows, pick]
    keep = np.isfinite(depth)
    epsilon = math.pi - 2 * np.arctan(lam.imag / lam.real)
    omega = 2 * math.pi * frequencies
    result = []
    for k in lobes:
        period = (epsilon + 2 * k * math.pi) / omega
        result.append(Lobe(k, frequencies[keep], (60 / (teeth * period))[keep], depth[keep]))
    return result


def depth_limit(lobes: list[Lobe], speed_rpm) -> np.ndarray:
    """The stability boundary: the lowest lobe depth (m) at each speed (rev/min)."""
    speeds = np.atleast_1d(np.asarray(speed_rpm, float))
    boundary = np.full(speeds.shape, np.inf)
    for lobe in lobes:
        order = np.argsort(lobe.speed_rpm)
        s, d = lobe.speed_rpm[order], lobe.depth_limit_m[order]
        inside = (speeds >= s[0]) & (speeds <= s[-1])
        boundary[inside] = np.minimum(boundary[inside], np.interp(speeds[inside], s, d))
    return boundary


def chatter_frequency(lobes: list[Lobe], speed_rpm: float) -> float:
    """The chatter frequency (Hz) of the lobe that bounds stability at ``speed_rpm``."""
    best, frequency = math.inf, math.nan
    for lobe in lobes:
        order = np.argsort(lobe.speed_rpm)
        s = lobe.speed_rpm[order]
        if s[0] <= speed_rpm <= s[-1]:
            d = np.interp(speed_rpm, s, lobe.depth_limit_m[order])
            if d < best:
                best, frequency = d, float(np.interp(speed_rpm, s, lobe.chatter_hz[order]))
    return frequency
