"""Node ``load_predictor``: one-step-ahead Kalman prediction of a measured load.

Seed 000 part 2, eqs 6.2-6.7 (library: :mod:`hex_control.estimation`). Generic in what it
predicts: the input is any numeric field of any message type (e.g. ``wrench.force.z``
of a ``geometry_msgs/msg/WrenchStamped``, or ``data`` of a ``std_msgs/msg/Float64``).

Topics:
    <input_topic> (param, default ``load``)   in   the measured load y(t) + L_bar; a relative
                  name resolves in the node's namespace, or with ``input_namespace`` ``parent``
                  in the one holding it (the cell, for a predictor run under <cell>/load_predictor);
                  only from ``input_owner`` if set (e.g. the plant: a forged pass result does
                  not move the K1 the sequence planner plans with)
    ~/prediction  hex_control_msgs/LoadPrediction  out  prediction of the next sample
    /diagnostics  diagnostic_msgs/DiagnosticArray  out  counters, model, warnings

The model (a, W, V, mean) is either fixed by parameters or, with ``identify_window`` > 0,
re-identified by maximum likelihood over the last N samples every ``identify_every``
samples, in a worker thread so that filtering never waits for it. With
``drift_rate_variance`` > 0 the load may also start to drift (a disk that dulls): the
predictor is then an IMM of that model and a drifting one
(:mod:`hex_control.estimation.drift`), and says how likely the drift is.
"""

from __future__ import annotations

import math
from collections import deque
from concurrent.futures import ThreadPoolExecutor

from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter

from hex_control.estimation import GaussMarkovModel, OneStepPredictor, identify
from hex_control.estimation.drift import DriftingLoadPredictor
from hex_control.grinding.config import cell_value
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.message_info import info_subscription
from hex_control.nodes.messages import check_numeric_field, get_field, message_class
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control.nodes.runtime import run_node
from hex_control_msgs.msg import LoadPrediction

#: samples before the first online identification (the window may still be filling)
_MIN_IDENTIFICATION_SAMPLES = 50
REJECTION_WARN_S = 10.0  # a rejected input keeps the node at WARN this long (wall s) after the last
_MODEL_PARAMETERS = ("a", "process_variance", "measurement_variance", "initial_variance", "mean")


# the model's values are set live (or by the online identification); the rest at start-up
PARAMETERS = {
    "input_topic": Spec("load", "topic of the measured load"),
    "input_namespace": Spec("node", "where a relative input_topic resolves: node (the node's namespace, as ROS "
                            "resolves it) or parent (the namespace holding the node's: the cell, for a predictor "
                            "run under <cell>/load_predictor)", choices=("node", "parent")),
    "input_owner": Spec("", "node(s) whose input_topic messages are taken, comma-separated (others refused and "
                        "counted as foreign_measurements); a relative name resolves where input_topic does; "
                        "'' = every publisher"),
    "input_type": Spec("std_msgs/msg/Float64", "message type of input_topic"),
    "input_field": Spec("data", "dotted path of the numeric load field, e.g. wrench.force.z"),
    "quantity": Spec("load", "name and unit of the predicted quantity, e.g. normal_force_n"),
    "a": Spec(0.9, "Gauss-Markov coefficient a (eq. 6.2)", -0.9999, 0.9999, read_only=False),
    "process_variance": Spec(1.0, "W, variance of w(t) (load unit^2)", 0.0, 1e12, read_only=False),
    "measurement_variance": Spec(1.0, "V, variance of v(t) (load unit^2)", 0.0, 1e12, read_only=False),
    "initial_variance": Spec(-1.0, "P(0) = sigma(0) (load unit^2); < 0 = stationary W/(1-a^2)", -1e12, 1e12,
                             read_only=False),
    "mean": Spec(0.0, "mean load L_bar subtracted before filtering (load unit)", -1e12, 1e12, read_only=False),
    "mean_from_cell": Spec("", "start with the mean the cell gives (config/cell.yaml), e.g. "
                           "process.specific_energy_j_mm3; '' = the mean parameter"),
    "identify_window": Spec(0, "identify a, W, V, mean online over the last N samples; 0 = off", 0, 1_000_000),
    "identify_every": Spec(0, "samples between identifications; 0 = window/4", 0, 1_000_000),
    "drift_rate_variance": Spec(0.0, "variance of the drift's change per sample (load unit^2 per sample^2); "
                                "> 0 adds a drifting mode (IMM), 0 = seed 000's predictor alone", 0.0, 1e12),
    "drift_switch_probability": Spec(0.05, "probability per sample that the load starts or stops drifting",
                                     1e-9, 0.4999),
    "drift_initial_rate_variance": Spec(-1.0, "prior variance of the drift per sample (load unit^2 per "
                                        "sample^2); < 0 = drift_rate_variance", -1e12, 1e12),
    "valid_min": Spec(-1e9, "measurements below this are rejected (load unit)", -1e12, 1e12),
    "valid_max": Spec(1e9, "measurements above this are rejected (load unit)", -1e12, 1e12),
    "qos_depth": Spec(100, "history depth of the input and output streams (samples)", 1, 10_000),
    "diagnostics_period_s": Spec(1.0, "period of /diagnostics (s)", 0.01, 60.0),
}


