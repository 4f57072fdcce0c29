"""The peer a power engineer would use (issue 24 item 6): the deterministic day as one
mixed-integer linear program, solved by HiGHS through scipy.optimize.milp.

Per hour t and unit i: on u(t,i) in {0,1}, generation G(t,i), running cost z(t,i),
starting cost c(t,i); per hour the transfer r(t). Then

- demand (2.2): sum_i G(t,i) - r(t) = L(t); bounds u G_min <= G <= u G_max;
- running cost (2.5) from below by its tangents at ``tangents`` points of each unit's
  range: z >= CG(g_k) u + CG'(g_k) (G - g_k u), so z is the quadratic cost up to at most
  a3 h^2 / 4 for tangent spacing h, never above it;
- starting cost by hours down (the tables' CS(1..6), nondecreasing): c(t) >=
  CS(k) (u(t) - sum_{n=1..k} u(t-n)) for every k, which is CS(d) after d hours down (the
  standard formulation of down-time-dependent start-up costs; Carrion and Arroyo, IEEE
  Trans. Power Systems 21(3), 2006, eq. 12-13);
- the store (2.3, 2.4, 4.3): R bounds, S bounds on S(0) + the transfers so far, sum r = 0.

Because every term is a bound from below, the program's optimum -- and HiGHS's dual bound
-- is a lower bound on the true cheapest day; the program's commitments, with their
exact dispatch and cheapest transfers, are a true day, an upper bound. The two bracket
the optimum that the table algorithm is measured against.

Units: MW, MWh, cost units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, milp

from hex_control.seeds.unit_commitment.day import DayPlan
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.search import hours_down, search_commitments
from hex_control.seeds.unit_commitment.storage import Storage
from hex_control.seeds.unit_commitment.transfers import cheapest_transfers


@dataclass(frozen=True)
class MilpDay:
    plan: DayPlan  # the program's commitments, exactly dispatched: a true day (upper bound)
    lower_bound: float  # no day is cheaper (HiGHS's dual bound on the under-estimating program)
    objective: float  # the program's value at its solution (the tangent costs)
    status: str

    @property
    def gap(self) -> float:
        """(upper - lower) / upper: how far from the optimum the plan can be."""
        return (self.plan.total_cost - self.lower_bound) / self.plan.total_cost


def milp_schedule(fleet: Fleet, demand_mw, storage: Storage, initially_on=None, tangents: int = 12,
                  *, mip_rel_gap: float = 1e-4, time_limit_s: float | None = None) -> MilpDay:
    demand = np.asarray(demand_mw, float)
    n_hours, n_units = demand.size, len(fleet)
    on_before = np.ones(n_units, bool) if initially_on is None else np.array(initially_on, bool)
    block = n_hours * n_units
    u0, g0, z0, c0, r0 = 0, block, 2 * block, 3 * block, 4 * block  # variable offsets

    def index(offset, t, i):
        return offset + t * n_units + i

    rows, cols, vals, lower, upper = [], [], [], [], []

    def constraint(terms, low, high):
        row = len(lower)
        for col, val in terms:
            rows.append(row)
            cols.append(col)
            vals.append(val)
        lower.append(low)
        upper.append(high)

    for t in range(n_hours):
        constraint([(index(g0, t, i), 1.0) for i in range(n_units)] + [(r0 + t, -1.0)], demand[t], demand[t])
        for i, unit in enumerate(fleet.units):
            u, g, z, c = (index(offset, t, i) for offset in (u0, g0, z0, c0))
            constraint([(g, 1.0), (u, -unit.g_min_mw)], 0.0, np.inf)
            constraint([(g, 1.0), (u, -unit.g_max_mw)], -np.inf, 0.0)
            for point in np.linspace(unit.g_min_mw, unit.g_max_mw, tangents):
                slope = float(unit.incremental_cost(point))
                constraint([(z, 1.0), (u, -(float(unit.running_cost(point)) - slope * point)), (g, -slope)],
                           0.0, np.inf)
            for k, cost in enumerate(unit.start_cost, start=1):
                terms, before_day = [(c, 1.0), (u, -cost)], 0.0
                for back in range(1, k + 1):
                    if t - back >= 0:
                        terms.append((index(u0, t - back, i), cost))
                    elif on_before[i]:
                        before_day += cost  # on the night before: no start this hour
                constraint(terms, -before_day, np.inf)
    constraint([(r0 + t, 1.0) for t in range(n_hours)], 0.0, 0.0)
    for t in range(n_hours):
        constraint([(r0 + s, 1.0) for s in range(t + 1)], storage.s_min_mwh - storage.s_start_mwh,
                   storage.s_max_mwh - storage.s_start_mwh)

    n_vars = 4 * block + n_hours
    matrix = sparse.csr_array((vals, (rows, cols)), shape=(len(lower), n_vars))
    g_max = np.tile([u.g_max_mw for u in fleet.units], n_hours)
    cost_high = np.tile([float(u.running_cost(u.g_max_mw)) for u in fleet.units], n_hours)
    start_high = np.tile([max(u.start_cost) for u in fleet.units], n_hours)
    bounds = Bounds(np.concatenate([np.zeros(4 * block), np.full(n_hours, storage.r_min_mw)]),
                    np.concatenate([np.ones(block), g_max, cost_high, start_high, np.full(n_hours, storage.r_max_mw)]))
    objective = np.concatenate([np.zeros(2 * block), np.ones(2 * block), np.zeros(n_hours)])
    integrality = np.concatenate([np.ones(block), np.zeros(3 * block + n_hours)])
    options = {"mip_rel_gap": mip_rel_gap, "disp": False}
    if time_limit_s is not None:
        options["time_limit"] = time_limit_s
    result = milp(objective, constraints=LinearConstraint(matrix, lower, upper), integrality=integrality,
                  bounds=bounds, options=options)
    if result.x is None:
        raise ValueError(f"the program found no day: {result.message}")
    commitments = [tuple(bool(x > 0.5) for x in result.x[u0 + t * n_units:u0 + (t + 1) * n_units])
                   for t in range(n_hours)]
    transfers = cheapest_transfers(fleet, commitments, demand, storage)
    schedule = search_commitments(fleet, demand + transfers, lambda t: [commitments[t]], hours_down(on_before, n_units))
    return MilpDay(DayPlan(demand, transfers, schedule, rounds=0), float(result.mip_dual_bound),
                   float(result.fun), str(result.message))
