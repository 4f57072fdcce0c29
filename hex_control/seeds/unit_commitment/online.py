"""On-line stochastic scheduling (seed 000 part 2, sections 6-7, Fig. 4-5): the off-line
plan of the mean day corrected hour by hour for the demand that actually comes.

The demand is L(t) = L_bar(t) (1 + e(t)), with the relative fluctuation e either
independent and uniform on [-alpha, alpha] (eq. 6.1) or first-order Gauss-Markov (6.2),
measured as y(t) = e(t) + v(t) (6.3). What is known when:

1. Before hour t the commitment is chosen. The one-step Kalman predictor of
   :mod:`hex_control.estimation` (eq. 6.6-6.7, with a, W, V identified from a history of
   measurements, as section 6 says they must be) predicts e(t); the later hours decay
   towards the mean as a^k. The rest of the day is re-planned for the predicted demand,
   starting from the plan (r-bar, G-bar) as the paper does: the transfers for the plan's
   commitments with the store as it is now, returning it to where the day began (eq.
   4.3); then, at that generation, the commitments among the table's candidates and the
   plan's, with the starting costs from every unit's hours down now. That re-plan, the
   last one and holding on are costed at their own transfers, and the cheapest first
   hour is taken; a unit is stopped only where that pays over draws of the demand from
   the identified model (:func:`fluctuation_scenarios`), since starting it again may cost
   10,000.
2. The hour's transfer is set then too, from the same re-plan: the store smooths what is
   predicted, not what comes (section 6: the prediction lets the store "smooth out the
   fluctuations between two time intervals"). In hour t the actual demand comes and the
   committed units follow it at their economic dispatch; only what they cannot generate
   goes to the store, within its rates; if even that fails, the next candidate is taken
   (an unplanned start, paid for).
3. After hour t its measurement y(t) updates the predictor.

For white noise the identified a is near 0, so the prediction is the mean: the same
algorithm with no foresight (the paper substitutes the current fluctuation for the
prediction in its random model; for independent noise that is no better than the mean).

The mean day's plan keeps a reserve in the store (:func:`reserved_store`); on-line the
whole store is used. If the last hours cannot bring the store back exactly, what is left is settled at the
day's mean incremental cost, so every day is charged for the energy it served.

Units: MW, MWh, cost units; fluctuations relative (dimensionless).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hex_control.estimation.gauss_markov import GaussMarkovModel
from hex_control.estimation.identify import identify
from hex_control.estimation.kalman import OneStepPredictor
from hex_control.seeds.unit_commitment.day import DayPlan, deterministic_schedule
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.search import (
    hour_step,
    incremental_costs,
    running_cost,
    running_costs,
    search_commitments,
    starting_cost,
)
from hex_control.seeds.unit_commitment.storage import Storage
from hex_control.seeds.unit_commitment.table import TableRow, candidates_at
from hex_control.seeds.unit_commitment.transfers import cheapest_transfers, transfer_bounds


@dataclass(frozen=True)
class LoadFluctuation:
    """The relative demand fluctuation of eq. 6.1 (``uniform``) or 6.2-6.3 (``gauss_markov``),
    with standard deviation ``relative_std`` either way; ``a`` is the Gauss-Markov
    coefficient per hour; every hour's measurement has noise of ``measurement_std``."""

    kind: str
    relative_std: float = 0.0142
    a: float = 0.8
    measurement_std: float = 0.002

    def __post_init__(self):
        if self.kind not in ("uniform", "gauss_markov"):
            raise ValueError(f"a fluctuation is uniform or gauss_markov, not {self.kind!r}")
        if not (self.relative_std >= 0 and self.measurement_std >= 0 and abs(self.a) < 1):
            raise ValueError(f"need standard deviations >= 0 and |a| < 1, got {self}")

    def draw(self, hours: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(e(t), y(t)) for ``hours`` consecutive hours."""
        if self.kind == "uniform":
            alpha = math.sqrt(3.0) * self.relative_std  # uniform on [-alpha, alpha] has std alpha / sqrt 3
            fluctuation = rng.uniform(-alpha, alpha, hours)
        else:
            model = GaussMarkovModel(self.a, self.relative_std**2 * (1 - self.a**2), 0.0)
            fluctuation, _ = model.simulate(hours, rng)
        return fluctuation, fluctuation + rng.normal(0.0, self.measurement_std, hours)


def reserved_store(storage: Storage, demand_mw, fluctuation: LoadFluctuation, sigmas: float = 3.0,
                   hours: float = 2.0) -> Storage:
    """The store the mean day is planned with: its size less a reserve at both ends, the
    energy of a ``sigmas`` forecast error at the peak for ``hours``, kept for the on-line
    scheduler. Without it the plan empties the store at the evening peak, and a demand
    above the prediction there can only be met by starting a unit."""
    reserve_mwh = sigmas * fluctuation.relative_std * float(np.max(demand_mw)) * hours
    low, high = storage.s_min_mwh + reserve_mwh, storage.s_max_mwh - reserve_mwh
    if not low <= storage.s_start_mwh <= high:
        return storage  # too small a store to hold a reserve back
    return replace(storage, s_min_mwh=low, s_max_mwh=high)


def fluctuation_scenarios(predictor: OneStepPredictor, hours: int, count: int,
                          rng: np.random.Generator) -> np.ndarray:
    """``count`` draws (count x ``hours``) of the relative demand fluctuation over the next
    hours, by the predictor's model from its present estimate (eq. 6.2-6.3): the first
    hour's about the prediction with its variance P, each later one a times the last plus
    the process noise (W), and every hour the measurement noise too (V). V counts as demand:
    white-noise demand is identified largely as V (a and W cannot be told apart from V
    there), and leaving it out would take the random load for nearly certain."""
    model = predictor.model
    state = rng.normal(predictor.prediction - predictor.mean, math.sqrt(predictor.prediction_variance), count)
    draws = np.empty((count, hours))
    for k in range(hours):
        if k:
            state = model.a * state + rng.normal(0.0, math.sqrt(model.process_variance), count)
        draws[:, k] = predictor.mean + state + rng.normal(0.0, math.sqrt(model.measurement_variance), count)
    return draws


@dataclass(frozen=True)
class OnlineDay:
    commitments: list[tuple[bool, ...]]
    demand_mw: np.ndarray  # what came
    transfers_mw: np.ndarray
    running_cost: float
    starting_cost: float
    settlement_cost: float  # of the store's energy not brought back (-: a credit for energy left in it)
    unplanned: int  # hours whose chosen commitment could not meet the demand

    @property
    def total_cost(self) -> float:
        return self.running_cost + self.starting_cost + self.settlement_cost

    @property
    def unit_cost(self) -> float:
        """Cost per MWh served (section 7's unit generation cost)."""
        return self.total_cost / float(np.sum(self.demand_mw))


class OnlineScheduler:
    """Runs days of actual demand against the plan of the mean day (see the module). A
    decision to stop units is weighed over ``scenarios`` draws of the rest of the day's
    demand (:func:`fluctuation_scenarios`, seeded by ``seed``)."""

    def __init__(self, fleet: Fleet, table: list[TableRow], plan: DayPlan, storage: Storage,
                 *, predictor: OneStepPredictor, scenarios: int = 24, seed: int = 0, last_fluctuation: bool = False):
        if scenarios < 1:
            raise ValueError(f"need at least one scenario, got {scenarios}")
        self.fleet, self.table, self.plan, self.storage, self.predictor = fleet, table, plan, storage, predictor
        # the paper's random model (section 6, Fig. 4): the next hour's fluctuation taken as
        # the last one measured instead of the predictor's estimate
        self.last_fluctuation, self.last_measured = last_fluctuation, None
        self.scenarios, self.rng = scenarios, np.random.default_rng(seed)
        self.down = tuple(0 for _ in fleet.units)  # every unit's hours down
        self.stored_mwh = storage.s_start_mwh

    def _store_now(self) -> Storage:
        return replace(self.storage, s_start_mwh=min(max(self.stored_mwh, self.storage.s_min_mwh),
                                                     self.storage.s_max_mwh))

    def _transfers(self, commitments, demand) -> np.ndarray:
        """The cheapest transfers of the rest of the day; as near to returning the store to
        its start as the commitments allow."""
        store = self._store_now()
        lower, upper = transfer_bounds(self.fleet, commitments, demand, store)
        owed = float(np.clip(self.storage.s_start_mwh - self.stored_mwh, lower.sum(), upper.sum()))
        return cheapest_transfers(self.fleet, commitments, demand, store, owed)

    def _options(self, generation_mw: float, *extra) -> list[tuple[bool, ...]]:
        levels = self.table[0].total_mw, self.table[-1].total_mw
        options = candidates_at(self.table, float(np.clip(generation_mw, *levels)))
        return options + [on for on in dict.fromkeys(extra) if on not in options]

    def _ranked(self, t: int, predicted_mw: np.ndarray, previous, incumbent):
        """(hour t's candidates, best first; the commitments of the later hours).

        The rest of the day is re-planned for the prediction: the transfers for the plan's
        commitments, then the commitments by dynamic programming from every unit's hours
        down now, each hour among the table's candidates at its generation, the plan's for
        it and the hours either side (a unit the plan starts for the peak may be needed an
        hour sooner), the incumbent's (the last re-plan's) and the last hour's. The DP's
        generation comes from the plan's commitments, and a commitment at the edge of its
        capacity there may fall short by a few MW that its own transfers would take. The DP
        prices it at what it can generate, the store making up the rest at the day's
        incremental cost, rather than refuse it: refused, the re-plan swapped a running
        unit for one at 10,000 a start. Priced so, a path may lean on the store where a
        draw of the demand cannot, so the DP is also run refusing them. Its paths are
        approximate, so four are costed, each at its own cheapest transfers: the two
        re-plans, the incumbent, and holding the last hour's commitment; the cheapest
        comes first.

        Stopping a running unit is a bet that the day can go without it: a path cheaper
        than keeping them is taken, cheapest first, only where stopping pays on average
        over draws of the demand (:meth:`_stopping_pays`), else the cheapest that stops
        none comes first. Starting needs no such care: a unit started when the demand
        comes costs what it would have cost in advance. The other candidates follow by
        running plus starting cost: the table's, and the last hour's with one unit more
        (the cheapest recourse when the demand outruns the first)."""
        planned = self.plan.schedule.commitments
        try:
            generation = predicted_mw[t:] + self._transfers(planned[t:], predicted_mw[t:])
        except ValueError:  # the plan cannot meet the prediction: take the store's plan
            generation = predicted_mw[t:] + self.plan.transfers_mw[t:]
        options = [self._options(g, *planned[max(t + k - 1, 0):t + k + 2], incumbent[t + k], previous)
                   for k, g in enumerate(generation)]
        paths = [list(incumbent[t:]), [previous] + list(incumbent[t + 1:])]
        price = float(np.mean(incremental_costs(self.fleet, planned[t:], generation)))
        for reach in (None, self._reach(predicted_mw[t:], generation)):  # the DP refusing short ones, and not
            try:
                replan = search_commitments(self.fleet, generation, lambda k: options[k], self.down, reach,
                                            energy_price=price)
                paths.insert(0, replan.commitments)
            except ValueError:
                pass
        costs = {}  # the two re-plans are often the same path: cost it once

        def cost(path):
            key = tuple(path)
            if key not in costs:
                costs[key] = self._rest_of_day_cost(path, predicted_mw[t:])
            return costs[key]

        paths.sort(key=cost)  # stable: a re-plan on a tie
        if _stopped(previous, paths[0][0]):
            keep = next(path for path in paths if not _stopped(previous, path[0]))  # holding stops nothing
            stopping = paths[:paths.index(keep)]  # those cheaper than keeping, cheapest first
            chosen = next((path for path in stopping if self._stopping_pays(t, path, keep, previous)), keep)
            paths.remove(chosen)
            paths.insert(0, chosen)
        ranked, later = list(dict.fromkeys(path[0] for path in paths)), paths[0][1:]

        def score(on):
            return running_cost(self.fleet, on, generation[0]) + hour_step(self.fleet, self.down, on)[1]

        # should the demand outrun them: the table's others, or one more unit started now
        one_more = [tuple(state or k == i for k, state in enumerate(previous)) for i in range(len(previous))]
        rest = sorted((on for on in dict.fromkeys(options[0] + one_more) if on not in ranked), key=score)
        return ranked + rest + [(True,) * len(self.fleet)], later  # all on: the last resort

    def _reach(self, predicted_mw, generation_mw):
        """(lowest, highest) generation of each hour the store could make up instead: the
        rates, and the energy the store would have at every later hour along the transfers
        behind ``generation_mw`` (drawing more in an hour lowers every later level)."""
        transfers = np.asarray(generation_mw) - predicted_mw
        levels = self.stored_mwh + np.cumsum(transfers)
        can_draw = np.minimum.accumulate((levels - self.storage.s_min_mwh)[::-1])[::-1]
        can_take = np.minimum.accumulate((self.storage.s_max_mwh - levels)[::-1])[::-1]
        lowest = np.maximum(predicted_mw + self.storage.r_min_mw, generation_mw - np.maximum(can_draw, 0.0))
        highest = np.minimum(predicted_mw + self.storage.r_max_mw, generation_mw + np.maximum(can_take, 0.0))
        return np.minimum(lowest, generation_mw), np.maximum(highest, generation_mw)

    def _stopping_pays(self, t: int, stopping, keeping, previous) -> bool:
        """Whether the path ``stopping`` (which stops units running in ``previous``) costs
        less than ``keeping`` on average over draws of the demand from hour t on. In a draw
        the stopping path cannot meet, the units are started again: it costs their most
        expensive start more than the keeping path."""
        mean = self.plan.demand_mw[t:]
        restart = sum(max(unit.start_cost) for unit, now, then in zip(self.fleet.units, previous, stopping[0])
                      if now and not then)
        differences = []
        for fluctuation in fluctuation_scenarios(self.predictor, mean.size, self.scenarios, self.rng):
            demand = mean * (1 + fluctuation)
            stop, keep = self._rest_of_day_cost(stopping, demand), self._rest_of_day_cost(keeping, demand)
            if math.isfinite(keep):
                differences.append(stop - keep if math.isfinite(stop) else restart)
            # else neither path holds this draw: both must start something, alike
        return not differences or float(np.mean(differences)) < 0.0

    def _rest_of_day_cost(self, path, predicted_mw) -> float:
        """Running plus starting cost of the commitments ``path`` from now to the day's end
        at their own cheapest transfers for ``predicted_mw``; inf if they cannot meet it."""
        try:
            transfers = self._transfers(path, predicted_mw)
        except ValueError:
            return math.inf
        running = running_costs(self.fleet, path, predicted_mw + transfers)
        return float(running.sum()) + starting_cost(self.fleet, self.down, path)

    def _hour_transfer(self, on, later, predicted_mw, demand_mw: float) -> float | None:
        """This hour's transfer with commitment ``on``: set for the prediction with ``later``
        to follow (or, if they cannot meet it, ``on`` held for the rest of the day: the next
        re-plan mends it), then clipped to what the units cannot take of the actual
        ``demand_mw``; None if the store cannot make up the difference."""
        for rest_of_day in ([on] + list(later), [on] * len(predicted_mw)):
            try:
                r = self._transfers(rest_of_day, predicted_mw)[0]
                lower, upper = transfer_bounds(self.fleet, [on], [demand_mw], self._store_now())
                return float(np.clip(r, lower[0], upper[0]))
            except ValueError:
                continue
        return None

    def run_day(self, fluctuation, measurement) -> OnlineDay:
        """One day: ``fluctuation`` e(t) and its ``measurement`` y(t), relative, per hour."""
        mean = self.plan.demand_mw
        fluctuation, measurement = np.asarray(fluctuation, float), np.asarray(measurement, float)
        if fluctuation.shape != mean.shape or measurement.shape != mean.shape:
            raise ValueError(f"need {mean.size} hours of fluctuation and measurement")
        hours = mean.size
        a = self.predictor.model.a
        demand = mean * (1 + fluctuation)
        self.down = tuple(0 for _ in self.fleet.units)  # each day starts as the plan's: every unit on
        commitments, transfers = [], np.zeros(hours)
        incumbent = list(self.plan.schedule.commitments)  # the commitments in force for the hours to come
        running = starting = 0.0
        unplanned = 0
        for t in range(hours):
            expected = self.predictor.prediction - self.predictor.mean
            if self.last_fluctuation:
                expected = 0.0 if self.last_measured is None else self.last_measured - self.predictor.mean
            predicted = mean[t:] * (1 + self.predictor.mean + expected * a ** np.arange(hours - t))
            predicted = np.concatenate([mean[:t], predicted])
            previous = commitments[-1] if commitments else (True,) * len(self.fleet)
            ranked, later = self._ranked(t, predicted, previous, incumbent)
            for rank, on in enumerate(ranked):
                r = self._hour_transfer(on, later, predicted[t:], demand[t])
                cost = math.inf if r is None else running_cost(self.fleet, on, demand[t] + r)
                if math.isfinite(cost):
                    break
            else:
                raise ValueError(f"hour {t}: {demand[t]:.0f} MW is beyond every commitment")
            unplanned += rank > 0
            self.down, start = hour_step(self.fleet, self.down, on)
            running, starting = running + cost, starting + start
            commitments.append(on)
            incumbent[t + 1:] = later
            transfers[t] = r
            self.stored_mwh += r
            self.predictor.step(float(measurement[t]))
            self.last_measured = float(measurement[t])
        left_in_store = self.stored_mwh - self.storage.s_start_mwh
        lam = float(np.mean(incremental_costs(self.fleet, commitments, demand + transfers)))
        self.stored_mwh = self.storage.s_start_mwh  # settled
        return OnlineDay(commitments, demand, transfers, running, starting, -left_in_store * lam, int(unplanned))


def _stopped(before, after) -> bool:
    """Whether commitment ``after`` stops a unit that runs in ``before``."""
    return any(now and not then for now, then in zip(before, after))


def identified_predictor(fluctuation: LoadFluctuation, history_hours: int, rng: np.random.Generator):
    """The predictor section 6 asks for: a, W, V identified from ``history_hours`` of
    measurements (the paper used 80 days), then filtered through that history."""
    _, history = fluctuation.draw(history_hours, rng)
    found = identify(history)
    predictor = OneStepPredictor(found.model, found.mean)
    predictor.warm_start(history)
    return predictor, found


@dataclass(frozen=True)
class OnlineComparison:
    """Per simulated day, the on-line unit cost's increase (relative) over the deterministic
    cost: that of the mean day's plan (the paper's measure) and that of the day's own
    demand known in advance (hindsight: the same table algorithm off-line)."""

    fluctuation: LoadFluctuation
    over_plan: np.ndarray
    over_hindsight: np.ndarray
    unplanned_hours: int
    identified: GaussMarkovModel
    energy_deviation: np.ndarray  # per day, (served - mean day's) / mean day's energy: a control variate, mean 0


def compare_online(fleet: Fleet, table: list[TableRow], plan: DayPlan, storage: Storage,
                   fluctuation: LoadFluctuation, *, days: int, rng: np.random.Generator, history_days: int = 80,
                   progress=None, last_fluctuation: bool = False) -> OnlineComparison:
    """``days`` consecutive days of demand (one fluctuation process), each scheduled on-line;
    ``progress(day, days)`` after each; ``last_fluctuation``: the paper's random model's
    prediction (:class:`OnlineScheduler`)."""
    predictor, found = identified_predictor(fluctuation, history_days * plan.demand_mw.size, rng)
    scheduler = OnlineScheduler(fleet, table, plan, storage, predictor=predictor, last_fluctuation=last_fluctuation)
    hours = plan.demand_mw.size
    fluctuations, measurements = fluctuation.draw(days * hours, rng)
    over_plan, over_hindsight, unplanned, deviation = [], [], 0, []
    for day in range(days):
        hourly = slice(day * hours, (day + 1) * hours)
        result = scheduler.run_day(fluctuations[hourly], measurements[hourly])
        hindsight = deterministic_schedule(fleet, result.demand_mw, storage, table, also=plan.schedule.commitments)
        over_plan.append(result.unit_cost / plan.unit_cost - 1)
        over_hindsight.append(result.unit_cost / hindsight.unit_cost - 1)
        unplanned += result.unplanned
        deviation.append(float(result.demand_mw.sum() / plan.demand_mw.sum() - 1))
        if progress:
            progress(day + 1, days)
    return OnlineComparison(fluctuation, np.array(over_plan), np.array(over_hindsight), unplanned, found.model,
                            np.array(deviation))
