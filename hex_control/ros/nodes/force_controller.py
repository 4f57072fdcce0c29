"""Node ``force_controller``: the bottom tier -- the force loop (seed 002 ch. 7).

Its behaviour is :class:`hex_control.control.force_loop.ForceLoop` (force law, touch-down,
watchdog ramp, F_max ceiling, saturation, overload back-off, stamps and clock jumps, which
trajectories and setpoints it takes); the node reads its parameters into the loop's settings,
converts messages, publishes the commands the loop returns and reports its counters and
faults on /diagnostics. ``trigger``: ``timer`` runs the loop at ``rate_hz`` on the node clock
(sim time when use_sim_time is set); ``measurement`` once per received wrench, at its stamp
(what the plant's lock-step needs for a deterministic loop).

Topics (relative: one namespace is one cell); an ``*_owner`` names the node(s) an input takes
messages from ('' = the first heard, for hand use; config/force_controller.yaml names them):
  in  grinding/pass_command (PassCommand, latched): the pass a trajectory must belong to
  in  grinding/force_trajectory (ForceTrajectory, latched): desired force from header.stamp
  in  ~/setpoint (Float64, N): a direct desired force, refused while a trajectory is held
  in  plant/wrench (WrenchStamped): measured force, wrench.force.z (N)
  in  load_predictor/force/prediction (LoadPrediction): feed-forward (optional)
  out plant/force_axis_command (ForceAxisCommand, mm): stamped with the state it answers
      (trigger measurement) or the node's time
  out ~/status (DiagnosticStatus, latched): "trajectory", job_id and pass_index held (a
      lock-step plant starts a pass only once its controller has it); /diagnostics
"""

from __future__ import annotations

from dataclasses import MISSING, fields

from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from std_msgs.msg import Float64

from hex_control.config import cell_configuration
from hex_control.control.force_law import FORCE_LAWS, ROLL_OFFS
from hex_control.control.force_loop import LIVE, TRIGGERS, Command, ForceLoop, ForceLoopSettings, Trajectory
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.parameters import ParameterError, declare_parameters
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.runtime import run_node
from hex_control_msgs.msg import ForceAxisCommand, ForceTrajectory, LoadPrediction, PassCommand

_CELL = cell_configuration()  # config/cell.yaml: the one source of these defaults
CELL = {"max_force_n": _CELL.force_max_n,  # F_max
        "stiffness_n_per_mm": _CELL.stiffness_n_per_mm,  # K_x = K_theta / R^2 (eq. 7.1b)
        "contact_mm": _CELL.value("table.contact_mm"), "overload_n": _CELL.overload_n}  # the plant's trip
_D = {**{f.name: f.default for f in fields(ForceLoopSettings) if f.default is not MISSING}, **CELL}


_CHOICES = {"trigger": TRIGGERS, "law": tuple(FORCE_LAWS), "roll_off": ROLL_OFFS}
_MEANINGS = {  # name: (meaning, low, high); the default is the loop's (or the cell's), live if in LIVE
    "rate_hz": ("control rate of the timer trigger; the period of the force law", 1.0, 10_000.0),
    "trigger": ("timer: a period of the node clock; measurement: each new wrench (lock-step)", None, None),
    "law": ("force law: PI (seed 002 eq. 7.6) or energy-optimal (seed 004 eq. 9-10)", None, None),
    "kp_mm_per_n": ("PI proportional gain", 0.0, 1.0),
    "ki_mm_per_n_s": ("PI integral gain", 0.0, 100.0),
    "output_min_mm": ("lowest table command: the retracted stop", -50.0, 50.0),
    "output_max_mm": ("highest table command", -50.0, 50.0),
    "setpoint_timeout_s": ("age of a direct setpoint after which the watchdog retracts", 0.001, 60.0),
    "measurement_timeout_s": ("age of the measured force after which the watchdog retracts", 0.001, 60.0),
    "ramp_down_s": ("time of the watchdog's ramp over the whole command range", 0.001, 60.0),
    "feed_forward_mm_per_n": ("gain on the predicted load fluctuation (prediction - mean)", -1.0, 1.0),
    "roll_off": ("filter on the PI output (seed 002 section 8.3 item 2)", None, None),
    "roll_off_hz": ("corner or notch frequency of roll_off (Hz)", 0.01, 1000.0),
    "roll_off_quality": ("quality factor of the roll-off filter", 0.01, 100.0),
    "stiffness_n_per_mm": ("contact stiffness K_x of the energy-optimal law (default: the cell's K_theta / R^2)",
                           1e-3, 1e6),
    "contact_mm": ("table position at which the disk touches the work (default: the cell's)", -50.0, 50.0),
    "energy_q1": ("energy-optimal law: weight on the force error", 0.0, 1e9),
    "energy_q2": ("energy-optimal law: weight on the rate of the force error", 0.0, 1e9),
    "energy_r": ("energy-optimal law: weight on the command energy", 1e-12, 1e12),
    "energy_correction_limit_mm": ("energy-optimal law: largest correction per period", 0.0, 50.0),
    "touch_standoff_mm": ("touch-down: distance short of contact_mm to approach to", 0.0, 10.0),
    "touch_speed_mm_s": ("touch-down: approach speed", 0.01, 1000.0),
    "touch_settle_s": ("touch-down: time at the stand-off before the pass starts", 0.0, 10.0),
    "touch_felt_n": ("touch-down: a force above this stops the approach (early contact)", 0.0, 1000.0),
    "max_force_n": ("ceiling of the desired force (seed 002 sec. 5.1); the cell's F_max (config/cell.yaml) by "
                    "default and at most", 0.0, None),
    "saturation_warn_s": ("a command held at output_min_mm or output_max_mm this long while tracking is "
                          "reported (WARN) until it comes off the limit", 0.0, 3600.0),
    "max_stamp_step_s": ("trigger measurement: a wrench stamped further than this from the last (backwards or "
                         "ahead) is a clock jump only once the next confirms it", 0.001, 3600.0),
    "overload_n": ("a measured force above this retracts until the next pass (default: the cell's trip)",
                   1.0, 1e5),
    "overforce_ratio": ("so does one above this times max_force_n for overforce_s", 1.0, 100.0),
    "overforce_s": ("see overforce_ratio", 0.0, 60.0),
    "require_pass_command": ("take a trajectory only for the pass of the latest accepted pass command", None, None),
}
PARAMETERS = {name: Spec(_D[name], meaning, low, high, _CHOICES.get(name, ()), name not in LIVE)
              for name, (meaning, low, high) in _MEANINGS.items()}
