"""Node force_controller over real topics against a lock-step force-table stand-in on sim time."""

import math

import pytest
from geometry_msgs.msg import Vector3, Wrench, WrenchStamped
from rclpy.parameter import Parameter
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from hex_control.nodes.force_controller import ForceControllerNode
from hex_control.plant.force_table import ForceTable, ForceTableParameters
from hex_control_msgs.msg import ForceAxisCommand
from ros_harness import wait_until


class LockStepTablePlant:
    """A force table on sim time: each command advances it one control period (5 ms), then
    it publishes the wrench, the setpoint its schedule gives for the new time, and /clock,
    whose tick fires the controller's next period. Time moves only when the loop does, so
    what the test sees in sim time does not depend on how busy the machine is."""

    PERIOD_NS = 5_000_000  # whole nanoseconds: a float stamp 1 ns short of a period fires no timer

    def __init__(self, ros, setpoint_at, silent_from_s=math.inf, restart_at_s=math.inf, hold_at_s=math.inf):
        self.table = ForceTable(ForceTableParameters(stiction_n=0.0, contact_mm=0.0), step_s=0.001)
        self.table.reset(-2.0)
        self.setpoint_at, self.silent_from_s, self.restart_at_s = setpoint_at, silent_from_s, restart_at_s
        self.hold_at_s = hold_at_s  # the loop stands still there (nothing sent) until resume()
        self.timeline = 0  # restarts so far: each one starts sim time from zero again
        self.time_ns = 0
        self.nan_sent = False
        self.history = []  # (sim time s, command mm, force N) after each step of the current timeline
        self.node = ros.node("table_plant")
        self.wrenches = self.node.create_publisher(WrenchStamped, "/plant/wrench", 100)
        self.setpoints = self.node.create_publisher(Float64, "/force_controller/setpoint", 100)
        self.clock = self.node.create_publisher(Clock, "/clock", 100)
        self.node.create_subscription(ForceAxisCommand, "/plant/force_axis_command", self.on_command, 100)
        # as the real plant does: a state unanswered for 0.5 s of wall time is sent again (the
        # first may go out before the controller has matched; a restarted clock is confirmed so),
        # or, with ``advance_unanswered``, the plant steps on with the last command (a timer on a
        # sim clock that went back waits for the clock to pass its next period)
        self.answered, self.advance_unanswered, self.last_command = False, False, None
        self.node.create_timer(0.5, self._unanswered)

    def _unanswered(self) -> None:
        if not self.answered:
            if self.advance_unanswered and self.last_command is not None:
                self.on_command(self.last_command)
            else:
                self.publish()

    def on_command(self, msg: ForceAxisCommand) -> None:
        self.answered, self.last_command = True, msg
        for _ in range(5):
            self.table.step(msg.position_mm)
        self.time_ns += self.PERIOD_NS
        self.history.append((self.time_s, msg.position_mm, self.table.force_n))
        if self.time_s >= self.restart_at_s:  # the plant restarts: a fresh table, sim time from 0
            self.table.reset(-2.0)
            self.time_ns, self.history, self.restart_at_s = -self.PERIOD_NS, [], math.inf
            self.timeline += 1
        if self.time_s < self.hold_at_s - 1e-9:
            self.publish()

    def resume(self, hold_at_s=math.inf) -> None:
        self.hold_at_s = hold_at_s
        self.publish()

    @property
    def time_s(self) -> float:
        return self.time_ns * 1e-9

    def publish(self) -> None:
        stamp = Time(nanoseconds=self.time_ns + self.PERIOD_NS).to_msg()
        if self.time_s < self.silent_from_s:
            wrench = WrenchStamped()
            wrench.header.stamp = stamp
            wrench.wrench.force.z = self.table.measured_n
            self.wrenches.publish(wrench)
        elif not self.nan_sent:  # its last word is malformed
            self.wrenches.publish(WrenchStamped(wrench=Wrench(force=Vector3(z=math.nan))))
            self.nan_sent = True
        setpoint = self.setpoint_at(self.time_s)
        if setpoint is not None:
            self.setpoints.publish(Float64(data=setpoint))
        self.clock.publish(Clock(clock=stamp))
        self.answered = False

    def run_until(self, time_s: float, timeline: int = 0) -> None:
        wait_until(lambda: self.timeline == timeline and self.time_s >= time_s, 120.0,
                   what=f"sim time {time_s} s of timeline {timeline}")

    def at(self, time_s: float):
        """(command mm, force N) at the first step at or after ``time_s``."""
        return next((command, force) for t, command, force in self.history if t >= time_s)


