"""The force loop's PI gains tuned by simulation on the plant's force table: the ITAE of a
force step (seed 001 section 3.2), minimized by :func:`hex_control.control.itae.minimize_itae`."""

from __future__ import annotations

import math

from hex_control.control.force_law import PIForceLaw
from hex_control.control.itae import itae, minimize_itae
from hex_control.control.pi import TustinPI
from hex_control.plant.force_table import ForceTable, ForceTableParameters, simulate_force_loop


def step_itae(kp: float, ki: float, parameters: ForceTableParameters, period_s: float, force_n: float,
              *, duration_s: float, start_mm: float = -1.0) -> float:
    """ITAE of a force step from contact (table at ``start_mm`` = the contact point)."""
    table = ForceTable(parameters, step_s=period_s / 5)
    table.reset(start_mm)
    pi = TustinPI(kp, ki, period_s)
    pi.reset(start_mm)
    log = simulate_force_loop(table, PIForceLaw(pi), lambda _t: force_n, period_s, duration_s)
    value = itae(log["time"], log["setpoint"] - log["force"])
    return value if math.isfinite(value) else math.inf


def tune_pi_itae(parameters: ForceTableParameters, period_s: float, force_n: float, duration_s: float,
                 initial=(0.002, 0.05), *, start_mm: float = -1.0) -> tuple[float, float, float]:
    """(kp, ki, itae) minimizing the step ITAE, from ``initial``."""
    (kp, ki), value = minimize_itae(lambda gains: step_itae(gains[0], gains[1], parameters, period_s, force_n,
                                                            duration_s=duration_s, start_mm=start_mm), initial)
    return kp, ki, value
