"""The pieces the off-line day (:mod:`.day`) and the on-line scheduler (:mod:`.online`)
share (seed 000 part 2, sections 2-3 and 6): a commitment's running cost at its economic
dispatch, the starting costs by every unit's hours down, and the dynamic programme over
the hours whose state is those down times, so that the starting costs are exact.

Starting costs (the tables' CS(1..6)) are paid in the hour a unit comes on. Of identical
units, those down the shortest are the ones on (:meth:`Starts.realize`).

Units: MW, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.dispatch import committed_bounds, dispatch_hours
from hex_control.seeds.unit_commitment.fleet import TABLE_HOURS, Fleet

CAP_HOURS = TABLE_HOURS  # the tables' last column: a longer down time costs as much to start


@dataclass(frozen=True)
class DaySchedule:
    commitments: list[tuple[bool, ...]]  # per hour
    running_cost: float
    starting_cost: float

    @property
    def total_cost(self) -> float:
        return self.running_cost + self.starting_cost


class Starts:
    """Each unit's starting cost by hours down, and the hours beyond which it stops
    changing: down times are counted only up to there (states that differ beyond it cost
    the same, so the search merges them -- exactly)."""

    def __init__(self, fleet: Fleet):
        arrays = fleet.arrays
        self.costs, self.caps, self.twins = arrays.start_costs, arrays.caps, arrays.twins

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
    return Starts(fleet).step(down, on)


def starting_cost(fleet: Fleet, down: tuple[int, ...], path) -> float:
    """The starting costs of the commitments ``path`` hour after hour from the down times ``down``."""
    starts, total = Starts(fleet), 0.0
    for on in path:
        down, cost = starts.step(down, on)
        total += cost
    return total


def running_costs(fleet: Fleet, on, total_mw) -> np.ndarray:
    """(T,) the running cost per hour of each commitment of ``on`` (T, M) at the economic
    dispatch of its ``total_mw``; inf where its units cannot generate it."""
    on = np.atleast_2d(np.asarray(on, bool))
    total = np.broadcast_to(np.asarray(total_mw, float), on.shape[:1])
    low, high = committed_bounds(fleet.arrays, on)
    tolerance = 1e-9 * np.maximum(high, 1.0)
    cost = dispatch_hours(fleet.arrays, on, total)[0]
    feasible = on.any(axis=1) & (total >= low - tolerance) & (total <= high + tolerance) & np.isfinite(total)
    return np.where(feasible, cost, np.inf)


def running_cost(fleet: Fleet, on: tuple[bool, ...], total_mw: float) -> float:
    """The running cost per hour of ``on`` at the economic dispatch of ``total_mw``; inf if
    its units cannot generate it."""
    return float(running_costs(fleet, [on], [total_mw])[0])


def running_costs_near(fleet: Fleet, on, total_mw, lowest_mw, highest_mw, *, energy_price: float) -> np.ndarray:
    """:func:`running_costs` of each commitment of ``on`` (N, M) at the total nearest
    ``total_mw`` within [lowest, highest] (each one value or N) that it can generate, plus
    the difference at ``energy_price``; inf where none."""
    on = np.atleast_2d(np.asarray(on, bool))
    low, high = committed_bounds(fleet.arrays, on)
    low, high = np.maximum(lowest_mw, low), np.minimum(highest_mw, high)
    nearest = np.clip(total_mw, low, np.maximum(low, high))
    cost = running_costs(fleet, on, nearest) + energy_price * (total_mw - nearest)
    return np.where(low > high + 1e-9, np.inf, cost)


def incremental_costs(fleet: Fleet, commitments, generation_mw) -> np.ndarray:
    """(T,) each hour's incremental cost (per MWh) at the economic dispatch of its
    generation, clipped to its committed units' bounds."""
    return dispatch_hours(fleet.arrays, commitments, generation_mw)[1]


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
    (per MWh): the store makes it up, and other hours' units generate it.

    Each hour every state is tried with every option at once (arrays of states x options x
    units); of the paths into one state the cheapest is kept, on a tie the first (states
    in the order they were first reached, options in the order given)."""
    arrays = fleet.arrays
    n = arrays.size
    caps = np.asarray(arrays.caps)
    states = np.minimum(np.asarray(down, int), caps)[None, :]  # (S, M) hours down, capped
    totals, starting = np.zeros(1), np.zeros(1)  # of the cheapest day into each state
    history = []  # per hour: (each new state's parent state, its commitment)
    # every hour's options priced at once (one dispatch for the day)
    generation = np.asarray(generation_mw, float)
    hours = generation.size
    lowest, highest = (generation, generation) if reach_mw is None else (np.asarray(reach_mw[0], float),
                                                                         np.asarray(reach_mw[1], float))
    per_hour = [list(options(t)) for t in range(hours)]
    rows = np.repeat(np.arange(hours), [len(o) for o in per_hour])
    every = np.asarray([on for o in per_hour for on in o], bool).reshape(rows.size, arrays.size)
    prices = running_costs_near(fleet, every, generation[rows], lowest[rows], highest[rows],
                                energy_price=energy_price)
    ends = np.cumsum([len(o) for o in per_hour])
    for t in range(hours):
        hour_prices, hour_on = prices[ends[t] - len(per_hour[t]):ends[t]], every[ends[t] - len(per_hour[t]):ends[t]]
        usable = np.isfinite(hour_prices)
        if not usable.any():
            raise ValueError(f"no commitment generates {generation[t]} MW in hour {t}")
        on, costs = hour_on[usable], hour_prices[usable]
        count, choices = len(states), len(on)
        # of identical units, those down the shortest are on (then the first): a unit's rank
        # among its twins by (hours down, index) against how many of them the option has on
        d = states[:, None, :]  # (S, 1, M): unit k's hours down
        before = arrays.same_kind & ((d < d.transpose(0, 2, 1)) | ((d == d.transpose(0, 2, 1)) & arrays.earlier))
        rank = before.sum(axis=2)  # (S, M)
        realized = rank[:, None, :] < (on.astype(int) @ arrays.same_kind.T.astype(int))[None, :, :]  # (S, O, M)
        start_now = arrays.start_by_down[np.arange(n), states]  # (S, M): a start now costs (0 if on)
        start_costs = (realized * start_now[:, None, :]).sum(axis=2)  # (S, O)
        after = np.where(realized, 0, np.minimum(states + 1, caps)[:, None, :]).reshape(count * choices, n)
        candidate = ((totals[:, None] + costs[None, :]) + start_costs).ravel()
        keys = np.ascontiguousarray(after.astype(np.uint8)).view(np.dtype((np.void, n))).ravel()
        _, first, group = np.unique(keys, return_index=True, return_inverse=True)
        flat = np.arange(candidate.size)
        best = np.lexsort((flat, candidate, group))  # per state: cheapest, then first
        is_first = np.ones(best.size, bool)
        is_first[1:] = group[best[1:]] != group[best[:-1]]
        chosen = best[is_first]  # one per state, in the order of the unique keys
        chosen = chosen[np.argsort(first, kind="stable")]  # states in the order first reached
        parents, options_taken = np.divmod(chosen, choices)
        history.append((parents, realized.reshape(count * choices, n)[chosen]))
        states, totals = after[chosen], candidate[chosen]
        starting = starting[parents] + start_costs.ravel()[chosen]
    final = int(np.argmin(totals))  # the first of the cheapest
    day_cost, started = float(totals[final]), float(starting[final])
    commitments = []
    for parents, committed in reversed(history):  # linked back hour by hour
        commitments.append(tuple(bool(x) for x in committed[final]))
        final = int(parents[final])
    return DaySchedule(commitments[::-1], day_cost - started, started)
