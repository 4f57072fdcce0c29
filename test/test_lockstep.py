"""The plant's behaviour without ROS (hex_control.plant.core, .lockstep; issue 38 item 1):
the lock-step gate, the cover of a pass, the free run of a silent controller, the strut
inputs and the amplifier's watchdog, in milliseconds. The ROS tests (test_plant_node.py)
check the same over real topics; these check the rules."""

import numpy as np
import pytest

from hex_control.grinding.contour import weld_bead
from hex_control.grinding.dynamic import DiskModel
from hex_control.grinding.variation import ProcessVariation
from hex_control.plant.core import CoreSettings, EventLog, PlantCore
from hex_control.plant.grinding_cell import GrindingCell
from hex_control.plant.limits import ForceAxisLimits
from hex_control.plant.lockstep import LockstepGate, pass_covered, time_ns
from hex_control.plant.pass_monitor import PassMonitor, ScheduledPass
from hex_control.plant.simulator import PlantSimulator
from hex_control.plant.strut_trajectory import StrutTrajectory

PERIOD = 0.005
NAMES = [f"strut_{i}" for i in range(6)]
TIMEOUT = 1.0


class Clock:
    """A wall clock the test moves by hand (s)."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class Outputs:
    def __init__(self):
        self.states, self.holds, self.started, self.ended = [], [], [], []
        self.measurements = []  # (time s, measured force N)

    def measurement(self, time_s, measured_force_n):
        self.measurements.append((time_s, measured_force_n))

    def state(self, snapshot):  # right after its own period's measurement
        assert self.measurements[-1] == (snapshot.time_s, snapshot.measured_force_n)
        self.states.append(snapshot.time_s)

    def hold(self, snapshot):
        self.holds.append(snapshot.time_s)

    def pass_started(self, scheduled):
        self.started.append(scheduled)

    def pass_ended(self, report):
        self.ended.append(report)


def stroke_check(lengths_m):
    if not all(2.0 <= v <= 3.4 for v in lengths_m):
        raise ValueError(f"out of stroke: {lengths_m}")


def make_core(mode="lockstep", grinding=False, wait_for_controller=True, end_time_s=0.0, command_timeout_s=0.1, *,
              plan_ahead_s=0.0):
    clock, outputs, events = Clock(), Outputs(), EventLog()
    settings = CoreSettings(mode, PERIOD, 1.0, command_timeout_s, -5.0, -1.0, end_time_s, wait_for_controller,
                            plan_ahead_s)
    monitor = None
    if grinding:  # the pass bookkeeping only: the workpiece is not on this simulator
        monitor = PassMonitor(GrindingCell(weld_bead(60.0, 0.8, seed=1), DiskModel(), ProcessVariation(0.0, 0.0)))
    core = PlantCore(settings, PlantSimulator(seed=3), axis_limits=ForceAxisLimits(), outputs=outputs, events=events,
                     strut_names=NAMES, monitor=monitor, check_struts=stroke_check, clock=clock)
    core.publish_state()
    return core, outputs, events, clock


def answer(core, stamp_s=None, position_mm=-2.0):
    """The controller's answer to the state the plant waits on (or to another stamp)."""
    core.on_force_command(position_mm, time_ns(core.sim.time_s if stamp_s is None else stamp_s))


def ramp(start_s, seconds=1.0):
    t = np.arange(0.0, seconds + 1e-9, PERIOD)
    return StrutTrajectory(start_s, t, np.repeat(np.linspace(2.60, 2.62, t.size)[:, None], 6, axis=1))


def test_the_measurement_goes_out_before_the_machine_steps_and_a_failed_step_stops_nothing():
    """The wrench the controller answers leaves as soon as the force table has stepped; the
    struts step after it (the controller computes meanwhile). A step that then fails (the
    tool beyond the forward kinematics) is counted, its state never sent, and the answer to
    its measurement steps the loop on."""
    core, outputs, events, _ = make_core()
    core.on_strut_command([], [2.6] * 6, 0.0)
    machine_step = core.sim.machine.advance
    seen = []

    def advance(commands_m, steps):
        seen.append(outputs.measurements[-1][0])  # the period's measurement is already out
        if len(seen) == 2:
            raise ValueError("forward kinematics did not converge")
        machine_step(commands_m, steps)

    core.sim.machine.advance = advance
    answer(core)
    answer(core)
    assert seen == pytest.approx([0.005, 0.01]) and events.counts == {"simulation_errors": 1}
    assert outputs.states == pytest.approx([0.0, 0.005])  # not the failed period's
    answer(core)
    assert [t for t, _ in outputs.measurements] == pytest.approx([0.0, 0.005, 0.01, 0.015])
    assert outputs.states[-1] == pytest.approx(0.015) and core.gate.timing.missed == 0


