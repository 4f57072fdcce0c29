"""The K cheapest commitments for one total generation (seed 000 part 2, section 4: a row
block of the scheduling table), found exactly.

A commitment is the set of units on; its cost is their running cost at the economic
dispatch of the total (eq. 2.5, 2.7), starting costs left out as the table leaves them.
The 2^M commitments cannot be listed for M = 41, so they are searched by branch and bound:
units are fixed on or off one at a time, cheapest per MW first, and a branch is cut when
a lower bound on every commitment in it is no better than the K-th found so far. The bound
is the Lagrangian dual of the dispatch (the relaxation of Bertsekas et al., the paper's
[3]): for any lambda, lambda G + sum over units of min over their states of (CG - lambda
G_i), each unit on or off as it likes unless fixed; it is maximized over lambda on a
fixed grid of 1025 points (the dual is concave), updated unit by unit down a branch. Weak duality makes it a
bound at every lambda, so the search is exact. Of commitments of equal cost the one with
units earlier in the fleet on ranks first, and a branch whose bound ties the K-th cost is
searched, so the table does not depend on the order of the search.

Units: MW, cost units per hour.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.dispatch import dispatch_hours
from hex_control.seeds.unit_commitment.fleet import Fleet


@dataclass(frozen=True)
class Commitment:
    on: tuple[bool, ...]  # per unit of the fleet
    levels_mw: np.ndarray  # (M,) the economic dispatch, 0 for the units off
    cost_per_h: float
    incremental_cost: float  # lambda of the dispatch (per MWh)


class Bound:
    """The Lagrangian bound on the fleet's arrays (:attr:`Fleet.arrays`)."""

    def __init__(self, fleet: Fleet, grid_points: int = 1025, stages: int = 0):
        self.arrays = arrays = fleet.arrays
        self.g_min, self.g_max, self.a1, self.a2, self.a3 = arrays.g_min, arrays.g_max, arrays.a1, arrays.a2, arrays.a3
        # above this lambda every unit would rather be on, at G_max (CG(G_max) < lambda G_max)
        self.lambda_max = float(np.max(self.a2 + 2 * self.a3 * self.g_max + self.a1 / self.g_max)) + 1.0
        self.half_inverse_a3 = 0.5 / self.a3
        # every unit's term on a fixed grid of lambda, once: a bound at each point costs two
        # matrix-vector products
        self.grid = np.linspace(0.0, self.lambda_max, grid_points)
        self.grid_terms = self._terms(self.grid[:, None])
        self.grid_negative = np.minimum(self.grid_terms, 0.0)
        self.stages = stages

    def _terms(self, lam: np.ndarray) -> np.ndarray:
        """min over G_i of CG_i - lambda G_i, per lambda (rows) and unit (columns)."""
        g = np.minimum(np.maximum((lam - self.a2) * self.half_inverse_a3, self.g_min), self.g_max)
        return self.a1 + (self.a2 - lam) * g + self.a3 * g * g

    def grid_dual(self, total_mw: float, on: np.ndarray, free: np.ndarray) -> np.ndarray:
        """The dual on the fixed grid (each point a bound); a branch updates it unit by unit
        (:meth:`fixed`)."""
        return self.grid * total_mw + self.grid_terms @ on + self.grid_negative @ free

    def fixed(self, dual: np.ndarray, unit: int, state: bool) -> np.ndarray:
        """``dual`` with the free ``unit`` fixed on (its term always counts) or off (never)."""
        change = self.grid_terms[:, unit] - self.grid_negative[:, unit] if state else -self.grid_negative[:, unit]
        return dual + change

    def bound(self, total_mw: float, on: np.ndarray, free: np.ndarray, dual: np.ndarray | None = None,
              *, cut_above: float = np.inf, points: int = 16) -> tuple[float, np.ndarray | None]:
        """The dual bound of every commitment with the units ``on`` on and the ``free`` ones
        either way (the rest off), from ``dual`` on the fixed grid (:meth:`grid_dual`). The
        dual is concave in lambda: it is taken on the fixed grid, then on a grid of
        ``points`` that closes in around the best point, ``stages`` times (each grid's best
        is a bound, by weak duality). By default no stage: on the appendix fleets the
        1025-point grid's bound finds the same commitments 3 times faster than with two
        stages. A fixed grid of 16 points and 4 stages is the search this replaced, which
        the bench times against. A grid bound above ``cut_above``
        already cuts the branch: it is returned at once, without which units the relaxation
        would have on (None); otherwise also those."""
        dual = self.grid_dual(total_mw, on, free) if dual is None else dual
        i = int(np.argmax(dual))
        best = float(dual[i])
        if best > cut_above:
            return best, None
        wanted = self.grid_terms[i] < 0
        step = self.grid[1] - self.grid[0]
        centre = self.grid[i]
        for _ in range(self.stages):
            low = max(0.0, centre - step)
            step = (centre + step - low) / (points - 1)
            lam = low + step * np.arange(points)
            terms = self._terms(lam[:, None])
            dual = lam * total_mw + terms @ on + np.minimum(terms, 0.0) @ free
            i = int(np.argmax(dual))
            if dual[i] > best:
                best, wanted = float(dual[i]), terms[i] < 0
            centre = lam[i]
        return best, wanted


