"""Issue 42 item 2: does the start's J predict the charge of jobs run as the cell runs them?

A closed-loop stand-in for the campaign, in process (a job in about 0.3 s): the sequence
planner's policy re-solved on the pass-rate predictor's K1 (the predictor of
config/load_predictor.yaml, re-solving beyond a 5 % move) and on the force the plans reach
(the scanned bead's prior, ``measured_part.prior_force_limit_n``, then 47.6 N, what the
grid's plans reached); each pass guarded as the pass planner plans it (at most 0.78 of eq.
4.6's F_max cut at its feed, the grid's measured fraction) and cut with the pass's own K1
(log-normal, mean 10 J/mm^3, cv 15 %, as the plant draws it): delta-hat K-hat / K1. With
the K1 sequences the grid's seeds 200-202 drew it reproduces their jobs' charges
(docs/results/issue42_grid.md); over many seeds it gives the mean charge J should predict.

    python scripts/closed_loop_study.py --jobs 400 --cells 1.0/60 1.2/60            # the planner's model
    python scripts/closed_loop_study.py --jobs 400 --cells 1.0/60 --thesis-model    # c1, shifted Rayleigh
    python scripts/closed_loop_study.py --before --replay-seeds 300 301 302 303 304 # the code before issue 42
    python scripts/closed_loop_study.py --jobs 300 --row-groups 60 --cells 1.0/45 1.0/60 1.0/90

Units: mm, s, N, J/mm^3.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import sys

import numpy as np
import yaml

from hex_control.config import config_file
from hex_control.estimation.load_predictor import LoadPredictorCore, LoadPredictorSettings
from hex_control.grinding.config import parse_planner_config
from hex_control.grinding.contour import weld_bead
from hex_control.grinding.measured_part import PartRule, Profile, prior_force_limit_n
from hex_control.grinding.sdp import build_controls, solve
from hex_control.grinding.sequencer import K1_ESTIMATE_CV
from hex_control.grinding.stochastic import planned_on_estimate

CONFIG = yaml.safe_load(config_file("sequence_planner.yaml").read_text())
PROCESS, CHARGES, GRID, MODEL = parse_planner_config(CONFIG)
JOB = dataclasses.replace(PROCESS, bead_length_mm=150.0, reset_time_s=4.705)  # the campaign's t_R
GUARD = 0.78  # the pass planner's guarded cut over eq. 4.6's at F_max (the grid: 0.74-0.80 by feed)
LEARNED_FORCE_N = 47.6  # the force the grid's plans reached after the first (47.1-48.8 N)
PREDICTOR = LoadPredictorSettings(a=0.98, process_variance=0.5, measurement_variance=2.25, mean=10.0,
                                  drift_rate_variance=0.5, drift_switch_probability=0.05,
                                  drift_initial_rate_variance=4.0)
#: K1 (J/mm^3) of each pass the plant drew for the grid's seeds (its jobs' measured K1)
GRID_SEEDS = {200: [10.36, 9.28, 9.17, 10.30, 11.46, 10.39, 9.01],
              201: [13.18, 9.03, 7.26, 8.35, 12.68, 10.27, 9.33],
              202: [12.96, 8.87, 8.41, 9.29]}
SIGMA = math.sqrt(math.log1p(0.15**2))


@functools.lru_cache(maxsize=20000)
def policy(k1, force_n, deadline_s, x0, *, model, factor):
    process = dataclasses.replace(JOB, specific_energy_j_mm3=k1 / factor, force_max_n=force_n)
    return solve(process, CHARGES, GRID.covering(deadline_s, x0), model)


def job(seed, deadline_s, x0, prior_n, *, model, factor, k1s=None):
    """(charge, final X mm, passes) of one job."""
    rng = np.random.default_rng(seed)
    predictor = LoadPredictorCore(PREDICTOR)
    estimate, solved = 10.0, (10.0, prior_n)
    t, x, passes = deadline_s, x0, 0
    while True:
        # the solve's K1 to 0.5 %: policies cached
        decision = policy(round(solved[0] * 20) / 20, round(solved[1], 2), deadline_s, x0, model=model,
                          factor=factor).lookup(t, x)
        if decision["action"] != "grind":
            return float(CHARGES.deadline(x)), x, passes
        force, feed = decision["force_n"], decision["feed_mm_s"]
        planner = dataclasses.replace(JOB, specific_energy_j_mm3=estimate)
        command = float(planner.cut_depth_mm(force, feed))
        if x > 0:
            command = min(command, x)  # the pass planner caps a cut at the material left
        planned = min(command, GUARD * float(planner.cut_depth_mm(JOB.force_max_n, feed)))
        k1 = k1s[passes] if k1s is not None and passes < len(k1s) else 10.0 * rng.lognormal(-SIGMA**2 / 2, SIGMA)
        x -= planned * estimate / k1
        t -= decision["duration_s"] - 0.075  # a pass takes its whole stages less 0.075 s (the grid's)
        passes += 1
        estimate = float(predictor.measure(k1).step.prediction)
        if abs(estimate / solved[0] - 1) > 0.05 or abs(LEARNED_FORCE_N / solved[1] - 1) > 0.05:
            solved = (estimate, LEARNED_FORCE_N)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=400)
    parser.add_argument("--cells", nargs="+", default=["1.0/60"], help="bead height mm / deadline s")
    parser.add_argument("--thesis-model", action="store_true", help="solve with the configured cut model")
    parser.add_argument("--before", action="store_true",
                        help="the planner before issue 42: the configured cut model from the configured F_max "
                             "(60 N) until the first plan's force is learned")
    parser.add_argument("--estimate-cv", type=float, default=K1_ESTIMATE_CV)
    parser.add_argument("--row-groups", type=int, default=0,
                        help="also the charge / J of the cells pooled (a bead row) over this many groups of five "
                             "consecutive seeds, as the grid's five seeds give it (needs --jobs >= 5 x groups)")
    parser.add_argument("--replay-seeds", type=int, nargs="*", default=[],
                        help="also each job of these campaign seeds, from the K1 the plant draws for them")
    args = parser.parse_args(argv)
    if not 1 <= args.jobs <= 100_000:
        print("--jobs must be in [1, 100000]", file=sys.stderr)
        return 2
    if not 0 <= 5 * args.row_groups <= args.jobs:
        print("--row-groups must be in [0, jobs / 5]", file=sys.stderr)
        return 2
    thesis = args.thesis_model or args.before
    model, factor = (MODEL, 1.0) if thesis else planned_on_estimate(MODEL, args.estimate_cv)
    print(f"model {model}, mean factor {factor:.4f}")
    print("| bead mm | deadline s | J at start | mean charge (jobs) | charge / J | overgrind part | P(X < 0) | "
          "median | seeds 200-202's K1: mean charge, / J |")
    print("|---|---|---|---|---|---|---|---|---|")
    row_j, row_charges, replays = [], [], []
    for cell in args.cells:
        height, deadline = (float(v) for v in cell.split("/"))
        x0, prior = cell_start(height, deadline, args.before)
        run = functools.partial(job, deadline_s=deadline, x0=x0, prior_n=prior, model=model, factor=factor)
        j = policy(10.0, round(prior, 2), deadline, x0, model=model, factor=factor).expected_penalty(deadline, x0)
        runs = np.array([run(s) for s in range(1000, 1000 + args.jobs)])
        charge, final = runs[:, 0], runs[:, 1]
        seeds = np.mean([run(s, k1s=k1s)[0] for s, k1s in GRID_SEEDS.items()])
        error = charge.std() / math.sqrt(len(charge))
        print(f"| {height:g} | {deadline:g} | {j:.4f} | {charge.mean():.4f} +- {error:.4f} ({len(charge)}) | "
              f"{charge.mean() / j:.2f} | {np.where(final < 0, charge, 0).mean():.4f} | {np.mean(final < 0):.1%} | "
              f"{np.median(charge):.4f} | {seeds:.4f}, {seeds / j:.2f} |", flush=True)
        row_j.append(j)
        row_charges.append(charge)
        if args.replay_seeds:
            replays.append((height, deadline, [run(s, k1s=plant_k1(s)) for s in args.replay_seeds]))
    for height, deadline, jobs in replays:
        print(f"replay {height:g} mm / {deadline:g} s, seeds {args.replay_seeds}: "
              + " ".join(f"{c:.4f} (X {x:+.3f}, {n})" for c, x, n in jobs)
              + f", mean {np.mean([c for c, _, _ in jobs]):.4f}", flush=True)
    if args.row_groups:
        print_row_spread(np.array(row_charges), np.mean(row_j), args.row_groups)
    return 0


def cell_start(height_mm: float, deadline_s: float, before: bool) -> tuple[float, float]:
    """(X mm, force limit N) a cell's job starts from: the bead's mean, and the scanned bead's
    prior force (the configured F_max before issue 42)."""
    bead = weld_bead(150.0, height_mm, 12.0, ripple_mm=0.05, seed=0)
    profile = Profile(bead.x_mm, bead.z_mm, bead.parent_mm)
    if before:
        return profile.mean_mm, JOB.force_max_n
    feeds = build_controls(JOB, GRID.covering(deadline_s, profile.mean_mm), MODEL).feeds_mm_s
    return profile.mean_mm, prior_force_limit_n(profile, JOB, feeds, PartRule())


def print_row_spread(charges, mean_j: float, groups: int) -> None:
    """The spread of a bead row's charge / J (cells x jobs ``charges``, the cells' mean J)
    over groups of five consecutive seeds: what the grid's five seeds per cell can show."""
    ratios = np.array([charges[:, 5 * g:5 * g + 5].mean() / mean_j for g in range(groups)])
    inside = np.mean((ratios >= 1 / 1.5) & (ratios <= 1.5))
    quantiles = np.quantile(ratios, [0.05, 0.25, 0.5, 0.75, 0.95])
    print(f"row charge / J over {groups} groups of 5 seeds: all seeds {charges.mean() / mean_j:.2f}; "
          f"5/25/50/75/95 % {' / '.join(f'{q:.2f}' for q in quantiles)}; within 1.5x either way in {inside:.0%}")


def plant_k1(seed: int, passes: int = 20) -> list[float]:
    """The K1 (J/mm^3) the plant draws for the passes of the campaign job of ``seed``
    (``ProcessVariation.draw``: its generator seeded with the job's seed, friction fixed)."""
    from hex_control.grinding.variation import _unit_lognormal

    rng = np.random.default_rng(seed)
    return [JOB.specific_energy_j_mm3 * _unit_lognormal(rng, 0.15) for _ in range(passes)]


if __name__ == "__main__":
    sys.exit(main())