def test_the_plants_own_work_after_the_measurement_is_not_the_controllers_silence():
    """The watchdog times the controller from the end of the period, not from the
    measurement: a rest of the period that takes longer than the timeout (a loaded machine, a
    scan) runs nobody free, and the answer that then comes steps the loop."""
    core, outputs, events, clock = make_core()
    core.on_strut_command([], [2.6] * 6, 0.0)
    answer(core)
    machine_step = core.sim.machine.advance

    def slow_advance(commands_m, steps):
        clock.now += 2 * TIMEOUT  # the struts and the part take 2 s of wall time
        machine_step(commands_m, steps)

    core.sim.machine.advance = slow_advance
    answer(core)
    core.lockstep_watchdog(TIMEOUT)
    assert not core.gate.free_running and "lockstep_timeouts" not in events.counts
    answer(core)
    assert outputs.states[-1] == pytest.approx(0.015) and not core.gate.free_running
    assert core.gate.timing.latencies_s[-1] == pytest.approx(2 * TIMEOUT)  # it counts from the measurement
    clock.now += TIMEOUT  # now the controller is silent for the whole timeout
    core.lockstep_watchdog(TIMEOUT)
    assert core.gate.free_running and events.counts["lockstep_timeouts"] == 1


def test_a_lost_answer_is_asked_for_again_before_the_plant_runs_free():
    """A quarter of the timeout after its period, the waiting measurement goes out once more
    (a flood on the topic can push the answer out of the plant's queue; the controller
    answers a repeat with the same command), and the answer to it steps the loop as the
    first would have. Silent for the whole timeout, the plant runs free."""
    core, outputs, events, clock = make_core()
    answer(core)
    clock.now += TIMEOUT / 8
    core.lockstep_watchdog(TIMEOUT)
    assert len(outputs.measurements) == 2  # not yet
    clock.now += TIMEOUT / 4
    core.lockstep_watchdog(TIMEOUT)
    core.lockstep_watchdog(TIMEOUT)
    assert outputs.measurements[1:] == [outputs.measurements[1]] * 2 and events.counts["measurements_resent"] == 1
    answer(core)
    assert outputs.states[-1] == pytest.approx(0.01) and not core.gate.free_running
    clock.now += TIMEOUT
    core.lockstep_watchdog(TIMEOUT)
    assert events.counts == {"measurements_resent": 2, "lockstep_timeouts": 1} and core.gate.free_running



def test_the_plants_own_stand_is_not_the_controllers_silence_but_silence_still_times_out():
    """The watchdog ticks every quarter of the timeout. A tick late by more than a tick means
    the plant itself stood (stopped, swapped out): that time is set aside, and the answer sent
    meanwhile steps the loop when it comes. A controller silent tick after tick still runs the
    plant free after the whole timeout."""
    core, outputs, events, clock = make_core()
    answer(core)
    core.watchdog_tick(TIMEOUT)
    clock.now += 3 * TIMEOUT  # the plant stopped for three timeouts
    assert core.watchdog_tick(TIMEOUT) is False and events.counts["plant_stalls"] == 1
    assert "lockstep_timeouts" not in events.counts
    answer(core)  # what the controller had sent comes
    assert outputs.states[-1] == pytest.approx(0.01) and not core.gate.free_running
    for _ in range(3):  # now the controller is silent, the plant on time
        clock.now += TIMEOUT / 4
        assert core.watchdog_tick(TIMEOUT) is False
    clock.now += TIMEOUT / 4
    assert core.watchdog_tick(TIMEOUT) is True and events.counts["lockstep_timeouts"] == 1
    assert events.counts["plant_stalls"] == 1


