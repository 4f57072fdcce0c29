"""Benchmark of the force-table plant (issue target: >= 100,000 internal steps/s)."""

from __future__ import annotations


import numpy as np
from scipy.signal import cont2discrete, dlsim, tf2ss

from hex_control.bench import benchmark, best_time
from hex_control.plant.force_table import ForceTable, ForceTableParameters, position_loop


@benchmark("plant")
def plant_speed(quick: bool) -> list[str]:
    n = 20_000 if quick else 200_000
    parameters = ForceTableParameters(runout_mm=0.02, sensor_noise_n=0.5)
    table = ForceTable(parameters, step_s=1e-3)

    def stepped():
        table.reset(0.0)
        for _ in range(n):
            table.step(0.3)
    stepped_s = best_time(stepped, repeat=3)
    linear = cont2discrete(tf2ss(*position_loop("two_pole")), 1e-3, method="zoh")
    bulk_s = best_time(lambda: dlsim(linear, np.full(n, 0.3)), repeat=3)
    return [f"force table at 1 kHz (stiction, contact, runout, sensor, noise), {n} steps",
            f"step by step : {n / stepped_s:12,.0f} steps/s (target >= 100,000), "
            f"real-time factor {n * 1e-3 / stepped_s:.0f}x",
            f"bulk dlsim of the linear table alone: {n / bulk_s:12,.0f} steps/s (baseline)",
            f"ratio step-by-step / bulk: {bulk_s / stepped_s:.2f}"]