def start_loop(ros, plant, trigger="timer"):
    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("trigger", value=trigger),
        Parameter("kp_mm_per_n", value=0.0098), Parameter("ki_mm_per_n_s", value=0.48)]))  # ITAE-tuned
    for topic in ("/plant/wrench", "/force_controller/setpoint", "/clock"):
        ros.wait_for_match(plant.node, topic, subscribers=1)
    ros.wait_for_match(plant.node, "/plant/force_axis_command", publishers=1)
    plant.publish()
    return controller


def test_tracks_a_force_step_then_the_watchdog_retracts(ros):
    # 20 N for 3 s, no setpoint for 2 s (stale after 0.5 s, then a ramp to -2 mm over 0.5 s), 10 N again
    schedule = lambda t: 20.0 if t < 3.0 else (10.0 if t >= 5.0 else None)  # noqa: E731
    plant = LockStepTablePlant(ros, schedule)
    controller = start_loop(ros, plant)
    plant.run_until(7.5)
    assert plant.at(3.0)[1] == pytest.approx(20.0, abs=1.0)
    assert max(c for _, c, _ in plant.history) <= 2.0 and min(c for _, c, _ in plant.history) >= -2.0
    assert plant.at(3.4)[1] == pytest.approx(20.0, abs=1.0)  # within the setpoint timeout: still tracking
    assert plant.at(4.1) == (-2.0, 0.0)  # retracted 0.5 s + 0.5 s after the last setpoint
    assert controller.diagnostics.counters["watchdog_trips"] == 1
    assert plant.at(7.5)[1] == pytest.approx(10.0, abs=1.0)  # fresh again
    assert controller.diagnostics.summary()[1] == "tracking"  # the watchdog's WARN cleared


def test_a_saturated_command_warns_until_it_comes_off_the_limit(ros):
    """Issue 21 items 8-9: with the work out of reach the stand-alone force-loop recipe
    (docs/nodes.md) measured 0 N, the command pinned at +2 mm, and the controller said OK.
    Now a command held at a limit for saturation_warn_s (1 s) while tracking is a WARN that
    clears when the work is reached."""
    from hex_control.nodes.diagnostics import OK, WARN

    plant = LockStepTablePlant(ros, lambda t: 20.0, hold_at_s=1.5)
    plant.table.surface_mm = 5.0  # beyond the controller's +2 mm
    controller = start_loop(ros, plant)
    plant.run_until(1.5)
    level, message = controller.diagnostics.summary()
    assert level == WARN and "saturated at +2.00 mm" in message and "measured 0.0 N" in message, message
    assert controller.diagnostics.counters["saturations"] == 1
    plant.table.surface_mm = None  # the work within reach again: contact at 0 mm
    plant.resume(hold_at_s=3.0)
    plant.run_until(3.0)
    assert plant.at(3.0)[1] == pytest.approx(20.0, abs=1.0)
    assert controller.diagnostics.summary() == (OK, "tracking")
    assert controller.diagnostics.counters["saturations"] == 1


def test_the_desired_force_is_limited_to_f_max(ros):
    """Issue 21: the force controller clamps its desired force to F_max (max_force_n, 60 N):
    a 100 N setpoint is held at 60 N, counted."""
    plant = LockStepTablePlant(ros, lambda t: 100.0)
    controller = start_loop(ros, plant)
    plant.run_until(1.5)
    assert plant.at(1.5)[1] == pytest.approx(60.0, abs=1.5)
    assert max(force for _, _, force in plant.history) < 75.0
    assert controller.diagnostics.counters["clamped_setpoints"] > 0


def test_stale_measurement_trips_and_nan_is_rejected(ros):
    plant = LockStepTablePlant(ros, lambda t: 15.0, silent_from_s=1.5)  # then one NaN, then nothing
    controller = start_loop(ros, plant)
    plant.run_until(2.5)
    assert plant.at(1.5)[1] == pytest.approx(15.0, abs=1.0)
    assert plant.at(2.2)[0] == -2.0  # stale after 0.1 s, ramped to retracted over 0.5 s
    assert controller.diagnostics.counters["watchdog_trips"] == 1
    assert controller.diagnostics.counters["rejected_measurement"] == 1


