"""Roll-off filters for the force loop: the thesis's own recommendation (seed 002 section 8.3
item 2: "increase the high frequency rolloff of the controller to allow for higher bandwidth
control while limiting the effects of the grinding noise"), which it did not try.

Second-order sections by the bilinear transform with frequency pre-warping, so that the
cutoff or notch frequency is exact at the sample rate:
- low-pass  H(s) = w^2 / (s^2 + 2 zeta w s + w^2)
- notch     H(s) = (s^2 + w^2) / (s^2 + (w / Q) s + w^2)   (zero gain at w, width w/Q)
Direct form II transposed, one sample at a time. Frequencies in Hz, period in s.
"""

from __future__ import annotations

import math

import numpy as np


class SecondOrderSection:
    """y_k from x_k for H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2)."""

    def __init__(self, b, a):
        b, a = np.asarray(b, float), np.asarray(a, float)
        if b.shape != (3,) or a.shape != (3,) or a[0] == 0 or not (np.all(np.isfinite(b)) and np.all(np.isfinite(a))):
            raise ValueError("need three finite numerator and denominator coefficients, a0 != 0")
        self.b, self.a = b / a[0], a / a[0]
        self.reset()

    def reset(self, value: float = 0.0) -> None:
        """Start in steady state at ``value`` (no transient from a held input)."""
        gain = self.b.sum() / self.a.sum()
        y = gain * value
        self._z1 = self.b[1] * value - self.a[1] * y + self.b[2] * value - self.a[2] * y
        self._z2 = self.b[2] * value - self.a[2] * y

    def step(self, x: float) -> float:
        if not math.isfinite(x):
            raise ValueError("filter input must be finite")
        y = self.b[0] * x + self._z1
        self._z1 = self.b[1] * x - self.a[1] * y + self._z2
        self._z2 = self.b[2] * x - self.a[2] * y
        return y

    def response(self, frequency_hz, period_s: float) -> np.ndarray:
        """Complex frequency response at the given frequencies."""
        z = np.exp(-1j * 2 * np.pi * np.asarray(frequency_hz, float) * period_s)
        return (self.b[0] + self.b[1] * z + self.b[2] * z * z) / (1 + self.a[1] * z + self.a[2] * z * z)


def _prewarped(frequency_hz: float, period_s: float) -> tuple[float, float]:
    if not (0 < frequency_hz < 0.5 / period_s):
        raise ValueError(f"frequency must be between 0 and Nyquist ({0.5 / period_s:g} Hz), got {frequency_hz}")
    k = 2.0 / period_s
    return k, k * math.tan(math.pi * frequency_hz * period_s)  # analog w that maps onto frequency_hz


def low_pass(cutoff_hz: float, period_s: float, damping: float = 0.707) -> SecondOrderSection:
    k, w = _prewarped(cutoff_hz, period_s)
    # s = k (1 - z^-1)/(1 + z^-1) into w^2 / (s^2 + 2 zeta w s + w^2)
    a = [k * k + 2 * damping * w * k + w * w, 2 * w * w - 2 * k * k, k * k - 2 * damping * w * k + w * w]
    return SecondOrderSection([w * w, 2 * w * w, w * w], a)


def notch(frequency_hz: float, period_s: float, quality: float = 2.0) -> SecondOrderSection:
    if quality <= 0:
        raise ValueError("quality must be > 0")
    k, w = _prewarped(frequency_hz, period_s)
    b = [k * k + w * w, 2 * w * w - 2 * k * k, k * k + w * w]
    a = [k * k + w / quality * k + w * w, 2 * w * w - 2 * k * k, k * k - w / quality * k + w * w]
    return SecondOrderSection(b, a)
