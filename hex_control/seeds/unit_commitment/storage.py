"""The storage transfers of the off-line schedule (seed 000 part 2, sections 2 and 4): r(t)
pumped into (r > 0) or drawn from (r < 0) storage each hour, so that the generation
G(t) = L(t) + r(t) (eq. 2.2) is as flat as possible -- with convex running costs a flat G
is the cheapest -- while the stored energy comes back to where it started, sum r = 0
(eq. 4.3), each hour's transfer stays within R_min..R_max (2.3) and the store within
S_min..S_max (2.4, here a constraint instead of the paper's clipping).

"As flat as possible" is min sum G(t)^2 for the fixed sum of G. Without the store's bounds
it is water-filling: G(t) = clip(c, L + R_min, L + R_max) with the level c that makes
sum r = 0, found exactly by bisection; with them the same convex quadratic program is
solved by scipy's interior-point trust-constr.

Units: MW (per hour: MWh a step), MWh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, minimize


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
    lower_triangle = np.tril(np.ones((n, n)))  # S(t) - S(0) = sum of r up to t
    constraints = [LinearConstraint(np.ones((1, n)), transfer_total_mwh, transfer_total_mwh),
                   LinearConstraint(lower_triangle, storage.s_min_mwh - storage.s_start_mwh,
                                    storage.s_max_mwh - storage.s_start_mwh)]
    # with sum r fixed, sum G^2 differs from sum ((G - mean L) / scale)^2 by constants: the same
    # minimum, on numbers of order one
    mean, scale = demand.mean(), max(float(np.ptp(demand)), 1.0)
    result = minimize(lambda r: float(np.sum(((demand + r - mean) / scale) ** 2)), np.zeros(n),
                      jac=lambda r: 2 * (demand + r - mean) / scale**2, hess=lambda r: np.eye(n) * 2 / scale**2,
                      method="trust-constr", constraints=constraints,
                      bounds=Bounds(np.full(n, storage.r_min_mw), np.full(n, storage.r_max_mw)),
                      options={"gtol": 1e-10, "xtol": 1e-12, "maxiter": 5000})
    if not result.success:
        raise ValueError(f"no storage schedule within the limits: {result.message}")
    return result.x
