"""The three jobs of ``hexctl unit-commitment``: build a fleet's scheduling table, schedule
its example day off-line (against the MILP peer if asked), and run it on-line under both
load models. Each writes its PNG and a summary JSON into the output folder and returns
the summary; the table is kept there and reused (it depends only on the fleet, K and the
step).
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from hex_control.seeds.unit_commitment.day import deterministic_schedule
from hex_control.seeds.unit_commitment.demand import example_day
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.online import LoadFluctuation, compare_online, reserved_store
from hex_control.seeds.unit_commitment.plots import plot_day, plot_online, plot_table
from hex_control.seeds.unit_commitment.storage import Storage
from hex_control.seeds.unit_commitment.table import load_table, save_table, scheduling_table


def table_for(fleet: Fleet, output: Path, k: int, step_mw: float) -> tuple[list, float | None]:
    """(the table, seconds it took to build; None if it was read from the output folder)."""
    path = output / f"table_{file_name(fleet)}_k{k}_step{step_mw:g}.json"
    if path.is_file():
        try:
            return load_table(path, fleet), None
        except (KeyError, TypeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path}: not a scheduling table ({type(exc).__name__}: {exc}); delete it to rebuild "
                             "it") from None
    top = fleet.capacity_mw[1]
    start = time.perf_counter()
    with tqdm(total=round(top), desc=f"table {fleet.name}", unit="MW") as bar:
        rows = scheduling_table(fleet, k=k, step_mw=step_mw, progress=lambda level, end: bar.update(
            round(level) - bar.n))
    seconds = time.perf_counter() - start
    output.mkdir(parents=True, exist_ok=True)
    save_table(rows, path)
    return rows, seconds


def file_name(fleet: Fleet) -> str:
    """The fleet's name as part of a file name (no separators)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", fleet.name).lstrip(".") or "fleet"


def _check(k: int, step_mw: float) -> None:
    if k < 1 or not step_mw > 0 or not np.isfinite(step_mw):
        raise ValueError(f"need --k >= 1 and a finite --step > 0 MW, got {k} and {step_mw}")


def build_table(fleet_file: str, output, k: int = 5, step_mw: float = 100.0) -> dict:
    _check(k, step_mw)
    fleet, output = Fleet.from_yaml(fleet_file), Path(output)
    rows, seconds = table_for(fleet, output, k, step_mw)
    plot_table(output / f"table_{file_name(fleet)}.png", fleet, rows)
    summary = {"fleet": fleet.name, "png": str(output / f"table_{file_name(fleet)}.png"), "units": len(fleet),
               "levels": len(rows), "k": k, "step_mw": step_mw,
               "build_s": seconds, "levels_mw": [rows[0].total_mw, rows[-1].total_mw]}
    (output / f"table_{file_name(fleet)}.summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def schedule_day(fleet_file: str, output, k: int = 5, step_mw: float = 100.0, milp: bool = False) -> dict:
    _check(k, step_mw)
    fleet, output = Fleet.from_yaml(fleet_file), Path(output)
    rows, _ = table_for(fleet, output, k, step_mw)
    day = example_day(fleet)
    start = time.perf_counter()
    plan = deterministic_schedule(fleet, day.demand_mw, day.storage, rows)
    seconds = time.perf_counter() - start
    png = output / f"day_{file_name(fleet)}.png"
    plot_day(png, fleet, plan.demand_mw, plan.transfers_mw, plan.schedule.commitments,
             title=f"Off-line schedule of {fleet.name}: cost {plan.total_cost:,.0f} "
             f"(starts {plan.schedule.starting_cost:,.0f})")
    summary = {"fleet": fleet.name, "png": str(png), "cost": plan.total_cost,
               "running_cost": plan.schedule.running_cost,
               "starting_cost": plan.schedule.starting_cost, "unit_cost_per_mwh": plan.unit_cost,
               "schedule_s": seconds, "rounds": plan.rounds,
               "generation_mw": plan.generation_mw.round(1).tolist(),
               "transfers_mw": plan.transfers_mw.round(1).tolist(),
               "units_on": [int(sum(on)) for on in plan.schedule.commitments]}
    if milp:
        from hex_control.seeds.unit_commitment.milp import milp_schedule

        start = time.perf_counter()
        peer = milp_schedule(fleet, day.demand_mw, day.storage, mip_rel_gap=1e-3)
        summary["milp"] = {"cost": peer.plan.total_cost, "lower_bound": peer.lower_bound, "gap": peer.gap,
                           "solve_s": time.perf_counter() - start, "status": peer.status,
                           "table_over_lower_bound": plan.total_cost / peer.lower_bound - 1}
    (output / f"day_{file_name(fleet)}.summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def run_online(fleet_file: str, output, days: int = 40, history_days: int = 80, relative_std: float = 0.0142,
               *, a: float = 0.8, seed: int = 0, k: int = 5, step_mw: float = 100.0,
               unbounded_store: bool = False) -> dict:
    """Both load models on-line; ``unbounded_store``: the store's energy without bounds (its
    rates kept)."""
    _check(k, step_mw)
    if days < 2 or history_days < 2:
        raise ValueError(f"need --days >= 2 (a standard error) and --history-days >= 2, got {days} and {history_days}")
    models = [LoadFluctuation(kind, relative_std, a) for kind in ("uniform", "gauss_markov")]  # checked before work
    fleet, output = Fleet.from_yaml(fleet_file), Path(output)
    rows, _ = table_for(fleet, output, k, step_mw)
    day = example_day(fleet)
    store = Storage(day.storage.r_min_mw, day.storage.r_max_mw) if unbounded_store else day.storage
    comparisons = []
    summary = {"fleet": fleet.name, "png": str(output / f"online_{file_name(fleet)}.png"), "days": days,
               "history_days": history_days, "relative_std": relative_std,
               "unbounded_store": unbounded_store, "models": {}}
    for fluctuation in models:
        kind = fluctuation.kind
        plan = deterministic_schedule(fleet, day.demand_mw, reserved_store(store, day.demand_mw, fluctuation), rows)
        with tqdm(total=days, desc=f"on-line {kind}", unit="day") as bar:
            comparison = compare_online(fleet, rows, plan, store, fluctuation, days=days,
                                        rng=np.random.default_rng(seed), history_days=history_days,
                                        progress=lambda done, total: bar.update(done - bar.n))
        comparisons.append(comparison)
        summary["models"][kind] = {
            name: {"mean_percent": 100 * float(values.mean()),
                   "standard_error_percent": 100 * float(values.std(ddof=1) / np.sqrt(values.size))}
            for name, values in (("over_hindsight", comparison.over_hindsight), ("over_plan", comparison.over_plan))}
        summary["models"][kind]["unplanned_hours"] = comparison.unplanned_hours
        summary["models"][kind]["identified_a"] = comparison.identified.a
        summary["models"][kind]["deterministic_unit_cost"] = plan.unit_cost
    plot_online(output / f"online_{file_name(fleet)}.png", comparisons)
    (output / f"online_{file_name(fleet)}.summary.json").write_text(json.dumps(summary, indent=2))
    return summary
