"""A day's commitments and storage transfers with starting costs (seed 000 part 2,
sections 3 and 5).

Given each hour's total generation G(t) = L(t) + r(t):

- :func:`schedule_from_table`: the paper's way -- each hour one of the table's cheapest
  commitments of its level (section 4), or of another hour's level (so that a unit may
  stay on rather than pay to start again), chosen by dynamic programming over the hours
  whose state is every unit's hours down, so the starting costs are exact: the cheapest
  day over those candidates. Of identical units, those down the shortest are the ones on;
- :func:`exact_schedule`: the peer for small fleets -- dynamic programming over every
  commitment and every unit's hours down (capped at the tables' 6), exact.

Given the demand L(t) and the store, :func:`deterministic_schedule` is the off-line
algorithm of section 3: r(t) that makes G(t) as flat as possible, the table's commitments
for it, then the paper's "adjustment and compensation of r": here, instead of random
disturbances of r, the transfers that are cheapest for the chosen commitments
(:func:`cheapest_transfers`, exact: every hour at one incremental cost where the store's
limits allow), and the commitments again for those, until the day's cost stops falling.
Each round can only lower it: the commitments are chosen with the last round's among the
candidates, and the transfers are optimal for the commitments.

Starting costs (the tables' CS(1..6)) are paid in the hour a unit comes on; every unit
starts the day on, as if it had run the night before unless ``initially_on`` says otherwise.

Units: MW, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from hex_control.seeds.unit_commitment.dispatch import economic_dispatch
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.storage import Storage, flatten
from hex_control.seeds.unit_commitment.table import TableRow, candidates_at

CAP_HOURS = 6  # the tables' last column: a longer down time costs as much to start


@dataclass(frozen=True)
class DaySchedule:
    commitments: list[tuple[bool, ...]]  # per hour
    running_cost: float
    starting_cost: float

    @property
    def total_cost(self) -> float:
        return self.running_cost + self.starting_cost


class _Starts:
    """Each unit's starting cost by hours down, and the hours beyond which it stops
    changing: down times are counted only up to there (states that differ beyond it cost
    the same, so the search merges them -- exactly)."""

    def __init__(self, fleet: Fleet):
        self.costs = [unit.start_cost for unit in fleet.units]
        self.caps = [1 + max([j for j in range(1, len(c)) if c[j] != c[j - 1]], default=0) for c in self.costs]
        groups = {}
        for i, unit in enumerate(fleet.units):
            groups.setdefault(unit, []).append(i)
        self.twins = [members for members in groups.values() if len(members) > 1]

    def realize(self, down: tuple[int, ...], on: tuple[bool, ...]) -> tuple[bool, ...]:
        """``on`` with, of identical units, those on that were down the shortest: the same
        running cost, the least starting cost now -- and no more later either, as long as
        a start costs less the sooner it follows a stop by no less than later (concave in
        the hours down, as eq. 2.6 is)."""
        if not self.twins:
            return on
        chosen = None
        for members in self.twins:
            wanted = sum(on[i] for i in members)
            if wanted in (0, len(members)):
                continue  # all of them off, or all on: nothing to choose
            chosen = chosen or list(on)
            for rank, i in enumerate(sorted(members, key=lambda i: (down[i], i))):
                chosen[i] = rank < wanted
        return on if chosen is None else tuple(chosen)

    def step(self, down: tuple[int, ...], on: tuple[bool, ...]) -> tuple[tuple[int, ...], float]:
        """(the down times after an hour with ``on``, the starting costs paid in it)."""
        cost = 0.0
        after = []
        for costs, cap, d, state in zip(self.costs, self.caps, down, on):
            if state:
                if d > 0:
                    cost += costs[min(d, len(costs)) - 1]
                after.append(0)
            else:
                after.append(min(d + 1, cap))
        return tuple(after), cost


def hour_step(fleet: Fleet, down: tuple[int, ...], on: tuple[bool, ...]) -> tuple[tuple[int, ...], float]:
    """(the down times after an hour with ``on``, the starting costs paid in it)."""
    return _Starts(fleet).step(down, on)


def running_cost(fleet: Fleet, on: tuple[bool, ...], total_mw: float) -> float:
    """The running cost per hour of ``on`` at the economic dispatch of ``total_mw``; inf if
    its units cannot generate it."""
    try:  # the dispatch refuses a total its units cannot generate
        return economic_dispatch([u for u, state in zip(fleet.units, on) if state], total_mw).cost_per_h
    except ValueError:
        return np.inf


def _running_cost_near(fleet: Fleet, on: tuple[bool, ...], total_mw: float, lowest_mw: float,
                       highest_mw: float, *, energy_price: float) -> float:
    """:func:`running_cost` at the total nearest ``total_mw`` within [lowest, highest] that
    ``on``'s units can generate, plus the difference at ``energy_price``; inf if none."""
    low = max(lowest_mw, sum(u.g_min_mw for u, state in zip(fleet.units, on) if state))
    high = min(highest_mw, sum(u.g_max_mw for u, state in zip(fleet.units, on) if state))
    if low > high + 1e-9:
        return np.inf
    nearest = min(max(total_mw, low), high)
    return running_cost(fleet, on, nearest) + energy_price * (total_mw - nearest)


