"""One-step-ahead Kalman predictor of a Gauss-Markov load (seed 000 part 2, eqs 6.6-6.7).

The seed's predictor, with the signed innovation (its print shows |.|, a typesetting
slip) and the Riccati recursion re-derived, because the printed P-update (6.7) is garbled::

    dL(t+1|t) = a dL(t|t-1) + K(t) [y(t) - dL(t|t-1)]                  (6.6)
    K(t)      = a P(t) / (P(t) + V)                                     (6.7)
    P(t+1)    = a^2 P(t) - a^2 P(t)^2 / (P(t) + V) + W
              = a^2 P(t) V / (P(t) + V) + W,          P(0) = sigma(0)

P(t) is the variance of the prediction error dL(t) - dL(t|t-1). Derivation: the
measurement update gives the filtered variance P V / (P + V) (the scalar case of
P - P H' (H P H' + V)^-1 H P with H = 1), and the time update multiplies it by a^2 and
adds W (Anderson & Moore, *Optimal Filtering*, 1979, section 3.1, eqs 1.9-1.11;
Kalman, 1960). The gains do not depend on the data, so, as the seed says, K(t) and P(t)
can be computed off-line; :func:`predict_series` uses that to filter a whole series
with a linear filter once the gain has converged.

Loads are in the caller's unit; ``mean`` is the mean load L_bar of eq. 6.1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.estimation.gauss_markov import GaussMarkovModel

#: relative change of P below which the Riccati recursion counts as converged
_RICCATI_TOLERANCE = 1e-13


def riccati_step(model: GaussMarkovModel, p: float) -> tuple[float, float]:
    """One step of eq. 6.7: from P(t) return (K(t), P(t+1))."""
    a, w, v = model.a, model.process_variance, model.measurement_variance
    s = p + v
    return a * p / s, a * a * p * v / s + w


def steady_state_variance(model: GaussMarkovModel) -> float:
    """Fixed point of the Riccati recursion, P = a^2 P V / (P + V) + W.

    The positive root of P^2 + (V (1 - a^2) - W) P - W V = 0.
    """
    a, w, v = model.a, model.process_variance, model.measurement_variance
    b = v * (1.0 - a * a) - w
    return 0.5 * (-b + math.sqrt(b * b + 4.0 * w * v))


def gain_sequence(model: GaussMarkovModel, n: int) -> tuple[np.ndarray, np.ndarray]:
    """K(t) for t = 0..n-1 and P(t) for t = 0..n, computed off-line (eq. 6.7).

    The recursion runs until P stops changing; the rest is filled with the limit.
    """
    gains = np.empty(n)
    variances = np.empty(n + 1)
    p = model.p0
    variances[0] = p
    for t in range(n):
        k, p_next = riccati_step(model, p)
        gains[t], variances[t + 1] = k, p_next
        if abs(p_next - p) <= _RICCATI_TOLERANCE * max(p, 1e-300):
            gains[t + 1 :] = k
            variances[t + 2 :] = p_next
            break
        p = p_next
    return gains, variances


@dataclass(frozen=True)
class PredictionStep:
    """Result of filtering one measurement y(t); loads in the caller's unit."""

    measurement: float  # y(t) + mean, as given
    prior: float  # L(t|t-1) = mean + dL(t|t-1)
    innovation: float  # y(t) - dL(t|t-1)
    innovation_variance: float  # P(t) + V
    gain: float  # K(t)
    prediction: float  # L(t+1|t) = mean + dL(t+1|t)
    prediction_variance: float  # P(t+1)


