"""Economic dispatch (seed 000 part 2, eq. 2.7): the committed units share a total
generation at one incremental cost lambda, each within its bounds. With the quadratic
costs of eq. 2.5 each unit's output G_i(lambda) = clip((lambda - a2) / (2 a3), G_min, G_max)
is piecewise linear in lambda, and so is the total: between two consecutive breakpoints
(a unit reaching a bound) it is a straight line, so lambda is found exactly on the
breakpoints, without iteration.

:func:`dispatch_hours` is the one implementation: many hours (or commitments) at once, on
the fleet's arrays; :func:`economic_dispatch` is it for one list of units.

Units: MW, cost units per hour, lambda in cost units per MWh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.fleet import FleetArrays, Unit


@dataclass(frozen=True)
class Dispatch:
    levels_mw: np.ndarray  # (n,) each committed unit's generation
    incremental_cost: float  # lambda (per MWh)
    cost_per_h: float  # the running costs' sum (eq. 2.5)


def committed_bounds(arrays: FleetArrays, on) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest) total (MW) that each commitment of ``on`` (..., M) can generate."""
    on = np.asarray(on, bool)
    return on @ arrays.g_min, on @ arrays.g_max


def dispatch_hours(arrays: FleetArrays, on, generation_mw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(running cost per hour (T,), lambda (T,), levels (T, M), 0 for units off) of the
    economic dispatch of each row of ``on`` (T, M) at its ``generation_mw`` (T,), clipped to
    what its units can generate. Exact: each row's total is piecewise linear in lambda
    between the fleet's breakpoints, so lambda is interpolated between the two that bracket
    the total. Every unit that is on needs a3 > 0."""
    on = np.atleast_2d(np.asarray(on, bool))
    low, high = committed_bounds(arrays, on)
    generation = np.clip(np.broadcast_to(np.asarray(generation_mw, float), low.shape), low, high)
    breakpoints = arrays.breakpoints
    if breakpoints.size == 1:  # every unit's range is one point of lambda: any lambda there
        lam = np.full(generation.shape, breakpoints[0])
    else:
        totals = on @ arrays.outputs_at_breakpoints.T  # (T, K), nondecreasing along a row
        j = np.clip((totals < generation[:, None]).sum(axis=1), 1, breakpoints.size - 1)
        rows = np.arange(generation.size)
        below, above = totals[rows, j - 1], totals[rows, j]
        rising = above > below
        lam = np.where(rising, breakpoints[j - 1] + (generation - below) * (breakpoints[j] - breakpoints[j - 1])
                       / np.where(rising, above - below, 1.0), breakpoints[j])
    levels = arrays.outputs(lam) * on
    cost = ((arrays.a1 + arrays.a2 * levels + arrays.a3 * levels * levels) * on).sum(axis=1)
    return cost, lam, levels


def economic_dispatch(units: list[Unit] | tuple[Unit, ...], demand_mw: float) -> Dispatch:
    """The cheapest levels of these (committed) units that sum to ``demand_mw``; ValueError
    if it is outside their combined bounds. Every unit needs a3 > 0."""
    if not units:
        raise ValueError("no unit committed")
    if any(u.a3 <= 0 for u in units):
        raise ValueError("economic dispatch by incremental cost needs a3 > 0 for every unit")
    arrays = FleetArrays(units)
    low, high = arrays.g_min.sum(), arrays.g_max.sum()
    tolerance = 1e-9 * max(high, 1.0)
    if not np.isfinite(demand_mw) or not low - tolerance <= demand_mw <= high + tolerance:
        raise ValueError(f"demand {demand_mw} MW is outside the committed units' {low:g}..{high:g} MW")
    cost, lam, levels = dispatch_hours(arrays, np.ones((1, len(units)), bool), [float(demand_mw)])
    return Dispatch(levels[0], float(lam[0]), float(cost[0]))
