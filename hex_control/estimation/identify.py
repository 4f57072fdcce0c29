"""Identify a, W, V of the Gauss-Markov load from a recorded series.

The seed says these "must be identified from actual load data" (seed 000 part 2,
after eq. 6.5) and does not say how. Here: exact Gaussian maximum likelihood by the
prediction-error decomposition -- the Kalman predictor of eqs 6.6-6.7 itself yields the
innovations e(t) and their variances S(t) = P(t) + V, and

    -log p(y) = 1/2 sum_t [ log(2 pi S(t)) + e(t)^2 / S(t) ]

with P(0) the stationary variance (Harvey, *Forecasting, Structural Time Series Models
and the Kalman Filter*, 1989, section 3.4). Standard errors come from the inverse of the
numerical Hessian of that negative log-likelihood at the optimum (observed information).

:func:`method_of_moments` is the closed-form sanity check: the autocovariances
gamma_k of y satisfy gamma_1 = a sigma_x^2, gamma_2 = a^2 sigma_x^2, gamma_0 = sigma_x^2 + V,
so a = gamma_2/gamma_1, W = (1 - a^2) gamma_1 / a, V = gamma_0 - gamma_1 / a.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.estimation.gauss_markov import GaussMarkovModel
from hex_control.estimation.kalman import predict_series

_A_BOUND = 0.9999  # |a| < 1: the likelihood assumes a stationary fluctuation


@dataclass(frozen=True)
class Identification:
    """Estimated model with its uncertainty.

    Attributes:
        model: the estimate (a, W, V; P(0) stationary).
        mean: the sample mean L_bar that was subtracted (load unit).
        standard_errors: (se_a, se_W, se_V) from the observed information; NaN when
            the estimate lies on the boundary (W or V ~ 0 -- the ML estimate of a small V
            piles up at zero on short, weakly correlated series) or the Hessian is not
            positive definite there.
        log_likelihood: at the estimate.
        samples: series length used.
    """

    model: GaussMarkovModel
    mean: float
    standard_errors: tuple[float, float, float]
    log_likelihood: float
    samples: int


def _check_series(measurements, minimum: int) -> np.ndarray:
    y = np.asarray(measurements, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"the series must be one-dimensional, got shape {y.shape}")
    if y.size < minimum:
        raise ValueError(f"need at least {minimum} samples to identify a, W, V, got {y.size}")
    if not np.all(np.isfinite(y)):
        raise ValueError("the series must be finite")
    if np.ptp(y) <= 1e-12 * np.max(np.abs(y)):
        # no fluctuation at all (e.g. a sensor that repeats one value): every lag
        # autocovariance is 0 and a = gamma_1/gamma_0 is 0/0
        raise ValueError(f"the series is constant ({y[0]!r} x {y.size}): a, W, V are not identifiable")
    return y


def negative_log_likelihood(model: GaussMarkovModel, fluctuation) -> float:
    """Exact Gaussian -log p(y) of a zero-mean series under ``model``."""
    series = predict_series(model, fluctuation)
    s = series.innovation_variance
    return 0.5 * float(np.sum(np.log(2.0 * math.pi * s) + series.innovation**2 / s))


def method_of_moments(measurements) -> GaussMarkovModel | None:
    """Closed-form estimate from the first three sample autocovariances.

    Returns ``None`` when the moments admit no model (e.g. gamma_1 <= 0, or a
    resulting variance negative) -- common for short or weakly correlated series.
    """
    y = _check_series(measurements, 4)
    x = y - y.mean()
    n = x.size
    g0, g1, g2 = (float(np.dot(x[: n - k], x[k:]) / n) for k in range(3))
    if g1 <= 0 or g2 <= 0:
        return None
    a = g2 / g1
    w = (1.0 - a * a) * g1 / a
    v = g0 - g1 / a
    if not (0 < a < 1) or w <= 0 or v < 0:
        return None
    return GaussMarkovModel(a, w, v)


def _to_model(theta) -> GaussMarkovModel:
    return GaussMarkovModel(_A_BOUND * math.tanh(theta[0]), math.exp(theta[1]), math.exp(theta[2]))


def _to_theta(model: GaussMarkovModel, floor: float) -> np.ndarray:
    a = min(max(model.a / _A_BOUND, -0.999), 0.999)
    return np.array([math.atanh(a), math.log(max(model.process_variance, floor)),
                     math.log(max(model.measurement_variance, floor))])


def _starting_points(x: np.ndarray) -> list[GaussMarkovModel]:
    var = float(np.var(x))
    lag1 = float(np.dot(x[:-1], x[1:]) / np.dot(x, x))
    a0 = min(max(lag1, 0.05), 0.99)
    starts = [GaussMarkovModel(a0, var * (1 - a0 * a0) * f, var * (1 - f)) for f in (0.9, 0.5, 0.1)]
    moments = method_of_moments(x)
    if moments is not None:
        starts.insert(0, moments)
    return starts


def _hessian(f, x: np.ndarray) -> np.ndarray:
    """Central-difference Hessian with steps relative to each coordinate."""
    h = 1e-4 * np.maximum(np.abs(x), 1e-6)
    n = x.size
    hess = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            ei, ej = np.eye(n)[i] * h[i], np.eye(n)[j] * h[j]
            value = (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4 * h[i] * h[j])
            hess[i, j] = hess[j, i] = value
    return hess


def identify(measurements) -> Identification:
    """Maximum-likelihood a, W, V (and the mean) of a measured load series.

    Args:
        measurements: y(t) + L_bar, shape (n,), n >= 20, finite.
    """
    y = _check_series(measurements, 20)
    mean = float(y.mean())
    x = y - mean
    floor = 1e-12 * max(float(np.var(x)), 1e-300)

    def objective(theta):
        return negative_log_likelihood(_to_model(theta), x)

    from scipy.optimize import minimize  # here: 0.3 s of a predictor node's start, which may never identify

    best = None
    for start in _starting_points(x):
        result = minimize(objective, _to_theta(start, floor), method="Nelder-Mead",
                          options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})
        if best is None or result.fun < best.fun:
            best = result
    model = _to_model(best.x)

    natural = np.array([model.a, model.process_variance, model.measurement_variance])

    def natural_objective(p):
        if abs(p[0]) >= 1 or p[1] <= 0 or p[2] <= 0:
            return math.inf
        return negative_log_likelihood(GaussMarkovModel(*p), x)

    errors = (math.nan,) * 3
    if natural[2] > 1e-6 * natural[1] and natural[1] > 1e-6 * natural[2]:
        hess = _hessian(natural_objective, natural)
        if np.all(np.isfinite(hess)):
            try:
                covariance = np.linalg.inv(hess)
                diag = np.diag(covariance)
                if np.all(diag > 0):
                    errors = tuple(float(e) for e in np.sqrt(diag))
            except np.linalg.LinAlgError:
                pass
    return Identification(model, mean, errors, -float(best.fun), int(y.size))
