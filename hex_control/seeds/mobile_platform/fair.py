"""The fair comparison of seed 004 section 4: the energy-index law (eq. 19-21) and the two
PIDs tuned by one optimizer, on one criterion, with one budget of simulations, at the
encoders' resolution (5.2 um of wheel arc a count) and on both plants (as modelled, and
loaded with the payload and the gear friction the model does not know).

The criterion is the seed's figure of merit, how near H stays to the path (Fig. 10):
the RMS distance of H from the path, summed over the two plants on Fig. 7's path
(``rms_path``); the older ITAE of |H - H_bar(t)| (``itae``) is kept for comparison.

The optimizer (:func:`tune`): the controller's positive gains on a log box; the first
third of the budget is a scrambled Sobol sample of the box (seeded), the rest a
Nelder-Mead search from the best sample, stopped when the budget of evaluations (two
simulations each) is spent. The same function, box width per gain, seed and budget serve
both controllers. SI units."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc

from hex_control.seeds.mobile_platform.case import PlatformCase
from hex_control.seeds.mobile_platform.simulation import tracking_figures

#: each controller's gains and their search box (low, high), positive, searched in log
BOXES = {
    "energy_index": {"gain": (30.0, 30000.0), "k": (0.3, 10.0)},
    "two_pid": {"speed_kp": (3.0, 3000.0), "speed_ki": (1.0, 30000.0), "speed_kd": (1e-4, 1.0),
                "turn_kp": (1e-3, 100.0), "turn_ki": (0.1, 1000.0), "turn_kd": (1e-4, 1.0), "k": (0.3, 10.0)},
}
CRITERIA = ("rms_path", "itae")


def make_controller(case: PlatformCase, family: str, gains: dict):
    if family == "energy_index":
        return case.energy_controller(gains["gain"], gains["k"])
    if family == "two_pid":
        return case.pid_controller([gains["speed_kp"], gains["speed_ki"], gains["speed_kd"]],
                                   [gains["turn_kp"], gains["turn_ki"], gains["turn_kd"]], gains["k"])
    raise ValueError(f"unknown controller family {family!r}; known: {', '.join(BOXES)}")


def case_gains(case: PlatformCase, family: str) -> dict:
    """The case file's gains as the box's names."""
    if family == "energy_index":
        return dict(case.energy_index)
    pid = case.two_pid
    return {"speed_kp": pid["speed"][0], "speed_ki": pid["speed"][1], "speed_kd": pid["speed"][2],
            "turn_kp": pid["turn"][0], "turn_ki": pid["turn"][1], "turn_kd": pid["turn"][2], "k": pid["k"]}


def as_case_gains(family: str, gains: dict) -> dict:
    """The box's names back in the case file's form (energy_index: gain, k; two_pid: speed,
    turn as [kp, ki, kd], k), to 8 significant digits: the errors are a few encoder counts,
    and 5 digits move them by a count."""
    def r(x):
        return float(f"{x:.8g}")

    if family == "energy_index":
        return {"gain": r(gains["gain"]), "k": r(gains["k"])}
    return {"speed": [r(gains[f"speed_{g}"]) for g in ("kp", "ki", "kd")],
            "turn": [r(gains[f"turn_{g}"]) for g in ("kp", "ki", "kd")], "k": r(gains["k"])}


def cost(case: PlatformCase, family: str, gains: dict, criterion: str = "rms_path", desired=None) -> float:
    """The criterion summed over the two plants on Fig. 7's path (or ``desired``), encoders on."""
    if criterion not in CRITERIA:
        raise ValueError(f"unknown criterion {criterion!r}; known: {', '.join(CRITERIA)}")
    desired = desired or case.desired()
    total = 0.0
    for plant in case.tuning_plants:
        figures = tracking_figures(case.run(plant, make_controller(case, family, gains), desired,
                                            with_friction=False), desired)
        value = figures.rms_path_error_m if criterion == "rms_path" else figures.itae_m_s2
        total += value if math.isfinite(value) else math.inf
    return total


@dataclass(frozen=True)
class Tuned:
    family: str
    criterion: str
    gains: dict
    value: float
    evaluations: int


