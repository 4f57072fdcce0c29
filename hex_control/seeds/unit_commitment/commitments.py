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
grid that closes in (the dual is concave). Weak duality makes it a bound at every lambda, so the search is
exact; where the bound ties the K-th cost the branch is cut, which may drop a commitment
of that same cost, never a cheaper one.

Units: MW, cost units per hour.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.dispatch import economic_dispatch
from hex_control.seeds.unit_commitment.fleet import Fleet


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
        self.half_inverse_a3 = 0.5 / self.a3

    def bound(self, total_mw: float, on: np.ndarray, free: np.ndarray, stages: int = 5,
              points: int = 16) -> tuple[float, np.ndarray]:
        """The dual bound of every commitment with the units ``on`` on and the ``free`` ones
        either way (the rest off). The dual is concave in lambda: it is taken on a grid of
        ``points``, which then closes in around the best of them, ``stages`` times (each
        grid's best is a bound; the last is within a hundredth of a cost unit of the dual's
        maximum on the appendix fleets). Also which units the relaxation would have on there."""
        low, high, best, wanted = 0.0, self.lambda_max, -np.inf, None
        for _ in range(stages):
            lam = np.linspace(low, high, points)[:, None]
            g = np.minimum(np.maximum((lam - self.a2) * self.half_inverse_a3, self.g_min), self.g_max)
            terms = self.a1 + (self.a2 - lam) * g + self.a3 * g * g  # min over G_i of CG - lambda G_i
            dual = lam[:, 0] * total_mw + terms[:, on].sum(axis=1) + np.minimum(terms[:, free], 0.0).sum(axis=1)
            i = int(np.argmax(dual))
            if dual[i] > best:
                best, wanted = float(dual[i]), terms[i] < 0
            step = (high - low) / (points - 1)
            low, high = max(0.0, float(lam[i, 0]) - step), float(lam[i, 0]) + step
        return best, wanted


def cheapest_commitments(fleet: Fleet, total_mw: float, k: int = 5) -> list[Commitment]:
    """The ``k`` cheapest commitments of ``fleet`` that can generate ``total_mw`` (fewer if
    fewer can), cheapest first. Commitments that differ only in which of several identical
    units are on are one: it is listed with the first of them (in the fleet's order) on."""
    if k < 1:
        raise ValueError(f"need k >= 1, got {k}")
    arrays = _Fleet(fleet)
    n = len(fleet)
    if not 0 < total_mw <= arrays.g_max.sum():
        raise ValueError(f"{total_mw} MW is beyond the fleet's 0..{arrays.g_max.sum():g} MW")
    order = np.argsort(arrays.a1 / arrays.g_max + arrays.a2 + arrays.a3 * arrays.g_max, kind="stable")
    # cheapest per MW first; identical units (the same in every figure) end up side by side
    # and are one choice: of a run of them the first ones are on, so each way of having
    # n of them on is counted once
    twin_of_previous = [depth > 0 and fleet.units[order[depth]] == fleet.units[order[depth - 1]]
                        for depth in range(n)]
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
        bound, wanted = arrays.bound(total_mw, on, free)
        if bound >= kth_cost():
            return
        unit = order[depth]
        states = (True, False) if wanted[unit] else (False, True)  # the relaxation's choice first
        if twin_of_previous[depth] and not on[order[depth - 1]]:
            states = (False,)
        for state in states:
            branch_on, branch_free = on.copy(), free.copy()
            branch_free[unit] = False
            branch_on[unit] = state
            search(depth + 1, branch_on, branch_free)

    search(0, np.zeros(n, bool), np.ones(n, bool))
    return [entry for _, _, entry in sorted(found, key=lambda item: -item[0])]
