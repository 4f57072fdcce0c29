"""Node ``input_shaper``: shapes motion so that it does not excite a lightly damped
structural mode (seed 003; behaviour: :class:`hex_control.shaping.motion_shaper.MotionShaper`).

Topics:
    /motion/tool_path_raw (ToolPath, latched)  in   a pass's whole tool path, obeyed only
                                                   from ``tool_path_owner`` (the pass planner)
    /motion/tool_path     (ToolPath, latched)  out  the same path shaped whole, longer by the
                                                   shaper's delay (it ends at rest), stamped
                                                   the shaper's lag early (on time at
                                                   constant velocity)
    /motion/setpoint_raw (``input_topic``)     in   jogging: a stream of PoseStamped or
                                                   JointState (``input_type``), from
                                                   ``sample_owner``
    /motion/setpoint     (``output_topic``)    out  the same type, shaped, one message per input
    /diagnostics                              out  paths, samples, rejected and foreign inputs,
                                                   shaper in use

The graph the project starts publishes nothing on setpoint_raw: it is the door for jogging
by hand, so ``sample_owner`` defaults to '' (the first publisher heard owns the stream, and
a publisher of its node, or anyone once it has left, takes over). Name a node there to lock
it; the kinematics node relays only this node's setpoints to the plant. Shaper type,
frequency, damping and V_tol may change at run time (the output fades from the old shaper
to the new one); ``shaper: optimized`` designs a sequence for ``optimized_frequencies_hz``
in a worker thread and switches to it when ready.
"""

from __future__ import annotations

from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from hex_control.config import cell_configuration
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, stamp_s, time_msg, tool_path_message, tool_path_rows
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import in_background, run_node
from hex_control.shaping.motion_shaper import MotionShaper, ShaperChoice, refusal
from hex_control.shaping.optimize import optimize
from hex_control.shaping.shapers import SHAPERS
from hex_control_msgs.msg import ToolPath

#: latched paths in, 10 deep: another publisher's burst must not push the owner's path out
#: of a depth-1 reader queue before it is taken (the burst is refused, the pass left pathless)
PATHS_IN = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
TYPES = {"pose": PoseStamped, "joint_state": JointState}
_MODE = cell_configuration()
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
    # the design mode defaults to the machine's structural mode (the machine file's structure)
    "frequency_hz": Spec(_MODE.value("structure.mode_frequency_hz"), "design frequency of a closed-form shaper "
                         "(Hz)", 0.01, 1000.0, read_only=False),
    "damping": Spec(_MODE.value("structure.mode_damping"), "design damping ratio of a closed-form shaper",
                    0.0, 0.99, read_only=False),
    "vibration_tolerance": Spec(0.05, "residual vibration allowed by the EI shapers (fraction)", 0.0, 0.5,
                                read_only=False),
    "optimized_frequencies_hz": Spec([4.25, 5.0, 7.5], "modes the optimized shaper is designed over (Hz)",
                                     read_only=False),
    "tool_path_owner": Spec("pass_planner", "whose motion/tool_path_raw is shaped (a node name, relative ones "
                            "resolved in this node's namespace)"),
    "sample_owner": Spec("", "whose samples on input_topic are shaped (as tool_path_owner; '' = the first "
                         "publisher heard: for jogging by hand)"),
}


