"""Node force_controller over real topics against a lock-step force-table stand-in on sim time."""

import math
import time

import pytest
from geometry_msgs.msg import Vector3, Wrench, WrenchStamped
from rclpy.parameter import Parameter
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, Header

from hex_control.plant.force_table import ForceTable, ForceTableParameters
from hex_control.ros.nodes.force_controller import ForceControllerNode
from hex_control_msgs.msg import ForceAxisCommand
from ros_harness import wait_until


class LockStepTablePlant:
    """A force table on sim time: each command advances it one control period (5 ms), then
    it publishes the wrench, the setpoint its schedule gives for the new time, and /clock,
    whose tick fires the controller's next period. Time moves only when the loop does, so
    what the test sees in sim time does not depend on how busy the machine is."""

    PERIOD_NS = 5_000_000  # whole nanoseconds: a float stamp 1 ns short of a period fires no timer

    def __init__(self, ros, setpoint_at, silent_from_s=math.inf, restart_at_s=math.inf, *, hold_at_s=math.inf,
                 limits=None):
        self.limits = limits  # the plant's own travel and overload trip (ForceAxisLimits), if given
        self.table = ForceTable(ForceTableParameters(stiction_n=0.0, contact_mm=0.0), step_s=0.001)
        self.table.reset(-2.0)
        self.setpoint_at, self.silent_from_s, self.restart_at_s = setpoint_at, silent_from_s, restart_at_s
        self.hold_at_s = hold_at_s  # the loop stands still there (nothing sent) until resume()
        self.timeline = 0  # restarts so far: each one starts sim time from zero again
        self.time_ns = 0
        self.nan_sent = False
        self.history = []  # (sim time s, command mm, force N) after each step of the current timeline
        self.node = ros.node("plant")  # the controller takes wrenches from the node named plant only
        self.wrenches = self.node.create_publisher(WrenchStamped, "/plant/wrench", 100)
        self.setpoints = self.node.create_publisher(Float64, "/force_controller/setpoint", 100)
        self.clock = self.node.create_publisher(Clock, "/clock", 100)
        self.node.create_subscription(ForceAxisCommand, "/plant/force_axis_command", self.on_command, 100)
        # as the real plant does: a state unanswered for 0.5 s of wall time is sent again (the
        # first may go out before the controller has matched; a restarted clock is confirmed so),
        # or, with ``advance_unanswered``, the plant steps on with the last command (a timer on a
        # sim clock that went back waits for the clock to pass its next period); and it steps
        # only on the answer to the state it waits on (stamped so): an answer to a re-sent state
        # answered already would step it twice, and two states in flight delay the loop a period
        self.answered, self.advance_unanswered, self.last_command = False, False, None
        self.waiting_on, self.sent_s, self.stale_commands = None, 0.0, 0
        self.node.create_timer(0.1, self._unanswered)

    def _unanswered(self) -> None:
        if not self.answered and time.monotonic() - self.sent_s >= 0.5:
            if self.advance_unanswered and self.last_command is not None:
                self.answered = True
                self._advance(self.last_command.position_mm)
            else:
                self.publish()

    def on_command(self, msg: ForceAxisCommand) -> None:
        if self.answered or (msg.header.stamp != self.waiting_on and not self.advance_unanswered):
            self.stale_commands += 1
            return
        self.answered, self.last_command = True, msg
        self._advance(msg.position_mm)

    def _advance(self, position_mm: float) -> None:
        for _ in range(5):
            self.table.step(position_mm if self.limits is None
                            else self.limits.command_mm(position_mm, self.table.force_n))
        self.time_ns += self.PERIOD_NS
        self.history.append((self.time_s, position_mm, self.table.force_n))
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
        self.answered, self.waiting_on, self.sent_s = False, stamp, time.monotonic()

    def run_until(self, time_s: float, timeline: int = 0) -> None:
        wait_until(lambda: self.timeline == timeline and self.time_s >= time_s, 120.0,
                   what=f"sim time {time_s} s of timeline {timeline}")

    def at(self, time_s: float):
        """(command mm, force N) at the first step at or after ``time_s``."""
        return next((command, force) for t, command, force in self.history if t >= time_s)