class OneStepPredictor:
    """Streaming form of eqs 6.6-6.7: feed y(t), get the prediction of L(t+1)."""

    def __init__(self, model: GaussMarkovModel, mean: float = 0.0):
        if not math.isfinite(mean):
            raise ValueError(f"mean must be finite, got {mean!r}")
        self.model = model
        self.mean = float(mean)
        self.reset()

    def reset(self) -> None:
        """Forget the history: back to dL(0|-1) = 0, P(0) = sigma(0)."""
        self._estimate = 0.0
        self._variance = self.model.p0
        self.sample_count = 0

    def restore(self, prior: float, prior_variance: float) -> None:
        """Continue from a known state: L(t|t-1) = ``prior`` and P(t) = ``prior_variance``
        (e.g. from the last published LoadPrediction after a restart)."""
        if not (math.isfinite(prior) and math.isfinite(prior_variance) and prior_variance >= 0):
            raise ValueError(f"need a finite prior and variance >= 0, got {prior!r}, {prior_variance!r}")
        self._estimate = prior - self.mean
        self._variance = prior_variance

    def warm_start(self, measurements) -> None:
        """Reset, then filter a recorded history at once; streaming continues after it."""
        self.reset()
        if len(measurements):
            series = predict_series(self.model, measurements, self.mean)
            self._estimate = float(series.prediction[-1]) - self.mean
            self._variance = float(series.prediction_variance[-1])
            self.sample_count = len(measurements)

    @property
    def prediction(self) -> float:
        """Current prediction of the next load, mean + dL(t|t-1)."""
        return self.mean + self._estimate

    @property
    def prediction_variance(self) -> float:
        return self._variance

    def step(self, measurement: float) -> PredictionStep:
        """Filter y(t) = ``measurement`` and advance to the prediction of L(t+1)."""
        if not math.isfinite(measurement):
            raise ValueError(f"measurement must be finite, got {measurement!r}")
        prior = self._estimate
        innovation = (measurement - self.mean) - prior
        innovation_variance = self._variance + self.model.measurement_variance
        gain, next_variance = riccati_step(self.model, self._variance)
        self._estimate = self.model.a * prior + gain * innovation
        self._variance = next_variance
        self.sample_count += 1
        return PredictionStep(
            measurement=float(measurement),
            prior=self.mean + prior,
            innovation=innovation,
            innovation_variance=innovation_variance,
            gain=gain,
            prediction=self.mean + self._estimate,
            prediction_variance=next_variance,
        )


@dataclass(frozen=True)
class PredictionSeries:
    """Eqs 6.6-6.7 over a whole series; every array has shape (n,)."""

    prior: np.ndarray  # L(t|t-1)
    prior_variance: np.ndarray  # P(t)
    innovation: np.ndarray  # y(t) - dL(t|t-1)
    innovation_variance: np.ndarray  # P(t) + V
    gain: np.ndarray  # K(t)
    prediction: np.ndarray  # L(t+1|t)
    prediction_variance: np.ndarray  # P(t+1)