def cheapest_commitments(fleet: Fleet, total_mw: float, k: int = 5, *, bound: Bound | None = None) -> list[Commitment]:
    """The ``k`` cheapest commitments of ``fleet`` that can generate ``total_mw`` (fewer if
    fewer can), cheapest first. Commitments that differ only in which of several identical
    units are on are one: it is listed with the first of them (in the fleet's order) on."""
    if k < 1:
        raise ValueError(f"need k >= 1, got {k}")
    arrays = bound or fleet.arrays.cache.get("bound") or fleet.arrays.cache.setdefault("bound", Bound(fleet))
    n = len(fleet)
    if not 0 < total_mw <= arrays.g_max.sum():
        raise ValueError(f"{total_mw} MW is beyond the fleet's 0..{arrays.g_max.sum():g} MW")
    order = np.argsort(arrays.a1 / arrays.g_max + arrays.a2 + arrays.a3 * arrays.g_max, kind="stable")
    # cheapest per MW first; identical units (the same in every figure) end up side by side
    # and are one choice: of a run of them the first ones are on, so each way of having
    # n of them on is counted once
    twin_of_previous = [depth > 0 and fleet.units[order[depth]] == fleet.units[order[depth - 1]]
                        for depth in range(n)]
    # a max-heap on cost, by negation; of equal costs the commitment with units earlier in
    # the fleet on ranks first (so the table does not depend on the order of the search)
    found: list[tuple[float, tuple[bool, ...], Commitment]] = []

    def kth_cost() -> float:
        return -found[0][0] if len(found) == k else np.inf

    def search(depth: int, on: np.ndarray, free: np.ndarray, dual: np.ndarray) -> None:
        if arrays.g_min[on].sum() > total_mw + 1e-9 or arrays.g_max[on | free].sum() < total_mw - 1e-9:
            return  # no commitment in this branch can generate the total
        if depth == n:
            costs, lam, levels = dispatch_hours(arrays.arrays, on[None], [total_mw])
            cost = float(costs[0])
            key = (-cost, tuple(bool(x) for x in on))
            if len(found) < k or key > found[0][:2]:
                entry = Commitment(tuple(bool(x) for x in on), levels[0], cost, float(lam[0]))
                heapq.heappush(found, (*key, entry))
                if len(found) > k:
                    heapq.heappop(found)
            return
        bound, wanted = arrays.bound(total_mw, on, free, dual, cut_above=kth_cost())
        if bound > kth_cost():  # a tie may still rank first
            return
        unit = order[depth]
        states = (True, False) if wanted[unit] else (False, True)  # the relaxation's choice first
        if twin_of_previous[depth] and not on[order[depth - 1]]:
            states = (False,)
        for state in states:
            branch_on, branch_free = on.copy(), free.copy()
            branch_free[unit] = False
            branch_on[unit] = state
            search(depth + 1, branch_on, branch_free, arrays.fixed(dual, unit, state))

    everything_free = np.ones(n, bool)
    search(0, np.zeros(n, bool), everything_free, arrays.grid_dual(total_mw, np.zeros(n, bool), everything_free))
    return [entry for *_, entry in sorted(found, key=lambda item: item[:2], reverse=True)]
