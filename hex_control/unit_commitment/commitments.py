"""The K cheapest commitments for one total generation (seed 000 part 2, section 4: a row
block of the scheduling table), found exactly.

A commitment is the set of units on; its cost is their running cost at the economic
dispatch of the total (eq. 2.5, 2.7), starting costs left out as the table leaves them.
The 2^M commitments cannot be listed for M = 41, so they are searched by branch and bound:
units are fixed on or off one at a time, cheapest per MW first, and a branch is cut when
a lower bound on every commitment in it is no better than the K-th found so far. The bound
is the Lagrangian dual of the dispatch (the relaxation of Bertsekas et al., the paper's
[3]): for any lambda, lambda G + sum over units of min over their states of (CG - lambda
G_i), each unit on or off as it likes unless fixed; it is maximized over lambda by
bisection on its slope. Weak duality makes it a bound at every lambda, so the search is
exact; where the bound ties the K-th cost the branch is cut, which may drop a commitment
of that same cost, never a cheaper one.

Units: MW, cost units per hour.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from hex_control.unit_commitment.dispatch import economic_dispatch
from hex_control.unit_commitment.fleet import Fleet


@dataclass(frozen=True)
class Commitment:
    on: tuple[bool, ...]  # per unit of the fleet
    levels_mw: np.ndarray  # (M,) the economic dispatch, 0 for the units off
    cost_per_h: float
    incremental_cost: float  # lambda of the dispatch (per MWh)


class _Fleet:
    """The fleet as arrays, for the bound."""

    def __init__(self, fleet: Fleet):
        self.fleet = fleet
        names = ("g_min_mw", "g_max_mw", "a1", "a2", "a3")
        self.g_min, self.g_max, self.a1, self.a2, self.a3 = (
            np.array([getattr(u, name) for u in fleet.units], float) for name in names)
        # above this lambda every unit would rather be on, at G_max (CG(G_max) < lambda G_max)
        self.lambda_max = float(np.max(self.a2 + 2 * self.a3 * self.g_max + self.a1 / self.g_max)) + 1.0

    def unit_terms(self, lam: float):
        """(min over G_i in bounds of CG - lambda G_i, its G_i) of every unit at ``lam``."""
        g = np.clip((lam - self.a2) / (2 * self.a3), self.g_min, self.g_max)
        return self.a1 + (self.a2 - lam) * g + self.a3 * g * g, g

    def bound(self, total_mw: float, on: np.ndarray, free: np.ndarray, iterations: int = 60) -> float:
        """The dual bound of every commitment with the units ``on`` on and the ``free`` ones
        either way (the rest off)."""
        def slope(lam):
            terms, g = self.unit_terms(lam)
            used = on | (free & (terms < 0))
            return total_mw - g[used].sum()

        low, high = 0.0, self.lambda_max
        for _ in range(iterations):  # the dual is concave: its slope falls through zero
            middle = 0.5 * (low + high)
            if slope(middle) > 0:
                low = middle
            else:
                high = middle
        best = -np.inf
        for lam in (low, high):
            terms, _ = self.unit_terms(lam)
            best = max(best, lam * total_mw + terms[on].sum() + np.minimum(terms[free], 0.0).sum())
        return float(best)


def cheapest_commitments(fleet: Fleet, total_mw: float, k: int = 5) -> list[Commitment]:
    """The ``k`` cheapest commitments of ``fleet`` that can generate ``total_mw`` (fewer if
    fewer can), cheapest first."""
    if k < 1:
        raise ValueError(f"need k >= 1, got {k}")
    arrays = _Fleet(fleet)
    n = len(fleet)
    if not 0 < total_mw <= arrays.g_max.sum():
        raise ValueError(f"{total_mw} MW is beyond the fleet's 0..{arrays.g_max.sum():g} MW")
    order = np.argsort(arrays.a1 / arrays.g_max + arrays.a2 + arrays.a3 * arrays.g_max)  # cheapest per MW first
    found: list[tuple[float, int, Commitment]] = []  # a max-heap on cost, by negation
    counter = 0

    def kth_cost() -> float:
        return -found[0][0] if len(found) == k else np.inf

    def search(depth: int, on: np.ndarray, free: np.ndarray) -> None:
        nonlocal counter
        if arrays.g_min[on].sum() > total_mw + 1e-9 or arrays.g_max[on | free].sum() < total_mw - 1e-9:
            return  # no commitment in this branch can generate the total
        if depth == n:
            units = [fleet.units[i] for i in np.flatnonzero(on)]
            dispatch = economic_dispatch(units, total_mw)
            if dispatch.cost_per_h < kth_cost():
                levels = np.zeros(n)
                levels[on] = dispatch.levels_mw
                entry = Commitment(tuple(bool(x) for x in on), levels, dispatch.cost_per_h, dispatch.incremental_cost)
                counter += 1
                heapq.heappush(found, (-dispatch.cost_per_h, counter, entry))
                if len(found) > k:
                    heapq.heappop(found)
            return
        if arrays.bound(total_mw, on, free) >= kth_cost():
            return
        unit = order[depth]
        for state in (True, False):
            branch_on, branch_free = on.copy(), free.copy()
            branch_free[unit] = False
            branch_on[unit] = state
            search(depth + 1, branch_on, branch_free)

    search(0, np.zeros(n, bool), np.ones(n, bool))
    return [entry for _, _, entry in sorted(found, key=lambda item: -item[0])]
