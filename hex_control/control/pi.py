"""Digital PI force controller by the Tustin transform (seed 002 section 7.3, eq. 7.4-7.6).

    U(s) = (K_p + K_I / s) E(s)                                   (7.4)
    s = (2/T) (z - 1)/(z + 1)                                      (7.5)
    xi_{k+1} = xi_k + e_k
    u_k = (K_I T) xi_k + (K_p + K_I T / 2) e_k                     (7.6)

(7.5 prints "2z-1 / Tz+1"; the Tustin substitution it names is the one above.)
Additions the thesis did not have:
- output limits, with anti-windup by conditional integration: the accumulator does not
  integrate an error that would push a saturated output further into its limit;
- bumpless gain change: when K_p or K_I change, xi is rescaled so that u_k is unchanged
  for the same error;
- feed-forward: a term added to the output before the limits (e.g. the load predictor's
  prediction converted to a command).
Units: error in N, output in mm of table position command (gains in mm/N and mm/(N s)).
"""

from __future__ import annotations

import math


class TustinPI:
    def __init__(self, kp: float, ki: float, period_s: float, output_min: float = -math.inf,
                 output_max: float = math.inf):
        if not (period_s > 0 and math.isfinite(period_s)):
            raise ValueError(f"period_s must be positive and finite, got {period_s!r}")
        if not output_min < output_max:
            raise ValueError("output_min must be below output_max")
        self.period_s = period_s
        self.output_min, self.output_max = output_min, output_max
        self.kp, self.ki = self._checked(kp, ki)
        self.xi = 0.0

    @staticmethod
    def _checked(kp: float, ki: float) -> tuple[float, float]:
        if not (math.isfinite(kp) and math.isfinite(ki) and kp >= 0 and ki >= 0):
            raise ValueError(f"gains must be finite and >= 0, got kp={kp!r}, ki={ki!r}")
        return float(kp), float(ki)

    def reset(self, output: float = 0.0) -> None:
        """Start so that a zero error gives ``output`` (bumpless start from a held command)."""
        self.xi = output / (self.ki * self.period_s) if self.ki > 0 else 0.0

    def set_gains(self, kp: float, ki: float) -> None:
        """Change gains without a jump in the integral part of the output."""
        kp, ki = self._checked(kp, ki)
        integral = self.ki * self.period_s * self.xi
        self.kp, self.ki = kp, ki
        self.xi = integral / (ki * self.period_s) if ki > 0 else 0.0

    def step(self, error: float, feed_forward: float = 0.0) -> float:
        """u_k for the error e_k (eq. 7.6), limited; then xi advances (unless winding up)."""
        if not (math.isfinite(error) and math.isfinite(feed_forward)):
            raise ValueError("error and feed-forward must be finite")
        t = self.period_s
        raw = self.ki * t * self.xi + (self.kp + self.ki * t / 2) * error + feed_forward
        output = min(max(raw, self.output_min), self.output_max)
        winding_up = (raw > self.output_max and error > 0) or (raw < self.output_min and error < 0)
        if not winding_up:
            self.xi += error
        return output
