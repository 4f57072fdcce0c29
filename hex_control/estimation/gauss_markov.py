"""First-order Gauss-Markov load fluctuation and its noisy measurement.

Seed 000 part 2, eqs 6.2-6.5::

    dL(t+1) = a * dL(t) + w(t),    E[w(t) w(s)] = W * delta_st      (6.2)
    y(t)    = dL(t) + v(t),        E[v(t) v(s)] = V * delta_st      (6.3)
    E[dL(0)] = 0,  E[dL(0)^2] = sigma(0)

with w, v, dL(0) mutually uncorrelated (6.4). The load is L(t) = L_bar + dL(t) (6.1).
Values are in the unit of the load itself (N for a force, W for a power, ...);
variances in that unit squared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GaussMarkovModel:
    """Parameters of eqs 6.2-6.5.

    Attributes:
        a: transition coefficient of the fluctuation (dimensionless).
        process_variance: W, variance of w(t) (load unit squared).
        measurement_variance: V, variance of v(t) (load unit squared).
        initial_variance: sigma(0) = P(0), variance of dL(0). ``None`` means the
            stationary variance W / (1 - a^2), which requires |a| < 1.
    """

    a: float
    process_variance: float
    measurement_variance: float
    initial_variance: float | None = None

    def __post_init__(self) -> None:
        for name in ("a", "process_variance", "measurement_variance"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"GaussMarkovModel.{name} must be finite, got {value!r}")
        if self.process_variance < 0 or self.measurement_variance < 0:
            raise ValueError(
                "variances must be >= 0, got W="
                f"{self.process_variance!r}, V={self.measurement_variance!r}"
            )
        if self.initial_variance is None:
            if abs(self.a) >= 1:
                raise ValueError(
                    f"|a| = {abs(self.a)} >= 1 has no stationary variance; give initial_variance"
                )
        elif not (math.isfinite(self.initial_variance) and self.initial_variance >= 0):
            raise ValueError(f"initial_variance must be finite and >= 0, got {self.initial_variance!r}")
        if self.p0 + self.measurement_variance <= 0:
            raise ValueError("P(0) + V must be > 0, or the first gain K(0) is undefined")

    @property
    def stationary_variance(self) -> float:
        """Variance of dL(t) in steady state, W / (1 - a^2) (load unit squared)."""
        if abs(self.a) >= 1:
            return math.inf
        return self.process_variance / (1.0 - self.a**2)

    @property
    def p0(self) -> float:
        """P(0) = sigma(0), the variance of the first prediction error."""
        return self.stationary_variance if self.initial_variance is None else self.initial_variance

    def simulate(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``n`` steps of the fluctuation dL(t) and its measurement y(t).

        Returns:
            (dL, y), each of shape (n,).
        """
        w = rng.normal(0.0, math.sqrt(self.process_variance), n)
        v = rng.normal(0.0, math.sqrt(self.measurement_variance), n)
        # dL(t) = a dL(t-1) + w(t-1), driven by [dL(0), w(0), ..., w(n-2)]
        drive = np.concatenate(([rng.normal(0.0, math.sqrt(self.p0))], w[:-1]))
        from scipy.signal import lfilter  # here: 0.6 s of a predictor node's start, which never draws

        state = lfilter([1.0], [1.0, -self.a], drive)
        return state, state + v
