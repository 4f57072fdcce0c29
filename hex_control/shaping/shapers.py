"""Impulse sequences (amplitudes A_i summing to 1, times t_i in s) of the classic shapers.

Each function is small and returns a :class:`Shaper` for a mode at ``frequency_hz`` with
damping ratio ``damping``. Damping enters through K = exp(-zeta pi / sqrt(1 - zeta^2)) and
the damped period T_d = 1/(f sqrt(1 - zeta^2)):
- ZV, ZVD and ZV-D^n: Singer and Seering, "Preshaping command inputs to reduce system
  vibration", J. Dyn. Sys. Meas. Control 112 (1990) -- exact for any damping;
- MZV: Singhose's modified ZV (impulses at 0, 3/8, 3/4 T_d), as in Klipper's shaper_defs;
- EI, 2-hump EI, 3-hump EI with vibration tolerance V_tol: Singhose, Seering and Singer,
  "Residual vibration reduction using vector diagrams to generate shaping inputs",
  J. Mech. Des. 116 (1994) and Singhose, Porter, Tuttle, Singer, "Vibration reduction using
  multi-hump input shapers", J. Dyn. Sys. Meas. Control 119 (1997): the closed forms are
  exact for an undamped mode; damping is included by the K factor (the published damped
  designs are curve fits, which Klipper also replaces this way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Shaper:
    amplitudes: np.ndarray
    times_s: np.ndarray

    def __post_init__(self):
        a, t = np.asarray(self.amplitudes, float), np.asarray(self.times_s, float)
        if a.shape != t.shape or a.ndim != 1 or a.size == 0:
            raise ValueError("amplitudes and times must be equal non-empty 1-D arrays")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(t))) or np.any(t < 0):
            raise ValueError("amplitudes and times must be finite, times >= 0")
        if abs(a.sum()) < 1e-12:
            raise ValueError("amplitudes sum to zero: the shaper would not preserve the step")
        order = np.argsort(t, kind="stable")
        object.__setattr__(self, "amplitudes", a[order] / a.sum())
        object.__setattr__(self, "times_s", t[order])

    @property
    def delay_s(self) -> float:
        """Time of the last impulse: the delay the shaper adds (seed 003 eq. 6)."""
        return float(self.times_s[-1])


def _k_and_period(frequency_hz: float, damping: float) -> tuple[float, float]:
    if not (frequency_hz > 0 and 0 <= damping < 1):
        raise ValueError(f"need frequency_hz > 0 and 0 <= damping < 1, got {frequency_hz}, {damping}")
    df = math.sqrt(1.0 - damping**2)
    return math.exp(-damping * math.pi / df), 1.0 / (frequency_hz * df)


def convolve(first: Shaper, second: Shaper) -> Shaper:
    """The sequence that cancels both modes (seed 003 section 2: convolution of sequences)."""
    amplitudes = np.outer(first.amplitudes, second.amplitudes).ravel()
    times = np.add.outer(first.times_s, second.times_s).ravel()
    unique, inverse = np.unique(np.round(times, 12), return_inverse=True)
    return Shaper(np.bincount(inverse, amplitudes), unique)


def zv(frequency_hz: float, damping: float = 0.0) -> Shaper:
    k, t = _k_and_period(frequency_hz, damping)
    return Shaper(np.array([1.0, k]), np.array([0.0, 0.5 * t]))


def zv_dn(frequency_hz: float, damping: float = 0.0, derivatives: int = 1) -> Shaper:
    """ZV-D^n: ZV convolved with itself n times (ZVD n = 1, ZVDD n = 2)."""
    shaper = zv(frequency_hz, damping)
    for _ in range(derivatives):
        shaper = convolve(shaper, zv(frequency_hz, damping))
    return shaper


def zvd(frequency_hz: float, damping: float = 0.0) -> Shaper:
    return zv_dn(frequency_hz, damping, 1)


def zvdd(frequency_hz: float, damping: float = 0.0) -> Shaper:
    return zv_dn(frequency_hz, damping, 2)


def mzv(frequency_hz: float, damping: float = 0.0) -> Shaper:
    _, t = _k_and_period(frequency_hz, damping)
    k = math.exp(-0.75 * damping * math.pi / math.sqrt(1.0 - damping**2))
    a1 = 1.0 - 1.0 / math.sqrt(2.0)
    return Shaper(np.array([a1, (math.sqrt(2.0) - 1.0) * k, a1 * k * k]), np.array([0.0, 0.375 * t, 0.75 * t]))


def ei(frequency_hz: float, damping: float = 0.0, vibration_tolerance: float = 0.05) -> Shaper:
    k, t = _k_and_period(frequency_hz, damping)
    v = vibration_tolerance
    a1 = 0.25 * (1.0 + v)
    return Shaper(np.array([a1, 0.5 * (1.0 - v) * k, a1 * k * k]), np.array([0.0, 0.5 * t, t]))


def ei_2hump(frequency_hz: float, damping: float = 0.0, vibration_tolerance: float = 0.05) -> Shaper:
    k, t = _k_and_period(frequency_hz, damping)
    v2 = vibration_tolerance**2
    x = (v2 * (math.sqrt(1.0 - v2) + 1.0)) ** (1.0 / 3.0)
    a1 = (3.0 * x * x + 2.0 * x + 3.0 * v2) / (16.0 * x)
    a2 = (0.5 - a1) * k
    return Shaper(np.array([a1, a2, a2 * k, a1 * k**3]), np.array([0.0, 0.5 * t, t, 1.5 * t]))


def ei_3hump(frequency_hz: float, damping: float = 0.0, vibration_tolerance: float = 0.05) -> Shaper:
    k, t = _k_and_period(frequency_hz, damping)
    v = vibration_tolerance
    a1 = 0.0625 * (1.0 + 3.0 * v + 2.0 * math.sqrt(2.0 * (v + 1.0) * v))
    a2 = 0.25 * (1.0 - v) * k
    a3 = (0.5 * (1.0 + v) - 2.0 * a1) * k * k
    return Shaper(np.array([a1, a2, a3, a2 * k * k, a1 * k**4]), np.array([0.0, 0.5 * t, t, 1.5 * t, 2.0 * t]))


SHAPERS = {"zv": zv, "zvd": zvd, "zvdd": zvdd, "mzv": mzv, "ei": ei, "2hump_ei": ei_2hump, "3hump_ei": ei_3hump}


def design(kind: str, frequency_hz: float, damping: float = 0.0, vibration_tolerance: float = 0.05) -> Shaper:
    """A shaper by name (``SHAPERS``)."""
    if kind not in SHAPERS:
        raise ValueError(f"unknown shaper {kind!r}; known: {sorted(SHAPERS)}")
    if kind.endswith("ei"):
        return SHAPERS[kind](frequency_hz, damping, vibration_tolerance)
    return SHAPERS[kind](frequency_hz, damping)
