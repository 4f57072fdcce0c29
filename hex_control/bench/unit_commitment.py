"""Benchmark of the unit-commitment scheduler (seed 000 part 2) on the example day: the
scheduling table and the 24-hour schedule against the paper's VAX 11/780 minutes (Table
2) and against the MILP peer on the same day; one on-line hourly decision against the
paper's 0.06-0.09 s (Fig. 6) and against re-planning the rest of the day off-line."""

from __future__ import annotations

import time

import numpy as np

from hex_control.bench import benchmark
from hex_control.seeds.unit_commitment.day import deterministic_schedule
from hex_control.seeds.unit_commitment.demand import example_day
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.milp import milp_schedule
from hex_control.seeds.unit_commitment.online import LoadFluctuation, OnlineScheduler, identified_predictor
from hex_control.seeds.unit_commitment.table import scheduling_table

PAPER_MIN = {18: (120.0, 1 + 35 / 60), 41: (200.0, 3 + 50 / 60)}  # Table 2: table build, 24-hour schedule


def _seconds(function):
    start = time.perf_counter()
    value = function()
    return value, time.perf_counter() - start


@benchmark("unit_commitment")
def unit_commitment_speed(quick: bool) -> list[str]:
    fleet = Fleet.from_yaml("fleet_18.yaml" if quick else "fleet_41.yaml")
    day = example_day(fleet)
    table, table_s = _seconds(lambda: scheduling_table(fleet, k=5))
    plan, day_s = _seconds(lambda: deterministic_schedule(fleet, day.demand_mw, day.storage, table))
    peer, milp_s = _seconds(lambda: milp_schedule(fleet, day.demand_mw, day.storage, mip_rel_gap=1e-3))
    paper_table, paper_day = PAPER_MIN[len(fleet)]
    lines = [f"{len(fleet)} machines, table of {len(table)} levels: {table_s:.1f} s "
             f"(paper, VAX 11/780: {paper_table:.0f} min)",
             f"24-hour schedule: {day_s:.2f} s (paper: {paper_day:.2f} min); MILP (HiGHS, 0.1 % gap) on the same day: "
             f"{milp_s:.2f} s, ratio MILP / table algorithm {milp_s / day_s:.2f}",
             f"daily cost: table algorithm {plan.total_cost:,.1f}, MILP {peer.plan.total_cost:,.1f}, MILP lower bound "
             f"{peer.lower_bound:,.1f}: the table algorithm {100 * (plan.total_cost / peer.lower_bound - 1):.3f} % "
             "above it"]
    rng = np.random.default_rng(0)
    fluctuation = LoadFluctuation("gauss_markov")
    predictor, _ = identified_predictor(fluctuation, 80 * 24, rng)
    scheduler = OnlineScheduler(fleet, table, plan, day.storage, predictor=predictor)
    hours = 6 if quick else 24
    e, y = fluctuation.draw(24, rng)
    _, online_s = _seconds(lambda: scheduler.run_day(e, y))
    actual = plan.demand_mw * (1 + e)
    _, replan_s = _seconds(lambda: [deterministic_schedule(fleet, actual, day.storage, table) for _ in range(hours)])
    lines.append(f"on-line hourly decision (Gauss-Markov load, Kalman predictor): {online_s / 24:.3f} s "
                 f"(paper: 0.06-0.09 s); re-planning the day off-line instead: {replan_s / hours:.2f} s, "
                 f"ratio {replan_s / hours / (online_s / 24):.1f}")
    return lines