PARAMETERS |= {f"{name}_owner": Spec(owner, f"the node(s) whose {name} messages are taken ('' = the first heard)")
               for name, owner in (("trajectory", ""), ("pass_command", "sequence_planner"), ("measurement", "plant"))}


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class ForceControllerNode(Node):
    READY_PARAMETERS = ("law", "trigger", "rate_hz")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("force_controller", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = {name: self.get_parameter(name).value for name in PARAMETERS}
        try:
            settings = ForceLoopSettings(cell_force_max_n=CELL["max_force_n"],
                                         **{f.name: p[f.name] for f in fields(ForceLoopSettings) if f.name in p})
        except ValueError as error:
            raise ParameterError(str(error)) from None
        self.diagnostics = Diagnostics(self)
        logger = self.get_logger()
        self.loop = ForceLoop(settings, self.diagnostics, logger.warning,
                              lambda text: logger.warning(text, throttle_duration_sec=1.0))
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(
            lambda parameters: self.loop.update(**{q.name: q.value for q in parameters if q.name in LIVE}))
        self.publisher = self.create_publisher(ForceAxisCommand, "plant/force_axis_command", 10)
        self._answer = ForceAxisCommand()
        self.status_publisher = self.create_publisher(DiagnosticStatus, "~/status", LATCHED)
        owner = {name: p[f"{name}_owner"] for name in ("pass_command", "trajectory", "measurement")}
        # latched: a controller that matches the planners late still gets the pass it must run
        info_subscription(self, PassCommand, "grinding/pass_command", self._on_pass_command, LATCHED,
                          diagnostics=self.diagnostics, name="pass_command", owner_node=owner["pass_command"])
        info_subscription(self, ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, LATCHED,
                          diagnostics=self.diagnostics, name="trajectory", owner_node=owner["trajectory"])
        info_subscription(self, Float64, "~/setpoint", lambda m: self.loop.on_setpoint(m.data, self._clock_ns()), 10,
                          diagnostics=self.diagnostics, name="setpoint")
        info_subscription(self, WrenchStamped, "plant/wrench", self._on_wrench, 100, diagnostics=self.diagnostics,
                          name="measurement", owner_node=owner["measurement"])
        self.create_subscription(LoadPrediction, "load_predictor/force/prediction",
                                 lambda m: self.loop.on_prediction(m.prediction, m.mean), 10)
        if not self.loop.measurement_triggered:
            self.create_timer(self.loop.period_s, lambda: self._send(self.loop.tick(self._clock_ns())))
            # a sim clock that goes back (a restarted plant): rcl re-times the timer itself
            self._jump_handler = self.get_clock().create_jump_callback(
                JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
                post_callback=lambda jump: self.loop.clock_jumped(jump.delta.nanoseconds * 1e-9))

    def _check_parameters(self, parameters) -> SetParametersResult:
        for parameter in parameters:
            reason = parameter.name == "max_force_n" and self.loop.settings.ceiling_refusal(parameter.value)
            if reason:
                self.diagnostics.fault("parameter", reason, hold_s=5.0)
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _clock_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def _on_pass_command(self, msg: PassCommand) -> None:
        adopted = self.loop.on_pass_command(msg.job_id, msg.pass_index, msg.stop)
        if adopted is not None:
            self._publish_status(adopted)

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        if self.loop.on_trajectory(_ns(msg.header.stamp), msg.time_from_start_s, msg.normal_force_n, msg.job_id,
                                   msg.pass_index).accepted:
            self._publish_status(self.loop.trajectory)

    def _on_wrench(self, msg: WrenchStamped) -> None:
        loop = self.loop  # the node clock only for the timer trigger: measurements run on their stamps
        command = loop.on_measurement(msg.wrench.force.z, _ns(msg.header.stamp),
                                      None if loop.measurement_triggered else self._clock_ns())
        if command is not None:
            self._send(command)

    def _send(self, command: Command) -> None:
        answer = self._answer  # one message filled anew each period: building one cost more than sending it
        answer.position_mm = float(command.position_mm)
        answer.header.stamp = TimeMsg(sec=command.stamp_ns // 1_000_000_000, nanosec=command.stamp_ns % 1_000_000_000)
        self.publisher.publish(answer)

    def _publish_status(self, trajectory: Trajectory) -> None:
        self.status_publisher.publish(DiagnosticStatus(
            level=DiagnosticStatus.OK, name=self.get_fully_qualified_name(), message="trajectory",
            values=[KeyValue(key="job_id", value=trajectory.job_id),
                    KeyValue(key="pass_index", value=str(trajectory.pass_index))]))


def main(args=None) -> int:
    return run_node(ForceControllerNode, args)


if __name__ == "__main__":
    main()
