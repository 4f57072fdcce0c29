"""The drift-detecting IMM predictor (hex_control/estimation/drift.py) against seed 000's
predictor and a dulling disk: K1 growing 25 % a pass under 15 % pass-to-pass scatter."""

import math

import numpy as np
import pytest

from hex_control.estimation import GaussMarkovModel, OneStepPredictor
from hex_control.estimation.drift import DriftingLoadPredictor

PASS_MODEL = GaussMarkovModel(0.98, 0.5, 2.25)  # config/load_predictor.yaml, the pass-rate instance
K1 = 10.0  # J/mm^3
SCATTER = math.sqrt(math.log1p(0.15 ** 2))  # log-normal sigma of 15 % scatter (the plant's ProcessVariation)


def _shipped() -> DriftingLoadPredictor:
    return DriftingLoadPredictor(PASS_MODEL, K1, rate_variance=0.5, switch_probability=0.05, initial_rate_variance=4.0)


def _jobs(dulling: float, jobs: int = 200, passes: int = 7):
    """(true K1 (jobs, passes), measured K1): pass k's K1 is K1 (1 + dulling)^k times scatter."""
    rng = np.random.default_rng(8)
    true = K1 * (1 + dulling) ** np.arange(passes) * np.ones((jobs, 1))
    return true, true * rng.lognormal(-SCATTER ** 2 / 2, SCATTER, true.shape)


def _run(make, measured):
    """Per series: the prediction of the next pass after each and the drift probability."""
    predictions, probabilities = np.empty_like(measured), np.zeros_like(measured)
    for j, series in enumerate(measured):
        predictor = make()
        for k, value in enumerate(series):
            step = predictor.step(value)
            predictions[j, k] = step.prediction
            probabilities[j, k] = getattr(step, "drift_probability", 0.0)
    return predictions, probabilities


def _relative_rms(predictions, true) -> float:
    return float(np.sqrt(np.mean(((predictions[:, :-1] - true[:, 1:]) / true[:, 1:]) ** 2)))


def test_without_switching_it_is_seed_000s_predictor():
    """Switch probability -> 0: the steady mode alone, i.e. eqs 6.6-6.7."""
    rng = np.random.default_rng(1)
    seed_000, imm = OneStepPredictor(PASS_MODEL, K1), DriftingLoadPredictor(PASS_MODEL, K1, switch_probability=1e-12)
    for value in K1 + rng.normal(0.0, 1.5, 30):
        expected, step = seed_000.step(value), imm.step(value)
        assert step.prediction == pytest.approx(expected.prediction, abs=1e-9)
        assert step.prediction_variance == pytest.approx(expected.prediction_variance, rel=1e-9)
        assert step.gain == pytest.approx(expected.gain, rel=1e-9)


def test_it_agrees_with_filterpys_imm_estimator():
    """The same two modes in filterpy's general IMMEstimator (its prior after predict()
    weighs the modes by mu; the one-step prediction weighs them by cbar = mu M)."""
    from filterpy.kalman import IMMEstimator, KalmanFilter

    p, rate_variance = 0.05, 0.5
    filters = []
    for transition, noise, rate_p0 in (([[0.98, 0], [0, 0]], [0.5, 0.0], 0.0),
                                       ([[1, 1], [0, 1]], [0.5, rate_variance], 4.0)):
        kf = KalmanFilter(dim_x=2, dim_z=1)
        kf.F, kf.Q, kf.H, kf.R = np.array(transition, float), np.diag(noise), np.array([[1.0, 0.0]]), np.array([[2.25]])
        kf.P = np.diag([PASS_MODEL.p0, rate_p0])
        filters.append(kf)
    # mu = (1, 0) before the first sample: cbar = (1 - p, p), the predicted odds ours starts with
    reference = IMMEstimator(filters, np.array([1.0, 0.0]), np.array([[1 - p, p], [p, 1 - p]]))
    ours = _shipped()
    for value in _jobs(0.25, jobs=1, passes=12)[1][0]:
        step = ours.step(value)
        reference.update(np.array([[value - K1]]))
        assert step.drift_probability == pytest.approx(reference.mu[1], abs=1e-12)
        assert step.drift_per_sample == pytest.approx(reference.x[1, 0], abs=1e-9)
        reference.predict()
        expected = K1 + sum(c * f.x[0, 0] for c, f in zip(reference.cbar, filters))
        assert step.prediction == pytest.approx(expected, abs=1e-9)


