"""Skill of a one-step prediction against naive persistence."""

from __future__ import annotations

import numpy as np


def skill_score(measurements, predictions, consecutive=None) -> float:
    """1 - MSE(prediction) / MSE(persistence) of one-step-ahead predictions.

    ``predictions[t]`` is the prediction of ``measurements[t + 1]`` made at t (the last
    one has no target and is ignored); persistence predicts ``measurements[t]``.
    ``consecutive`` (bool, length n - 1) marks the pairs where sample t + 1 really
    follows sample t -- for series received over a lossy transport; default all.
    1 is perfect, 0 is no better than persistence, negative is worse.
    """
    y = np.asarray(measurements, dtype=float)
    p = np.asarray(predictions, dtype=float)
    if y.shape != p.shape or y.ndim != 1 or y.size < 3:
        raise ValueError(f"need two equal 1-D series of >= 3 samples, got {y.shape} and {p.shape}")
    pairs = np.ones(y.size - 1, bool) if consecutive is None else np.asarray(consecutive, bool)
    if pairs.shape != (y.size - 1,) or not pairs.any():
        raise ValueError("consecutive must be a boolean mask of length n - 1 with a True")
    target = y[1:][pairs]
    mse_prediction = float(np.mean((target - p[:-1][pairs]) ** 2))
    mse_persistence = float(np.mean((target - y[:-1][pairs]) ** 2))
    if mse_persistence == 0:
        raise ValueError("persistence is exact on a constant series; skill is undefined")
    return 1.0 - mse_prediction / mse_persistence


def expected_skill(a: float, process_variance: float, measurement_variance: float,
                   prediction_variance: float) -> float:
    """Skill the steady-state Kalman predictor should reach on a long series.

    MSE(prediction) = P_ss + V; MSE(persistence) = E[(y(t+1) - y(t))^2]
    = 2 (1 - a) W / (1 - a^2) + 2 V.
    """
    stationary = process_variance / (1.0 - a * a)
    persistence = 2.0 * (1.0 - a) * stationary + 2.0 * measurement_variance
    return 1.0 - (prediction_variance + measurement_variance) / persistence
