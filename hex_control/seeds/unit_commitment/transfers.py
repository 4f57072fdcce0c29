"""The store's transfers r(t) that make a day cheapest for given commitments (seed 000 part
2, sections 2-4: eq. 2.2-2.4, 4.3), exactly.

For fixed commitments each hour's running cost C_t(L_t + r_t) is convex in r_t, and its
derivative, the hour's incremental cost lambda (eq. 2.7), is piecewise linear in the
generation (quadratic costs, units reaching their bounds). So the inverse is too: at a
price p the hour generates G_t(p) = sum of clip((p - a2) / (2 a3), G_min, G_max) over its
units, and transfers R_t(p) = clip(G_t(p) - L_t, R_min, R_max) -- continuous,
nondecreasing, piecewise linear in p.

The day is a dynamic programme over the stored energy x_t = S(0) + r_1 + ... + r_t with
S_min <= x_t <= S_max (2.4) and x_T = S(0) + the day's total (4.3). Its value functions are
convex, and are carried as the inverses of their derivatives (the x at which the cheapest
way to reach x costs p per MWh more): an infimal convolution of convex functions adds those
inverses, and the store's bounds clip them, so

    X_0(p) = S(0),   X_t(p) = clip(X_{t-1}(p) + R_t(p), S_min, S_max),

each again piecewise linear in p, carried exactly on its knots. Backwards, x_T is given; the
price p with X_{t-1}(p) + R_t(p) = x_t splits it into x_{t-1} and r_t, both at one marginal
cost (the optimality condition), hour by hour. Every hour where the store is not at a
bound between them runs at one incremental cost; the price changes only across an hour
where the store is full or empty. No iteration and no tolerance: the knots are the units'
breakpoints and the crossings of the bounds. (It replaces a general SLSQP solve, which
took two thirds of an on-line day on 41 machines.)

Units: MW (an hour's transfer, MWh a step), MWh, cost units per MWh for prices.
"""

from __future__ import annotations

import numpy as np

from hex_control.seeds.unit_commitment.dispatch import committed_bounds
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.storage import Storage


class PiecewiseLinear:
    """A continuous nondecreasing function of the price p, linear between its ``knots``
    (increasing) and constant beyond them."""

    __slots__ = ("knots", "values")

    def __init__(self, knots, values):
        self.knots, self.values = np.asarray(knots, float), np.asarray(values, float)

    def __call__(self, p):
        return np.interp(p, self.knots, self.values)

    def plus(self, other: PiecewiseLinear) -> PiecewiseLinear:
        knots = np.union1d(self.knots, other.knots)
        return PiecewiseLinear(knots, self(knots) + other(knots))

    def clipped(self, low: float, high: float) -> PiecewiseLinear:
        """clip(f, low, high), with a knot wherever f crosses a (finite) bound."""
        knots, values = self.knots, self.values
        crossings = []
        for level in (low, high):
            if np.isfinite(level):
                side = values - level
                k = np.flatnonzero(side[:-1] * side[1:] < 0)
                slope = (knots[k + 1] - knots[k]) / (values[k + 1] - values[k])
                crossings.append(knots[k] + (level - values[k]) * slope)
        if crossings and any(c.size for c in crossings):
            more = np.concatenate(crossings)
            merged = np.union1d(knots, more)
            values, knots = self(merged), merged
        return PiecewiseLinear(knots, np.clip(values, low, high))

    def inverse(self, x: float) -> float:
        """A p with f(p) = x (x within f's range; on a flat part, its first)."""
        values, knots = self.values, self.knots
        j = int(np.searchsorted(values, x, side="left"))  # values[j - 1] < x <= values[j]
        if j == 0:
            return float(knots[0])
        if j == values.size:
            return float(knots[-1])
        return float(knots[j - 1] + (x - values[j - 1]) * (knots[j] - knots[j - 1]) / (values[j] - values[j - 1]))


def transfer_bounds(fleet: Fleet, commitments, demand_mw, storage: Storage) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest) transfer of each hour (MW) that its committed units and the
    store's rate limits allow; ValueError if an hour has none."""
    demand = np.asarray(demand_mw, float)
    low, high = committed_bounds(fleet.arrays, commitments)
    lower = np.maximum(storage.r_min_mw, low - demand)
    upper = np.minimum(storage.r_max_mw, high - demand)
    if np.any(lower > upper + 1e-9):
        hours = np.flatnonzero(lower > upper + 1e-9)
        t = int(hours[0])
        raise ValueError(f"the commitments of hours {hours.tolist()} cannot meet their demand within the store's "
                         f"rates (hour {t}: demand {demand[t]:.1f} MW, its units {low[t]:.1f}..{high[t]:.1f} MW, "
                         f"the store {storage.r_min_mw:g}..{storage.r_max_mw:g} MW)")
    return lower, np.maximum(lower, upper)


