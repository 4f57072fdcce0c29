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
