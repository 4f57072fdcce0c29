"""The unit-commitment on-line statistics (seed 000 part 2, section 7) on the campaign
runner (issue 39 item 5, issue 41 item 3): blocks of days, each a job with its own seed,
run on any executor (serial, local processes, Ray) and gathered in seed order, so the table
depends on the seeds only.

Each job identifies the predictor from its own 80 days of history, schedules its block of
days on-line under one load model and returns, per day, the paper's measure -- the
increase of the unit cost (operating and starting costs per MWh) over the deterministic
plan of the mean day -- and the increase over the day's own demand scheduled in hindsight,
with the day's energy deviation (served over planned energy, less 1; mean 0 by
construction) for a control variate.

The paper's set-up is the default: the plan uses the whole store (no reserve held back;
the paper has none), and the random model predicts the next hour's fluctuation as the last
one measured (section 6: Fig. 4 with the prediction replaced by the current fluctuation).

ROS-free (the campaign package's rule).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from hex_control.campaign import Job, campaign_record, gather, run_campaign

MODELS = ("uniform", "gauss_markov")
STORES = ("full", "reserved", "unbounded")


def online_block(job: Job) -> dict:
    """One job: ``settings['days']`` days of one load model on-line (see the module)."""
    from hex_control.seeds.unit_commitment.day import deterministic_schedule
    from hex_control.seeds.unit_commitment.demand import example_day
    from hex_control.seeds.unit_commitment.fleet import Fleet
    from hex_control.seeds.unit_commitment.online import LoadFluctuation, compare_online, reserved_store
    from hex_control.seeds.unit_commitment.storage import Storage
    from hex_control.seeds.unit_commitment.table import load_table

    settings = job.settings
    fleet = Fleet.from_yaml(settings["fleet"])
    table = load_table(settings["table"], fleet)
    day = example_day(fleet)
    store = Storage(day.storage.r_min_mw, day.storage.r_max_mw) if settings["store"] == "unbounded" else day.storage
    fluctuation = LoadFluctuation(settings["kind"], settings["std"], settings["a"])
    planned_store = reserved_store(store, day.demand_mw, fluctuation) if settings["store"] == "reserved" else store
    plan = deterministic_schedule(fleet, day.demand_mw, planned_store, table)
    start = time.perf_counter()
    result = compare_online(fleet, table, plan, store, fluctuation, days=settings["days"],
                            rng=np.random.default_rng(job.seed), history_days=settings.get("history_days", 80),
                            last_fluctuation=settings["kind"] == "uniform" and settings["random_model"] == "paper")
    return {"kind": settings["kind"], "over_plan": result.over_plan.tolist(),
            "over_hindsight": result.over_hindsight.tolist(), "energy_deviation": result.energy_deviation.tolist(),
            "unplanned_hours": result.unplanned_hours, "identified_a": result.identified.a,
            "plan_unit_cost": plan.unit_cost, "seconds_per_day": (time.perf_counter() - start) / settings["days"]}


def _mean(values: np.ndarray) -> dict:
    n = values.size
    se = float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
    return {"mean_percent": 100 * float(values.mean()), "standard_error_percent": 100 * se, "days": int(n)}


def _controlled(values: np.ndarray, control: np.ndarray) -> dict:
    """The mean of ``values`` with the control variate ``control`` (known mean 0) regressed
    out: the same expectation, the day's own demand level's share of the spread removed."""
    c = control - control.mean()
    beta = float(c @ (values - values.mean()) / (c @ c)) if c @ c > 0 else 0.0
    adjusted = values - beta * control
    out = _mean(adjusted)
    out["standard_error_percent"] = 100 * float(adjusted.std(ddof=2) / math.sqrt(values.size))
    out["slope_per_relative_energy"] = beta
    return out


def _difference(first: dict, second: dict) -> dict:
    """first less second, its standard error, z, and how many days a model would give it
    3 standard errors at this difference and these spreads."""
    diff = first["mean_percent"] - second["mean_percent"]
    se = math.hypot(first["standard_error_percent"], second["standard_error_percent"])
    spread = math.hypot(first["standard_error_percent"] * math.sqrt(first["days"]),
                        second["standard_error_percent"] * math.sqrt(second["days"]))  # one day of each, %
    return {"percent": diff, "standard_error_percent": se, "z": diff / se if se > 0 else math.nan,
            "days_a_model_for_3_standard_errors": math.ceil((3 * spread / diff) ** 2) if diff else None}


def _demand_level(values: np.ndarray, energy: np.ndarray) -> dict:
    """The day's own demand level in the paper's measure: over the plan ~ c + b e + k e^2 in
    the energy deviation e (least squares); k Var(e) is what a model's spread of daily
    energy adds to the mean by the convexity of the costs, whatever the scheduler."""
    (c, b, k), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(energy), energy, energy**2]), values, rcond=None)
    return {"slope_percent_per_percent": float(b), "curvature": float(k),
            "energy_deviation_std_percent": 100 * float(energy.std(ddof=1)),
            "convexity_share_percent": 100 * float(k * energy.var(ddof=1))}


def statistics(summaries: list[dict]) -> dict:
    """Per load model the measures over all its days (jobs in seed order), and uniform less
    Gauss-Markov with its z (the paper: 0.058 % against 0.031 %, a difference of 0.027 %)."""
    out = {"models": {}}
    for kind in MODELS:
        mine = [s for s in summaries if s["kind"] == kind]
        if not mine:
            continue
        plan = np.concatenate([s["over_plan"] for s in mine])
        hindsight = np.concatenate([s["over_hindsight"] for s in mine])
        energy = np.concatenate([s["energy_deviation"] for s in mine])
        out["models"][kind] = {
            "over_plan": _mean(plan), "over_plan_controlled": _controlled(plan, energy),
            "over_hindsight": _mean(hindsight), "demand_level": _demand_level(plan, energy),
            "unplanned_hours": int(sum(s["unplanned_hours"] for s in mine)),
            "identified_a": [s["identified_a"] for s in mine], "plan_unit_cost": mine[0]["plan_unit_cost"],
            "seconds_per_day": float(np.mean([s["seconds_per_day"] for s in mine]))}
    if len(out["models"]) == 2:
        u, g = out["models"]["uniform"], out["models"]["gauss_markov"]
        out["uniform_less_gauss_markov"] = {name: _difference(u[name], g[name])
                                            for name in ("over_plan", "over_plan_controlled", "over_hindsight")}
    return out


def online_jobs(*, fleet: str, table: str, blocks: int, days_per_block: int, store: str = "full",
                random_model: str = "paper", std: float = 0.0142, a: float = 0.8, first_seed: int = 0) -> list[Job]:
    """``blocks`` jobs of ``days_per_block`` days per load model; the uniform model's seeds
    are ``first_seed`` + 0.., the Gauss-Markov model's ``first_seed`` + 10,000 + 0.."""
    if store not in STORES or random_model not in ("paper", "identified"):
        raise ValueError(f"store is one of {STORES} and random_model paper or identified, got {store}, {random_model}")
    if blocks < 1 or days_per_block < 1 or blocks * days_per_block < 2:
        raise ValueError(f"need at least one block of days and two days a model, got {blocks} x {days_per_block}")
    settings = {"fleet": fleet, "table": table, "days": days_per_block, "store": store, "random_model": random_model,
                "std": std, "a": a}
    return [Job(first_seed + 10_000 * m + b, "", {**settings, "kind": kind})
            for m, kind in enumerate(MODELS) for b in range(blocks)]