def start_loop(ros, plant, trigger="timer", *overrides):
    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("trigger", value=trigger),
        Parameter("kp_mm_per_n", value=0.0098), Parameter("ki_mm_per_n_s", value=0.48), *overrides]))  # ITAE
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
    from hex_control.ros.infra.diagnostics import OK, WARN

    plant = LockStepTablePlant(ros, lambda t: 20.0, hold_at_s=1.5)
    plant.table.surface_mm = 5.0  # beyond the controller's +2 mm
    # the work's return under the table at +2 mm is a 166 N spike: not an overload here
    controller = start_loop(ros, plant, "timer", Parameter("overload_n", value=1e4),
                            Parameter("overforce_ratio", value=100.0))
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
    """One wrench stamped 2^31 - 1 s, one before the plant's time and one 0.3 s ahead of it
    (issue 37: inside the old 1 s window, it dropped the pass) amid a lock-step loop, from a
    publisher the controller takes wrenches from: refused and counted, no jump, and the loop
    goes on answering."""
    plant = LockStepTablePlant(ros, lambda t: 20.0, hold_at_s=1.0)  # still while the strays come
    controller = start_loop(ros, plant, "measurement", Parameter("measurement_owner", value="plant,stray"))
    plant.run_until(1.0)
    node = ros.node("stray")
    stray = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    for stamp in (Time(seconds=2**31 - 1), Time(), Time(nanoseconds=plant.time_ns + 300_000_000)):
        stray.publish(WrenchStamped(header=Header(stamp=stamp.to_msg())))
    wait_until(lambda: controller.diagnostics.counters.get("rejected_stamp", 0) >= 3, 10.0, what="the strays")
    plant.resume()
    reached = plant.time_s
    plant.run_until(reached + 1.0)
    assert plant.at(reached + 1.0)[1] == pytest.approx(20.0, abs=1.0)
    assert controller.diagnostics.counters.get("clock_jumps", 0) == 0


def test_negative_stamps_are_refused_not_a_crash(ros):
    """rclpy's Time.from_msg raises on sec < 0: a wrench or a force trajectory stamped before
    the epoch is refused and counted, and the controller answers the next good measurement."""
    from hex_control.ros.infra.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory

    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("trigger", value="measurement"), Parameter("measurement_owner", value="")]))
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
        Parameter("trigger", value="measurement"), Parameter("measurement_owner", value="")]))
    node = ros.node("late_plant")
    wrenches = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    state = WrenchStamped()
    state.header.stamp.sec = 1
    wrenches.publish(state)  # nobody listens for the answer yet
    wait_until(lambda: controller.loop.stamps.last_ns == 1_000_000_000, 5.0, what="the first state answered")
    commands = ros.collect(ForceAxisCommand, "/plant/force_axis_command", 100, publishers=1)
    wait_until(lambda: controller.publisher.get_subscription_count() >= 1, 5.0, what="the command's match")
    wrenches.publish(state)  # the plant's re-send
    wait_until(lambda: commands, 5.0, what="the answer again")
    assert commands[-1].position_mm == -2.0 and commands[-1].header.stamp.sec == 1


# -- issue 37: what the controller takes, from whom ------------------------------------------
def _publisher_seen(ros, controller, name: str, msg_type, topic: str, *, qos):
    """A publisher of node ``name`` on ``topic``, once the controller's graph names its node."""
    publisher = ros.node(name).create_publisher(msg_type, topic, qos)
    wait_until(lambda: any(info.node_name == name for info in controller.get_publishers_info_by_topic(topic)),
               15.0, what=f"{name} on {topic} in the controller's graph")
    return publisher


def _trajectory(pass_index: int, force_n: float, length_s: float, start_s: float = 1.0, job_id: str = "job"):
    from hex_control_msgs.msg import ForceTrajectory

    msg = ForceTrajectory(job_id=job_id, pass_index=pass_index, time_from_start_s=[0.0, length_s],
                          normal_force_n=[force_n, force_n])
    msg.header.stamp = Time(nanoseconds=round(start_s * 1e9)).to_msg()
    return msg