def test_a_silent_controller_times_out_even_when_every_tick_comes_late():
    """Each late tick sets aside all but one tick of its gap: a plant that stands between
    all its ticks still runs free after about four of them when nobody answers."""
    core, outputs, events, clock = make_core()
    answer(core)
    core.watchdog_tick(TIMEOUT)
    free = []
    for _ in range(6):
        clock.now += 3 * TIMEOUT
        free.append(core.watchdog_tick(TIMEOUT))
    assert free == [False, False, False, True, True, True] and events.counts["lockstep_timeouts"] == 1


def test_a_stand_before_the_wait_began_leaves_the_wait_whole():
    """Only the part of the plant's stand after the state went out is set aside: a wait that
    began after the stand is the controller's from its start."""
    core, outputs, events, clock = make_core()
    answer(core)
    core.watchdog_tick(TIMEOUT)
    clock.now += 3 * TIMEOUT  # stood; on going on, the answer came first and a new state went out
    answer(core)
    clock.now += 0.9 * TIMEOUT
    assert core.watchdog_tick(TIMEOUT) is False  # the stall's tick: 0.9 of the timeout waited
    clock.now += 0.1 * TIMEOUT
    assert core.watchdog_tick(TIMEOUT) is True and events.counts["lockstep_timeouts"] == 1

def test_lockstep_steps_only_on_the_answer_to_the_state_it_waits_on():
    core, outputs, events, _ = make_core()
    assert outputs.states == [0.0]
    answer(core, 5.0)  # no state is stamped 5 s
    assert events.counts == {"stale_force_commands": 1} and outputs.states == [0.0]
    answer(core)
    assert outputs.states == pytest.approx([0.0, 0.005])
    answer(core, 0.0)  # the same answer again: it answers another state now
    assert events.counts["stale_force_commands"] == 2 and len(outputs.states) == 2
    answer(core)
    assert outputs.states == pytest.approx([0.0, 0.005, 0.01])
    core.on_force_command(float("nan"), time_ns(core.sim.time_s))
    core.on_force_command(-2.0, None)  # a stamp that is no stamp
    assert events.counts["rejected_force_command"] == 1 and events.counts["stale_force_commands"] == 3
    assert len(outputs.states) == 3


def test_a_state_is_sent_again_until_the_first_answer_then_silence_runs_free():
    core, outputs, events, clock = make_core()
    clock.now += TIMEOUT / 2
    core.lockstep_watchdog(TIMEOUT)
    assert outputs.states == [0.0]  # not yet
    clock.now += TIMEOUT
    core.lockstep_watchdog(TIMEOUT)
    assert outputs.states == [0.0, 0.0] and "lockstep_timeouts" not in events.counts  # said again
    answer(core)
    assert core.gate.started and outputs.states[-1] == pytest.approx(0.005)
    assert core.free_run() is False  # an answering controller: no free run (the node's timer stops)
    assert len(outputs.states) == 3
    clock.now += TIMEOUT
    assert core.lockstep_watchdog(TIMEOUT) is True  # the node starts the free run's timer
    assert events.counts["lockstep_timeouts"] == 1 and "free_running" in events.faults
    assert outputs.states[-1] == pytest.approx(0.01)  # advanced with the held command
    assert all(core.free_run() for _ in range(3))
    assert outputs.states[-1] == pytest.approx(0.025)
    core.on_force_command(-1.5, time_ns(1234.0))  # free running: any command is taken, answers the state
    assert not core.gate.free_running and "free_running" not in events.faults and core.command_mm == -1.5
    assert outputs.states[-1] == pytest.approx(0.03)  # and the lock-step resumes: no more free steps
    assert core.free_run() is False and core.lockstep_watchdog(TIMEOUT) is False
    assert outputs.states[-1] == pytest.approx(0.03)


