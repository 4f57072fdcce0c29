"""A day's commitments with starting costs (seed 000 part 2, sections 3 and 5), given each
hour's total generation G(t) = L(t) + r(t) (the storage transfers already chosen,
:mod:`hex_control.unit_commitment.storage`):

- :func:`schedule_from_table`: the paper's way -- each hour one of the K cheapest
  commitments of its level (section 4), chosen by dynamic programming over the hours whose
  state is every unit's hours down, so the starting costs are exact: the cheapest day over
  the table's candidates;
- :func:`exact_schedule`: the peer for small fleets -- dynamic programming over every
  commitment and every unit's hours down (capped at the tables' 6), exact.

Starting costs (the tables' CS(1..6)) are paid in the hour a unit comes on; every unit
starts the day on, as if it had run the night before unless ``initially_on`` says otherwise.

Units: MW, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from hex_control.unit_commitment.commitments import cheapest_commitments
from hex_control.unit_commitment.dispatch import economic_dispatch
from hex_control.unit_commitment.fleet import Fleet

CAP_HOURS = 6  # the tables' last column: a longer down time costs as much to start


@dataclass(frozen=True)
class DaySchedule:
    commitments: list[tuple[bool, ...]]  # per hour
    running_cost: float
    starting_cost: float

    @property
    def total_cost(self) -> float:
        return self.running_cost + self.starting_cost


def _step(fleet: Fleet, down: tuple[int, ...], on: tuple[bool, ...]) -> tuple[tuple[int, ...], float]:
    """(the down times after an hour with ``on``, the starting costs paid in it)."""
    cost = sum(unit.starting_cost(d) for unit, d, state in zip(fleet.units, down, on) if state and d > 0)
    return tuple(0 if state else min(d + 1, CAP_HOURS) for d, state in zip(down, on)), cost


def _running(fleet: Fleet, on: tuple[bool, ...], total_mw: float) -> float:
    try:  # the dispatch refuses a total its units cannot generate
        return economic_dispatch([u for u, state in zip(fleet.units, on) if state], total_mw).cost_per_h
    except ValueError:
        return np.inf


def _search(fleet: Fleet, generation_mw, options, initially_on) -> DaySchedule:
    """DP over the hours, each hour's commitments from ``options(t)``; a state is every unit's
    hours down (0: on), with the cheapest day into it."""
    start = tuple(0 if state else CAP_HOURS for state in initially_on)
    states = {start: (0.0, 0.0, [])}  # down times -> (running, starting, commitments)
    for t, total in enumerate(generation_mw):
        following = {}
        for down, (running, starting, path) in states.items():
            for on in options(t):
                cost = _running(fleet, on, float(total))
                if not np.isfinite(cost):
                    continue
                after, start_cost = _step(fleet, down, on)
                candidate = (running + cost, starting + start_cost, path + [on])
                if after not in following or sum(candidate[:2]) < sum(following[after][:2]):
                    following[after] = candidate
        if not following:
            raise ValueError(f"no commitment generates {total} MW in hour {t}")
        states = following
    running, starting, path = min(states.values(), key=lambda v: v[0] + v[1])
    return DaySchedule(path, running, starting)


def exact_schedule(fleet: Fleet, generation_mw, initially_on=None) -> DaySchedule:
    """The cheapest day over all 2^M commitments and every unit's down times (M <= 8)."""
    if len(fleet) > 8:
        raise ValueError(f"exact dynamic programming is for small fleets, not {len(fleet)} units")
    everything = list(itertools.product([False, True], repeat=len(fleet)))
    return _search(fleet, generation_mw, lambda t: everything, initially_on or (True,) * len(fleet))


def schedule_from_table(fleet: Fleet, generation_mw, k: int = 5, initially_on=None) -> DaySchedule:
    """The cheapest day whose hours each use one of the K cheapest commitments of their
    generation (the table's candidates, computed at each hour's level)."""
    candidates = [[c.on for c in cheapest_commitments(fleet, float(total), k)] for total in generation_mw]
    return _search(fleet, generation_mw, lambda t: candidates[t], initially_on or (True,) * len(fleet))