def test_a_force_trajectory_is_taken_only_from_the_planner_for_the_commanded_pass(ros):
    """Issue 37: one latched ForceTrajectory of 60 N for 200 s from another process was
    tracked and gouged the part 0.77 mm. As the graph configures it, the controller takes a
    trajectory only from the pass planner, and only for the pass the sequence planner
    commanded last (one that comes before its command waits for it)."""
    from diagnostic_msgs.msg import DiagnosticStatus

    from hex_control.ros.infra.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory, PassCommand

    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("require_pass_command", value=True), Parameter("trajectory_owner", value="pass_planner")]))
    counters = controller.diagnostics.counters
    status = ros.collect(DiagnosticStatus, "/force_controller/status", LATCHED)
    rogue = _publisher_seen(ros, controller, "rogue", ForceTrajectory, "/grinding/force_trajectory", qos=LATCHED)
    planner = _publisher_seen(ros, controller, "pass_planner", ForceTrajectory, "/grinding/force_trajectory",
                              qos=LATCHED)
    sequencer = _publisher_seen(ros, controller, "sequence_planner", PassCommand, "/grinding/pass_command", qos=LATCHED)
    rogue.publish(_trajectory(1, 60.0, 200.0))
    wait_until(lambda: counters["foreign_trajectory"] >= 1, 10.0, what="the rogue's trajectory refused")
    planner.publish(_trajectory(1, 20.0, 5.0))  # before its pass command
    wait_until(lambda: counters["refused_trajectory"] >= 1, 10.0, what="the early trajectory held back")
    assert controller.loop.trajectory is None
    assert "no accepted pass command for it (latest: none)" in controller.diagnostics.summary()[1]
    sequencer.publish(PassCommand(job_id="job", pass_index=1))
    wait_until(lambda: controller.loop.trajectory is not None, 10.0, what="the planned trajectory taken")
    assert controller.loop.trajectory.key == ("job", 1) and controller.loop.trajectory.forces_n.max() == 20.0
    held = wait_until(lambda: status and status[-1], 10.0, what="the controller's status")
    assert {kv.key: kv.value for kv in held.values} == {"job_id": "job", "pass_index": "1"}
    planner.publish(_trajectory(1, 61.0, 5.0))  # above max_force_n (60 N): refused whole
    wait_until(lambda: counters["refused_trajectory"] >= 2, 10.0, what="the 61 N trajectory refused")
    assert controller.loop.trajectory.forces_n.max() == 20.0
    assert "peak 61.0 N above max_force_n 60 N" in controller.diagnostics.summary()[1]


def test_a_direct_setpoint_does_not_drop_a_held_trajectory(ros):
    """Issue 37: one Float64 0.0 on ~/setpoint dropped the pass's trajectory (the pass cut
    0.048 of 0.308 mm). It is refused while a trajectory is held, counted, and said."""
    from hex_control.ros.infra.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory

    plant = LockStepTablePlant(ros, lambda t: None, hold_at_s=0.0)
    controller = start_loop(ros, plant, "measurement")
    jog = ros.node("jog")
    jog.create_publisher(ForceTrajectory, "/grinding/force_trajectory", LATCHED).publish(_trajectory(0, 20.0, 3.0,
                                                                                                      start_s=0.5))
    setpoints = jog.create_publisher(Float64, "/force_controller/setpoint", 10)
    wait_until(lambda: controller.loop.trajectory is not None, 10.0, what="the trajectory")
    plant.resume(hold_at_s=1.0)
    plant.run_until(1.0)
    ros.wait_for_match(jog, "/force_controller/setpoint", subscribers=1)
    setpoints.publish(Float64(data=0.0))
    wait_until(lambda: controller.diagnostics.counters["refused_setpoint"] >= 1, 10.0, what="the setpoint refused")
    assert "setpoint 0 N refused: the force trajectory of job pass 0 is held" in controller.diagnostics.summary()[1]
    plant.resume()
    plant.run_until(2.0)
    assert plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0) and controller.loop.trajectory is not None