def test_between_passes_the_clock_stands_still_until_a_pass_is_covered():
    """With a workpiece, sim time advances only while a pass runs or is announced with its
    whole path's strut trajectory held and its force trajectory in the controller's hands:
    the time a pass waits for is the planner's start_delay_s, whatever the wall clock did."""
    core, outputs, events, clock = make_core(grinding=True)
    answer(core)
    assert outputs.states == [0.0] and outputs.holds == [0.0]  # holding: said once where
    clock.now += 100.0
    core.lockstep_watchdog(TIMEOUT)
    core.free_run()
    assert outputs.states == [0.0] and outputs.holds == [0.0] and "lockstep_timeouts" not in events.counts
    scan_s, start_delay_s = 0.0, 0.6  # the pass planner starts the pass start_delay_s after the scan
    scheduled = ScheduledPass("job", 0, scan_s + start_delay_s, 0.7, 0.8, 0.9)
    core.on_pass_announced(scheduled)
    core.on_strut_trajectory(ramp(0.65))  # starts after the path: does not cover it
    core.on_controller_status("trajectory", {"job_id": "job", "pass_index": "0"})
    assert outputs.states == [0.0] and events.counts["passes_announced"] == 1
    core.on_strut_trajectory(ramp(0.5, 0.3))  # from before the path, but ends before it does
    assert outputs.states == [0.0]
    core.on_strut_trajectory(ramp(0.55, 0.4))  # the whole path (a shaped path starts early)
    assert outputs.states == pytest.approx([0.0, 0.005])
    while core.sim.time_s < 1.0:
        answer(core)
    assert [s.pass_index for s in outputs.started] == [0]
    assert outputs.states[-1] == pytest.approx(1.0)
    assert core.sim.strut_commands_m == pytest.approx([2.62] * 6, abs=1e-4)  # the trajectory was followed


def test_after_a_scan_the_clock_runs_on_plan_ahead_s_then_stands():
    """Issue 39: after the scan that ends a pass the plant runs on ``plan_ahead_s`` while the
    next pass is planned (its path starts start_delay_s after the scan, later than that), and
    stands there until the pass is covered; not before the first pass (the job's start)."""
    core, outputs, events, _ = make_core(grinding=True, plan_ahead_s=0.2)
    answer(core)
    assert outputs.states == [0.0] and outputs.holds == [0.0]  # no scan yet: the planners' first plan
    core.on_pass_announced(ScheduledPass("job", 0, 0.6, 0.7, 0.8, 0.9))
    core.on_strut_trajectory(ramp(0.55, 0.4))
    core.on_controller_status("trajectory", {"job_id": "job", "pass_index": "0"})
    while not outputs.ended:
        answer(core)
    scan_s = outputs.ended[0].end_s
    for _ in range(100):
        answer(core)
    assert outputs.states[-1] == pytest.approx(scan_s + 0.2) and outputs.holds[-1] == pytest.approx(scan_s + 0.2)
    assert len(outputs.holds) == 2  # standing: said once
    start_s = scan_s + 0.6  # the pass planner's start_delay_s after the scan
    core.on_pass_announced(ScheduledPass("job", 1, start_s, start_s + 0.1, start_s + 0.2, start_s + 0.3))
    core.on_strut_trajectory(ramp(start_s - 0.05, 0.4))
    core.on_controller_status("trajectory", {"job_id": "job", "pass_index": "1"})
    answer(core)
    assert outputs.states[-1] > scan_s + 0.2 + 1e-6 and "late_strut_trajectory" not in events.counts  # on again
    with pytest.raises(ValueError, match="plan_ahead_s"):
        CoreSettings("lockstep", PERIOD, 1.0, 0.1, -5.0, -1.0, 0.0, True, -0.1)


def test_a_pass_waits_for_the_controller_to_hold_it_unless_told_not_to():
    held = [ramp(0.5)]
    scheduled = ScheduledPass("job", 2, 0.6, 0.7, 0.8, 0.9)
    assert not pass_covered(scheduled, held, [("job", 1), ("other", 2)], True)
    assert pass_covered(scheduled, held, [("job", 2)], True)
    assert pass_covered(scheduled, held, [], False)
    assert not pass_covered(None, held, [("job", 2)], True)
    core, outputs, events, _ = make_core(grinding=True, wait_for_controller=False)
    core.on_pass_announced(scheduled)
    core.on_strut_trajectory(ramp(0.5))
    answer(core)
    assert outputs.states == pytest.approx([0.0, 0.005]) and outputs.holds == []
    core.on_controller_status("watchdog", {"pass_index": "2"})
    core.on_controller_status("trajectory", {"pass_index": "two"})
    core.on_controller_status("trajectory", {"pass_index": "\u00b2"})  # a digit to isdigit, not to int
    core.on_controller_status("trajectory", {"pass_index": "1" * 5000})  # beyond int's digits
    assert events.counts["ignored_controller_status"] == 4