def hours_down(initially_on, n_units: int) -> tuple[int, ...]:
    """Every unit's hours down before the day: 0 if on (all by default), else the cap."""
    return tuple(0 if state else CAP_HOURS for state in ((True,) * n_units if initially_on is None else initially_on))


def search_commitments(fleet: Fleet, generation_mw, options, down: tuple[int, ...], reach_mw=None,
                       *, energy_price: float = 0.0) -> DaySchedule:
    """DP over the hours, each hour's commitments from ``options(t)``, from every unit's
    hours ``down`` (0: on); a state is those down times, with the cheapest day into it.
    ``reach_mw``: (lowest, highest) total of each hour that the store could make up;
    a commitment that cannot generate the hour's total is then priced at the nearest total
    within them that it can instead of refused, plus the difference at ``energy_price``
    (per MWh): the store makes it up, and other hours' units generate it."""
    starts = _Starts(fleet)
    start = tuple(min(d, cap) for d, cap in zip(down, starts.caps))
    states = {start: (0.0, 0.0, None)}  # down times -> (total, starting, path) of the cheapest day into them
    for t, total in enumerate(generation_mw):
        following = {}
        lowest, highest = (total, total) if reach_mw is None else (reach_mw[0][t], reach_mw[1][t])
        costs = [(on, _running_cost_near(fleet, on, float(total), lowest, highest, energy_price=energy_price))
                 for on in options(t)]
        costs = [(on, cost) for on, cost in costs if np.isfinite(cost)]
        for down, (day_cost, starting, path) in states.items():
            for on, cost in costs:
                on = starts.realize(down, on)
                after, start_cost = starts.step(down, on)
                candidate = day_cost + cost + start_cost
                if after not in following or candidate < following[after][0]:
                    following[after] = (candidate, starting + start_cost, (path, on))
        if not following:
            raise ValueError(f"no commitment generates {total} MW in hour {t}")
        states = following
    day_cost, starting, path = min(states.values(), key=lambda v: v[0])
    commitments = []
    while path is not None:  # the path is linked back hour by hour
        path, on = path
        commitments.append(on)
    return DaySchedule(commitments[::-1], day_cost - starting, starting)


def exact_schedule(fleet: Fleet, generation_mw, initially_on=None) -> DaySchedule:
    """The cheapest day over all 2^M commitments and every unit's down times (M <= 8)."""
    if len(fleet) > 8:
        raise ValueError(f"exact dynamic programming is for small fleets, not {len(fleet)} units")
    everything = list(itertools.product([False, True], repeat=len(fleet)))
    return search_commitments(fleet, generation_mw, lambda t: everything, hours_down(initially_on, len(fleet)))


def schedule_from_table(fleet: Fleet, generation_mw, table: list[TableRow], initially_on=None,
                        also=None, *, borrow: int = 2) -> DaySchedule:
    """The cheapest day whose hours each use one of the table's candidates at their
    generation (:func:`~hex_control.seeds.unit_commitment.table.candidates_at`), one of the
    ``borrow`` cheapest at another hour's generation (so that a unit may stay on through
    hours whose own cheapest commitments have it off, rather than pay to start again), or
    the commitment ``also[t]`` if given."""
    own = [candidates_at(table, float(total)) for total in generation_mw]
    borrowed = list(dict.fromkeys(on for candidates in own for on in candidates[:borrow]))
    extra = also if also is not None else [None] * len(own)
    options = [list(dict.fromkeys(candidates + borrowed + ([more] if more is not None else [])))
               for candidates, more in zip(own, extra)]
    return search_commitments(fleet, generation_mw, lambda t: options[t], hours_down(initially_on, len(fleet)))