def test_a_wrench_from_another_node_is_refused(ros):
    """Issue 37: one wrench stamped +0.3 s from another process dropped the pass. Wrenches
    are taken from the node named plant only (measurement_owner)."""
    plant = LockStepTablePlant(ros, lambda t: 20.0, hold_at_s=1.0)
    controller = start_loop(ros, plant, "measurement")
    plant.run_until(1.0)
    counters = controller.diagnostics.counters
    foreign = counters["foreign_measurement"]  # the plant's first states, if sent before discovery named it
    stray = _publisher_seen(ros, controller, "rogue", WrenchStamped, "/plant/wrench", qos=10)
    stray.publish(WrenchStamped(header=Header(stamp=Time(nanoseconds=plant.time_ns + 300_000_000).to_msg())))
    wait_until(lambda: counters["foreign_measurement"] > foreign, 10.0, what="the rogue's wrench refused")
    plant.resume()
    plant.run_until(2.0)
    assert plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0)
    assert counters["clock_jumps"] == 0 and counters["rejected_stamp"] == 0


def test_max_force_cannot_be_raised_live_beyond_the_cells_f_max(ros):
    """Issue 37: max_force_n raised live to 10,000 N let the loop push the plant into its
    150 N overload trip. A value above the cell's F_max (config/cell.yaml) is refused, with why."""
    from rcl_interfaces.srv import SetParameters

    controller = ros.add(ForceControllerNode(context=ros.context))
    client = ros.node("operator").create_client(SetParameters, "/force_controller/set_parameters")

    def set_max_force(value: float):
        request = SetParameters.Request(parameters=[Parameter("max_force_n", value=value).to_parameter_msg()])
        return ros.call(client, request).results[0]

    refused = set_max_force(10_000.0)
    assert not refused.successful and "the cell's F_max is 60 N" in refused.reason
    assert controller.get_parameter("max_force_n").value == 60.0 and controller.loop.settings.max_force_n == 60.0
    assert set_max_force(45.0).successful
    assert controller.loop.settings.max_force_n == 45.0


def test_after_an_overload_trip_the_controller_backs_off_so_the_plant_resets(ros):
    """Issue 37: the plant tripped at 152 N and stayed at 0 N, the controller pushing on into
    the retracted table. The work rises 1.5 mm under a 60 N pass: the plant trips; the
    controller retracts and holds (the trip resets), until the next pass, which it tracks."""
    from hex_control.plant.limits import ForceAxisLimits
    from hex_control.ros.infra.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory

    limits = ForceAxisLimits(travel_mm=(-5.0, 2.0), overload_n=150.0)
    plant = LockStepTablePlant(ros, lambda t: None, hold_at_s=0.0, limits=limits)
    controller = start_loop(ros, plant, "measurement")
    planner = ros.node("planner").create_publisher(ForceTrajectory, "/grinding/force_trajectory", LATCHED)
    planner.publish(_trajectory(0, 60.0, 10.0, start_s=0.2))
    wait_until(lambda: controller.loop.trajectory is not None, 10.0, what="pass 0")
    plant.resume(hold_at_s=1.0)
    plant.run_until(1.0)
    assert plant.at(1.0)[1] == pytest.approx(60.0, abs=2.0)
    plant.table.surface_mm = -1.5
    plant.resume(hold_at_s=1.5)
    plant.run_until(1.5)
    assert limits.trips == 1 and controller.diagnostics.counters["overloads"] == 1
    assert "overload: contact lost right after" in controller.diagnostics.summary()[1]
    assert plant.at(1.5) == (-2.0, 0.0) and not limits.tripped  # retracted: the plant's trip reset
    plant.table.surface_mm = None
    planner.publish(_trajectory(1, 40.0, 2.0, start_s=2.0))
    wait_until(lambda: controller.loop.trajectory is not None, 10.0, what="pass 1")
    plant.resume()
    plant.run_until(3.0)
    assert plant.at(3.0)[1] == pytest.approx(40.0, abs=2.0) and limits.trips == 1
