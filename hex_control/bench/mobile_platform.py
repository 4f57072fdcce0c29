"""Benchmark of the platform loop (seed 004 section 4): simulated seconds per wall second of
the energy-index controller on Fig. 7's path, against a naive baseline in the same run: the
same loop integrating Lagrange's equations with multipliers, one 8 x 8 solve per evaluation,
instead of the closed-form Appell-Gibbs equations."""

from __future__ import annotations

import time

from hex_control.bench import benchmark
from hex_control.seeds.mobile_platform.case import PlatformCase
from hex_control.seeds.mobile_platform.simulation import simulate_platform


@benchmark("mobile_platform")
def platform_loop(quick: bool) -> list[str]:
    case = PlatformCase.from_yaml()
    desired = case.desired()
    walls = []
    for lagrange in (False, True):
        start = time.perf_counter()
        simulate_platform(case.plant, case.energy_controller(), desired, case.period_s, with_friction=False,
                          lagrange=lagrange)
        walls.append(time.perf_counter() - start)
    simulated_s = desired.time_s[-1]
    return [f"{simulated_s:.1f} s on Fig. 7's path at {1e3 * case.period_s:.0f} ms, RK4 x 4 per period: "
            f"{walls[0]:.2f} s wall, {simulated_s / walls[0]:.0f} simulated s per wall s",
            f"naive baseline (Lagrange with multipliers, a linear solve per evaluation): {simulated_s / walls[1]:.0f} "
            f"simulated s per wall s; ratio {walls[1] / walls[0]:.1f}"]


@benchmark("mobile_platform_fair")
def platform_fair(quick: bool) -> list[str]:
    """Seed 004 section 4 compared fairly (fair.py): both controllers tuned by one optimizer on
    the RMS path error with the same budget, the law's gain and k swept, and the tuned pair
    on the seed's named conditions. Writes docs/results/platform_fair_comparison.{txt,json}
    (not with --quick)."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    import numpy as np

    from hex_control.seeds.mobile_platform import fair

    case = PlatformCase.from_yaml()
    budget = 12 if quick else 60
    start = time.perf_counter()
    import sys

    def tick(label):
        return lambda: print(label, end="", file=sys.stderr, flush=True)

    tuned = {family: fair.tune(case, family, budget, progress=tick(family[0]))
             for family in ("energy_index", "two_pid")}
    tuning_s = time.perf_counter() - start
    gains = [100.0, 300.0, 1000.0, 3000.0, 10000.0] if not quick else [554.0]
    ks = [0.5, 0.74, 1.0, 2.0, 4.0] if not quick else [0.74]
    sweep = fair.sweep_energy_index(case, gains, ks, progress=tick("s"))
    table = fair.compare_tuned(case, {f: t.gains for f, t in tuned.items()}, progress=tick("c"))
    shipped = fair.compare_tuned(case, {f: fair.case_gains(case, f) for f in tuned}, progress=tick("c"))
    lines = [f"tuning: {budget} evaluations (2 simulations each) per controller, {tuning_s:.0f} s wall; criterion: "
             "RMS path error summed over the two plants, Fig. 7's path, 60 000-count encoders"]
    for family, t in tuned.items():
        lines.append(f"{family}: criterion {1e6 * t.value:.2f} um after {t.evaluations} evaluations; gains "
                     + ", ".join(f"{k} {v:.4g}" for k, v in t.gains.items()))
    lines.append(f"{'condition':36s} {'RMS path um (EI / PID)':>24s} {'max path um':>14s} {'max heading mrad':>17s} "
                 f"{'final um':>11s}  shipped gains RMS path um (EI / PID)")
    for name, row in table.items():
        e, p = row["energy_index"], row["two_pid"]
        s = shipped[name]
        lines.append(f"{name:36s} {1e6 * e.rms_path_error_m:10.2f} / {1e6 * p.rms_path_error_m:<11.2f} "
                     f"{1e6 * e.max_path_error_m:6.1f} / {1e6 * p.max_path_error_m:<6.1f} "
                     f"{1e3 * e.max_heading_error_rad:7.3f} / {1e3 * p.max_heading_error_rad:<8.3f} "
                     f"{1e6 * e.final_position_error_m:4.1f} / {1e6 * p.final_position_error_m:<5.1f} "
                     f"{1e6 * s['energy_index'].rms_path_error_m:6.2f} / {1e6 * s['two_pid'].rms_path_error_m:.2f}")
    lines.append("energy-index sweep, RMS path um as modelled / loaded (Fig. 7):")
    for row in sweep:
        lines.append(f"  q1/r {row['gain']:7.0f}  k {row['k']:4.2f}: {1e6 * row['rms_path_as_modelled_m']:9.2f} / "
                     f"{1e6 * row['rms_path_loaded_m']:9.2f}")
    if not quick:
        out = Path(__file__).resolve().parents[2] / "docs" / "results"
        out.mkdir(parents=True, exist_ok=True)
        (out / "platform_fair_comparison.txt").write_text("\n".join(lines) + "\n")
        (out / "platform_fair_comparison.json").write_text(json.dumps({
            "tuned": {f: asdict(t) for f, t in tuned.items()}, "sweep": sweep,
            "conditions": {n: {f: asdict(v) for f, v in row.items()} for n, row in table.items()},
            "shipped_gains": {n: {f: asdict(v) for f, v in row.items()} for n, row in shipped.items()},
        }, indent=1, default=lambda x: float(x) if isinstance(x, np.floating) else str(x)))
        lines.append("wrote docs/results/platform_fair_comparison.txt, .json")
    return lines
