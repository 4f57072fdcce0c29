"""One-step-ahead Kalman predictor: seed 000 part 2, eqs 6.2-6.7."""

import math

import numpy as np
import pytest

from hex_control.estimation import (
    GaussMarkovModel,
    MultiChannelPredictor,
    OneStepPredictor,
    expected_skill,
    predict_series,
    skill_score,
)
from hex_control.estimation.kalman import gain_sequence, riccati_step, steady_state_variance


def direct_prediction(model: GaussMarkovModel, y: np.ndarray):
    """dL(t+1|t) and P(t+1) by conditioning the joint Gaussian of (dL, y) directly.

    Independent of the recursion: cov(dL(i), dL(j)) = a^|i-j| Var dL(min(i, j)) with
    Var dL(t) = a^2t P(0) + W sum_k<t a^2k, and y = dL + v.
    """
    n = y.size
    a, w, v, p0 = model.a, model.process_variance, model.measurement_variance, model.p0
    var = np.array([a ** (2 * t) * p0 + w * sum(a ** (2 * k) for k in range(t)) for t in range(n + 1)])
    idx = np.arange(n + 1)
    cov_x = a ** np.abs(idx[:, None] - idx[None, :]) * var[np.minimum(idx[:, None], idx[None, :])]
    predictions, variances = [], []
    for t in range(n):
        cov_yy = cov_x[: t + 1, : t + 1] + v * np.eye(t + 1)
        cov_xy = cov_x[t + 1, : t + 1]
        weights = np.linalg.solve(cov_yy, cov_xy)
        predictions.append(weights @ y[: t + 1])
        variances.append(cov_x[t + 1, t + 1] - cov_xy @ weights)
    return np.array(predictions), np.array(variances)