def tune(case: PlatformCase, family: str, budget: int, criterion: str = "rms_path", *, seed: int = 4,
         progress=None) -> Tuned:
    """The best gains found in ``budget`` evaluations (see the module's docstring)."""
    if budget < 6:
        raise ValueError("budget must be >= 6 evaluations")
    box = BOXES[family]
    names = list(box)
    low = np.log([box[n][0] for n in names])
    high = np.log([box[n][1] for n in names])
    desired = case.desired()
    seen: list[tuple[float, np.ndarray]] = []

    def evaluate(log_gains) -> float:
        if len(seen) >= budget:
            raise _BudgetSpent
        log_gains = np.clip(log_gains, low, high)
        value = cost(case, family, dict(zip(names, np.exp(log_gains))), criterion, desired)
        seen.append((value, log_gains))
        if progress:
            progress()
        return value

    with warnings.catch_warnings():  # a budget's third is rarely a power of 2; the points stay well spread
        warnings.simplefilter("ignore", UserWarning)
        samples = qmc.Sobol(len(names), scramble=True, seed=seed).random(max(budget // 3, 2))
    try:
        for point in low + samples * (high - low):
            evaluate(point)
        start = min(seen, key=lambda s: s[0])[1]
        minimize(evaluate, start, method="Nelder-Mead",
                 options={"maxfev": budget - len(seen), "xatol": 1e-3, "fatol": 0.0, "initial_simplex":
                          _simplex(start, 0.1 * (high - low))})
    except _BudgetSpent:
        pass
    value, best = min(seen, key=lambda s: s[0])
    return Tuned(family, criterion, {n: float(g) for n, g in zip(names, np.exp(best))}, value, len(seen))


class _BudgetSpent(Exception):
    pass


def _simplex(start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    return np.vstack([start] + [start + np.eye(start.size)[i] * steps[i] for i in range(start.size)])


def sweep_energy_index(case: PlatformCase, gains, ks, progress=None) -> list[dict]:
    """The law's RMS path error on each plant over a grid of q1/r and k (Fig. 7's path)."""
    desired = case.desired()
    rows = []
    for gain in gains:
        for k in ks:
            row = {"gain": float(gain), "k": float(k)}
            for name, plant in zip(("as_modelled", "loaded"), case.tuning_plants):
                figures = tracking_figures(case.run(plant, case.energy_controller(gain, k), desired,
                                                    with_friction=False), desired)
                row[f"rms_path_{name}_m"] = figures.rms_path_error_m
                row[f"max_heading_{name}_rad"] = figures.max_heading_error_rad
            rows.append(row)
            if progress:
                progress()
    return rows


def conditions(case: PlatformCase) -> dict:
    """{name: (case, test_path, plant)}: the four cases the controllers are tuned near, and
    the seed's named conditions the tuning did not see: twice the gear friction, twice
    v_A, on Fig. 10's test path."""
    faster = replace(case, test_path=replace(case.test_path, speed_m_s=2 * case.test_path.speed_m_s))
    rough = replace(case.plant, gear_friction_n_m=2 * case.plant.gear_friction_n_m)
    return {"Fig. 7, as modelled": (case, False, case.model), "Fig. 7, loaded": (case, False, case.plant),
            "Fig. 10, as modelled": (case, True, case.model), "Fig. 10, loaded": (case, True, case.plant),
            "Fig. 10, loaded, 2x gear friction": (case, True, rough),
            "Fig. 10, as modelled, v_A 0.2 m/s": (faster, True, case.model)}


def compare_tuned(case: PlatformCase, tuned: dict, progress=None) -> dict:
    """{condition: {family: TrackingFigures}} for the tuned gains ({family: gains})."""
    table = {}
    for name, (where, test_path, plant) in conditions(case).items():
        desired = where.desired(test_path)
        table[name] = {}
        for family, gains in tuned.items():
            record = where.run(plant, make_controller(where, family, gains), desired)
            table[name][family] = tracking_figures(record, desired)
            if progress:
                progress()
    return table
