"""The load predictor node's behaviour without ROS (issue 38): hex_control.estimation.load_predictor.
The node tests (test_load_predictor_node.py) check the same over ROS; these in milliseconds."""

import math
import threading
from concurrent.futures import Future, wait

import numpy as np
import pytest

from hex_control.estimation import GaussMarkovModel, OneStepPredictor, identify, load_predictor
from hex_control.estimation.drift import DriftingLoadPredictor
from hex_control.estimation.load_predictor import LoadPredictorCore, LoadPredictorSettings

MODEL = GaussMarkovModel(0.95, 0.8, 1.5)
SETTINGS = LoadPredictorSettings(a=0.95, process_variance=0.8, measurement_variance=1.5)


def test_it_predicts_exactly_like_the_library_and_counts_what_it_refuses():
    core = LoadPredictorCore(LoadPredictorSettings(**{**SETTINGS.__dict__, "mean": 10.0, "valid_max": 1e6}))
    reference, counts, steps = OneStepPredictor(MODEL, mean=10.0), {}, []
    for value in (11.0, math.nan, 12.5, math.inf, 9.0, 1e12, -math.inf, 10.5, "x"):
        out = core.measure(value)
        for name, n in out.counts.items():
            counts[name] = counts.get(name, 0) + n
        if out.step is None:
            assert out.fault and out.log[0][0] == "warning"  # a refusal says why
        else:
            steps.append((value, out.step))
    assert counts == {"samples": 4, "rejected_nonfinite": 3, "rejected_out_of_range": 1, "rejected_malformed": 1}
    for value, step in steps:
        expected = reference.step(value)
        assert step.prediction == pytest.approx(expected.prediction, abs=1e-12)
        assert step.gain == pytest.approx(expected.gain, rel=1e-12)
    assert core.predictor.sample_count == 4


def test_a_repeated_stamp_is_counted_not_stepped_and_a_stamp_back_in_time_resets():
    core, counts = LoadPredictorCore(SETTINGS), []
    for sec, force in ((100, 1.0), (101, 2.0), (101, 2.0), (50, 3.0), (51, 4.0)):
        out = core.measure(force, sec * 1_000_000_000)
        counts.append((out.counts, out.step and core.predictor.sample_count))
    assert [c for c, _ in counts] == [{"samples": 1}, {"samples": 1}, {"repeated_measurements": 1},
                                     {"resets": 1, "samples": 1}, {"samples": 1}]
    assert [n for _, n in counts] == [1, 2, None, 1, 2]
    restarted = OneStepPredictor(MODEL)
    restarted.step(3.0)
    assert core.predictor.prediction == pytest.approx(restarted.step(4.0).prediction, abs=1e-12)
    assert core.reset("clock jumped back").counts == {"resets": 1} and core.last_stamp_ns is None


def test_a_drifting_load_is_predicted_and_flagged_like_the_library():
    settings = LoadPredictorSettings(a=0.98, process_variance=0.5, measurement_variance=2.25, mean=10.0,
                                     drift_rate_variance=0.5, drift_switch_probability=0.05,
                                     drift_initial_rate_variance=4.0)
    core = LoadPredictorCore(settings, "specific_energy_j_mm3")
    reference = DriftingLoadPredictor(GaussMarkovModel(0.98, 0.5, 2.25), 10.0, 0.5, 0.05, 4.0)
    detected = 0
    for value in (10.0 * 1.25 ** k for k in range(6)):
        out, expected = core.measure(value), reference.step(value)
        assert out.step.prediction == pytest.approx(expected.prediction, abs=1e-12)
        assert out.values["drift_probability"] == f"{expected.drift_probability:.3f}"
        detected += out.counts.get("drift_detected", 0)
        if out.counts.get("drift_detected"):
            assert out.log == [("info", out.log[0][1])] and "specific_energy_j_mm3 drifts" in out.log[0][1]
    assert detected == 1 and core.drifting


def test_a_drift_model_cannot_be_identified_online():
    with pytest.raises(ValueError, match="identify_window"):
        LoadPredictorCore(LoadPredictorSettings(drift_rate_variance=0.5, identify_window=100))


