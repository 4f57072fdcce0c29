"""The storage transfers of the off-line schedule (seed 000 part 2, sections 2 and 4): r(t)
pumped into (r > 0) or drawn from (r < 0) storage each hour, so that the generation
G(t) = L(t) + r(t) (eq. 2.2) is as flat as possible -- with convex running costs a flat G
is the cheapest -- while the stored energy comes back to where it started, sum r = 0
(eq. 4.3), each hour's transfer stays within R_min..R_max (2.3) and the store within
S_min..S_max (2.4, here a constraint instead of the paper's clipping).

"As flat as possible" is min sum G(t)^2 for the fixed sum of G. Without the store's bounds
it is water-filling: G(t) = clip(c, L + R_min, L + R_max) with the level c that makes
sum r = 0, found exactly by bisection; with them it is the cheapest transfers of one unit
costing G^2 (:func:`~.transfers.cheapest_transfers`, exact).

Units: MW (per hour: MWh a step), MWh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Storage:
    r_min_mw: float  # the most drawn in an hour (<= 0)
    r_max_mw: float  # the most pumped in an hour (>= 0)
    s_min_mwh: float = -math.inf
    s_max_mwh: float = math.inf
    s_start_mwh: float = 0.0

    def __post_init__(self):
        if not (self.r_min_mw <= 0 <= self.r_max_mw and self.s_min_mwh <= self.s_start_mwh <= self.s_max_mwh):
            raise ValueError(f"need R_min <= 0 <= R_max and S_min <= S(0) <= S_max, got {self}")

    def stored_mwh(self, r_mw) -> np.ndarray:
        """S(1..T) after each hour's transfer."""
        return self.s_start_mwh + np.cumsum(r_mw)


def water_filling(demand_mw, r_min_mw: float, r_max_mw: float, transfer_total_mwh: float = 0.0) -> np.ndarray:
    """r(t) with G = clip(c, L + R_min, L + R_max) and sum r = ``transfer_total_mwh`` (0:
    eq. 4.3), exact up to rounding."""
    demand = np.asarray(demand_mw, float)
    low, high = demand.min() + r_min_mw, demand.max() + r_max_mw
    for _ in range(200):  # sum r(c) grows with c, through zero
        level = 0.5 * (low + high)
        if np.sum(np.clip(level, demand + r_min_mw, demand + r_max_mw) - demand) > transfer_total_mwh:
            high = level
        else:
            low = level
    return np.clip(0.5 * (low + high), demand + r_min_mw, demand + r_max_mw) - demand


def flatten(demand_mw, storage: Storage, transfer_total_mwh: float = 0.0) -> np.ndarray:
    """The transfers r(t) (MW) that make L + r as flat as possible within the storage's
    limits, with sum r = ``transfer_total_mwh`` (0: the store ends as it began)."""
    demand = np.asarray(demand_mw, float)
    if demand.ndim != 1 or demand.size < 2 or not np.all(np.isfinite(demand)):
        raise ValueError("need a finite demand profile of at least two hours")
    n = demand.size
    if not n * storage.r_min_mw - 1e-9 <= transfer_total_mwh <= n * storage.r_max_mw + 1e-9:
        raise ValueError(f"{transfer_total_mwh} MWh cannot be transferred in {n} hours")
    start = water_filling(demand, storage.r_min_mw, storage.r_max_mw, transfer_total_mwh)
    stored = storage.stored_mwh(start)
    if np.all((stored >= storage.s_min_mwh - 1e-9) & (stored <= storage.s_max_mwh + 1e-9)):
        return start  # the store's bounds do not bind
    # sum G^2 is the running cost of one unit with CG = G^2 on all day: its cheapest transfers
    # within the store's bounds are this problem's exact solution (transfers.py)
    from hex_control.seeds.unit_commitment.fleet import Fleet, Unit
    from hex_control.seeds.unit_commitment.transfers import cheapest_transfers

    square = Fleet("sum_of_squares", (Unit(0.0, float(np.max(demand)) + storage.r_max_mw + 1.0, 0.0, 0.0, 1.0),))
    return cheapest_transfers(square, [(True,)] * n, demand, storage, transfer_total_mwh)