class InputShaperNode(Node):
    READY_PARAMETERS = ("shaper", "frequency_hz", "damping")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("input_shaper", **kwargs)
        declare_parameters(self, PARAMETERS)
        self._type = TYPES[self.get_parameter("input_type").value]
        self.diagnostics = Diagnostics(self)
        self._pending = None  # the optimized design under way (a Future)
        choice = self._choice()
        self.core = MotionShaper(choice, self.get_parameter("sample_period_s").value,
                                 self.get_parameter("interpolate").value, pose_stream=self._type is PoseStamped)
        if choice.shaper == "optimized":
            self._pending = in_background(optimize, self.core.apply(choice), 1)
        # setpoints must not be dropped: a queue of 100 samples (0.5 s at 200 Hz) each way
        self._publisher = self.create_publisher(self._type, self.get_parameter("output_topic").value, 100)
        info_subscription(self, self._type, self.get_parameter("input_topic").value, self._on_sample, 100,
                          diagnostics=self.diagnostics, name="samples",
                          owner_node=self.get_parameter("sample_owner").value)
        self._path_publisher = self.create_publisher(ToolPath, "motion/tool_path", LATCHED)
        info_subscription(self, ToolPath, "motion/tool_path_raw", self._on_path, PATHS_IN, diagnostics=self.diagnostics,
                          name="tool_path_raw", owner_node=self.get_parameter("tool_path_owner").value)
        self.add_on_set_parameters_callback(self._validate)
        self.add_post_set_parameters_callback(self._apply)
        self.diagnostics.set("shaper", self.core.label)

    # -- shapers ---------------------------------------------------------------------------
    def _choice(self, overrides=None) -> ShaperChoice:
        values = {name: self.get_parameter(name).value for name in SHAPER_PARAMETERS}
        values.update(overrides or {})
        values["optimized_frequencies_hz"] = tuple(values["optimized_frequencies_hz"])
        return ShaperChoice(**values)

    def _validate(self, parameters) -> SetParametersResult:
        reason = refusal(self._choice({p.name: p.value for p in parameters if p.name in SHAPER_PARAMETERS}))
        return SetParametersResult(successful=not reason, reason=reason)

    def _apply(self, parameters) -> None:
        if any(p.name in SHAPER_PARAMETERS for p in parameters):
            problem = self.core.apply(self._choice())
            if problem is None:
                self._switched()
            else:
                self._pending = in_background(optimize, problem, 1)
                self.diagnostics.set("shaper", self.core.label)

    def _switched(self) -> None:
        self.diagnostics.set("shaper", self.core.label)
        self.diagnostics.set("shaper_delay_s", f"{self.core.shaper.delay_s:.4f}")
        self.diagnostics.count("shaper_changes")

    def _take_design(self) -> None:
        if self._pending is not None and self._pending.done():
            result, self._pending = self._pending.result(), None
            self.core.switch(result.shaper, f"optimized (criterion {result.criterion:.2e})")
            self._switched()

    # -- path and stream -------------------------------------------------------------------
    def _on_path(self, msg: ToolPath) -> None:
        self._take_design()
        try:
            rows = tool_path_rows(msg)
        except ValueError as exc:
            self.diagnostics.count("rejected_paths")
            self.get_logger().warning(f"tool path of pass {msg.pass_index} rejected: {exc}")
            return
        shaped, start_s = self.core.shape_path(rows, msg.sample_period_s, stamp_s(msg.header.stamp))
        self._path_publisher.publish(tool_path_message(time_msg(start_s), msg.job_id, msg.pass_index,
                                                       msg.sample_period_s, shaped))
        self.diagnostics.count("paths")

    def _on_sample(self, msg) -> None:
        self._take_design()
        if self._type is PoseStamped:
            p, q = msg.pose.position, msg.pose.orientation
            shaped = self.core.step([p.x, p.y, p.z, q.x, q.y, q.z, q.w])
        else:
            shaped = self.core.step(msg.position)
        if shaped is None:
            self.diagnostics.count("rejected_nonfinite")
            self.get_logger().warning("non-finite or empty setpoint rejected", throttle_duration_sec=1.0)
            return
        if self._type is PoseStamped:
            out = PoseStamped(header=msg.header)
            out.pose.position.x, out.pose.position.y, out.pose.position.z = shaped[:3]
            out.pose.orientation.x, out.pose.orientation.y, out.pose.orientation.z, out.pose.orientation.w = shaped[3:]
        else:
            out = JointState(header=msg.header, name=list(msg.name), position=shaped.tolist())
        self._publisher.publish(out)
        self.diagnostics.count("samples")


def main(args=None) -> int:
    return run_node(InputShaperNode, args)


if __name__ == "__main__":
    main()