class _Committed:
    """The fleet's units as arrays and a day's commitments as a mask, for the transfers."""

    def __init__(self, fleet: Fleet, commitments):
        names = ("g_min_mw", "g_max_mw", "a1", "a2", "a3")
        self.g_min, self.g_max, self.a1, self.a2, self.a3 = (
            np.array([getattr(u, name) for u in fleet.units], float) for name in names)
        self.on = np.array(commitments, bool)  # (T, M)
        self.low, self.high = self.on @ self.g_min, self.on @ self.g_max  # (T,) what each hour can generate

    def generation_at(self, lam) -> np.ndarray:
        """(T,) each hour's total generation at incremental cost ``lam`` (eq. 2.7): one for
        all hours or (T,) of them."""
        lam = np.broadcast_to(np.asarray(lam, float), self.low.shape)[:, None]
        return (np.clip((lam - self.a2) / (2 * self.a3), self.g_min, self.g_max) * self.on).sum(axis=1)

    def dispatch(self, generation_mw) -> tuple[np.ndarray, np.ndarray]:
        """(T,) running cost and incremental cost of each hour's economic dispatch of
        ``generation_mw`` (within the hour's bounds), all hours at once and exactly: each
        hour's total is piecewise linear in lambda between the units' breakpoints (as in
        :func:`~hex_control.seeds.unit_commitment.dispatch.economic_dispatch`)."""
        breakpoints = np.unique(np.concatenate([self.a2 + 2 * self.a3 * self.g_min,
                                                self.a2 + 2 * self.a3 * self.g_max]))
        totals = self.on @ np.clip((breakpoints[:, None] - self.a2) / (2 * self.a3), self.g_min, self.g_max).T
        generation = np.clip(np.asarray(generation_mw, float), self.low, self.high)
        j = np.clip((totals < generation[:, None]).sum(axis=1), 1, breakpoints.size - 1)  # totals rise along a row
        rows = np.arange(generation.size)
        below, above = totals[rows, j - 1], totals[rows, j]
        rising = above > below
        lam = np.where(rising, breakpoints[j - 1] + (generation - below) * (breakpoints[j] - breakpoints[j - 1])
                       / np.where(rising, above - below, 1.0), breakpoints[j])
        g = np.clip((lam[:, None] - self.a2) / (2 * self.a3), self.g_min, self.g_max)
        return ((self.a1 + self.a2 * g + self.a3 * g * g) * self.on).sum(axis=1), lam


def incremental_costs(fleet: Fleet, commitments, generation_mw) -> np.ndarray:
    """(T,) each hour's incremental cost (per MWh) at the economic dispatch of its
    generation, clipped to its committed units' bounds."""
    return _Committed(fleet, commitments).dispatch(generation_mw)[1]


def transfer_bounds(fleet: Fleet, commitments, demand_mw, storage: Storage) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest) transfer of each hour (MW) that its committed units and the
    store's rate limits allow; ValueError if an hour has none."""
    demand = np.asarray(demand_mw, float)
    hours = _Committed(fleet, commitments)
    lower = np.maximum(storage.r_min_mw, hours.low - demand)
    upper = np.minimum(storage.r_max_mw, hours.high - demand)
    if np.any(lower > upper + 1e-9):
        raise ValueError(f"the commitments of hours {np.flatnonzero(lower > upper + 1e-9).tolist()} "
                         "cannot meet their demand within the store's rates")
    return lower, np.maximum(lower, upper)