def test_a_dulling_disk_is_flagged_by_its_fourth_pass_and_a_sharp_one_is_not():
    _, dull = _run(_shipped, _jobs(0.25)[1])
    _, sharp = _run(_shipped, _jobs(0.0)[1])
    flagged = lambda p, k: float(np.mean(p[:, : k + 1].max(axis=1) > 0.5))  # noqa: E731
    assert flagged(dull, 1) < 0.05  # two passes cannot tell a trend from scatter
    assert flagged(dull, 3) > 0.85
    assert flagged(dull, 5) > 0.98
    assert flagged(sharp, 6) < 0.05  # false alarms over a whole 7-pass job


def test_it_predicts_a_dulling_disk_better_and_a_sharp_one_nearly_as_well():
    """Relative rms error of the next pass's K1 against seed 000's predictor (the shipped AR(1))."""
    for dulling, bound in ((0.25, 0.75), (0.0, 1.2)):
        true, measured = _jobs(dulling)
        imm = _relative_rms(_run(_shipped, measured)[0], true)
        seed_000 = _relative_rms(_run(lambda: OneStepPredictor(PASS_MODEL, K1), measured)[0], true)
        assert imm < bound * seed_000, (dulling, imm, seed_000)


def test_a_clean_ramp_is_learned_as_a_drift():
    predictor = DriftingLoadPredictor(GaussMarkovModel(0.98, 0.01, 0.01), K1, rate_variance=0.1,
                                      switch_probability=0.001)  # the steady mode keeps ~p of the weight
    for k in range(12):
        step = predictor.step(K1 + 2.0 * k)
    assert step.drift_probability > 0.99
    assert step.drift_per_sample == pytest.approx(2.0, abs=0.05)
    assert step.prediction == pytest.approx(K1 + 2.0 * 12, abs=0.1)


def test_a_retuned_model_keeps_the_estimate_and_reset_forgets_it():
    predictor = _shipped()
    for value in (12.0, 15.0, 19.0):
        predictor.step(value)
    before = predictor.prediction
    predictor.model = GaussMarkovModel(0.98, 0.4, 2.0)
    assert predictor.prediction == pytest.approx(before)
    predictor.reset()
    assert (predictor.prediction, predictor.sample_count) == (K1, 0)
    assert predictor.drift_probability == pytest.approx(0.05)


@pytest.mark.parametrize("kwargs", [{"rate_variance": 0.0}, {"switch_probability": 0.0},
                                    {"switch_probability": 0.5}, {"mean": math.nan},
                                    {"initial_rate_variance": -1.0}])
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        DriftingLoadPredictor(PASS_MODEL, **{"mean": K1, **kwargs})


def test_a_non_finite_measurement_is_refused():
    with pytest.raises(ValueError):
        _shipped().step(math.inf)


def test_a_measurement_far_beyond_both_modes_does_not_break_the_filter():
    """Both modes' likelihoods underflow (K1 jumps from 10 to 200 J/mm^3, the node's valid
    maximum): the mode probabilities stay as predicted and the filter goes on, finite."""
    from hex_control.estimation import GaussMarkovModel
    from hex_control.estimation.drift import DriftingLoadPredictor

    predictor = DriftingLoadPredictor(GaussMarkovModel(0.98, 0.5, 0.01), mean=10.0)
    for value in (10.0, 10.1, 1e6, 10.0):
        step = predictor.step(value)
        assert math.isfinite(step.prediction) and 0.0 <= predictor.drift_probability <= 1.0
