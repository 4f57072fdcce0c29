"""Benchmarks of input shaping (issue target: the 5-impulse design under 10 s)."""

from __future__ import annotations

import time

import numpy as np

from hex_control.bench import benchmark, best_time
from hex_control.shaping.filter import ShaperFilter
from hex_control.shaping.optimize import DesignProblem, optimize
from hex_control.shaping.shapers import ei_2hump


@benchmark("shaping")
def shaping_speed(quick: bool) -> list[str]:
    n = 20_000 if quick else 200_000
    x = np.random.default_rng(0).normal(size=(n, 6)).cumsum(axis=0)
    shaper = ei_2hump(5.0, 0.02)
    batch = best_time(lambda: ShaperFilter(shaper, 0.001, 6).filter(x), repeat=3)
    stream_n = 5_000 if quick else 20_000
    online = ShaperFilter(shaper, 0.001, 6)
    loop = best_time(lambda: [online.step(row) for row in x[:stream_n]], repeat=1) * n / stream_n
    start = time.perf_counter()
    result = optimize(DesignProblem(frequencies_hz=(0.85, 1.0, 1.5), impulses=5, max_delay_s=1.5), seed=1)
    design_s = time.perf_counter() - start
    return [f"2-hump EI at 1 kHz, 6 channels, {n} samples",
            f"vectorized filter : {n / batch:12,.0f} samples/s",
            f"per-sample step() : {n / loop:12,.0f} samples/s   (baseline; {1e6 * loop / n:.0f} us per sample)",
            f"ratio: {loop / batch:.0f}x",
            f"5-impulse design (0.85, 1, 1.5 w0): {design_s:.2f} s (target < 10 s), criterion {result.criterion:.2e}"]
