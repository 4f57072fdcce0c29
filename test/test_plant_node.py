"""Node plant with the force controller over real topics, each in its own process:
lock-step tracking and bit-for-bit repeatability, real-time rate, strut commands."""

import time

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState

from hex_control_msgs.msg import ForceAxisCommand, ForceTrajectory
from ros_harness import diagnostics_value, wait_until

KEEP = QoSProfile(depth=10_000)
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
HISTORY = QoSProfile(depth=10_000, durability=DurabilityPolicy.TRANSIENT_LOCAL)  # a lock-step run can
# end before discovery has matched the collector: the plant keeps the true force for late joiners
PLANT = ["hex-plant", "--ros-args", "-p", "stiction_n:=4.8", "-p", "runout_mm:=0.02", "-p", "sensor_noise_n:=0.3",
         "-p", "seed:=7"]
CONTROLLER = ["hex-force-controller", "--ros-args", "-p", "use_sim_time:=true", "-p", "trigger:=measurement",
              "-p", "kp_mm_per_n:=0.0098", "-p", "ki_mm_per_n_s:=0.48"]  # ITAE-tuned gains


def _stamp_s(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def _plant_counter(diagnostics, key: str):
    """The plant's latest value of a /diagnostics counter, or None."""
    return diagnostics_value(diagnostics, "/plant", key)


def _lockstep_run(ros, spawn, end_time_s: float, trajectory_s: float = 10.0) -> list[tuple[float, float]]:
    """Controller, then a 20 N trajectory from 0.1 s for ``trajectory_s`` of sim time, then the plant;
    returns (stamp, true force) until the plant stops at ``end_time_s``."""
    controller = spawn(CONTROLLER)
    source = ros.node(f"trajectory_source_{time.monotonic_ns()}")
    publisher = source.create_publisher(ForceTrajectory, "/grinding/force_trajectory", LATCHED_QOS)
    wait_until(lambda: publisher.get_subscription_count() >= 1, 15.0, what="the controller")
    trajectory = ForceTrajectory()
    trajectory.header.stamp.nanosec = 100_000_000
    trajectory.time_from_start_s = [0.0, trajectory_s]
    trajectory.normal_force_n = [20.0, 20.0]
    publisher.publish(trajectory)
    forces = ros.collect(WrenchStamped, "/plant/true_wrench", HISTORY)
    time.sleep(0.5)
    plant = spawn(PLANT + ["-p", f"end_time_s:={end_time_s}"])
    wait_until(lambda: forces and _stamp_s(forces[-1]) >= end_time_s - 1e-9, 60.0, what="the end of the run")
    plant.stop()
    controller.stop()
    source.destroy_publisher(publisher)
    run = {}
    for message in forces:  # the state at t = 0 is re-sent until the controller answers: one copy
        stamp, force = _stamp_s(message), message.wrench.force.z
        assert run.setdefault(stamp, force) == force
    return sorted(run.items())


def test_lockstep_tracks_a_force_step_and_repeats_bit_for_bit(ros, spawn):
    first = _lockstep_run(ros, spawn, 1.5)
    second = _lockstep_run(ros, spawn, 1.5)
    assert first[-1][1] == pytest.approx(20.0, abs=2.0)  # tracked through stiction, runout, noise
    assert max(f for _, f in first) < 30.0
    assert len(first) == 301  # t = 0 to 1.5 s every 5 ms, none lost
    assert first == second  # same seed: the same floats at the same stamps


def test_lockstep_steps_only_on_the_answer_to_the_state_it_waits_on(ros, spawn):
    """A lock-step plant takes a force command only when it is stamped with the state the
    plant waits on: a late, repeated or stranger's answer (another stamp) is counted and
    does not step the loop, so it can neither stop nor shift it (issue 21 item 10)."""
    from diagnostic_msgs.msg import DiagnosticArray

    spawn(PLANT + ["-p", "lockstep_timeout_s:=3.0", "-p", "force_command_owner:=answers"])  # this test answers
    wrenches = ros.collect(WrenchStamped, "/plant/wrench", KEEP, publishers=1)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    node = ros.node("answers")
    commands = node.create_publisher(ForceAxisCommand, "/plant/force_axis_command", 10)
    wait_until(lambda: commands.get_subscription_count() >= 1, 15.0, what="the plant")

    def answer(stamp_s: float) -> None:
        command = ForceAxisCommand(position_mm=-2.0)
        command.header.stamp.sec, command.header.stamp.nanosec = int(stamp_s), round(stamp_s % 1 * 1e9)
        commands.publish(command)

    answer(5.0)  # no state is stamped 5 s
    wait_until(lambda: int(_plant_counter(diagnostics, "stale_force_commands") or 0) == 1 and wrenches, 10.0,
               what="the stale answer counted")
    assert {_stamp_s(w) for w in wrenches} == {0.0}  # re-sent while unanswered, never stepped
    answer(0.0)
    wait_until(lambda: _stamp_s(wrenches[-1]) == pytest.approx(0.005), 5.0, what="one step")
    answer(0.0)  # the same answer again (one writer: it arrives before the next)
    answer(0.005)
    wait_until(lambda: _stamp_s(wrenches[-1]) == pytest.approx(0.01), 5.0, what="the next step")
    # (checked before lockstep_timeout_s passes: then a plant whose controller fell silent runs free)
    assert sorted({round(_stamp_s(w), 6) for w in wrenches}) == [0.0, 0.005, 0.01]
    wait_until(lambda: int(_plant_counter(diagnostics, "stale_force_commands") or 0) == 2, 5.0,
               what="the repeated answer counted")
    # silent for lockstep_timeout_s: the plant runs free on the wall clock (its free run's timer
    # is started only then), a period every 5 ms with the held command
    wait_until(lambda: _stamp_s(wrenches[-1]) >= 0.1, 30.0, what="the free run")


def test_realtime_mode_keeps_its_rate_and_the_struts_follow(ros, spawn):
    """Sim time keeps pace with the wall clock: judged on the plant's own publish times (the
    DDS source timestamps), not on when this process gets to read the messages, which
    drifts with the load. A period's lag behind its schedule is the publish time less the
    sim stamp; its least over each end of a window of 2 s or more is the schedule's offset
    there, so a plant that keeps pace shows the same offset at both ends, late timer ticks
    aside. A plant starved of a core at the window's end (a fresh clone's CI, its colcon build
    beside three workers: 0.61 over 2 s) has caught up once it runs again: the window grows by
    a second at a time, up to 30 s; a slow plant's offset grows with it, and it fails."""
    spawn(["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "strut_command_owner:=strut_source"])
    states = ros.collect(JointState, "/plant/strut_states", KEEP)
    published: list[tuple[float, float]] = []  # (sim stamp s, the plant's publish time s)
    subscription = ros.node("rate_reader").create_subscription(
        WrenchStamped, "/plant/wrench", lambda msg, info: published.append(
            (_stamp_s(msg), info["source_timestamp"] * 1e-9)), KEEP)
    commands = ros.node("strut_source").create_publisher(JointState, "/plant/strut_command", 10)
    wait_until(lambda: commands.get_subscription_count() >= 1 and subscription.get_publisher_count() >= 1, 15.0,
               what="the plant")
    names = [f"strut_{i}" for i in range(6)]
    commands.publish(JointState(name=names, position=[2.6] * 6))  # inside the NIST stroke, 2.05 .. 3.35 m
    wait_until(lambda: states, 10.0, what="strut states")
    commands.publish(JointState(name=names, position=[2.61] * 6))
    start = len(published)

    def real_time_factor(span_s: float) -> float:
        wait_until(lambda: len(published) > start and published[-1][0] - published[start][0] >= span_s, 60.0,
                   what=f"{span_s:g} s of sim time")
        window = np.array(published[start:])
        sim_s, lag_s = window[:, 0], window[:, 1] - window[:, 0]
        first, last = sim_s < sim_s[0] + 0.5, sim_s > sim_s[-1] - 0.5
        drift_s = lag_s[last].min() - lag_s[first].min()
        return (sim_s[-1] - sim_s[0]) / (sim_s[-1] - sim_s[0] + drift_s)

    factors = []
    for span_s in range(2, 31):
        factors.append(real_time_factor(span_s))
        if factors[-1] == pytest.approx(1.0, rel=0.05):
            break
    assert factors[-1] == pytest.approx(1.0, rel=0.05), factors  # real-time factor 1
    sim_s = np.array(published[start:])[:, 0]
    # every 5 ms control period is published: none skipped, none repeated
    assert np.diff(sim_s) == pytest.approx(0.005, abs=1e-6)
    assert states[-1].position == pytest.approx([2.61] * 6, abs=1e-6)


def test_watchdog_retracts_on_sim_time_when_the_setpoint_ends(ros, spawn):
    """The trajectory ends at 0.6 s of sim time: the controller trips and ramps to its
    retracted limit over ramp_down_s (0.5 s); contact is lost within 0.1 s and stays lost."""
    run = _lockstep_run(ros, spawn, 1.5, trajectory_s=0.5)
    force_at = {round(s, 3): f for s, f in run}
    assert force_at[0.6] == pytest.approx(20.0, abs=3.0)
    assert all(f == 0.0 for s, f in run if s >= 0.7)


def test_the_pru3_head_follows_setpoints_through_the_kinematics_node(ros, spawn):
    """machine_file pru3 in both nodes: a tool setpoint (z 215 mm, alpha 0.08, beta -0.05 rad)
    becomes slider commands, and the head's dynamics under its drives carry the sliders
    there; a command the head cannot reach (sent once the kinematics node, the struts'
    owner, has left) is refused and counted, and a jump it can reach becomes a move within
    the sliders' speed limit (config/machines/pru3.yaml)."""
    import numpy as np
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PoseStamped
    from scipy.spatial.transform import Rotation

    from hex_control.config import config_file
    from hex_control.kinematics.pru3 import Pru3Geometry, inverse_kinematics

    machine = ["-p", f"machine_file:={config_file('machines/pru3.yaml')}"]
    # the struts obey the first node heard (the kinematics node), and the next once it has left
    spawn(["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "strut_command_owner:=''", *machine])
    kinematics = spawn(["hex-kinematics", "--ros-args", "-p", "use_sim_time:=true", "-p", "setpoint_owner:=pru3_source",
                        *machine])  # this test sends the setpoints
    states = ros.collect(JointState, "/plant/strut_states", KEEP)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    node = ros.node("pru3_source")
    setpoints = node.create_publisher(PoseStamped, "/motion/setpoint", 10)
    commands = node.create_publisher(JointState, "/plant/strut_command", 10)
    wait_until(lambda: setpoints.get_subscription_count() >= 1 and commands.get_subscription_count() >= 1, 15.0,
               what="the kinematics node and the plant")
    target = inverse_kinematics(Pru3Geometry(), np.array([215.0, 0.08, -0.05])).lengths_mm[0] / 1000.0
    setpoint = PoseStamped()
    setpoint.pose.position.z = 0.215
    (setpoint.pose.orientation.x, setpoint.pose.orientation.y, setpoint.pose.orientation.z,
     setpoint.pose.orientation.w) = Rotation.from_euler("xyz", [0.08, -0.05, 0.0]).as_quat()

    def settled():  # setpoints are a stream: keep sending while the graph finishes matching
        setpoints.publish(setpoint)
        return states and np.abs(np.array(states[-1].position) - target).max() < 1e-9
    wait_until(settled, 15.0, interval_s=0.05, what="the sliders to settle on the setpoint")
    assert list(states[-1].name) == ["strut_0", "strut_1", "strut_2"]
    kinematics.stop()  # the struts' owner leaves the graph: the next publisher takes over
    wait_until(lambda: commands.get_subscription_count() >= 1 and len(node.get_publishers_info_by_topic(
        "/plant/strut_command")) == 1, 15.0, what="the kinematics node to leave")
    commands.publish(JointState(name=["strut_0", "strut_1", "strut_2"], position=[0.0, 0.1, 0.1]))

    wait_until(lambda: _plant_counter(diagnostics, "rejected_strut_command") == "1", 5.0,
               what="the refused command to be counted")
    start = len(states)
    wait_until(lambda: len(states) > start + 20, 5.0, what="0.1 s more of the plant")
    assert np.abs(np.array(states[-1].position) - target).max() < 1e-9  # still where it was

    # a 30 mm jump of every slider (down in z): a move within the sliders' 200 mm/s
    start = len(states)
    commands.publish(JointState(name=["strut_0", "strut_1", "strut_2"], position=list(target - 0.03)))
    wait_until(lambda: np.abs(np.array(states[-1].position) - (target - 0.03)).max() < 1e-6, 10.0, what="the move")
    assert max(abs(v) for s in states[start:] for v in s.velocity) < 0.2 * 1.05  # the servos' lag adds little
    wait_until(lambda: int(_plant_counter(diagnostics, "limited_strut_commands") or 0) >= 15, 5.0,
               what="the limited periods counted")  # up to 0.2 m/s at 2 m/s^2: 0.1 s, 20 periods
    assert int(_plant_counter(diagnostics, "limited_strut_commands")) <= 30  # (braking is within the limits)


def test_a_held_strut_trajectory_is_followed_and_a_late_one_refused(ros, spawn):
    """Like ros2_control's joint trajectory controller: a JointTrajectory handed over before
    it starts is sampled at every control period once sim time reaches its stamp (the first
    point places the struts); one whose start sim time has passed is refused and counted."""
    import numpy as np
    from diagnostic_msgs.msg import DiagnosticArray
    from trajectory_msgs.msg import JointTrajectory

    from hex_control.ros.infra.interfaces import LATCHED, joint_trajectory_message, time_msg

    names = [f"strut_{i}" for i in range(6)]
    ramp = np.repeat(np.linspace(2.60, 2.62, 101)[:, None], 6, axis=1)  # 0.5 s at 5 ms, in stroke
    node = ros.node("trajectory_source")
    publisher = node.create_publisher(JointTrajectory, "/plant/strut_trajectory", LATCHED)
    publisher.publish(joint_trajectory_message(time_msg(0.2), names, 0.005, ramp))
    states = ros.collect(JointState, "/plant/strut_states", KEEP)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    spawn(PLANT + ["-p", "end_time_s:=1.0", "-p", "strut_command_owner:=trajectory_source"])  # holds at t = 0
    # until a controller answers
    ros.wait_for_match(node, "/plant/strut_states", publishers=1)
    ros.wait_for_match(node, "/plant/strut_trajectory", subscribers=1)
    spawn(CONTROLLER)
    wait_until(lambda: states and _stamp_s(states[-1]) >= 1.0 - 1e-9, 60.0, what="the end of the run")
    first = _stamp_s(states[0])
    assert first >= 0.2 - 1e-9  # nothing placed the struts before the trajectory began
    assert states[0].position == pytest.approx([2.60] * 6, abs=1e-9)
    assert states[-1].position == pytest.approx([2.62] * 6, abs=1e-5)  # followed through the servos
    publisher.publish(joint_trajectory_message(time_msg(0.5), names, 0.005, ramp[::-1]))

    wait_until(lambda: _plant_counter(diagnostics, "late_strut_trajectory") == "1", 5.0,
               what="the late trajectory to be counted")
    assert states[-1].position == pytest.approx([2.62] * 6, abs=1e-5)


def test_the_plant_enforces_its_own_limits_whoever_commands_it(ros, spawn):
    """Issue 21 item 3: 1000 mm on the force axis gave 7.9e4 N and a 50 m strut command drove
    every strut to 50 m. Now the table stops at its travel, the force trips the overload
    (150 N) and retracts the table until the command asks for no force, and a strut command
    outside the stroke is refused: the struts stay where they were; a jump inside it is
    made a move within the machine file's strut speed and acceleration."""
    from diagnostic_msgs.msg import DiagnosticArray

    spawn(["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "command_timeout_s:=10.0",
           "-p", "force_command_owner:=rogue", "-p", "strut_command_owner:=rogue"])  # this test commands
    forces = ros.collect(WrenchStamped, "/plant/true_wrench", KEEP)
    states = ros.collect(JointState, "/plant/strut_states", KEEP)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    node = ros.node("rogue")
    force_axis = node.create_publisher(ForceAxisCommand, "/plant/force_axis_command", 10)
    struts = node.create_publisher(JointState, "/plant/strut_command", 10)
    wait_until(lambda: force_axis.get_subscription_count() >= 1 and struts.get_subscription_count() >= 1, 15.0,
               what="the plant")
    names = [f"strut_{i}" for i in range(6)]
    struts.publish(JointState(name=names, position=[2.6] * 6))
    wait_until(lambda: states and states[-1].position[0] == pytest.approx(2.6, abs=1e-6), 10.0, what="the struts")

    def pushing():
        force_axis.publish(ForceAxisCommand(position_mm=1000.0))
        return _plant_counter(diagnostics, "overload_trips") == "1"
    wait_until(pushing, 15.0, interval_s=0.05, what="the overload trip")
    start = len(forces)
    wait_until(lambda: len(forces) > start + 100, 10.0, what="0.5 s more of the plant")
    assert max(f.wrench.force.z for f in forces) < 200.0  # 2 mm of travel: 166 N at most, tripped at 150
    assert forces[-1].wrench.force.z == 0.0  # held retracted while the command still pushes
    assert int(_plant_counter(diagnostics, "clamped_force_commands")) >= 1

    def backing_off():  # no force asked: the trip resets
        force_axis.publish(ForceAxisCommand(position_mm=-1.0))
        return _plant_counter(diagnostics, "overload_resets") == "1"
    wait_until(backing_off, 10.0, interval_s=0.05, what="the trip's reset")
    force_axis.publish(ForceAxisCommand(position_mm=0.3))
    wait_until(lambda: forces[-1].wrench.force.z > 15.0, 10.0, what="force again after the reset")

    struts.publish(JointState(name=names, position=[50.0] * 6))
    wait_until(lambda: _plant_counter(diagnostics, "rejected_strut_command") == "1", 5.0, what="the refusal")
    assert states[-1].position == pytest.approx([2.6] * 6, abs=1e-6)

    start = len(states)  # a jump inside the stroke: a move within the servos' 500 mm/s
    struts.publish(JointState(name=names, position=[3.0] * 6))
    wait_until(lambda: states[-1].position[0] == pytest.approx(3.0, abs=1e-6), 10.0, what="the move")
    assert max(abs(v) for s in states[start:] for v in s.velocity) < 0.5 * 1.05  # the servo's lag adds little
    wait_until(lambda: int(_plant_counter(diagnostics, "limited_strut_commands") or 0) >= 150, 5.0,
               what="the limited periods counted")  # 0.4 m at 0.5 m/s: 0.8 s, 160 periods
    assert int(_plant_counter(diagnostics, "limited_strut_commands")) <= 200  # and none once there


def test_each_command_input_obeys_one_publisher_and_counts_the_others(ros, spawn):
    """Issue 21 item 3, command ownership: the force axis obeys the configured node
    (operator, named relative to the plant's namespace) only, even when a rogue publishes
    first; the struts obey the first node heard (''). A rogue's commands are refused and
    counted, and change nothing."""
    from diagnostic_msgs.msg import DiagnosticArray

    spawn(["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "command_timeout_s:=10.0",
           "-p", "force_command_owner:=operator", "-p", "strut_command_owner:=''"])
    forces = ros.collect(WrenchStamped, "/plant/true_wrench", KEEP)
    states = ros.collect(JointState, "/plant/strut_states", KEEP)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    operator, rogue = ros.node("operator"), ros.node("rogue")
    publishers = {(who, topic): who.create_publisher(msg_type, topic, 10) for who in (operator, rogue)
                  for topic, msg_type in (("/plant/force_axis_command", ForceAxisCommand),
                                          ("/plant/strut_command", JointState))}
    wait_until(lambda: all(p.get_subscription_count() >= 1 for p in publishers.values()), 15.0, what="the plant")
    names = [f"strut_{i}" for i in range(6)]

    def command(who, topic, msg, counter=None, until=None):
        def done():
            publishers[who, topic].publish(msg)
            return until() if until else _plant_counter(diagnostics, counter) not in (None, "0")
        wait_until(done, 10.0, interval_s=0.05, what=f"{topic} from {who.get_name()}")

    command(rogue, "/plant/force_axis_command", ForceAxisCommand(position_mm=0.3), "foreign_force_command")
    # the counter came on /diagnostics; this reader of the force may match the plant later
    wait_until(lambda: forces, 10.0, what="the plant's true force")
    assert max(f.wrench.force.z for f in forces) == 0.0  # refused although first
    command(operator, "/plant/force_axis_command", ForceAxisCommand(position_mm=0.3),
            until=lambda: forces[-1].wrench.force.z > 15.0)
    command(operator, "/plant/strut_command", JointState(name=names, position=[2.6] * 6),
            until=lambda: states and states[-1].position[0] == pytest.approx(2.6, abs=1e-6))

    refused = int(_plant_counter(diagnostics, "foreign_force_command"))
    command(rogue, "/plant/force_axis_command", ForceAxisCommand(position_mm=-5.0),
            until=lambda: int(_plant_counter(diagnostics, "foreign_force_command")) > refused)
    command(rogue, "/plant/strut_command", JointState(name=names, position=[2.61] * 6), "foreign_strut_command")
    start = len(forces)
    wait_until(lambda: len(forces) > start + 100, 10.0, what="0.5 s more of the plant")
    assert min(f.wrench.force.z for f in forces[start:]) > 15.0  # still pushed as the operator asked
    assert states[-1].position == pytest.approx([2.6] * 6, abs=1e-6)
    assert _plant_counter(diagnostics, "rejected_strut_command") is None  # refused as foreign, not as invalid


def test_every_command_input_names_its_owner_by_default(ros, spawn):
    """Issue 37 item 3, authority by configuration: in the graph the project starts each
    input obeys its node of the cell from the start, not the first publisher heard: a jog
    command sent before the force controller is up is refused, the controller's taken."""
    from diagnostic_msgs.msg import DiagnosticArray

    from hex_control.config import node_parameters
    from hex_control.ros.nodes.plant_setup import PARAMETERS

    owners = {"force_command_owner": "force_controller", "strut_command_owner": "kinematics",
              "force_trajectory_owner": "pass_planner", "controller_status_owner": "force_controller"}
    assert {name: PARAMETERS[name].default for name in owners} == owners
    assert {name: node_parameters("plant.yaml", "plant")[name] for name in owners} == owners

    spawn(["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "command_timeout_s:=10.0"])
    forces = ros.collect(WrenchStamped, "/plant/true_wrench", KEEP)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
    jog = ros.node("jog").create_publisher(ForceAxisCommand, "/plant/force_axis_command", 10)
    controller = ros.node("force_controller").create_publisher(ForceAxisCommand, "/plant/force_axis_command", 10)
    wait_until(lambda: jog.get_subscription_count() >= 1 and controller.get_subscription_count() >= 1, 15.0,
               what="the plant")

    def refused():
        jog.publish(ForceAxisCommand(position_mm=0.3))
        return _plant_counter(diagnostics, "foreign_force_command") not in (None, "0")
    wait_until(refused, 10.0, interval_s=0.05, what="the jog command refused")
    wait_until(lambda: forces, 15.0, what="the plant's true force")  # its stream may match after the refusal
    assert max(f.wrench.force.z for f in forces) == 0.0  # first, and still refused

    def obeyed():
        controller.publish(ForceAxisCommand(position_mm=0.3))
        return forces[-1].wrench.force.z > 15.0
    wait_until(obeyed, 10.0, interval_s=0.05, what="the force controller obeyed")


def test_the_events_executor_is_made_where_stderr_is_captured(capsys):
    """Issue 39: the job's observer spins on the graph's executor; rclpy's EventsExecutor
    enables faulthandler on sys.stderr, which a captured stderr (capsys here) cannot take."""
    import sys

    import rclpy
    from rclpy.context import Context

    from hex_control.ros.infra.runtime import make_executor

    context = Context()
    rclpy.init(context=context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
    captured = sys.stderr
    try:
        executor = make_executor(context=context)
        assert type(executor).__name__ == "EventsExecutor"
        assert sys.stderr is captured
        executor.shutdown()
    finally:
        context.try_shutdown()
