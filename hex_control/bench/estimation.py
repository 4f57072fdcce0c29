"""Benchmarks of the load predictor."""

from __future__ import annotations

import numpy as np

from hex_control.bench import benchmark, best_time
from hex_control.estimation import GaussMarkovModel, OneStepPredictor, predict_series


def _plain_loop(model: GaussMarkovModel, y: list[float]) -> list[float]:
    """Eqs 6.6-6.7 as a plain Python loop: the baseline."""
    a, w, v = model.a, model.process_variance, model.measurement_variance
    estimate, p, out = 0.0, model.p0, []
    for value in y:
        gain = a * p / (p + v)
        estimate = a * estimate + gain * (value - estimate)
        p = a * a * p * v / (p + v) + w
        out.append(estimate)
    return out


@benchmark("predictor")
def predictor_throughput(quick: bool) -> list[str]:
    n = 20_000 if quick else 200_000
    model = GaussMarkovModel(0.95, 0.8, 1.5)
    _, y = model.simulate(n, np.random.default_rng(0))
    y_list = y.tolist()
    streaming = OneStepPredictor(model)

    def stream():
        streaming.reset()
        for value in y_list:
            streaming.step(value)

    batch = best_time(lambda: predict_series(model, y))
    loop = best_time(lambda: _plain_loop(model, y_list), repeat=3)
    step = best_time(stream, repeat=3)
    assert np.allclose(predict_series(model, y).prediction, _plain_loop(model, y_list))
    return [
        f"{n} samples",
        f"batch predict_series : {n / batch:14,.0f} steps/s",
        f"plain Python loop    : {n / loop:14,.0f} steps/s   (baseline)",
        f"OneStepPredictor.step: {n / step:14,.0f} steps/s   ({loop / step:.2f}x baseline)",
        f"ratio batch / plain loop: {loop / batch:.1f}x",
    ]