class _Day:
    """The forward pass of the programme (see the module) for commitments and demand."""

    def __init__(self, fleet: Fleet, commitments, demand_mw, storage: Storage):
        arrays = fleet.arrays
        self.demand = np.asarray(demand_mw, float)
        self.lower, self.upper = transfer_bounds(fleet, commitments, self.demand, storage)
        on = np.asarray(commitments, bool)
        knots = arrays.breakpoints
        generation = on @ arrays.outputs_at_breakpoints.T  # (T, K): G_t at each breakpoint
        self.before, self.sums = [], []  # X_{t-1}, and X_{t-1} + R_t before the store's bounds
        stored = PiecewiseLinear([0.0], [storage.s_start_mwh])
        self.storage = storage
        for t in range(self.demand.size):
            transfer = PiecewiseLinear(knots, generation[t] - self.demand[t]).clipped(self.lower[t], self.upper[t])
            total = stored.plus(transfer)
            if total.values[0] > storage.s_max_mwh + 1e-6 or total.values[-1] < storage.s_min_mwh - 1e-6:
                raise ValueError(f"these commitments cannot keep the store within {storage.s_min_mwh:g}.."
                                 f"{storage.s_max_mwh:g} MWh in hour {t}")
            self.before.append(stored)
            self.sums.append(total)
            stored = total.clipped(storage.s_min_mwh, storage.s_max_mwh)
        self.reachable = (float(stored.values[0]) - storage.s_start_mwh, float(stored.values[-1]) - storage.s_start_mwh)

    def transfers(self, transfer_total_mwh: float) -> np.ndarray:
        x = self.storage.s_start_mwh + transfer_total_mwh
        r = np.empty(self.demand.size)
        for t in range(self.demand.size - 1, -1, -1):
            p = self.sums[t].inverse(x)
            previous = float(self.before[t](p))
            r[t], x = x - previous, previous
        return np.clip(r, self.lower, self.upper)


def _at_one_price(fleet: Fleet, commitments, demand, lower, upper, *, transfer_total_mwh: float) -> np.ndarray | None:
    """The cheapest transfers if the store's energy bounds do not bind: every hour at one
    price p, sum R_t(p) = the total (exact, all hours at once: the sum is linear between
    the breakpoints and the hours' crossings of their rate limits); None if no price
    reaches the total."""
    arrays = fleet.arrays
    knots = arrays.breakpoints
    generation = np.asarray(commitments, bool) @ arrays.outputs_at_breakpoints.T  # (T, K), rising along a row
    crossings = [knots]
    for level in (demand + lower, demand + upper):  # where each hour's G_t(p) crosses a rate limit
        j = (generation < level[:, None]).sum(axis=1) - 1
        inside = (j >= 0) & (j < knots.size - 1)
        t, j = np.flatnonzero(inside), j[inside]
        rise = generation[t, j + 1] - generation[t, j]
        ok = rise > 0
        t, j = t[ok], j[ok]
        crossings.append(knots[j] + (level[t] - generation[t, j]) * (knots[j + 1] - knots[j]) / rise[ok])
    prices = np.unique(np.concatenate(crossings))

    def transfers_at(p):
        if knots.size == 1:
            g = generation[:, :1] * np.ones(np.size(p))
        else:
            i = np.clip(np.searchsorted(knots, p, side="right"), 1, knots.size - 1)
            w = np.clip((p - knots[i - 1]) / (knots[i] - knots[i - 1]), 0.0, 1.0)
            g = generation[:, i - 1] + w * (generation[:, i] - generation[:, i - 1])
        return np.clip(g - demand[:, None], lower[:, None], upper[:, None])  # (T, P)

    total = transfers_at(prices).sum(axis=0)
    if not total[0] - 1e-6 <= transfer_total_mwh <= total[-1] + 1e-6:
        return None
    p = PiecewiseLinear(prices, total).inverse(transfer_total_mwh)
    return transfers_at(np.array([p]))[:, 0]


def cheapest_transfers(fleet: Fleet, commitments, demand_mw, storage: Storage,
                       transfer_total_mwh: float = 0.0) -> np.ndarray:
    """The transfers r(t) (MW) that make the day cheapest for the given commitments (one
    per hour): sum r = ``transfer_total_mwh`` (0: the store ends the day as it began, eq.
    4.3), R and S bounds (2.3, 2.4), and each hour's G = L + r within its committed units'
    bounds; exact (see the module). ValueError if no transfers are feasible."""
    demand = np.asarray(demand_mw, float)
    lower, upper = transfer_bounds(fleet, commitments, demand, storage)
    r = _at_one_price(fleet, commitments, demand, lower, upper, transfer_total_mwh=transfer_total_mwh)
    if r is not None:
        stored = storage.stored_mwh(r)
        if np.all(stored >= storage.s_min_mwh - 1e-6) and np.all(stored <= storage.s_max_mwh + 1e-6):
            return r  # the store's energy bounds do not bind
    day = _Day(fleet, commitments, demand, storage)
    least, most = day.reachable
    if not least - 1e-6 <= transfer_total_mwh <= most + 1e-6:
        raise ValueError(f"these commitments can transfer {least:g}..{most:g} MWh, not {transfer_total_mwh:g}")
    return day.transfers(min(max(transfer_total_mwh, least), most))