def predict_series(model: GaussMarkovModel, measurements, mean: float = 0.0) -> PredictionSeries:
    """Filter a whole series at once (vectorized equivalent of :class:`OneStepPredictor`).

    The gains are computed first (they do not depend on the data); while they still
    change the recursion runs step by step, after that it is the constant-coefficient
    linear filter dL(t+1|t) = (a - K) dL(t|t-1) + K dy(t), run by ``scipy.signal.lfilter``.
    """
    y = np.asarray(measurements, dtype=float) - mean
    if y.ndim != 1:
        raise ValueError(f"measurements must be one-dimensional, got shape {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError("measurements must be finite")
    n = y.size
    gains, variances = gain_sequence(model, n)
    estimates = np.zeros(n + 1)  # dL(t|t-1), t = 0..n
    converged = np.flatnonzero(gains != gains[-1]) if n else np.array([], dtype=int)
    transient = int(converged[-1]) + 1 if converged.size else 0
    a = model.a
    for t in range(transient):
        estimates[t + 1] = a * estimates[t] + gains[t] * (y[t] - estimates[t])
    if transient < n:
        k = gains[-1]
        c = a - k
        from scipy.signal import lfilter  # here: 0.4 s of a predictor node's start, which filters one step at a time

        estimates[transient + 1 :], _ = lfilter(
            [k], [1.0, -c], y[transient:], zi=[c * estimates[transient]]
        )
    prior = estimates[:-1]
    return PredictionSeries(
        prior=mean + prior,
        prior_variance=variances[:-1],
        innovation=y - prior,
        innovation_variance=variances[:-1] + model.measurement_variance,
        gain=gains,
        prediction=mean + estimates[1:],
        prediction_variance=variances[1:],
    )


class MultiChannelPredictor:
    """Vector form of eqs 6.6-6.7 for m channels, on ``filterpy.kalman.KalmanFilter``.

    dL(t+1) = A dL(t) + w,  y(t) = dL(t) + v,  cov(w) = W,  cov(v) = V  (all m x m),
    so channels may be coupled through A, W or V. Each :meth:`step` runs filterpy's
    measurement update then its time update, which leaves the filter at the one-step
    prediction dL(t+1|t) with covariance P(t+1) -- the seed's predictor.
    """

    def __init__(self, transition, process_covariance, measurement_covariance,
                 initial_covariance=None, mean=None):
        a = np.atleast_2d(np.asarray(transition, dtype=float))
        m = a.shape[0]
        w = np.atleast_2d(np.asarray(process_covariance, dtype=float))
        v = np.atleast_2d(np.asarray(measurement_covariance, dtype=float))
        for name, matrix in (("transition", a), ("process_covariance", w),
                             ("measurement_covariance", v)):
            if matrix.shape != (m, m):
                raise ValueError(f"{name} must be {m}x{m}, got {matrix.shape}")
            if not np.all(np.isfinite(matrix)):
                raise ValueError(f"{name} must be finite")
        if initial_covariance is None:
            if np.max(np.abs(np.linalg.eigvals(a))) >= 1:
                raise ValueError("transition is not stable; give initial_covariance")
            from scipy.linalg import solve_discrete_lyapunov

            initial_covariance = solve_discrete_lyapunov(a, w)
        self.mean = np.zeros(m) if mean is None else np.asarray(mean, dtype=float).reshape(m)
        self._initial_covariance = np.atleast_2d(np.asarray(initial_covariance, dtype=float))
        # imported here: filterpy.kalman's package imports scipy.stats and more, 0.6 s of CPU
        # at every start of the predictor nodes, which run the scalar filter above
        from filterpy.kalman import KalmanFilter

        self.filter = KalmanFilter(dim_x=m, dim_z=m)
        self.filter.F = a
        self.filter.H = np.eye(m)
        self.filter.Q = w
        self.filter.R = v
        self.reset()

    @classmethod
    def from_models(cls, models, mean=None) -> MultiChannelPredictor:
        """Independent channels, one :class:`GaussMarkovModel` each."""
        return cls(
            np.diag([m.a for m in models]),
            np.diag([m.process_variance for m in models]),
            np.diag([m.measurement_variance for m in models]),
            np.diag([m.p0 for m in models]),
            mean,
        )

    @property
    def channels(self) -> int:
        return self.filter.dim_x

    def reset(self) -> None:
        self.filter.x = np.zeros(self.channels)
        self.filter.P = self._initial_covariance.copy()

    @property
    def prediction(self) -> np.ndarray:
        """L(t+1|t) for every channel, shape (m,)."""
        return self.mean + self.filter.x

    @property
    def prediction_covariance(self) -> np.ndarray:
        """P(t+1), shape (m, m)."""
        return self.filter.P.copy()

    def step(self, measurement) -> np.ndarray:
        """Filter y(t) (shape (m,)) and return the prediction L(t+1|t)."""
        y = np.asarray(measurement, dtype=float).reshape(self.channels)
        if not np.all(np.isfinite(y)):
            raise ValueError("measurement must be finite")
        self.filter.update(y - self.mean)
        self.filter.predict()
        return self.prediction
