"""Residual vibration and insensitivity of an impulse sequence.

V(omega, zeta) = e^(-zeta omega t_N) |sum_i A_i e^(zeta omega t_i) e^(j omega_d t_i)|, the
residual vibration of a mode (natural frequency omega, damping zeta, omega_d =
omega sqrt(1 - zeta^2)) after the sequence, relative to a single unit impulse (Singer and
Seering 1990; seed 003 eq. 3 is its undamped numerator, eq. 8-9 its parts).
"""

from __future__ import annotations

import numpy as np

from hex_control.shaping.shapers import Shaper


def residual_vibration(shaper: Shaper, frequency_hz, damping: float = 0.0) -> np.ndarray:
    """V at each frequency (Hz) of ``frequency_hz`` (array-like), as a fraction."""
    omega = 2 * np.pi * np.atleast_1d(np.asarray(frequency_hz, float))[:, None]
    t, a = shaper.times_s[None, :], shaper.amplitudes[None, :]
    decay = np.exp(damping * omega * (t - shaper.times_s[-1]))
    phase = omega * np.sqrt(1 - damping**2) * t
    value = np.abs(np.sum(a * decay * np.exp(1j * phase), axis=1))
    return value if np.ndim(frequency_hz) else value[0]


def insensitivity(shaper: Shaper, design_hz: float, damping: float = 0.0, tolerance: float = 0.05,
                  ratio_max: float = 3.0, *, points: int = 60_001) -> float:
    """Width, in units of the design frequency, of the band around it where V <= tolerance."""
    ratios = np.linspace(1e-3, ratio_max, points)
    ok = residual_vibration(shaper, ratios * design_hz, damping) <= tolerance
    centre = int(np.argmin(np.abs(ratios - 1.0)))
    if not ok[centre]:
        return 0.0
    low = centre
    while low > 0 and ok[low - 1]:
        low -= 1
    high = centre
    while high < points - 1 and ok[high + 1]:
        high += 1
    return float(ratios[high] - ratios[low])


def mode_response(times_s: np.ndarray, command: np.ndarray, frequency_hz: float, damping: float) -> np.ndarray:
    """Position of a second-order mode x'' + 2 zeta w x' + w^2 x = w^2 u driven by the sampled
    command u (zero-order hold, exact discretization): the 'lightly damped mode' check."""
    from scipy.signal import cont2discrete, dlsim

    w = 2 * np.pi * frequency_hz
    dt = float(times_s[1] - times_s[0])
    system = cont2discrete((np.array([[0, 1], [-w * w, -2 * damping * w]]), np.array([[0], [w * w]]),
                            np.array([[1, 0]]), np.array([[0]])), dt, method="zoh")
    _, y, _ = dlsim(system[:4] + (dt,), command, x0=[command[0], 0.0])
    return y[:, 0]


def settle_time(times_s: np.ndarray, response: np.ndarray, target: float, start: float, band: float = 0.02) -> float:
    """Time (s) after which |response - target| stays within ``band`` x |target - start|."""
    outside = np.abs(np.asarray(response) - target) > band * abs(target - start)
    if not outside.any():
        return float(times_s[0])
    last = int(np.flatnonzero(outside)[-1])
    if last + 1 >= len(times_s):
        return float("inf")
    return float(times_s[last + 1])
