"""The off-line day (seed 000 part 2, sections 3 and 5): the commitments and storage
transfers of a known demand, with starting costs.

Given each hour's total generation G(t) = L(t) + r(t):

- :func:`schedule_from_table`: the paper's way -- each hour one of the table's cheapest
  commitments of its level (section 4), or of another hour's level (so that a unit may
  stay on rather than pay to start again), chosen by dynamic programming over the hours
  whose state is every unit's hours down (:func:`~.search.search_commitments`), so the
  starting costs are exact: the cheapest day over those candidates;
- :func:`exact_schedule`: the peer for small fleets -- dynamic programming over every
  commitment and every unit's hours down (capped at the tables' 6), exact.

Given the demand L(t) and the store, :func:`deterministic_schedule` is the off-line
algorithm of section 3: r(t) that makes G(t) as flat as possible, the table's commitments
for it, then the paper's "adjustment and compensation of r": here, instead of random
disturbances of r, the transfers that are cheapest for the chosen commitments
(:func:`~.transfers.cheapest_transfers`, exact), and the commitments again for those,
until the day's cost stops falling. Each round can only lower it: the commitments are
chosen with the last round's among the candidates, and the transfers are optimal for the
commitments.

Every unit starts the day on, as if it had run the night before unless ``initially_on``
says otherwise.

Units: MW, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.search import DaySchedule, hours_down, search_commitments
from hex_control.seeds.unit_commitment.storage import Storage, flatten
from hex_control.seeds.unit_commitment.table import TableRow, candidates_at
from hex_control.seeds.unit_commitment.transfers import cheapest_transfers


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


def check_day(fleet: Fleet, demand_mw, storage: Storage, table: list[TableRow]) -> None:
    """ValueError (one line) if the day's demand cannot be met: an hour's demand over what
    the whole fleet and the store's rate can give, or under what the least commitment of
    the table generates less what the store can take."""
    demand = np.asarray(demand_mw, float)
    if demand.ndim != 1 or demand.size < 2 or not np.all(np.isfinite(demand)) or np.any(demand < 0):
        raise ValueError(f"a day is at least two hours of finite demand >= 0 MW, got {demand}")
    low, high = table[0].total_mw, min(table[-1].total_mw, fleet.capacity_mw[1])
    over = demand + storage.r_min_mw - high  # the store giving all it can
    under = low - (demand + storage.r_max_mw)  # the store taking all it can
    if over.max() > 1e-9:
        t = int(np.argmax(over))
        raise ValueError(f"the demand is over the capacity: {demand[t]:.1f} MW in hour {t} against the fleet's "
                         f"{high:.1f} MW and the store's {-storage.r_min_mw:.1f} MW ({fleet.name})")
    if under.max() > 1e-9:
        t = int(np.argmax(under))
        raise ValueError(f"the demand is under the least the fleet can run at: {demand[t]:.1f} MW in hour {t} "
                         f"against {low:.1f} MW (the table's least level) less the store's {storage.r_max_mw:.1f} MW "
                         f"({fleet.name})")


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
    check_day(fleet, demand, storage, table)
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
