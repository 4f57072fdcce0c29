"""Benchmark of the sequence planner (issue target: 300 material states x 300 stages x
32 forces x 8 feeds with the PDF integral under 0.5 s, memory under 1 GB)."""

from __future__ import annotations

import time
import tracemalloc

from hex_control.bench import benchmark, best_time
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.sdp import Charges, PlannerGrid, solve
from hex_control.grinding.sdp_reference import solve_reference
from hex_control.grinding.stochastic import CutDepthModel


@benchmark("sdp")
def sdp_speed(quick: bool) -> list[str]:
    process = GrindingProcess()
    full = PlannerGrid(material_states=300, horizon_s=598.0, forces=32, feeds=8)
    solve_time = best_time(lambda: solve(process, grid=full), repeat=1 if quick else 3)
    tracemalloc.start()
    solve(process, grid=full)
    peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    small = PlannerGrid(material_min_mm=-0.5, material_max_mm=1.5, material_states=41, horizon_s=40.0,
                        forces=8, feeds=4)
    start = time.perf_counter()
    solve_reference(process, Charges(), small, CutDepthModel())
    loop = time.perf_counter() - start
    vectorized = best_time(lambda: solve(process, grid=small), repeat=5)
    lines = [f"full grid {len(full.material_mm)} x {len(full.time_s)} x 32 forces x 8 feeds, exact PDF "
             f"integral: {solve_time:.3f} s (target < 0.5 s), peak traced memory {peak_mb:.0f} MB",
             f"small grid 41 x 21 x 8 x 4: brute-force loops {loop:.3f} s, vectorized {vectorized * 1000:.1f} ms, "
             f"ratio {loop / vectorized:.0f}x"]
    if not quick:
        for states in (150, 300, 600):
            grid = PlannerGrid(material_states=states, horizon_s=2.0 * (states - 1), forces=32, feeds=8)
            seconds = best_time(lambda: solve(process, grid=grid), 1)
            lines.append(f"scaling: {states} x {states} states: {seconds:.3f} s")
    return lines