def run_online_campaign(jobs: list[Job], executor, output, *, name: str, progress: bool = True) -> dict:
    """Run the jobs, write ``output/<name>.json`` (statistics, the campaign record, the
    per-day values) and ``output/<name>.txt`` (the table); return the statistics."""
    start = time.monotonic()
    outcomes = run_campaign(jobs, online_block, executor, progress=progress)
    wall_s = time.monotonic() - start
    stats = gather(outcomes, statistics) or {}
    record = campaign_record(outcomes, executor.name, getattr(executor, "workers", None), wall_s)
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    settings = {key: value for key, value in jobs[0].settings.items() if key != "kind"}
    document = {"settings": settings, "statistics": stats, "campaign": record,
                "per_day": {o.seed: o.summary for o in outcomes if o.ok}}
    (output / f"{name}.json").write_text(json.dumps(document, indent=1) + "\n")
    (output / f"{name}.txt").write_text(table_text(stats, settings, record) + "\n")
    return stats


def restate(path) -> dict:
    """Recompute a written campaign's statistics from its per-day values (seed order) and
    rewrite its .json and .txt; return the statistics."""
    path = Path(path)
    document = json.loads(path.read_text())
    summaries = [document["per_day"][seed] for seed in sorted(document["per_day"], key=int)]
    document["statistics"] = stats = statistics(summaries)
    path.write_text(json.dumps(document, indent=1) + "\n")
    path.with_suffix(".txt").write_text(table_text(stats, document["settings"], document["campaign"]) + "\n")
    return stats