def test_an_online_identification_is_adopted_without_losing_count():
    """Scheduled once the window holds 50 samples, adopted ``identify_every`` samples later, at
    the sample that submits the next: the model identified on the window replaces the rough
    one, warm-started on the window as it is then, and sample_count goes on."""
    rng = np.random.default_rng(3)
    series = [float(v) for v in 40.0 + np.cumsum(rng.normal(0, 0.3, 160)) + rng.normal(0, 1.0, 160)]
    core = LoadPredictorCore(LoadPredictorSettings(identify_window=60, identify_every=100))
    adopted = [k for k, value in enumerate(series) if core.measure(value).counts.get("identifications")]
    assert adopted == [149]  # submitted after the 50th sample (index 49), taken up 100 samples later
    expected = identify(series[:50])
    assert core.predictor.model == expected.model and core.predictor.mean == expected.mean
    assert core.predictor.sample_count == len(series)
    reference = OneStepPredictor(expected.model, expected.mean)
    reference.warm_start(series[89:149])  # the window (60) when it was adopted
    for value in series[149:]:
        reference.step(value)
    assert core.predictor.prediction == pytest.approx(reference.prediction, abs=1e-12)


def _predict_all(core, series) -> list[float]:
    """Every sample's prediction, in order: measured, then the held ones resumed as each
    identification ends (as the node does when its thread wakes it)."""
    predictions = [p.step.prediction for value in series for p in core.measure(value).predictions]
    while core.held:
        wait([core._identification], timeout=10.0)
        predictions += [p.step.prediction for p in core.resume().predictions]
    return predictions


def test_the_predictions_do_not_depend_on_how_soon_the_identification_ends():
    """The identifying thread finishing at once or 30 ms later (a loaded machine): the same
    predictions, bit for bit (adopted when done, they differed, and a demo's skill with
    them); the samples due meanwhile are held, not the caller."""
    series = [float(v) for v in 40.0 + np.cumsum(np.random.default_rng(4).normal(0, 0.3, 400))]
    settings = LoadPredictorSettings(identify_window=120, identify_every=40)

    def late(function, *args):
        future = Future()
        threading.Timer(0.03, lambda: future.set_result(function(*args))).start()
        return future

    at_once, held = _predict_all(LoadPredictorCore(settings), series), LoadPredictorCore(settings, submit=late)
    outs = [held.measure(value) for value in series[:100]]
    assert [len(o.predictions) for o in outs] == [1] * 89 + [0] * 11  # due at index 89 (50 + 40 - 1)
    assert len(held.held) == 11 and not held.resume().predictions  # still running: still held
    assert [p.step.prediction for o in outs for p in o.predictions] + _predict_all(held, series[100:]) == at_once


def test_held_samples_keep_their_order_tags_and_stamp_checks_refusals_do_not_wait_a_reset_drops_them():
    release = threading.Event()

    def stalled(function, *args):
        future = Future()
        threading.Thread(target=lambda: (release.wait(10.0), future.set_result(function(*args)))).start()
        return future

    core = LoadPredictorCore(LoadPredictorSettings(identify_window=60, identify_every=20), submit=stalled)
    for k in range(75):
        core.measure(40.0 + 0.1 * k, k, tag=k)
    assert [tag for _, _, tag in core.held] == list(range(69, 75))
    assert core.measure(math.nan).counts == {"rejected_nonfinite": 1}  # refused at once, not held
    release.set()
    wait([core._identification], timeout=10.0)
    release.clear()  # the next identification (submitted as the first is adopted) stalls
    out = core.resume()
    assert [p.tag for p in out.predictions] == list(range(69, 75)) and out.counts["identifications"] == 1
    assert [p.sample_count for p in out.predictions] == list(range(70, 76))
    assert all(p.model == out.predictions[0].model != LoadPredictorSettings().model() for p in out.predictions)
    for k in range(75, 100):
        core.measure(40.0, k)
    assert len(core.held) == 11  # due at 89, 20 samples after the one that adopted the first
    core.measure(40.0, 3)  # back in time, while held: resets in its turn and drops nothing after it
    core.measure(40.0, 4)
    assert [stamp for _, stamp, _ in core.held][-3:] == [99, 3, 4]
    release.set()
    wait([core._identification], timeout=10.0)
    release.clear()
    out = core.resume()
    assert len(out.predictions) == 13 and out.counts["resets"] == 1 and core.predictor.sample_count == 2
    for k in range(5, 30):
        core.measure(40.0, k)
    held = list(core.held)
    assert len(held) == 18  # the identification submitted at 89 is due 20 samples later, at stamp 12
    assert core.reset("clock jumped back").counts == {"resets": 1, "held_samples_dropped": len(held)} and not core.held
    release.set()