def test_strut_commands_are_applied_when_sim_time_reaches_their_stamps():
    core, outputs, events, _ = make_core()
    core.on_strut_command(NAMES, [2.6] * 6, 0.0)  # now: placed at once
    assert core.sim.strut_commands_m == pytest.approx([2.6] * 6)
    core.on_strut_command(NAMES[::-1], [2.61] * 5 + [2.7], 0.01)  # by name, in any order: strut_0 gets 2.7
    core.on_strut_command([], [2.62] * 6, 0.02)  # no names: the machine's order
    core.on_strut_command(NAMES, [2.65] * 6, 0.015)  # stamped before the last queued: out of order
    assert events.counts["rejected_strut_command"] == 1
    answer(core)
    answer(core)  # the periods from 0 and 0.005 s
    assert core.sim.strut_commands_m == pytest.approx([2.6] * 6)
    answer(core)  # the period from 0.01 s: the command stamped 0.01 s holds in it
    assert core.sim.strut_commands_m == pytest.approx([2.7] + [2.61] * 5)
    answer(core)
    answer(core)
    assert core.sim.strut_commands_m == pytest.approx([2.62] * 6)  # from 0.02 s
    for bad in ([50.0] * 6, [float("nan")] * 6):
        core.on_strut_command(NAMES, bad, 0.0)
    core.on_strut_command(["strut_0"], [2.6], 0.0)  # names missing
    assert events.counts["rejected_strut_command"] == 4
    assert core.sim.strut_commands_m == pytest.approx([2.62] * 6)


def test_a_strut_trajectory_that_arrives_after_its_start_is_refused_and_a_later_one_replaces_the_rest():
    core, outputs, events, _ = make_core()
    for _ in range(4):
        answer(core)
    core.on_strut_trajectory(ramp(0.01))  # sim time is 0.02: never jump into a move part-way
    assert events.counts["late_strut_trajectory"] == 1 and core.trajectories == []
    core.on_strut_trajectory(ramp(0.5))
    core.on_strut_trajectory(ramp(1.0))
    core.on_strut_trajectory(ramp(0.8))  # replaces whatever the held ones would do from 0.8 s on
    assert [t.start_s for t in core.trajectories] == [0.5, 0.8]
    core.on_strut_trajectory(StrutTrajectory(1.0, np.array([0.0]), np.full((1, 6), 9.0)))  # out of stroke
    assert events.counts["rejected_strut_trajectory"] == 1 and events.counts["strut_trajectories"] == 3


def test_the_amplifier_watchdog_retracts_and_the_run_ends_at_its_end_time():
    core, outputs, events, clock = make_core(command_timeout_s=0.02, end_time_s=0.05)
    answer(core, position_mm=0.5)
    clock.now += TIMEOUT
    core.lockstep_watchdog(TIMEOUT)  # the controller falls silent: free running with the held command
    for _ in range(3):
        core.free_run()
    assert core.command_mm == 0.5  # 0.02 s old: still held
    core.free_run()
    assert core.command_mm == -5.0  # older than command_timeout_s: driven to the retract stop
    # 0.035 to 0.05 s; the step that reaches the end time says no more is due (the timer stops)
    assert [core.free_run() for _ in range(5)] == [True, True, True, False, False]
    assert outputs.states[-1] == pytest.approx(0.05) and core.loop_end_s == clock.now  # stopped there


def test_realtime_steps_the_periods_due_on_the_wall_clock():
    core, outputs, events, clock = make_core(mode="realtime")
    core.realtime_tick()
    assert outputs.states == pytest.approx([0.0, 0.005])
    clock.now += 3 * PERIOD  # a late tick steps the periods it owes
    core.realtime_tick()
    assert outputs.states[-1] == pytest.approx(0.02) and core.pacer.late_ticks == 1
    core.on_force_command(0.3, None)  # any command is taken in real time
    assert core.command_mm == 0.3 and "stale_force_commands" not in events.counts


def test_the_first_answer_starts_the_loop_timing():
    gate, now = LockstepGate(), 5.0
    assert not gate.answer(now)  # nothing sent: not an answer
    gate.sent(now)
    assert gate.answer(now + 0.001) and gate.started and gate.loop_start_s == now + 0.001
    assert gate.timing.latencies_s == []  # start-up is not the loop
    assert LockstepGate.answers(time_ns(0.005), 0.005) and not LockstepGate.answers(None, 0.0)