def table_text(stats: dict, settings: dict, record: dict) -> str:
    lines = [f"unit commitment on-line (seed 000 part 2, section 7): {settings['fleet']}, store {settings['store']}, "
             f"random model {settings['random_model']}, fluctuation {100 * settings['std']:.2f} % std, a = "
             f"{settings['a']}; {record['ran']} jobs ran, {record['failed']} failed, {record['wall_s']:.0f} s wall "
             f"({record['backend']}, {record['workers']} workers)",
             "unit cost increase, mean ± standard error (%)  [paper: random +0.058, Gauss-Markov +0.031]",
             f"{'model':14s} {'days':>5s} {'over the plan':>22s} {'over plan, controlled':>24s} "
             f"{'over hindsight':>22s} {'unplanned h':>11s}"]
    for kind, m in stats.get("models", {}).items():
        cells = [f"{m[k]['mean_percent']:+.4f} ± {m[k]['standard_error_percent']:.4f}"
                 for k in ("over_plan", "over_plan_controlled", "over_hindsight")]
        lines.append(f"{kind:14s} {m['over_plan']['days']:5d} {cells[0]:>22s} {cells[1]:>24s} {cells[2]:>22s} "
                     f"{m['unplanned_hours']:11d}")
    if "uniform_less_gauss_markov" in stats:
        d = stats["uniform_less_gauss_markov"]
        cells = [f"{d[k]['percent']:+.4f} (z {d[k]['z']:+.1f})"
                 for k in ("over_plan", "over_plan_controlled", "over_hindsight")]
        lines.append(f"{'uniform - G-M':14s} {'':5s} {cells[0]:>22s} {cells[1]:>24s} {cells[2]:>22s}")
        days = [d[k]["days_a_model_for_3_standard_errors"] for k in ("over_plan", "over_plan_controlled",
                                                                     "over_hindsight")]
        lines.append(f"{'days a model for 3 s.e. at these values':44s} {days[0]!s:>8s} {days[1]!s:>24s} "
                     f"{days[2]!s:>22s}")
    for kind, m in stats.get("models", {}).items():
        level = m["demand_level"]
        lines.append(f"{kind}: the day's energy varies {level['energy_deviation_std_percent']:.2f} % (std); over the "
                     f"plan moves {level['slope_percent_per_percent']:.3f} % per 1 % of energy; the costs' convexity "
                     f"adds {level['convexity_share_percent']:+.4f} % to the mean over the plan; "
                     f"{m['seconds_per_day']:.1f} s a day")
    return "\n".join(lines)