@pytest.mark.parametrize("model", [
    GaussMarkovModel(0.9, 1.0, 0.5),                          # stationary P(0)
    GaussMarkovModel(0.7, 0.3, 2.0, initial_variance=5.0),    # P(0) = sigma(0) given
    GaussMarkovModel(-0.5, 1.0, 0.1, initial_variance=0.0),   # known start, negative a
])
def test_recursion_matches_direct_gaussian_conditioning(model):
    """Eqs 6.6-6.7 (with the re-derived P update) equal the closed-form conditional mean."""
    y = np.random.default_rng(3).normal(0.0, 1.5, 12)
    expected_prediction, expected_variance = direct_prediction(model, y)
    series = predict_series(model, y)
    np.testing.assert_allclose(series.prediction, expected_prediction, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(series.prediction_variance, expected_variance, rtol=1e-9, atol=1e-12)


def test_printed_seed_update_is_not_the_error_variance():
    """Seed eq. 6.7 as printed, P(t+1) = (aP - aP^2)/(P + V + W), is garbled: it even goes
    negative for P > 1, and differs from the conditional variance the recursion must track."""
    model = GaussMarkovModel(0.9, 1.0, 0.5)
    p = model.p0
    printed = (model.a * p - model.a * p * p) / (p + model.measurement_variance + model.process_variance)
    _, derived = riccati_step(model, p)
    _, direct = direct_prediction(model, np.zeros(1))
    assert printed < 0
    assert derived == pytest.approx(direct[0], rel=1e-12)


def test_streaming_equals_batch_and_filterpy():
    model = GaussMarkovModel(0.95, 0.8, 1.5)
    _, y = model.simulate(3000, np.random.default_rng(11))
    y = y + 40.0
    batch = predict_series(model, y, mean=40.0)
    predictor = OneStepPredictor(model, mean=40.0)
    steps = [predictor.step(value) for value in y]
    np.testing.assert_allclose([s.prediction for s in steps], batch.prediction, rtol=0, atol=1e-10)
    np.testing.assert_allclose([s.gain for s in steps], batch.gain, rtol=1e-12)
    np.testing.assert_allclose([s.innovation for s in steps], batch.innovation, atol=1e-10)
    filterpy = MultiChannelPredictor.from_models([model], mean=[40.0])
    np.testing.assert_allclose([filterpy.step([v])[0] for v in y], batch.prediction, atol=1e-10)
    assert filterpy.prediction_covariance[0, 0] == pytest.approx(batch.prediction_variance[-1], rel=1e-9)


def test_multichannel_independent_channels_equal_scalar_predictors():
    models = [GaussMarkovModel(0.5, 1.0, 1.0), GaussMarkovModel(0.98, 0.1, 2.0)]
    rng = np.random.default_rng(5)
    ys = np.column_stack([m.simulate(500, rng)[1] for m in models])
    multi = MultiChannelPredictor.from_models(models)
    out = np.array([multi.step(row) for row in ys])
    for channel, model in enumerate(models):
        np.testing.assert_allclose(out[:, channel], predict_series(model, ys[:, channel]).prediction,
                                   atol=1e-10)


def test_multichannel_converges_to_the_discrete_are_and_uses_the_coupling():
    """Vector form: P(t+1) reaches the DARE solution P = A P A' - A P (P + V)^-1 P A' + W;
    with correlated process noise, a precise channel 1 sharpens channel 0's prediction."""
    from scipy.linalg import solve_discrete_are

    a = np.array([[0.9, 0.1], [0.0, 0.8]])
    w = np.array([[1.0, 0.95], [0.95, 1.0]])
    v = np.diag([4.0, 0.01])
    coupled = MultiChannelPredictor(a, w, v)
    alone = MultiChannelPredictor(a[:1, :1], w[:1, :1], v[:1, :1])
    for y in np.random.default_rng(2).normal(size=(200, 2)):
        coupled.step(y)
        alone.step(y[:1])
    np.testing.assert_allclose(coupled.prediction_covariance, solve_discrete_are(a.T, np.eye(2), w, v),
                               rtol=1e-8)
    # W_00 = 1 is the floor (next step's noise); alone the noisy channel stays near 2.1
    assert 1.0 < coupled.prediction_covariance[0, 0] < 0.7 * alone.prediction_covariance[0, 0]


def test_gain_sequence_converges_to_the_algebraic_riccati_solution():
    model = GaussMarkovModel(0.98, 0.2, 3.0)
    gains, variances = gain_sequence(model, 5000)
    p_ss = steady_state_variance(model)
    assert variances[-1] == pytest.approx(p_ss, rel=1e-10)
    assert gains[-1] == pytest.approx(model.a * p_ss / (p_ss + model.measurement_variance), rel=1e-10)
    assert np.all(np.diff(variances) <= 1e-15)  # from the stationary P(0) the error variance only falls


def test_simulated_series_has_the_model_statistics():
    model = GaussMarkovModel(0.9, 1.0, 0.5)
    state, y = model.simulate(200_000, np.random.default_rng(0))
    # standard errors of these estimates at n = 2e5 are below 1 %; allow 3 %
    assert np.var(state) == pytest.approx(model.stationary_variance, rel=0.03)
    assert np.corrcoef(state[:-1], state[1:])[0, 1] == pytest.approx(0.9, abs=0.005)
    assert np.var(y - state) == pytest.approx(0.5, rel=0.03)


def test_skill_matches_its_analytic_value_on_a_long_series():
    model = GaussMarkovModel(0.95, 0.8, 1.5)
    _, y = model.simulate(100_000, np.random.default_rng(9))
    series = predict_series(model, y)
    expected = expected_skill(model.a, model.process_variance, model.measurement_variance,
                              steady_state_variance(model))
    assert 0.2 < expected < 0.25
    assert skill_score(y, series.prediction) == pytest.approx(expected, abs=0.01)


def test_skill_score_reference_points():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    assert skill_score(y, np.append(y[1:], 0.0)) == 1.0           # perfect
    assert skill_score(y, y) == 0.0                              # persistence itself
    noisy = np.array([1.0, 5.0, 2.0, 4.0, 3.0])
    partial = skill_score(noisy, np.append(noisy[1:], 0.0) + [0, 9, 0, 0, 0], [True, False, True, True])
    assert partial == 1.0  # the pair with the wrong prediction is excluded
    with pytest.raises(ValueError, match="constant"):
        skill_score(np.ones(5), np.ones(5))


@pytest.mark.parametrize("kwargs, message", [
    (dict(a=math.nan, process_variance=1.0, measurement_variance=1.0), "finite"),
    (dict(a=0.5, process_variance=-1.0, measurement_variance=1.0), ">= 0"),
    (dict(a=1.0, process_variance=1.0, measurement_variance=1.0), "stationary"),
    (dict(a=0.5, process_variance=1.0, measurement_variance=0.0, initial_variance=0.0), "K\\(0\\)"),
])
def test_invalid_models_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        GaussMarkovModel(**kwargs)


def test_non_finite_measurements_are_refused():
    model = GaussMarkovModel(0.5, 1.0, 1.0)
    predictor = OneStepPredictor(model)
    with pytest.raises(ValueError):
        predictor.step(math.inf)
    assert predictor.sample_count == 0
    with pytest.raises(ValueError):
        predict_series(model, [1.0, math.nan])
