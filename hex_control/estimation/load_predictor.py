"""What the ``load_predictor`` node does, without ROS (issue 38): check each measured load,
predict the next sample (seed 000 part 2, eqs 6.2-6.7), re-identify the model online or
tell a drift (:mod:`hex_control.estimation.drift`), and say what to count and report.

Plain in, plain out: :meth:`LoadPredictorCore.measure` takes a value (load unit), its
stamp (ns, or None for a message without a header) and a tag of the caller's, and returns an
:class:`Outcome`: the predictions to publish, or why the value was refused, with the
diagnostics counters to add, the values to show and the lines to log. Identification runs
through ``submit`` (the node passes a background thread's; by default it runs at once). A
sample due to adopt an identification still running is held, with those after it, and
:meth:`LoadPredictorCore.resume` predicts them once it is in: the predictions never depend
on how busy the machine is, only when they are published does.
"""

from __future__ import annotations

import math
from collections import deque
from concurrent.futures import Future
from dataclasses import dataclass, field

from hex_control.estimation.drift import DriftingLoadPredictor
from hex_control.estimation.gauss_markov import GaussMarkovModel
from hex_control.estimation.identify import identify
from hex_control.estimation.kalman import OneStepPredictor, PredictionStep

#: samples before the first online identification (the window may still be filling)
MIN_IDENTIFICATION_SAMPLES = 50
#: samples held at most while an identification due to be adopted still runs (10 s at 200 Hz; the
#: shipped 1000-sample window is identified in about 70 ms quiet, 1-2 s beside two CPU burners):
#: beyond, they are predicted with the model in use and the identification is taken up when it
#: comes (counted ``identifications_late``: the predictions then depend on the load)
MAX_HELD_SAMPLES = 2000
#: the model's values: set live (or by the online identification); the rest at start-up
MODEL_VALUES = ("a", "process_variance", "measurement_variance", "initial_variance", "mean")


@dataclass(frozen=True)
class LoadPredictorSettings:
    """The node's parameters that shape its behaviour (descriptions and units: the node's
    PARAMETERS, whose defaults these are). Variances in load unit^2 (drift: per sample^2)."""

    a: float = 0.9
    process_variance: float = 1.0
    measurement_variance: float = 1.0
    initial_variance: float = -1.0  # < 0: the stationary W / (1 - a^2)
    mean: float = 0.0
    identify_window: int = 0  # samples; 0 = no online identification
    identify_every: int = 0  # samples; 0 = window / 4
    drift_rate_variance: float = 0.0  # > 0 adds the drifting mode (IMM)
    drift_switch_probability: float = 0.05
    drift_initial_rate_variance: float = -1.0  # < 0 = drift_rate_variance
    valid_min: float = -1e9
    valid_max: float = 1e9

    def model(self, values: dict | None = None) -> GaussMarkovModel:
        """The Gauss-Markov model of these settings, ``values`` (MODEL_VALUES) replacing
        some; ValueError if it is not one."""
        v = {name: getattr(self, name) for name in MODEL_VALUES} | (values or {})
        if not math.isfinite(v["mean"]):
            raise ValueError("mean must be finite")
        initial = v["initial_variance"]
        return GaussMarkovModel(v["a"], v["process_variance"], v["measurement_variance"],
                                None if initial < 0 else initial)


@dataclass(frozen=True)
class Prediction:
    """One sample predicted: its ``step``, the ``model`` and ``mean`` (load unit) it was
    predicted with, the predictor's ``sample_count`` after it, and the caller's ``tag``."""

    step: PredictionStep
    model: GaussMarkovModel
    mean: float
    sample_count: int
    tag: object = None


@dataclass(frozen=True)
class Retune:
    """A live change of the model (and its ``mean``, load unit), held in turn with the samples."""

    model: GaussMarkovModel
    mean: float


@dataclass
class Outcome:
    """What one input (or an identification's end) did: the ``predictions`` to publish, in
    order (none if refused, repeated or held), diagnostics ``counts`` to add, ``values`` to
    set, a refusal's ``fault`` text (the node holds a WARN), and ``log`` lines (level, text)."""

    predictions: list[Prediction] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    values: dict[str, str] = field(default_factory=dict)
    fault: str = ""
    log: list[tuple[str, str]] = field(default_factory=list)

    @property
    def step(self) -> PredictionStep | None:
        """The last prediction's step; None without one."""
        return self.predictions[-1].step if self.predictions else None

    def count(self, name: str, n: int = 1) -> None:
        self.counts[name] = self.counts.get(name, 0) + n