@pytest.mark.parametrize("trigger", ["timer", "measurement"])
def test_a_restarted_plant_is_followed_on_its_new_clock(ros, trigger):
    """The plant restarts at 2 s: sim time from 0 again, a fresh table. The controller notes
    the jump once, retracts, and tracks again on the new clock (timer: rcl re-times the
    timer; measurement: the plant's re-sent first state confirms the new timeline)."""
    plant = LockStepTablePlant(ros, lambda t: 20.0, restart_at_s=2.0)
    plant.advance_unanswered = trigger == "timer"
    controller = start_loop(ros, plant, trigger)
    plant.run_until(2.0, timeline=1)
    assert plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0)
    counters = controller.diagnostics.counters
    assert counters["clock_jumps"] == 1
    assert counters.get("rejected_stamp", 0) == (1 if trigger == "measurement" else 0)


def test_a_stray_stamp_changes_nothing(ros):
    """One wrench stamped 2^31 - 1 s (and one before the plant's time) amid a lock-step loop:
    refused and counted, no jump, and the loop goes on answering."""
    plant = LockStepTablePlant(ros, lambda t: 20.0)
    controller = start_loop(ros, plant, "measurement")
    plant.run_until(1.0)
    node = ros.node("stray")
    stray = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    for sec in (2**31 - 1, 0):
        wrench = WrenchStamped()
        wrench.header.stamp.sec = sec
        stray.publish(wrench)
    wait_until(lambda: controller.diagnostics.counters.get("rejected_stamp", 0) >= 2, 10.0, what="the strays")
    reached = plant.time_s
    plant.run_until(reached + 1.0)
    assert plant.at(reached + 1.0)[1] == pytest.approx(20.0, abs=1.0)
    assert controller.diagnostics.counters.get("clock_jumps", 0) == 0


def test_negative_stamps_are_refused_not_a_crash(ros):
    """rclpy's Time.from_msg raises on sec < 0: a wrench or a force trajectory stamped before
    the epoch is refused and counted, and the controller answers the next good measurement."""
    from hex_control.nodes.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory

    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("trigger", value="measurement")]))
    node = ros.node("negative_stamps")
    commands = ros.collect(ForceAxisCommand, "/plant/force_axis_command", 100)
    wrenches = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    trajectories = node.create_publisher(ForceTrajectory, "/grinding/force_trajectory", LATCHED)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    bad_trajectory = ForceTrajectory(time_from_start_s=[0.0, 1.0], normal_force_n=[10.0, 10.0])
    bad_trajectory.header.stamp.sec = -1
    trajectories.publish(bad_trajectory)
    bad_wrench = WrenchStamped()
    bad_wrench.header.stamp.sec = -5
    wrenches.publish(bad_wrench)
    good = WrenchStamped()
    good.header.stamp.sec = 1
    wait_until(lambda: controller.diagnostics.counters["rejected_measurement"] >= 1, 5.0, what="the bad wrench")
    wait_until(lambda: controller.diagnostics.counters["rejected_trajectory"] >= 1, 5.0, what="the bad trajectory")
    wrenches.publish(good)
    wait_until(lambda: commands, 5.0, what="the answer to the good wrench")
    assert commands[-1].position_mm == -2.0  # no setpoint: retracted


def test_an_answer_lost_before_the_plant_matched_is_given_again(ros):
    """The start-up hang of a lock-step graph (issue 21 item 10): the controller answered
    the plant's first state before its command publisher had matched the plant's
    subscription, so the answer went nowhere; the plant sends an unanswered state again
    (the same stamp), which the controller then ignored as already answered, for good. It
    answers a state sent again with the same command, stamped with the state it answers."""
    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("trigger", value="measurement")]))
    node = ros.node("late_plant")
    wrenches = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    state = WrenchStamped()
    state.header.stamp.sec = 1
    wrenches.publish(state)  # nobody listens for the answer yet
    wait_until(lambda: controller.stamps.last_ns == 1_000_000_000, 5.0, what="the first state answered")
    commands = ros.collect(ForceAxisCommand, "/plant/force_axis_command", 100, publishers=1)
    wait_until(lambda: controller.publisher.get_subscription_count() >= 1, 5.0, what="the command's match")
    wrenches.publish(state)  # the plant's re-send
    wait_until(lambda: commands, 5.0, what="the answer again")
    assert commands[-1].position_mm == -2.0 and commands[-1].header.stamp.sec == 1
