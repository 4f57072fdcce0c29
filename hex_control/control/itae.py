"""The ITAE criterion of seed 001 section 3.2, sum |e_k| t_k dt, and its minimization over a
controller's positive gains (Nelder-Mead on log-gains): the project's one tuning method, for
the force loop's PI (:mod:`hex_control.studies.tuning`) and the seed systems' controllers
(:mod:`hex_control.seeds.mobile_platform.tuning`)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize


def itae(times_s, errors) -> float:
    """Integral of time-weighted absolute error, sum |e_k| t_k dt (rectangle rule)."""
    t, e = np.asarray(times_s, float), np.asarray(errors, float)
    if t.shape != e.shape or t.size < 2:
        raise ValueError("need equal time and error series of at least two samples")
    return float(np.sum(np.abs(e) * t) * (t[1] - t[0]))


def minimize_itae(itae_of, initial, iterations_per_gain: int = 100) -> tuple[tuple[float, ...], float]:
    """(gains, ITAE): Nelder-Mead on the logarithms of positive gains from ``initial``, with
    ``iterations_per_gain`` x len(initial) iterations at most; ``itae_of(gains)`` runs the
    loop. The project's one tuning method, for any controller."""
    def cost(log_gains):
        value = itae_of(tuple(math.exp(g) for g in log_gains))
        return value if math.isfinite(value) else math.inf

    result = minimize(cost, np.log(initial), method="Nelder-Mead",
                      options={"xatol": 1e-3, "fatol": 1e-6, "maxiter": iterations_per_gain * len(initial)})
    return tuple(math.exp(g) for g in result.x), float(result.fun)