def _done(function, *args) -> Future:
    """``function(*args)`` run at once, as a finished Future (the default ``submit``)."""
    future = Future()
    try:
        future.set_result(function(*args))
    except Exception as exc:  # noqa: BLE001 - handed to whoever takes the result, as a worker would
        future.set_exception(exc)
    return future


class LoadPredictorCore:
    """The node's behaviour. ``quantity``: the predicted quantity's name (for log lines).
    ValueError at construction for settings that do not make a predictor."""

    def __init__(self, settings: LoadPredictorSettings, quantity: str = "load", submit=_done):
        self.settings, self.quantity, self._submit = settings, quantity, submit
        self.predictor = self._make_predictor()
        self.window = deque(maxlen=max(settings.identify_window, 1))
        self.identify_every = settings.identify_every or max(settings.identify_window // 4, 1)
        self._since_identification = self.identify_every  # identify as soon as possible
        self._identification: Future | None = None
        self._late: Future | None = None  # the identification no longer waited for (MAX_HELD_SAMPLES)
        self.held: deque[tuple[float, int | None, object] | Retune] = deque()  # (value, stamp ns, tag)s and Retunes
        self.drifting = False  # the drift probability is above one half
        self.last_stamp_ns: int | None = None

    def _make_predictor(self) -> OneStepPredictor | DriftingLoadPredictor:
        s = self.settings
        if s.drift_rate_variance <= 0:
            return OneStepPredictor(s.model(), s.mean)
        if s.identify_window > 0:
            raise ValueError("drift_rate_variance > 0 and identify_window > 0: a drift is not a Gauss-Markov "
                             "fluctuation to identify; use one or the other")
        initial = s.drift_initial_rate_variance
        return DriftingLoadPredictor(s.model(), s.mean, s.drift_rate_variance, s.drift_switch_probability,
                                     None if initial < 0 else initial)

    # -- the model ----------------------------------------------------------------------
    def model_values(self) -> dict[str, str]:
        """The diagnostics values of the model in use."""
        model = self.predictor.model
        return {"model_a": f"{model.a:.6g}", "model_w": f"{model.process_variance:.6g}",
                "model_v": f"{model.measurement_variance:.6g}", "mean": f"{self.predictor.mean:.6g}"}

    def retune(self, values: dict) -> dict[str, str]:
        """Set the model's ``values`` (MODEL_VALUES, the full set) live, keeping the estimate:
        a retuned model continues bumplessly. ValueError if they are not a model. Returns the
        new diagnostics values; while samples are held it takes effect after them, where it
        came in the stream, and returns none (:meth:`resume`'s outcome carries them)."""
        retune = Retune(self.settings.model(values), values["mean"])
        if self.held:
            self.held.append(retune)
            return {}
        return self._apply(retune)

    def _apply(self, retune: Retune) -> dict[str, str]:
        self.predictor.model, self.predictor.mean = retune.model, retune.mean
        return self.model_values()

    # -- filtering ----------------------------------------------------------------------
    def reset(self, reason: str) -> Outcome:
        """Forget the filter state (not the model) and the samples held; the next sample starts
        afresh."""
        out = self._restart(reason)
        for item in self.held:  # a retune held among them still takes effect
            if isinstance(item, Retune):
                out.values.update(self._apply(item))
            else:
                out.count("held_samples_dropped")
        self.held.clear()
        return out

    def _restart(self, reason: str) -> Outcome:
        """Forget the filter state (not the model, nor the samples held after this one)."""
        self.predictor.reset()
        self.drifting = False
        self.window.clear()
        self.last_stamp_ns = None
        out = Outcome(log=[("warning", f"predictor reset: {reason}")])
        out.count("resets")
        return out

    @staticmethod
    def refuse(counter: str, text: str) -> Outcome:
        out = Outcome(fault=text, log=[("warning", text)])
        out.count(counter)
        return out

    def measure(self, value, stamp_ns: int | None = None, tag: object = None) -> Outcome:
        """One measured load (``stamp_ns`` of its header, None without one; ``tag`` comes back
        with its prediction): refused if it is not a finite number inside [valid_min,
        valid_max]; else predicted in its turn, after the samples held before it (if any)."""
        try:
            value = float(value)
        except (TypeError, ValueError):
            return self.refuse("rejected_malformed", f"{value!r} is not a number")
        if not math.isfinite(value):
            return self.refuse("rejected_nonfinite", f"rejected non-finite measurement {value}")
        valid = (self.settings.valid_min, self.settings.valid_max)
        if not valid[0] <= value <= valid[1]:
            return self.refuse("rejected_out_of_range", f"rejected measurement {value} outside {valid}")
        self.held.append((value, stamp_ns, tag))
        return self.resume()

    def resume(self) -> Outcome:
        """Predict the samples held, in order, up to one due to adopt an identification that
        still runs (the node calls this again when it ends)."""
        out = Outcome()
        while self.held:
            if isinstance(self.held[0], Retune):
                out.values.update(self._apply(self.held.popleft()))
            elif self._waiting(out):
                break
            else:
                self._predict(*self.held.popleft(), out)
        return out

    def _predict(self, value: float, stamp_ns: int | None, tag: object, out: Outcome) -> None:
        """One sample: the same stamp again is the same measurement repeated (counted, not
        stepped); a stamp before the last resets first."""
        if stamp_ns is not None:
            if stamp_ns == self.last_stamp_ns:  # a restarted publisher's repeat
                out.count("repeated_measurements")
                return
            if self.last_stamp_ns is not None and stamp_ns < self.last_stamp_ns:
                reset = self._restart("measurement stamp went back in time")
                for name, n in reset.counts.items():
                    out.count(name, n)
                out.log += reset.log
            self.last_stamp_ns = stamp_ns
        self._adopt_identification(out)
        step = self.predictor.step(value)
        out.predictions.append(Prediction(step, self.predictor.model, self.predictor.mean,
                                          self.predictor.sample_count, tag))
        self.window.append(value)
        self._schedule_identification()
        out.count("samples")
        if isinstance(self.predictor, DriftingLoadPredictor):
            self._report_drift(out, step)

    def _report_drift(self, out: Outcome, step) -> None:
        out.values["drift_probability"] = f"{step.drift_probability:.3f}"
        drifting = step.drift_probability > 0.5
        if drifting != self.drifting:
            self.drifting = drifting
            out.count("drift_detected" if drifting else "drift_ended")
            out.log.append(("info", f"{self.quantity} {'drifts' if drifting else 'steady again'}: P(drift) "
                                    f"{step.drift_probability:.2f}, {step.drift_per_sample:+.3g} per sample"))

    # -- online identification ------------------------------------------------------------
    def _schedule_identification(self) -> None:
        window = self.settings.identify_window
        if window <= 0:
            return
        self._since_identification += 1
        if (len(self.window) >= min(window, MIN_IDENTIFICATION_SAMPLES)
                and self._since_identification >= self.identify_every and self._identification is None):
            self._since_identification = 0
            self._identification = self._submit(identify, list(self.window))

    def _due(self) -> bool:
        """The next sample is the one to adopt the pending identification."""
        return self._identification is not None and self._since_identification + 1 >= self.identify_every

    def _waiting(self, out: Outcome) -> bool:
        """The next held sample waits for the identification it is due to adopt; past
        MAX_HELD_SAMPLES no longer (counted once, logged)."""
        future = self._identification
        if not self._due() or future.done() or future is self._late:
            return False
        if len(self.held) <= MAX_HELD_SAMPLES:
            return True
        self._late = future
        out.count("identifications_late")
        out.log.append(("warning", f"identification still running {MAX_HELD_SAMPLES} samples after it was due: "
                                   "its model is taken up when it comes"))
        return False

    def _adopt_identification(self, out: Outcome) -> None:
        """The pending identification's model, adopted at the sample that submits the next one
        (``identify_every`` samples after it), whatever the load: a run's predictions do not
        depend on how soon the identifying thread finished (adopted when done, a demo's skill
        fell from 0.23 to -0.08 on a loaded machine). One that took longer holds that sample
        and the ones after it (:meth:`resume`); one late past MAX_HELD_SAMPLES is taken up at
        the first sample after it ends."""
        future = self._identification
        if not self._due() or not future.done():
            return
        self._identification = None
        try:
            result = future.result()
        except ValueError as exc:
            out.count("identification_failures")
            out.log.append(("warning", f"identification failed: {exc}"))
            return
        out.count("identifications")
        self.predictor.model, self.predictor.mean = result.model, result.mean
        count = self.predictor.sample_count  # a model swap is not a reset: keep counting
        self.predictor.warm_start(list(self.window))
        self.predictor.sample_count = count
        out.values.update(self.model_values())