def cheapest_transfers(fleet: Fleet, commitments, demand_mw, storage: Storage, transfer_total_mwh: float = 0.0):
    """The transfers r(t) (MW) that make the day cheapest for the given commitments (one
    per hour): sum r = ``transfer_total_mwh`` (0: the store ends the day as it began, eq.
    4.3), R and S bounds (2.3, 2.4), and each hour's G = L + r within its committed units'
    bounds. Without a binding S bound every hour runs at one incremental cost mu, clipped
    by its bounds, with mu found by bisection (exact); otherwise SLSQP on the convex day
    cost. ValueError if no transfers are feasible."""
    demand = np.asarray(demand_mw, float)
    hours = _Committed(fleet, commitments)
    lower, upper = transfer_bounds(fleet, commitments, demand, storage)
    if not lower.sum() - 1e-6 <= transfer_total_mwh <= upper.sum() + 1e-6:
        raise ValueError(f"these commitments can transfer {lower.sum():g}..{upper.sum():g} MWh, "
                         f"not {transfer_total_mwh:g}")

    def transfers(lam):
        return np.clip(hours.generation_at(lam) - demand, lower, upper)

    low = float(np.min(hours.a2))
    high = float(np.max(hours.a2 + 2 * hours.a3 * hours.g_max))
    for _ in range(100):  # sum r(mu) grows with mu
        middle = 0.5 * (low + high)
        low, high = (middle, high) if transfers(middle).sum() < transfer_total_mwh else (low, middle)
    r = transfers(0.5 * (low + high))
    r += (transfer_total_mwh - r.sum()) * (upper - lower) / max((upper - lower).sum(), 1e-12)  # rounding
    stored = storage.stored_mwh(r)
    if np.all(stored >= storage.s_min_mwh - 1e-6) and np.all(stored <= storage.s_max_mwh + 1e-6):
        return r
    return _transfers_within_the_store(hours, demand, storage, transfer_total_mwh, lower, upper=upper, start=r)


def _transfers_within_the_store(hours, demand, storage, transfer_total_mwh, lower, *, upper, start):
    n = len(demand)
    cumulative = np.tril(np.ones((n, n)))
    constraints = [{"type": "eq", "fun": lambda r: np.sum(r) - transfer_total_mwh, "jac": lambda r: np.ones(n)},
                   {"type": "ineq", "fun": lambda r: storage.s_start_mwh + cumulative @ r - storage.s_min_mwh,
                    "jac": lambda r: cumulative},
                   {"type": "ineq", "fun": lambda r: storage.s_max_mwh - storage.s_start_mwh - cumulative @ r,
                    "jac": lambda r: -cumulative}]
    scale = float(np.max(hours.a2 + 2 * hours.a3 * hours.g_max)) * max(float(np.max(demand)), 1.0)
    last = {}  # SLSQP asks for the cost and its gradient at the same point: one dispatch for both

    def dispatched(r):
        if last.get("r") is None or not np.array_equal(last["r"], r):
            last["r"], last["value"] = np.array(r), hours.dispatch(demand + r)
        return last["value"]

    result = minimize(lambda r: dispatched(r)[0].sum() / scale, start,
                      jac=lambda r: dispatched(r)[1] / scale, method="SLSQP",
                      bounds=list(zip(lower, upper)), constraints=constraints, options={"ftol": 1e-12, "maxiter": 500})
    if not result.success:
        raise ValueError(f"no transfers within the store's limits: {result.message}")
    return np.clip(result.x, lower, upper)


@dataclass(frozen=True)
class DayPlan:
    """The off-line schedule: demand, transfers and commitments of a day (MW per hour)."""

    demand_mw: np.ndarray
    transfers_mw: np.ndarray
    schedule: DaySchedule
    rounds: int  # of commitments and transfers

    @property
    def generation_mw(self) -> np.ndarray:
        return self.demand_mw + self.transfers_mw

    @property
    def total_cost(self) -> float:
        return self.schedule.total_cost

    @property
    def unit_cost(self) -> float:
        """Cost per MWh generated (section 7's unit generation cost)."""
        return self.total_cost / float(np.sum(self.generation_mw))


def deterministic_schedule(fleet: Fleet, demand_mw, storage: Storage, table: list[TableRow],
                           initially_on=None, *, max_rounds: int = 10, also=None) -> DayPlan:
    """The off-line algorithm of section 3 (see the module's docstring); ``also[t]``: a
    commitment to consider in hour t besides the table's (e.g. another day's plan)."""
    demand = np.asarray(demand_mw, float)
    transfers = flatten(demand, storage)
    schedule = schedule_from_table(fleet, demand + transfers, table, initially_on, also=also)
    for rounds in range(1, max_rounds + 1):
        # each step is no dearer: the transfers are the cheapest for the commitments, and
        # the commitments are chosen with the last ones among the candidates
        better_transfers = cheapest_transfers(fleet, schedule.commitments, demand, storage)
        better = schedule_from_table(fleet, demand + better_transfers, table, initially_on, also=schedule.commitments)
        if better.total_cost > schedule.total_cost:
            break  # only by the transfers' rounding
        gain = schedule.total_cost - better.total_cost
        schedule, transfers = better, better_transfers
        if gain <= 1e-7 * schedule.total_cost:
            break
    return DayPlan(demand, transfers, schedule, rounds)
