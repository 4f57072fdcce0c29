"""Node ``input_shaper``: shapes motion so that it does not excite a lightly damped
structural mode (seed 003; library :mod:`hex_control.shaping`).

Topics:
    /motion/tool_path_raw (ToolPath, latched)  in   a pass's whole tool path
    /motion/tool_path     (ToolPath, latched)  out  the same path shaped whole, longer by the
                                                   shaper's delay (it ends at rest), stamped
                                                   the shaper's lag early (on time at
                                                   constant velocity)
    /motion/setpoint_raw (``input_topic``)     in   jogging: a stream of PoseStamped or
                                                   JointState (``input_type``)
    /motion/setpoint     (``output_topic``)    out  the same type, shaped, one message per input
    /diagnostics                              out  paths, samples, rejected inputs, shaper in use

A path is shaped as six channels (x, y, z, roll, pitch, yaw) at its own sample period, the
way the online filter would stream it (``shape_whole``): the pass's trajectories are
handed over whole (DESIGN.md 4.1). On the jogging stream every input message is one
sample at period ``sample_period_s``. A pose is shaped as seven
channels (position and quaternion, renormalized after shaping -- adequate for the small
rotations of a reset move); a JointState as one channel per position. Shaper type,
frequency, damping and V_tol are parameters that may change at run time: the output fades
from the old shaper to the new one, without a jump. ``shaper: optimized`` designs a
sequence for ``optimized_frequencies_hz`` by differential evolution in a worker thread and
switches to it when ready.
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState

from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import LATCHED, stamp_s, time_msg, tool_path_message, tool_path_rows
from hex_control.nodes.message_info import info_subscription
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control.nodes.runtime import in_background, run_node
from hex_control.shaping.filter import ShaperFilter, shape_whole
from hex_control.shaping.optimize import DesignProblem, optimize
from hex_control.shaping.shapers import SHAPERS, design
from hex_control_msgs.msg import ToolPath

TYPES = {"pose": PoseStamped, "joint_state": JointState}
SHAPER_PARAMETERS = ("shaper", "frequency_hz", "damping", "vibration_tolerance", "optimized_frequencies_hz")
PARAMETERS = {
    "input_type": Spec("pose", "message type of the sample stream", choices=tuple(TYPES)),
    "input_topic": Spec("motion/setpoint_raw", "the unshaped sample stream"),
    "output_topic": Spec("motion/setpoint", "the shaped sample stream"),
    "sample_period_s": Spec(0.005, "period of the sample stream and of a shaped tool path", 1e-4, 1.0),
    "interpolate": Spec(True, "place impulses between samples by linear interpolation"),
    # the shaper may be changed live (validated, then re-designed off the executor thread)
    "shaper": Spec("zvd", "a closed-form shaper or 'optimized' (a robust design over "
                   "optimized_frequencies_hz)", choices=(*sorted(SHAPERS), "optimized"), read_only=False),
    "frequency_hz": Spec(5.0, "design frequency of a closed-form shaper (Hz)", 0.01, 1000.0, read_only=False),
    "damping": Spec(0.02, "design damping ratio of a closed-form shaper", 0.0, 0.99, read_only=False),
    "vibration_tolerance": Spec(0.05, "residual vibration allowed by the EI shapers (fraction)", 0.0, 0.5,
                                read_only=False),
    "optimized_frequencies_hz": Spec([4.25, 5.0, 7.5], "modes the optimized shaper is designed over (Hz)",
                                     read_only=False),
}


class InputShaperNode(Node):
    READY_PARAMETERS = ("shaper", "frequency_hz", "damping")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("input_shaper", **kwargs)
        declare_parameters(self, PARAMETERS)
        kind = self.get_parameter("input_type").value
        self._type = TYPES[kind]
        self.diagnostics = Diagnostics(self)
        self._pending = None
        self._filter = None
        self._shaper = self._closed_form(self._values()) if self._values()["shaper"] != "optimized" \
            else design("zvd", self._values()["frequency_hz"], self._values()["damping"])
        if self._values()["shaper"] == "optimized":
            self._start_design(self._values())
        # setpoints must not be dropped: a queue of 100 samples (0.5 s at 200 Hz) each way
        self._publisher = self.create_publisher(self._type, self.get_parameter("output_topic").value, 100)
        info_subscription(self, self._type, self.get_parameter("input_topic").value, self._on_sample, 100,
                          self.diagnostics, "samples")
        self._path_publisher = self.create_publisher(ToolPath, "motion/tool_path", LATCHED)
        self.create_subscription(ToolPath, "motion/tool_path_raw", self._on_path, LATCHED)
        self.add_on_set_parameters_callback(self._validate)
        self.add_post_set_parameters_callback(self._apply)
        self.diagnostics.set("shaper", self._values()["shaper"])

    # -- shapers ---------------------------------------------------------------------------
    def _values(self, overrides=None) -> dict:
        values = {name: self.get_parameter(name).value for name in SHAPER_PARAMETERS}
        values.update(overrides or {})
        return values

    @staticmethod
    def _closed_form(values: dict):
        return design(values["shaper"], values["frequency_hz"], values["damping"], values["vibration_tolerance"])

    def _start_design(self, values: dict) -> None:
        frequencies = tuple(float(f) for f in values["optimized_frequencies_hz"])
        period = 1.0 / min(frequencies)
        problem = DesignProblem(frequencies_hz=frequencies, impulses=5, max_delay_s=1.5 * period)
        self._pending = in_background(optimize, problem, 1)
        self.diagnostics.set("shaper", "optimized (designing)")

    def _validate(self, parameters) -> SetParametersResult:
        values = self._values({p.name: p.value for p in parameters if p.name in SHAPER_PARAMETERS})
        try:
            if values["shaper"] == "optimized":
                if not values["optimized_frequencies_hz"] or min(values["optimized_frequencies_hz"]) <= 0:
                    raise ValueError("optimized_frequencies_hz must be positive")
            else:
                self._closed_form(values)
        except (ValueError, TypeError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply(self, parameters) -> None:
        if not any(p.name in SHAPER_PARAMETERS for p in parameters):
            return
        values = self._values()
        if values["shaper"] == "optimized":
            self._start_design(values)
        else:
            self._switch(self._closed_form(values), values["shaper"])

    def _switch(self, shaper, label: str) -> None:
        self._shaper = shaper
        if self._filter is not None:
            self._filter.set_shaper(shaper)
        self.diagnostics.set("shaper", label)
        self.diagnostics.set("shaper_delay_s", f"{shaper.delay_s:.4f}")
        self.diagnostics.count("shaper_changes")

    # -- stream ----------------------------------------------------------------------------
    def _values_of(self, msg) -> np.ndarray:
        if self._type is PoseStamped:
            p, q = msg.pose.position, msg.pose.orientation
            return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w], float)
        return np.array(msg.position, float)

    def _take_design(self) -> None:
        if self._pending is not None and self._pending.done():
            result, self._pending = self._pending.result(), None
            self._switch(result.shaper, f"optimized (criterion {result.criterion:.2e})")

    def _on_path(self, msg: ToolPath) -> None:
        self._take_design()
        try:
            rows = tool_path_rows(msg)
        except ValueError as exc:
            self.diagnostics.count("rejected_paths")
            self.get_logger().warning(f"tool path of pass {msg.pass_index} rejected: {exc}")
            return
        shaped, lag_s = shape_whole(self._shaper, msg.sample_period_s, rows, self.get_parameter("interpolate").value)
        start_s = max(0.0, stamp_s(msg.header.stamp) - lag_s)  # on time where it moves steadily
        self._path_publisher.publish(tool_path_message(time_msg(start_s), msg.job_id, msg.pass_index,
                                                       msg.sample_period_s, shaped))
        self.diagnostics.count("paths")

    def _on_sample(self, msg) -> None:
        self._take_design()
        values = self._values_of(msg)
        if values.size == 0 or not np.all(np.isfinite(values)):
            self.diagnostics.count("rejected_nonfinite")
            self.get_logger().warning("non-finite or empty setpoint rejected", throttle_duration_sec=1.0)
            return
        if self._filter is None or self._filter.channels != values.size:
            self._filter = ShaperFilter(self._shaper, self.get_parameter("sample_period_s").value, values.size,
                                        self.get_parameter("interpolate").value)
        shaped = self._filter.step(values)
        if self._type is PoseStamped:
            out = PoseStamped(header=msg.header)
            out.pose.position.x, out.pose.position.y, out.pose.position.z = shaped[:3]
            q = shaped[3:] / (np.linalg.norm(shaped[3:]) or 1.0)
            out.pose.orientation.x, out.pose.orientation.y, out.pose.orientation.z, out.pose.orientation.w = q
        else:
            out = JointState(header=msg.header, name=list(msg.name), position=shaped.tolist())
        self._publisher.publish(out)
        self.diagnostics.count("samples")


def main(args=None) -> int:
    return run_node(InputShaperNode, args)


if __name__ == "__main__":
    main()