def test_a_retune_while_samples_are_held_takes_effect_where_it_came_in_the_stream():
    """The same retune after the 100th sample: with the identification done at once, and with
    it still running then (the retune held behind the samples due from the 89th): the same
    predictions; a clock jump's reset drops the samples held but not a retune among them."""
    series = [float(v) for v in 40.0 + np.cumsum(np.random.default_rng(6).normal(0, 0.3, 200))]
    settings = LoadPredictorSettings(identify_window=60, identify_every=40)
    values = {"a": 0.5, "process_variance": 2.0, "measurement_variance": 1.5, "initial_variance": -1.0, "mean": 40.0}
    pending = []

    def held(function, *args):
        future = Future()
        pending.append(lambda: future.set_result(function(*args)))
        return future

    runs, outcomes = [], []
    for submit in (None, held):
        core = LoadPredictorCore(settings, submit=submit) if submit else LoadPredictorCore(settings)
        predictions = [p.step.prediction for value in series[:100] for p in core.measure(value).predictions]
        outcomes.append(core.retune(values))
        predictions += [p.step.prediction for value in series[100:] for p in core.measure(value).predictions]
        while pending:
            pending.pop(0)()
            out = core.resume()
            outcomes.append(out.values)
            predictions += [p.step.prediction for p in out.predictions]
        runs.append(predictions)
    assert len(runs[0]) == 200 and runs[0] == runs[1]
    assert outcomes[0]["model_a"] == "0.5" and outcomes[1] == {}  # held: reported when applied
    core = LoadPredictorCore(settings, submit=held)
    for value in series[:100]:
        core.measure(value)
    core.retune(values)
    core.measure(40.0)
    reset = core.reset("clock jumped back")
    assert reset.values["model_a"] == "0.5" and core.predictor.model.a == 0.5
    assert reset.counts["held_samples_dropped"] == 12  # due at 89 (50 + 40 - 1): 89-99 and the one after


def test_an_identification_later_than_its_hold_is_counted_and_taken_up_when_it_comes(monkeypatch):
    """A window too large for its interval (or a machine far too slow) holds at most
    MAX_HELD_SAMPLES samples, once; then they are predicted with the model in use and the
    identification comes in at the first sample after its thread ends."""
    monkeypatch.setattr(load_predictor, "MAX_HELD_SAMPLES", 10)
    release = threading.Event()

    def stalled(function, *args):
        future = Future()
        threading.Thread(target=lambda: (release.wait(10.0), future.set_result(function(*args)))).start()
        return future

    series = [float(v) for v in 40.0 + np.cumsum(np.random.default_rng(5).normal(0, 0.3, 200))]
    core = LoadPredictorCore(LoadPredictorSettings(identify_window=60, identify_every=20), submit=stalled)
    outs = [core.measure(value) for value in series[:100]]
    assert sum(o.counts.get("identifications_late", 0) for o in outs) == 1  # once, not at every sample
    assert sum(len(o.predictions) for o in outs) == 100 and not core.held
    assert not any(o.counts.get("identifications") for o in outs)
    release.set()
    assert wait([core._identification], timeout=10.0).done  # the thread ends: a condition, not a sleep
    assert core.measure(series[100]).counts.get("identifications") == 1
    assert core.predictor.model == identify(series[:50]).model


def test_a_failed_identification_is_counted_and_filtering_goes_on():
    def failing(function, *args):
        future = Future()
        future.set_exception(ValueError("no fit"))
        return future

    core = LoadPredictorCore(LoadPredictorSettings(identify_window=60, identify_every=10), submit=failing)
    outs = [core.measure(float(v)) for v in range(60)]
    assert sum(o.counts.get("identification_failures", 0) for o in outs) >= 1
    assert any("identification failed: no fit" in text for o in outs for _, text in o.log)
    assert core.predictor.model.a == 0.9 and core.predictor.sample_count == 60


def test_a_retuned_model_continues_from_the_estimate_and_a_bad_one_is_refused():
    core = LoadPredictorCore(SETTINGS)
    for value in (1.0, 2.0, 3.0):
        core.measure(value)
    before = core.predictor.prediction - core.predictor.mean
    values = {"a": 0.5, "process_variance": 2.0, "measurement_variance": 1.5, "initial_variance": -1.0, "mean": 0.0}
    assert core.retune(values)["model_w"] == "2"
    assert core.predictor.prediction - core.predictor.mean == before and core.predictor.sample_count == 3
    with pytest.raises(ValueError, match="finite"):
        core.settings.model({**values, "mean": math.nan})


def test_the_node_parameters_default_to_the_settings():
    """One source: the node's PARAMETERS take their defaults from LoadPredictorSettings."""
    from dataclasses import fields

    from hex_control.ros.nodes.load_predictor import PARAMETERS

    for f in fields(LoadPredictorSettings):
        assert PARAMETERS[f.name].default == f.default, f.name
