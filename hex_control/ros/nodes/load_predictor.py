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
    ~/prediction  hex_control_msgs/LoadPrediction  out  prediction of the next sample (with
                  ``latched``, the last kept for late joiners)
    /diagnostics  diagnostic_msgs/DiagnosticArray  out  counters, model, warnings

The behaviour is :class:`hex_control.estimation.load_predictor.LoadPredictorCore`; this
node reads its parameters into the core's settings, converts messages and spins. The model
(a, W, V, mean) is fixed by parameters or, with ``identify_window`` > 0, re-identified online
in a background thread, the samples due after it held until it is in (the core's
``resume``); with ``drift_rate_variance`` > 0 the predictor is an IMM that tells a drifting
load (a disk that dulls) from a steady one (:mod:`hex_control.estimation.drift`).
"""

from __future__ import annotations

from dataclasses import fields

from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Header

from hex_control.estimation import load_predictor as predictor_core
from hex_control.estimation.load_predictor import MODEL_VALUES, LoadPredictorCore, LoadPredictorSettings, Outcome
from hex_control.grinding.config import cell_value
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED
from hex_control.ros.infra.message_info import info_subscription, input_topic_name
from hex_control.ros.infra.messages import check_numeric_field, get_field, message_class
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import in_background, run_node
from hex_control_msgs.msg import LoadPrediction

REJECTION_WARN_S = 10.0  # a rejected input keeps the node at WARN this long (wall s) after the last
D = LoadPredictorSettings()  # the parameters' defaults; the model's (a ... mean) are set live too

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
    "a": Spec(D.a, "Gauss-Markov coefficient a (eq. 6.2)", -0.9999, 0.9999, read_only=False),
    "process_variance": Spec(D.process_variance, "W, variance of w(t) (load unit^2)", 0.0, 1e12, read_only=False),
    "measurement_variance": Spec(D.measurement_variance, "V, variance of v(t) (load unit^2)", 0, 1e12, read_only=False),
    "initial_variance": Spec(D.initial_variance, "P(0) = sigma(0) (load unit^2); < 0 = stationary W/(1-a^2)",
                             -1e12, 1e12, read_only=False),
    "mean": Spec(D.mean, "mean load L_bar subtracted before filtering (load unit)", -1e12, 1e12, read_only=False),
    "mean_from_cell": Spec("", "start with the mean the cell gives (config/cell.yaml), e.g. "
                           "process.specific_energy_j_mm3; '' = the mean parameter"),
    "identify_window": Spec(D.identify_window, "identify a, W, V, mean online over the last N samples; 0 = off",
                            0, 1_000_000),
    "identify_every": Spec(D.identify_every, "samples between identifications; 0 = window/4", 0, 1_000_000),
    "drift_rate_variance": Spec(D.drift_rate_variance, "variance of the drift's change per sample (load unit^2 per "
                                "sample^2); > 0 adds a drifting mode (IMM), 0 = seed 000's predictor alone",
                                0.0, 1e12),
    "drift_switch_probability": Spec(D.drift_switch_probability, "probability per sample that the load starts or "
                                     "stops drifting", 1e-9, 0.4999),
    "drift_initial_rate_variance": Spec(D.drift_initial_rate_variance, "prior variance of the drift per sample "
                                        "(load unit^2 per sample^2); < 0 = drift_rate_variance", -1e12, 1e12),
    "valid_min": Spec(D.valid_min, "measurements below this are rejected (load unit)", -1e12, 1e12),
    "valid_max": Spec(D.valid_max, "measurements above this are rejected (load unit)", -1e12, 1e12),
    "qos_depth": Spec(100, "history depth of the input and output streams (samples); the output's at least "
                      f"{predictor_core.MAX_HELD_SAMPLES + 1} with identify_window > 0 (held ones go out at once)",
                      1, 10_000),
    "latched": Spec(False, "keep the last prediction for a late joiner (transient local, depth 1): the pass "
                    "rate's, so that a sequence planner restarted mid-job has the K1 of the pass it resumes after"),
    "diagnostics_period_s": Spec(1.0, "period of /diagnostics (s)", 0.01, 60.0),
}


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

        self.diagnostics = Diagnostics(self, p("diagnostics_period_s").value)
        settings = LoadPredictorSettings(**{f.name: p(f.name).value for f in fields(LoadPredictorSettings)})
        self.core = LoadPredictorCore(settings, self._quantity, self._identify)
        for key, value in self.core.model_values().items():
            self.diagnostics.set(key, value)

        depth = p("qos_depth").value
        if settings.identify_window > 0:  # the samples held for an identification go out at once
            if p("latched").value:
                raise ValueError("latched keeps one prediction, and a burst of held ones after an identification "
                                 "would overwrite each other unheard: latched or identify_window > 0, not both")
            depth = max(depth, predictor_core.MAX_HELD_SAMPLES + 1)
        self._publisher = self.create_publisher(LoadPrediction, "~/prediction",
                                                LATCHED if p("latched").value else depth)
        relative_to = p("input_namespace").value
        self.input_topic = input_topic_name(p("input_topic").value, relative_to, self.get_namespace())
        owners = [input_topic_name(name.strip(), relative_to, self.get_namespace())
                  for name in p("input_owner").value.split(",") if name.strip()]
        info_subscription(self, input_class, self.input_topic, self._on_measurement, depth,
                          diagnostics=self.diagnostics, name="measurements", owner_node=tuple(owners) or None)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._jump_handler = self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=True),
            post_callback=lambda _jump: self._report(self.core.reset("clock jumped back")))

    # -- parameters ------------------------------------------------------------------
    def _model_values(self, parameters=()) -> dict:
        values = {n: self.get_parameter(n).value for n in MODEL_VALUES}
        return values | {q.name: q.value for q in parameters if q.name in values}

    def _validate_parameters(self, parameters) -> SetParametersResult:
        try:
            self.core.settings.model(self._model_values(parameters))
        except (TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        if any(q.name in MODEL_VALUES for q in parameters):
            for key, value in self.core.retune(self._model_values()).items():
                self.diagnostics.set(key, value)

    # -- filtering -------------------------------------------------------------------
    def _report(self, out: Outcome) -> None:
        """The core's counters, values, refusal and log lines into diagnostics and the log."""
        for name, n in out.counts.items():
            self.diagnostics.count(name, n)
        for key, value in out.values.items():
            self.diagnostics.set(key, value)
        if out.fault:
            self.diagnostics.fault("rejected", out.fault, hold_s=REJECTION_WARN_S)
        for level, text in out.log:
            if level == "info":
                self.get_logger().info(text)
            else:
                self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _on_measurement(self, msg) -> None:
        try:
            value = float(get_field(msg, self._input_field))
        except (TypeError, ValueError):
            self._report(self.core.refuse("rejected_malformed", f"{self._input_field} is not a number"))
            return
        if self._has_header:
            stamp_ns, header = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, msg.header
        else:
            stamp_ns, header = None, Header(stamp=self.get_clock().now().to_msg())
        self._publish(self.core.measure(value, stamp_ns, tag=header))

    def _identify(self, function, *args):
        """The core's ``submit``: in a background thread, the held samples resumed when it ends."""
        return in_background(function, *args, then=(self, lambda: self._publish(self.core.resume())))

    def _publish(self, out: Outcome) -> None:
        """Report ``out`` and publish its predictions, each stamped as its measurement."""
        self._report(out)
        for p in out.predictions:
            step, model = p.step, p.model
            self._publisher.publish(LoadPrediction(
                header=p.tag, quantity=self._quantity, measurement=step.measurement, mean=p.mean,
                prediction=step.prediction, prediction_variance=step.prediction_variance,
                innovation=step.innovation, innovation_variance=step.innovation_variance, gain=step.gain,
                model_a=model.a, model_w=model.process_variance, model_v=model.measurement_variance,
                sample_count=p.sample_count, drift_probability=getattr(step, "drift_probability", 0.0),
                drift_per_sample=getattr(step, "drift_per_sample", 0.0)))


def main(args=None) -> int:
    return run_node(LoadPredictorNode, args)


if __name__ == "__main__":
    main()
