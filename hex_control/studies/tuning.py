"""Gain tuning by simulation: the ITAE criterion of seed 001 section 3.2, sum |e_k| t_k dt,
minimized over a controller's gains (Nelder-Mead on log-gains, so they stay > 0): the PI
gains of the force loop here, the platform's controllers in mobile_platform.tuning."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize

from hex_control.control.force_law import PIForceLaw
from hex_control.control.pi import TustinPI
from hex_control.plant.force_table import ForceTable, ForceTableParameters, simulate_force_loop


def itae(times_s, errors) -> float:
    """Integral of time-weighted absolute error, sum |e_k| t_k dt (rectangle rule)."""
    t, e = np.asarray(times_s, float), np.asarray(errors, float)
    if t.shape != e.shape or t.size < 2:
        raise ValueError("need equal time and error series of at least two samples")
    return float(np.sum(np.abs(e) * t) * (t[1] - t[0]))


def step_itae(kp: float, ki: float, parameters: ForceTableParameters, period_s: float, force_n: float,
              duration_s: float, start_mm: float = -1.0) -> float:
    """ITAE of a force step from contact (table at ``start_mm`` = the contact point)."""
    table = ForceTable(parameters, step_s=period_s / 5)
    table.reset(start_mm)
    pi = TustinPI(kp, ki, period_s)
    pi.reset(start_mm)
    log = simulate_force_loop(table, PIForceLaw(pi), lambda _t: force_n, period_s, duration_s)
    value = itae(log["time"], log["setpoint"] - log["force"])
    return value if math.isfinite(value) else math.inf


def tune_pi_itae(parameters: ForceTableParameters, period_s: float, force_n: float, duration_s: float,
                 initial=(0.002, 0.05), start_mm: float = -1.0) -> tuple[float, float, float]:
    """(kp, ki, itae) minimizing the step ITAE, from ``initial``."""
    (kp, ki), value = minimize_itae(lambda gains: step_itae(gains[0], gains[1], parameters, period_s, force_n,
                                                            duration_s, start_mm), initial)
    return kp, ki, value


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
