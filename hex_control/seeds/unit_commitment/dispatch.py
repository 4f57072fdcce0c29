"""Economic dispatch (seed 000 part 2, eq. 2.7): the committed units share a total
generation at one incremental cost lambda, each within its bounds. With the quadratic
costs of eq. 2.5 each unit's output G_i(lambda) = clip((lambda - a2) / (2 a3), G_min, G_max)
is piecewise linear in lambda, and so is the total: between two consecutive breakpoints
(a unit reaching a bound) it is a straight line, so lambda is found exactly on the
breakpoints, without iteration.

Units: MW, cost units per hour, lambda in cost units per MWh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.fleet import Unit


@dataclass(frozen=True)
class Dispatch:
    levels_mw: np.ndarray  # (n,) each committed unit's generation
    incremental_cost: float  # lambda (per MWh)
    cost_per_h: float  # the running costs' sum (eq. 2.5)


def _outputs(lam, a2, a3, g_min, g_max) -> np.ndarray:
    return np.clip((np.asarray(lam, float)[..., None] - a2) / (2.0 * a3), g_min, g_max)


def economic_dispatch(units: list[Unit] | tuple[Unit, ...], demand_mw: float) -> Dispatch:
    """The cheapest levels of these (committed) units that sum to ``demand_mw``; ValueError
    if it is outside their combined bounds. Every unit needs a3 > 0."""
    if not units:
        raise ValueError("no unit committed")
    g_min, g_max, a2, a3 = (np.array([getattr(u, name) for u in units], float)
                            for name in ("g_min_mw", "g_max_mw", "a2", "a3"))
    if np.any(a3 <= 0):
        raise ValueError("economic dispatch by incremental cost needs a3 > 0 for every unit")
    low, high = g_min.sum(), g_max.sum()
    tolerance = 1e-9 * max(high, 1.0)
    if not np.isfinite(demand_mw) or not low - tolerance <= demand_mw <= high + tolerance:
        raise ValueError(f"demand {demand_mw} MW is outside the committed units' {low:g}..{high:g} MW")
    demand = min(max(float(demand_mw), low), high)
    breakpoints = np.unique(np.concatenate([a2 + 2 * a3 * g_min, a2 + 2 * a3 * g_max]))
    totals = _outputs(breakpoints, a2, a3, g_min, g_max).sum(axis=1)  # nondecreasing
    j = int(np.clip(np.searchsorted(totals, demand), 1, len(breakpoints) - 1)) if len(breakpoints) > 1 else 0
    if len(breakpoints) == 1 or totals[j] == totals[j - 1]:
        lam = float(breakpoints[j])
    else:  # the total is a straight line between breakpoints j - 1 and j
        lam = float(breakpoints[j - 1] + (demand - totals[j - 1]) * (breakpoints[j] - breakpoints[j - 1])
                    / (totals[j] - totals[j - 1]))
    levels = _outputs(lam, a2, a3, g_min, g_max)
    cost = float(sum(u.running_cost(g) for u, g in zip(units, levels)))
    return Dispatch(levels, lam, cost)
