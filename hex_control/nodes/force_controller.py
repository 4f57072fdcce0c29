"""Node ``force_controller``: the bottom tier -- the force loop (seed 002 ch. 7).

Every control period the force law turns the desired and measured force into a table
position command: ``law`` = ``pi`` (eq. 7.6, optionally through a roll-off filter, low-pass
or notch, section 8.3 item 2) or ``energy_optimal`` (seed 004 eq. 9-10 on the table model),
with the control-rate load prediction as feed-forward (:mod:`hex_control.control.force_law`).

``trigger``: ``timer`` runs the loop at ``rate_hz`` on the node clock (sim time when
use_sim_time is set); ``measurement`` runs it once per received wrench, with the wrench's
stamp as the time -- what the plant's lock-step mode needs for a deterministic loop.

Topics:
    /grinding/force_trajectory  hex_control_msgs/ForceTrajectory  in  (latched) desired force vs
                                 time (time_from_start_s measured from header.stamp)
    ~/setpoint                   std_msgs/Float64                  in  a direct desired force (N)
    /plant/wrench                geometry_msgs/WrenchStamped       in  measured force, wrench.force.z (N)
    /load_predictor/force/prediction  LoadPrediction              in  feed-forward (optional)
    /plant/force_axis_command    hex_control_msgs/ForceAxisCommand out table position command (mm),
                                 stamped with the measurement it answers (trigger measurement) or
                                 the node's time (trigger timer)
    ~/status                     diagnostic_msgs/DiagnosticStatus  out (latched) "trajectory" with the
                                 job_id and pass_index of the force trajectory it holds: the plant
                                 in lock-step starts a pass only once its controller has it
    /diagnostics

Touch-down: while a force trajectory waits for its start, the table moves from wherever it
was held to ``touch_standoff_mm`` short of ``contact_mm`` at ``touch_speed_mm_s``, arriving
``touch_settle_s`` before the start (:mod:`hex_control.control.touch_down`), so the loop
closes on the work at the pass's first samples instead of travelling the gap under them.

Watchdog: when the setpoint or the measurement is older than its timeout, the command
ramps to ``output_min_mm`` (retracted: no force) over ``ramp_down_s`` and a WARN is
reported; the loop restarts bumplessly when both are fresh again. Non-finite inputs are
rejected and counted; the desired force is limited to ``max_force_n`` (F_max) and the
command to [output_min_mm, output_max_mm]. A command held at one of those limits for
``saturation_warn_s`` while tracking is a WARN (no contact, or work out of reach).

Answers (trigger measurement): a wrench stamped like the last one answered is the plant
sending an unanswered state again (its first answer may have gone out before this node's
publisher had matched the plant): the same command is sent again, unchanged, the loop not
stepped. Clock jumps (:mod:`hex_control.control.stamp_guard`): a wrench
stamped off the plant's timeline is refused (``rejected_stamp``) unless the next confirms a
new timeline; backwards (a restarted plant), or a sim clock that goes back under the timer,
drops the force trajectory and retracts (``clock_jumps``, WARN) until the next pass.
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import WrenchStamped
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time
from std_msgs.msg import Float64

from hex_control.control.force_law import FORCE_LAWS, ROLL_OFFS, make_force_law
from hex_control.control.stamp_guard import Stamp, StampGuard
from hex_control.control.touch_down import TouchDown
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import LATCHED
from hex_control.nodes.message_info import info_subscription
from hex_control.nodes.parameters import ParameterError, declare_parameters
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.runtime import run_node
from hex_control.plant.force_table import ForceTableParameters
from hex_control_msgs.msg import ForceAxisCommand, ForceTrajectory, LoadPrediction

CEILING_WARN_S = 5.0  # a desired force above max_force_n keeps the WARN this long (wall s) after the last
_TABLE = ForceTableParameters()

PARAMETERS = {
    "rate_hz": Spec(200.0, "control rate of the timer trigger; the period of the force law", 1.0, 10_000.0),
    "trigger": Spec("timer", "timer: a period of the node clock; measurement: each new wrench (lock-step)",
                    choices=("timer", "measurement")),
    "law": Spec("pi", "force law: PI (seed 002 eq. 7.6) or energy-optimal (seed 004 eq. 9-10)",
                choices=tuple(FORCE_LAWS)),
    "kp_mm_per_n": Spec(0.002, "PI proportional gain", 0.0, 1.0),
    "ki_mm_per_n_s": Spec(0.05, "PI integral gain", 0.0, 100.0),
    "output_min_mm": Spec(-2.0, "lowest table command: the retracted stop", -50.0, 50.0),
    "output_max_mm": Spec(2.0, "highest table command", -50.0, 50.0),
    "setpoint_timeout_s": Spec(0.5, "age of a direct setpoint after which the watchdog retracts", 0.001, 60.0,
                               read_only=False),
    "measurement_timeout_s": Spec(0.1, "age of the measured force after which the watchdog retracts",
                                  0.001, 60.0, read_only=False),
    "ramp_down_s": Spec(0.5, "time of the watchdog's ramp over the whole command range", 0.001, 60.0,
                        read_only=False),
    "feed_forward_mm_per_n": Spec(0.0, "gain on the predicted load fluctuation (prediction - mean)", -1.0, 1.0,
                                  read_only=False),
    "roll_off": Spec("none", "filter on the PI output (seed 002 section 8.3 item 2)",
                     choices=ROLL_OFFS),
    "roll_off_hz": Spec(8.0, "corner or notch frequency of roll_off (Hz)", 0.01, 1000.0),
    "roll_off_quality": Spec(0.5, "quality factor of the roll-off filter", 0.01, 100.0),
    "stiffness_n_per_mm": Spec(_TABLE.stiffness_n_mm, "contact stiffness K_x of the energy-optimal law's model",
                               1e-3, 1e6),
    "contact_mm": Spec(_TABLE.contact_mm, "table position at which the disk touches the work", -50.0, 50.0),
    "energy_q1": Spec(1.0, "energy-optimal law: weight on the force error", 0.0, 1e9),
    "energy_q2": Spec(1.0, "energy-optimal law: weight on the rate of the force error", 0.0, 1e9),
    "energy_r": Spec(1e3, "energy-optimal law: weight on the command energy", 1e-12, 1e12),
    "energy_correction_limit_mm": Spec(0.5, "energy-optimal law: largest correction per period", 0.0, 50.0),
    "touch_standoff_mm": Spec(0.1, "touch-down: distance short of contact_mm to approach to", 0.0, 10.0),
    "touch_speed_mm_s": Spec(10.0, "touch-down: approach speed", 0.01, 1000.0),
    "touch_settle_s": Spec(0.1, "touch-down: time at the stand-off before the pass starts", 0.0, 10.0),
    "touch_felt_n": Spec(2.0, "touch-down: a force above this stops the approach (early contact)", 0.0, 1000.0),
    "max_force_n": Spec(60.0, "ceiling of the desired force, F_max of the process (seed 002 sec. 5.1)", 0.0, 1e4,
                        read_only=False),
    "saturation_warn_s": Spec(1.0, "a command held at output_min_mm or output_max_mm this long while tracking "
                              "is reported (WARN) until it comes off the limit", 0.0, 3600.0, read_only=False),
    "max_stamp_step_s": Spec(1.0, "trigger measurement: a wrench stamped further than this from the last "
                             "(backwards or ahead) is a clock jump only once the next confirms it", 0.001, 3600.0),
}


class ForceControllerNode(Node):
    READY_PARAMETERS = ("law", "trigger", "rate_hz")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("force_controller", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.period_s = 1.0 / p("rate_hz")
        self.limits = (p("output_min_mm"), p("output_max_mm"))
        if not self.limits[0] < self.limits[1]:
            raise ParameterError(f"output_min_mm {self.limits[0]} must be below output_max_mm {self.limits[1]}")
        self.law = make_force_law(p("law"), {name: p(name) for name in PARAMETERS}, self.period_s, self.limits)
        self.law.reset(self.limits[0])
        self.touch_down = TouchDown(p("contact_mm"), p("touch_standoff_mm"), p("touch_speed_mm_s"),
                                    p("touch_settle_s"), p("touch_felt_n"))
        self.diagnostics = Diagnostics(self)
        self.command_mm = self.limits[0]
        self.trajectory = None
        self.direct_setpoint = None
        self.setpoint_time = None
        self.measured_n = None
        self.measured_time = None
        self.feed_forward_n = 0.0
        self.tripped = True  # start retracted; only a loss of inputs while tracking is a trip
        self.saturated_s = 0.0  # how long the command has been held at a limit while tracking
        self.stamps = StampGuard(round(p("max_stamp_step_s") * 1e9))
        self.publisher = self.create_publisher(ForceAxisCommand, "plant/force_axis_command", 10)
        self.answer = None  # the last command sent (ForceAxisCommand)
        self.status_publisher = self.create_publisher(DiagnosticStatus, "~/status", LATCHED)
        # latched: a controller that matches the pass planner late still gets the pass it must run
        self.create_subscription(ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, LATCHED)
        info_subscription(self, Float64, "~/setpoint", self._on_setpoint, 10, self.diagnostics, "setpoint")
        info_subscription(self, WrenchStamped, "plant/wrench", self._on_wrench, 100, self.diagnostics,
                          "measurement")
        self.create_subscription(LoadPrediction, "load_predictor/force/prediction", self._on_prediction, 10)
        self.measurement_triggered = p("trigger") == "measurement"
        if not self.measurement_triggered:
            self.create_timer(self.period_s, lambda: self._tick(self.get_clock().now()))
            # a sim clock that goes back (a restarted plant): rcl re-times the timer itself
            self._jump_handler = self.get_clock().create_jump_callback(
                JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
                post_callback=lambda jump: self._clock_jumped(jump.delta.nanoseconds * 1e-9))

    # -- inputs ----------------------------------------------------------------------------
    def _reject(self, what: str) -> None:
        self.diagnostics.count(f"rejected_{what}")
        self.get_logger().warning(f"malformed {what} rejected", throttle_duration_sec=1.0)

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        t, f = np.asarray(msg.time_from_start_s, float), np.asarray(msg.normal_force_n, float)
        if t.size == 0 or t.shape != f.shape or not (np.all(np.isfinite(t)) and np.all(np.isfinite(f))) \
                or np.any(np.diff(t) <= 0) or np.any(f < 0) or msg.header.stamp.sec < 0:
            self._reject("trajectory")
            return
        self.trajectory = (Time.from_msg(msg.header.stamp), t, f)
        self.direct_setpoint = None
        self.setpoint_time = self._now()
        self.status_publisher.publish(DiagnosticStatus(
            level=DiagnosticStatus.OK, name=self.get_fully_qualified_name(), message="trajectory",
            values=[KeyValue(key="job_id", value=msg.job_id), KeyValue(key="pass_index", value=str(msg.pass_index))]))

    def _on_setpoint(self, msg: Float64) -> None:
        if not (math.isfinite(msg.data) and msg.data >= 0):
            self._reject("setpoint")
            return
        self.direct_setpoint, self.trajectory = msg.data, None
        self.setpoint_time = self._now()

    def _on_wrench(self, msg: WrenchStamped) -> None:
        if not math.isfinite(msg.wrench.force.z) or msg.header.stamp.sec < 0:  # Time.from_msg raises on sec < 0
            self._reject("measurement")
            return
        if self.measurement_triggered:
            stamp = Time.from_msg(msg.header.stamp, clock_type=self.get_clock().clock_type)
            verdict = self.stamps.check(stamp.nanoseconds)
            if verdict is Stamp.REPEAT:  # sent again: the plant has not had the answer
                if self.answer is not None and self.answer.header.stamp == msg.header.stamp:
                    self.publisher.publish(self.answer)
                    self.diagnostics.count("answers_repeated")
                return
            if verdict is Stamp.REFUSED:
                self._reject("stamp")
                return
            if verdict is Stamp.JUMPED:
                self._clock_jumped(self.stamps.jump_ns * 1e-9)
            self.measured_n, self.measured_time = msg.wrench.force.z, stamp
            self._tick(stamp)
        else:
            self.measured_n, self.measured_time = msg.wrench.force.z, self.get_clock().now()

    def _clock_jumped(self, jump_s: float) -> None:
        """The plant's clock jumped (restarted, when backwards): a trajectory and the times
        held are of the old timeline, so they go and the loop retracts until the next pass."""
        self.diagnostics.count("clock_jumps")
        if jump_s > 0:  # later, on the same timeline: the trajectory still holds
            self.get_logger().warning(f"measurement stamps leapt {jump_s:+.3f} s")
            return
        self.trajectory = self.direct_setpoint = self.setpoint_time = self.measured_time = None
        if not self.tripped:
            self.tripped = True
            self.diagnostics.count("watchdog_trips")
        self.diagnostics.fault("clock_jump", f"clock jumped {jump_s:+.3f} s: force trajectory dropped, retracting")
        self.get_logger().warning(f"clock jumped {jump_s:+.3f} s: force trajectory dropped, retracting")

    def _on_prediction(self, msg: LoadPrediction) -> None:
        if math.isfinite(msg.prediction) and math.isfinite(msg.mean):
            self.feed_forward_n = msg.prediction - msg.mean
        else:
            self._reject("prediction")

    # -- loop ------------------------------------------------------------------------------
    def _now(self) -> Time | None:
        """The loop's time: the latest measurement's stamp when measurements trigger it (the
        plant's clock, whatever this node's says), else the node clock."""
        return self.measured_time if self.measurement_triggered else self.get_clock().now()

    def _elapsed_s(self, now) -> float | None:
        """Time into the held force trajectory (negative before its start), None without one."""
        if self.direct_setpoint is not None or self.trajectory is None:
            return None
        return (now - self.trajectory[0]).nanoseconds * 1e-9

    def _desired(self, now) -> float | None:
        if self.direct_setpoint is not None:
            return self.direct_setpoint
        elapsed = self._elapsed_s(now)
        if elapsed is None or elapsed < 0 or elapsed > self.trajectory[1][-1]:
            return None  # no trajectory, not started, or over
        _, t, f = self.trajectory
        return float(np.interp(elapsed, t, f))

    def _limited(self, desired_n: float | None) -> float | None:
        """The desired force no higher than ``max_force_n`` (F_max): above it the disk burns
        the work whatever the planner asked (counted, a WARN for a few seconds)."""
        ceiling = self.get_parameter("max_force_n").value
        if desired_n is None or desired_n <= ceiling:
            return desired_n
        self.diagnostics.count("clamped_setpoints")
        self.diagnostics.fault("ceiling", f"desired {desired_n:.1f} N limited to max_force_n {ceiling:g} N",
                               hold_s=CEILING_WARN_S)
        return ceiling

    def _stale(self, stamp, timeout: float, now) -> bool:
        return stamp is None or not 0 <= (now - stamp).nanoseconds * 1e-9 <= timeout

    def _tick(self, now: Time) -> None:
        elapsed = self._elapsed_s(now)
        fresh_measurement = not self._stale(self.measured_time, self.get_parameter("measurement_timeout_s").value, now)
        if elapsed is not None and elapsed < 0 and fresh_measurement:
            # a pass is coming: touch down in time; the loop starts bumplessly from there
            self.tripped = True
            command = self.touch_down.command_mm(self.command_mm, -elapsed, self.measured_n, self.period_s)
            self.command_mm = min(max(command, self.limits[0]), self.limits[1])
            self.law.hold(self.command_mm)
            self._send(now)
            return
        desired = self._limited(self._desired(now))
        fresh_setpoint = desired is not None and (self.trajectory is not None or not self._stale(
            self.setpoint_time, self.get_parameter("setpoint_timeout_s").value, now))
        if fresh_setpoint and fresh_measurement:
            if self.tripped:
                self.tripped = False
                self.law.reset(self.command_mm)  # bumpless restart from where the ramp left it
                self.diagnostics.clear("watchdog")
                self.diagnostics.clear("clock_jump")
                self.diagnostics.state = "tracking"
            feed_forward = self.get_parameter("feed_forward_mm_per_n").value * self.feed_forward_n
            command = self.law.command(desired, self.measured_n, feed_forward)
            self._watch_saturation(command, desired)
        else:
            if not self.tripped:  # was tracking: a real watchdog trip
                self.tripped = True
                self.diagnostics.count("watchdog_trips")
                reason = "setpoint" if not fresh_setpoint else "measurement"
                self.diagnostics.fault("watchdog", f"watchdog: stale {reason}, retracting")
                self.saturated_s = 0.0
                self.get_logger().warning(f"watchdog: stale {reason}, ramping the force to zero")
            span = self.limits[1] - self.limits[0]
            step = span * self.period_s / self.get_parameter("ramp_down_s").value
            command = max(self.command_mm - step, self.limits[0])
            self.law.hold(command)
        self.command_mm = min(max(command, self.limits[0]), self.limits[1])
        self._send(now)

    def _send(self, now: Time) -> None:
        self.answer = ForceAxisCommand(position_mm=self.command_mm)
        self.answer.header.stamp = now.to_msg()
        self.publisher.publish(self.answer)

    def _watch_saturation(self, command_mm: float, desired_n: float) -> None:
        """A command held at a limit for ``saturation_warn_s`` while tracking is a fault (no
        contact, or the work out of reach), cleared as soon as the command comes off it."""
        if not self.limits[0] < command_mm < self.limits[1]:
            self.saturated_s += self.period_s
            if self.saturated_s >= self.get_parameter("saturation_warn_s").value \
                    and not self.diagnostics.active("saturated"):
                self.diagnostics.count("saturations")
                text = (f"command saturated at {command_mm:+.2f} mm for {self.saturated_s:.2f} s: desired "
                        f"{desired_n:.1f} N, measured {self.measured_n:.1f} N")
                self.diagnostics.fault("saturated", text)
                self.get_logger().warning(text)
        else:
            self.saturated_s = 0.0
            self.diagnostics.clear("saturated")


def main(args=None) -> int:
    return run_node(ForceControllerNode, args)


if __name__ == "__main__":
    main()