def input_topic_name(topic: str, relative_to: str, namespace: str) -> str:
    """The name to subscribe ``topic`` by: as given (ROS resolves a relative name in the node's
    ``namespace``), or with ``relative_to`` 'parent' a relative name made absolute in the
    namespace that holds ``namespace`` (/cell2/load_predictor -> /cell2/<topic>; the root's
    parent is the root). ValueError for a private (~) name there: it has no parent reading."""
    if relative_to == "node" or topic.startswith("/"):
        return topic
    if relative_to != "parent":
        raise ValueError(f"input_namespace {relative_to!r} is not 'node' or 'parent'")
    if topic.startswith("~"):
        raise ValueError(f"input_topic {topic!r} is private to the node: input_namespace 'parent' cannot place it")
    return namespace.rstrip("/").rpartition("/")[0] + "/" + topic


class LoadPredictorNode(Node):
    READY_PARAMETERS = ("input_topic", "input_namespace", "quantity")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("load_predictor", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = self.get_parameter
        if p("mean_from_cell").value:
            self.set_parameters([Parameter("mean", value=cell_value(p("mean_from_cell").value))])
        self._input_field = p("input_field").value
        input_class = message_class(p("input_type").value)
        check_numeric_field(input_class, self._input_field)
        self._has_header = "header" in input_class.get_fields_and_field_types()
        self._quantity = p("quantity").value
        self._valid_range = (p("valid_min").value, p("valid_max").value)

        self.diagnostics = Diagnostics(self, p("diagnostics_period_s").value)
        self._window = deque(maxlen=max(p("identify_window").value, 1))
        self._identify_every = p("identify_every").value or max(p("identify_window").value // 4, 1)
        self._since_identification = self._identify_every  # identify as soon as possible
        self._identifier = ThreadPoolExecutor(max_workers=1, thread_name_prefix="identify")
        self._predictor = self._make_predictor()
        self._drifting = False  # the drift probability is above one half
        self._identification = None
        self._last_stamp_ns = None
        self._publish_model_values()

        depth = p("qos_depth").value
        self._publisher = self.create_publisher(LoadPrediction, "~/prediction", depth)
        relative_to = p("input_namespace").value
        self.input_topic = input_topic_name(p("input_topic").value, relative_to, self.get_namespace())
        owners = [input_topic_name(name.strip(), relative_to, self.get_namespace())
                  for name in p("input_owner").value.split(",") if name.strip()]
        info_subscription(self, input_class, self.input_topic, self._on_measurement, depth, self.diagnostics,
                          "measurements", owner_node=tuple(owners) or None)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._jump_handler = self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=True),
            post_callback=lambda _jump: self.reset("clock jumped back"))

    # -- parameters ------------------------------------------------------------------
    def _make_predictor(self) -> OneStepPredictor | DriftingLoadPredictor:
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        if p("drift_rate_variance") <= 0:
            return OneStepPredictor(self._model_from_parameters(), p("mean"))
        if p("identify_window") > 0:
            raise ValueError("drift_rate_variance > 0 and identify_window > 0: a drift is not a Gauss-Markov "
                             "fluctuation to identify; use one or the other")
        initial = p("drift_initial_rate_variance")
        return DriftingLoadPredictor(self._model_from_parameters(), p("mean"), p("drift_rate_variance"),
                                     p("drift_switch_probability"), None if initial < 0 else initial)

    def _model_from_values(self, values: dict) -> GaussMarkovModel:
        initial = values["initial_variance"]
        return GaussMarkovModel(values["a"], values["process_variance"],
                                values["measurement_variance"], None if initial < 0 else initial)

    def _model_from_parameters(self) -> GaussMarkovModel:
        return self._model_from_values({n: self.get_parameter(n).value for n in _MODEL_PARAMETERS})

    def _validate_parameters(self, parameters) -> SetParametersResult:
        values = {n: self.get_parameter(n).value for n in _MODEL_PARAMETERS}
        values.update({q.name: q.value for q in parameters if q.name in values})
        try:
            if not math.isfinite(values["mean"]):
                raise ValueError("mean must be finite")
            self._model_from_values(values)
        except (TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        if any(q.name in _MODEL_PARAMETERS for q in parameters):
            # Keep the current estimate: a retuned model continues bumplessly.
            self._predictor.model = self._model_from_parameters()
            self._predictor.mean = self.get_parameter("mean").value
            self._publish_model_values()

    def _publish_model_values(self) -> None:
        model = self._predictor.model
        self.diagnostics.set("model_a", f"{model.a:.6g}")
        self.diagnostics.set("model_w", f"{model.process_variance:.6g}")
        self.diagnostics.set("model_v", f"{model.measurement_variance:.6g}")
        self.diagnostics.set("mean", f"{self._predictor.mean:.6g}")

    # -- filtering -------------------------------------------------------------------
    def reset(self, reason: str) -> None:
        """Forget the filter state (not the model); the next sample starts afresh."""
        self._predictor.reset()
        self._drifting = False
        self._window.clear()
        self._last_stamp_ns = None
        self.diagnostics.count("resets")
        self.get_logger().warning(f"predictor reset: {reason}", throttle_duration_sec=1.0)

    def _reject(self, counter: str, text: str) -> None:
        self.diagnostics.count(counter)
        self.diagnostics.fault("rejected", text, hold_s=REJECTION_WARN_S)
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _on_measurement(self, msg) -> None:
        try:
            value = float(get_field(msg, self._input_field))
        except (TypeError, ValueError):
            self._reject("rejected_malformed", f"{self._input_field} is not a number")
            return
        if not math.isfinite(value):
            self._reject("rejected_nonfinite", f"rejected non-finite measurement {value}")
            return
        if not self._valid_range[0] <= value <= self._valid_range[1]:
            self._reject("rejected_out_of_range", f"rejected measurement {value} outside {self._valid_range}")
            return
        if self._has_header:
            stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if stamp_ns == self._last_stamp_ns:  # the same measurement again (a restarted publisher's repeat)
                self.diagnostics.count("repeated_measurements")
                return
            if self._last_stamp_ns is not None and stamp_ns < self._last_stamp_ns:
                self.reset("measurement stamp went back in time")
            self._last_stamp_ns = stamp_ns
            stamp = msg.header.stamp
        else:
            stamp = self.get_clock().now().to_msg()

        self._adopt_identification()
        step = self._predictor.step(value)
        self._window.append(value)
        self._schedule_identification()
        self.diagnostics.count("samples")

        out = LoadPrediction()
        out.header.stamp = stamp
        out.header.frame_id = msg.header.frame_id if self._has_header else ""
        out.quantity = self._quantity
        out.measurement = step.measurement
        out.mean = self._predictor.mean
        out.prediction = step.prediction
        out.prediction_variance = step.prediction_variance
        out.innovation = step.innovation
        out.innovation_variance = step.innovation_variance
        out.gain = step.gain
        model = self._predictor.model
        out.model_a, out.model_w, out.model_v = model.a, model.process_variance, model.measurement_variance
        out.sample_count = self._predictor.sample_count
        out.drift_probability = getattr(step, "drift_probability", 0.0)
        out.drift_per_sample = getattr(step, "drift_per_sample", 0.0)
        self._publisher.publish(out)
        if isinstance(self._predictor, DriftingLoadPredictor):
            self._report_drift(step)

    def _report_drift(self, step) -> None:
        self.diagnostics.set("drift_probability", f"{step.drift_probability:.3f}")
        drifting = step.drift_probability > 0.5
        if drifting != self._drifting:
            self._drifting = drifting
            self.diagnostics.count("drift_detected" if drifting else "drift_ended")
            self.get_logger().info(f"{self._quantity} {'drifts' if drifting else 'steady again'}: P(drift) "
                                   f"{step.drift_probability:.2f}, {step.drift_per_sample:+.3g} per sample")

    # -- online identification -----------------------------------------------------------
    def _schedule_identification(self) -> None:
        window = self.get_parameter("identify_window").value
        if window <= 0:
            return
        self._since_identification += 1
        if (len(self._window) >= min(window, _MIN_IDENTIFICATION_SAMPLES)
                and self._since_identification >= self._identify_every
                and self._identification is None):
            self._since_identification = 0
            self._identification = self._identifier.submit(identify, list(self._window))

    def _adopt_identification(self) -> None:
        future = self._identification
        if future is None or not future.done():
            return
        self._identification = None
        try:
            result = future.result()
        except ValueError as exc:
            self.diagnostics.count("identification_failures")
            self.get_logger().warning(f"identification failed: {exc}")
            return
        self.diagnostics.count("identifications")
        self._predictor.model = result.model
        self._predictor.mean = result.mean
        count = self._predictor.sample_count  # a model swap is not a reset: keep counting
        self._predictor.warm_start(list(self._window))
        self._predictor.sample_count = count
        self._publish_model_values()

    def destroy_node(self):
        self._identifier.shutdown(wait=False, cancel_futures=True)
        return super().destroy_node()


def main(args=None) -> int:
    return run_node(LoadPredictorNode, args)


if __name__ == "__main__":
    main()
