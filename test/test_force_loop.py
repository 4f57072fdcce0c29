"""Force table model and the PI force loop (seed 002 section 7.2-7.3); and below,
ForceLoop (hex_control.control.force_loop), the force controller's supervisor without ROS,
closed on the plant's force table in lock-step: what test_force_controller_node checks over
real topics (watchdog trip and ramp, bumpless restart, saturation, F_max ceiling, repeated
answers, clock jumps), touch-down, and issue 37's hardening (plans, setpoints, stamps, the
ceiling, overload back-off), in milliseconds."""

import math

import numpy as np
import pytest

from hex_control.control.force_law import PIForceLaw
from hex_control.control.force_loop import ForceLoop, ForceLoopSettings, Tally
from hex_control.control.pi import TustinPI
from hex_control.plant.force_table import ForceTable, ForceTableParameters, simulate_force_loop
from hex_control.plant.limits import ForceAxisLimits

LINEAR = ForceTableParameters(stiction_n=0.0, contact_mm=-1.0)  # always in contact, no stiction


def test_compliance_is_k_theta_over_r_squared():
    """Eq. 7.1b: 6e5 N mm/rad on an 85 mm disk is 83.04 N/mm."""
    assert ForceTableParameters().stiffness_n_per_mm == pytest.approx(6e5 / 85**2)


def test_position_loop_poles_and_unit_gain():
    import control  # here, not at every worker's collection: 1 s with the matplotlib it loads
    table = ForceTable(LINEAR, step_s=1e-4)
    positions = []
    for _ in range(5000):
        table.step(1.0)
        positions.append(table.position_mm)
    w1, w2 = 2 * math.pi * 9, 2 * math.pi * 40
    reference = control.tf([w1 * w2], np.polymul([1, w1], [1, w2]))
    _, expected = control.step_response(reference, T=np.arange(0, 5001) * 1e-4)  # T[0] is t = 0
    np.testing.assert_allclose(positions, np.squeeze(expected)[1:], atol=1e-9)


def test_linear_closed_loop_matches_python_control():
    """PI (Tustin) + 2-pole table + compliance + 2-pole sensor, sampled at 200 Hz: rise time
    and overshoot of the measured force equal python-control's sampled-data prediction. The
    traces differ by the simulation's holding of the force into the sensor over each internal
    step, an error first order in that step: 0.067 N at 1 ms, 0.0067 N at 0.1 ms."""
    import control  # here, not at every worker's collection: 1 s with the matplotlib it loads
    period = 0.005
    kp, ki = 0.002, 0.05  # mm/N, mm/(N s)
    k = LINEAR.stiffness_n_per_mm
    b1, b2, w = 2 * math.pi * 9, 2 * math.pi * 40, 2 * math.pi * 30
    table_tf = control.tf([b1 * b2 * k], np.polymul([1, b1], [1, b2]))
    sensor_tf = control.tf([w * w], [1, 2 * 0.707 * w, w * w])
    plant = control.sample_system(table_tf * sensor_tf, period, method="zoh")
    pi_tf = control.sample_system(control.tf([kp, ki], [1, 0]), period, method="tustin")
    loop = control.feedback(pi_tf * plant, 1)
    t_ref, y_ref = control.step_response(loop * 20.0, T=np.arange(0, 4.0, period))
    expected = control.step_info(np.squeeze(y_ref), t_ref)
    table = ForceTable(LINEAR, step_s=period / 5)
    table.reset(-1.0)  # at the contact point: zero force
    pi = TustinPI(kp, ki, period)
    pi.reset(-1.0)  # bumpless start from the held table position
    log = simulate_force_loop(table, PIForceLaw(pi), lambda _t: 20.0, period, 4.0)
    got = control.step_info(log["measured"], log["time"])
    assert got["RiseTime"] == pytest.approx(expected["RiseTime"], rel=0.03)
    assert got["Overshoot"] == pytest.approx(expected["Overshoot"], abs=1.0)
    coarse = np.max(np.abs(log["measured"] - np.squeeze(y_ref)))
    table = ForceTable(LINEAR, step_s=period / 50)
    table.reset(-1.0)
    pi = TustinPI(kp, ki, period)
    pi.reset(-1.0)
    measured = simulate_force_loop(table, PIForceLaw(pi), lambda _t: 20.0, period, 4.0)["measured"]
    fine = np.max(np.abs(measured - np.squeeze(y_ref)))
    assert coarse < 0.1 and fine < coarse / 8  # 0.5 % of the step, shrinking with the step size


def test_stiction_makes_the_table_hesitate_on_reversal_and_contact_loss_gives_zero_force():
    table = ForceTable(ForceTableParameters(contact_mm=0.0), step_s=1e-3)
    play = 4.8 / table.p.stiffness_n_per_mm
    for _ in range(500):
        table.step(0.5)
    top = table.position_mm
    for _ in range(500):
        table.step(0.5 - 0.9 * play)  # back by less than the play: the table does not move
    assert table.position_mm == pytest.approx(top, abs=1e-9)
    for _ in range(500):
        table.step(-1.0)
    assert table.force_n == 0.0  # off the work: no pulling force


def test_runout_is_a_force_at_the_disk_frequency():
    p = ForceTableParameters(stiction_n=0.0, contact_mm=-1.0, runout_mm=0.02, disk_frequency_hz=35.0)
    table = ForceTable(p, step_s=1e-4)
    table.reset(-0.5)
    forces = []
    for _ in range(10_000):
        table.step(-0.5)
        forces.append(table.force_n)
    forces = np.array(forces) - np.mean(forces)
    spectrum = np.abs(np.fft.rfft(forces))
    frequency = np.fft.rfftfreq(len(forces), 1e-4)[np.argmax(spectrum)]
    assert frequency == pytest.approx(35.0, abs=0.2)
    assert np.max(forces) == pytest.approx(p.stiffness_n_per_mm * 0.02, rel=0.02)


def test_appendix_b_model_has_the_9_hz_pole_of_eq_7_3():
    """Eq. 7.2 re-derived from Fig. B-7 with the Appendix B constants (p_a = 1100 rad/s,
    z_a = 5000 rad/s): unit DC gain, a real pole at 9.0 Hz -- the dominant pole of the
    two-pole fit (7.3) -- and a well-damped pair far above it (313 Hz, damping 0.47)."""
    from hex_control.plant.force_table import appendix_b_position_loop
    num, den = appendix_b_position_loop()
    assert len(den) == 4 and len(num) == 2  # third order with one zero: K_G (s + z)/(s^3 + ...)
    assert np.polyval(num, 0) / np.polyval(den, 0) == pytest.approx(1.0, rel=1e-12)
    poles = np.roots(den)
    real = poles[np.abs(poles.imag) < 1e-9].real
    assert real.size == 1 and -real[0] / (2 * math.pi) == pytest.approx(9.0, abs=0.1)
    pair = poles[poles.imag > 0][0]
    assert abs(pair) / (2 * math.pi) == pytest.approx(313, rel=0.01)
    assert -pair.real / abs(pair) == pytest.approx(0.47, abs=0.01)
    assert -np.roots(num)[0] == pytest.approx(5000.0)


@pytest.mark.parametrize("kind", ["two_pole", "third_order"])
def test_the_plants_state_space_is_scipy_signals_bit_for_bit(kind):
    """The plant builds its table and machine without scipy.signal (0.4 s of its start): the
    canonical form and the zero-order hold are tf2ss's and cont2discrete's to the last bit."""
    from scipy.signal import cont2discrete, tf2ss

    from hex_control.control.discretize import controller_canonical, zero_order_hold
    from hex_control.plant.force_table import position_loop
    num, den = position_loop(kind)
    a, b, c, _ = tf2ss(num, den)
    mine = controller_canonical(num, den)
    assert all(np.array_equal(x, y) for x, y in zip(mine, (a, b, c[0])))
    ad, bd, *_ = cont2discrete((a, b, np.eye(len(a)), np.zeros((len(a), 1))), 1e-3, method="zoh")
    assert all(np.array_equal(x, y) for x, y in zip(zero_order_hold(*mine[:2], 1e-3), (ad, bd)))
    two_inputs = np.hstack([b, -2 * b])  # the machine's struts: several inputs
    ad, bd, *_ = cont2discrete((a, two_inputs, np.eye(len(a)), np.zeros((len(a), 2))), 1e-3, method="zoh")
    assert all(np.array_equal(x, y) for x, y in zip(zero_order_hold(a, two_inputs, 1e-3), (ad, bd)))


def test_third_order_table_tracks_like_the_two_pole_fit_at_low_frequency():
    """Both position loops: the same steady state, and a step response whose 63 % time is
    set by the 9 Hz pole (about 18 ms for one pole at 9 Hz; the 40 Hz pole of 7.3 adds 4 ms)."""
    times = {}
    for kind in ("two_pole", "third_order"):
        table = ForceTable(ForceTableParameters(stiction_n=0.0, contact_mm=-5.0, position_loop=kind), step_s=1e-4)
        table.reset(0.0)
        assert table.position_mm == pytest.approx(0.0)
        trace = []
        for _ in range(3000):
            table.step(1.0)
            trace.append(table.position_mm)
        assert trace[-1] == pytest.approx(1.0, abs=1e-3)
        times[kind] = (np.argmax(np.array(trace) >= 1 - math.exp(-1)) + 1) * 1e-4
    assert times["third_order"] == pytest.approx(1 / (2 * math.pi * 9.0), rel=0.05)
    assert times["two_pole"] == pytest.approx(times["third_order"] + 0.004, abs=0.002)
    with pytest.raises(ValueError, match="position_loop"):
        ForceTable(ForceTableParameters(position_loop="fourth"))


def test_force_laws_are_built_by_name_from_the_controllers_parameters():
    from hex_control.control.force_law import FORCE_LAWS, EnergyForceLaw, make_force_law
    from hex_control.ros.nodes.force_controller import PARAMETERS

    parameters = {name: spec.default for name, spec in PARAMETERS.items()}
    assert set(FORCE_LAWS) == {"pi", "energy_optimal"} == set(PARAMETERS["law"].choices)
    pi = make_force_law("pi", parameters, 0.005, (-2.0, 2.0))
    assert isinstance(pi, PIForceLaw) and pi.pi.kp == parameters["kp_mm_per_n"]
    assert isinstance(make_force_law("energy_optimal", parameters, 0.005, (-2.0, 2.0)), EnergyForceLaw)
    with pytest.raises(ValueError, match="law must be one of pi, energy_optimal"):
        make_force_law("bang_bang", parameters, 0.005, (-2.0, 2.0))


# -- the supervisor: ForceLoop (hex_control.control.force_loop) ----------------------------
PERIOD_NS = 5_000_000
S = 1_000_000_000  # ns
CELL = {"cell_force_max_n": 60.0, "max_force_n": 60.0, "stiffness_n_per_mm": 83.0, "contact_mm": 0.0,
        "overload_n": 150.0}
ITAE = {"kp_mm_per_n": 0.0098, "ki_mm_per_n_s": 0.48}  # the ROS tests' gains


def make_loop(**options) -> ForceLoop:
    return ForceLoop(ForceLoopSettings(**{**CELL, **ITAE, **options}), Tally())


class LockStep:
    """The ROS tests' stand-in without ROS: each command advances the table one control
    period (5 ms); then the plant says its state at the new time (wrench, setpoint from the
    schedule) and the loop answers it (trigger measurement) or ticks at it (trigger timer).
    ``limits``: the plant's own travel and overload trip below the controller."""

    def __init__(self, loop: ForceLoop, setpoint_at=lambda t: None, silent_from_s=math.inf, limits=None):
        self.loop, self.setpoint_at, self.silent_from_s, self.limits = loop, setpoint_at, silent_from_s, limits
        self.table = ForceTable(ForceTableParameters(stiction_n=0.0, contact_mm=0.0), step_s=0.001)
        self.table.reset(-2.0)
        self.time_ns = 0
        self.history = []  # (sim time s, command mm, force N) after each step
        self.nan_sent = False

    @property
    def time_s(self) -> float:
        return self.time_ns * 1e-9

    def state(self):
        """The next state's answer (a Command, or None)."""
        stamp = self.time_ns + PERIOD_NS
        setpoint = self.setpoint_at(self.time_s)
        if setpoint is not None:
            self.loop.on_setpoint(setpoint, stamp)
        if self.time_s < self.silent_from_s:
            answer = self.loop.on_measurement(self.table.measured_n, stamp, stamp)
        else:
            if not self.nan_sent:
                self.loop.on_measurement(math.nan, 0, stamp)
                self.nan_sent = True
            answer = None
        return answer if self.loop.measurement_triggered else self.loop.tick(stamp)

    def step(self, command) -> None:
        assert command is not None and command.stamp_ns == self.time_ns + PERIOD_NS  # lock-step: the answer
        position = command.position_mm
        for _ in range(5):
            applied = position if self.limits is None else self.limits.command_mm(position, self.table.force_n)
            self.table.step(applied)
        self.time_ns += PERIOD_NS
        self.history.append((self.time_s, position, self.table.force_n))

    def run_until(self, time_s: float) -> None:
        while self.time_s < time_s - 1e-9:
            self.step(self.state())

    def at(self, time_s: float):
        return next((command, force) for t, command, force in self.history if t >= time_s - 1e-9)


def test_tracks_a_force_step_then_the_watchdog_retracts_and_restarts_bumplessly():
    # 20 N for 3 s, no setpoint for 2 s (stale after 0.5 s, then a ramp to -2 mm over 0.5 s), 10 N again
    loop = make_loop()
    plant = LockStep(loop, lambda t: 20.0 if t < 3.0 else (10.0 if t >= 5.0 else None))
    plant.run_until(7.5)
    assert plant.at(3.0)[1] == pytest.approx(20.0, abs=1.0)
    assert max(c for _, c, _ in plant.history) <= 2.0 and min(c for _, c, _ in plant.history) >= -2.0
    assert plant.at(3.4)[1] == pytest.approx(20.0, abs=1.0)  # within the setpoint timeout: still tracking
    assert plant.at(4.1) == (-2.0, 0.0)  # retracted 0.5 s + 0.5 s after the last setpoint
    ramp = [c for t, c, _ in plant.history if 3.5 < t < 4.0 and c > -2.0]
    assert len(ramp) > 10 and np.allclose(np.diff(ramp), -4.0 * 0.005 / 0.5)  # the ramp: the whole range in ramp_down_s
    assert loop.report.counters["watchdog_trips"] == 1
    assert plant.at(7.5)[1] == pytest.approx(10.0, abs=1.0)  # fresh again
    assert loop.report.state == "tracking" and "watchdog" not in loop.report.faults
    # bumpless: the first tracking command starts from the held -2 mm (no jump to the old integral)
    restart = next(i for i, (t, _, _) in enumerate(plant.history) if t > 5.0)
    assert abs(plant.history[restart][1] - (-2.0)) < 0.2


def test_a_saturated_command_warns_until_it_comes_off_the_limit():
    loop = make_loop(overload_n=1e4, overforce_ratio=100.0)  # the work's return at +2 mm is a 166 N spike
    plant = LockStep(loop, lambda t: 20.0)
    plant.table.surface_mm = 5.0  # beyond the controller's +2 mm
    plant.run_until(1.5)
    assert "saturated at +2.00 mm" in loop.report.faults["saturated"]
    assert "measured 0.0 N" in loop.report.faults["saturated"]
    assert loop.report.counters["saturations"] == 1
    plant.table.surface_mm = None  # the work within reach again: contact at 0 mm
    plant.run_until(3.0)
    assert plant.at(3.0)[1] == pytest.approx(20.0, abs=1.0)
    assert loop.report.faults == {} and loop.report.counters["saturations"] == 1


def test_the_desired_force_is_limited_to_f_max():
    loop = make_loop()
    plant = LockStep(loop, lambda t: 100.0)
    plant.run_until(1.5)
    assert plant.at(1.5)[1] == pytest.approx(60.0, abs=1.5)
    assert max(force for _, _, force in plant.history) < 75.0
    assert loop.report.counters["clamped_setpoints"] > 0
    assert "limited to max_force_n 60" in loop.report.faults["ceiling"]


def test_stale_measurement_trips_and_nan_is_rejected():
    loop = make_loop()
    plant = LockStep(loop, lambda t: 15.0, silent_from_s=1.5)  # then one NaN, then nothing
    plant.run_until(2.5)
    assert plant.at(1.5)[1] == pytest.approx(15.0, abs=1.0)
    assert plant.at(2.2)[0] == -2.0  # stale after 0.1 s, ramped to retracted over 0.5 s
    assert loop.report.counters["watchdog_trips"] == 1 and loop.report.counters["rejected_measurement"] == 1


def test_a_state_sent_again_is_answered_again_without_stepping_the_loop():
    loop = make_loop(trigger="measurement")
    first = loop.on_measurement(0.0, 1 * S)
    integral = loop.law.pi.xi
    assert loop.on_measurement(0.0, 1 * S) is first  # the same answer, stamped with the state it answers
    assert loop.law.pi.xi == integral and loop.report.counters["answers_repeated"] == 1
    assert first.stamp_ns == 1 * S and first.position_mm == -2.0  # no setpoint: retracted


def test_negative_stamps_and_malformed_trajectories_are_refused():
    loop = make_loop(trigger="measurement")
    assert not loop.on_trajectory(-1, [0.0, 1.0], [10.0, 10.0]).accepted
    assert not loop.on_trajectory(0, [0.0, 0.0], [10.0, 10.0]).accepted  # not increasing
    assert not loop.on_trajectory(0, [0.0, 1.0], [10.0, math.nan]).accepted
    assert loop.on_measurement(0.0, -5 * S) is None
    assert loop.report.counters["rejected_trajectory"] == 3 and loop.report.counters["rejected_measurement"] == 1
    assert loop.on_measurement(0.0, 1 * S).position_mm == -2.0


def pass_trajectory(loop: ForceLoop, start_s: float = 1.0, force_n: float = 20.0, length_s: float = 2.0,
                    job_id: str = "job", *, pass_index: int = 0):
    return loop.on_trajectory(round(start_s * S), [0.0, length_s], [force_n, force_n], job_id, pass_index)


@pytest.mark.parametrize("trigger", ["timer", "measurement"])
def test_touch_down_then_the_pass_is_tracked_from_its_first_samples(trigger):
    loop = make_loop(trigger=trigger)
    assert pass_trajectory(loop, start_s=1.0).accepted
    plant = LockStep(loop)
    plant.run_until(0.99)
    assert plant.at(0.91)[0] == pytest.approx(-0.1, abs=1e-9)  # at the stand-off touch_settle_s before
    assert plant.at(0.5)[0] == -2.0  # held retracted while far from the start
    assert plant.at(0.8)[0] == pytest.approx(-1.1, abs=0.06)  # on the way since 0.71 s at touch_speed_mm_s
    plant.run_until(3.5)
    assert plant.at(1.3)[1] == pytest.approx(20.0, abs=2.0)  # in contact within 0.3 s of the start
    assert plant.at(3.3)[0] < -1.0  # over: retracted


def test_a_restarted_plant_drops_the_trajectory_after_one_confirmation():
    """Measurement stamps from 0 again (the plant restarted at 2 s): refused once, confirmed
    by the plant's re-send, the trajectory of the old timeline dropped and the loop retracted."""
    loop = make_loop(trigger="measurement")
    assert pass_trajectory(loop, start_s=0.5, length_s=10.0).accepted
    plant = LockStep(loop)
    plant.run_until(2.0)
    assert plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0)
    assert loop.on_measurement(20.0, PERIOD_NS) is None  # the restarted plant's first state: held
    answer = loop.on_measurement(20.0, PERIOD_NS)  # its re-send: a confirmed jump back
    assert answer is not None and loop.trajectory is None
    assert loop.report.counters["clock_jumps"] == 1 and loop.report.counters["rejected_stamp"] == 1
    assert "clock jumped -1.99" in loop.report.faults["clock_jump"]
    assert answer.position_mm < plant.history[-1][1]  # ramping back


def test_a_timer_clock_that_goes_back_drops_the_trajectory():
    loop = make_loop()
    assert pass_trajectory(loop, start_s=0.5, length_s=10.0).accepted
    plant = LockStep(loop)
    plant.run_until(1.0)
    loop.clock_jumped(-1.0)
    assert loop.trajectory is None and loop.report.counters["clock_jumps"] == 1
    loop.clock_jumped(+0.5)  # forward, same timeline: counted, nothing dropped
    assert loop.report.counters["clock_jumps"] == 2


# -- issue 37 ------------------------------------------------------------------------------
def test_a_trajectory_is_tracked_only_for_the_commanded_pass_within_f_max():
    loop = make_loop(require_pass_command=True)
    forged = pass_trajectory(loop, force_n=60.0, length_s=200.0, job_id="job", pass_index=1)
    assert not forged.accepted and "no accepted pass command" in forged.reason
    assert loop.trajectory is None and "latest: none" in loop.report.faults["trajectory"]
    loop.on_pass_command("job", 0)
    assert not pass_trajectory(loop, pass_index=1).accepted  # another pass than the one commanded
    assert not pass_trajectory(loop, job_id="other", pass_index=0).accepted  # another job
    too_hard = pass_trajectory(loop, force_n=61.0)
    assert not too_hard.accepted and "peak 61.0 N above max_force_n 60" in too_hard.reason
    assert pass_trajectory(loop, force_n=60.0).accepted and loop.trajectory.key == ("job", 0)
    assert "trajectory" not in loop.report.faults
    assert loop.report.counters["refused_trajectory"] == 4


def test_a_planned_trajectory_that_comes_before_its_command_waits_for_it():
    """A restarted controller hears both latched messages, in any order."""
    loop = make_loop(require_pass_command=True)
    assert not pass_trajectory(loop, pass_index=3).accepted
    assert loop.on_pass_command("job", 2) is None and loop.trajectory is None
    adopted = loop.on_pass_command("job", 3)
    assert adopted is not None and loop.trajectory is adopted and adopted.key == ("job", 3)


def test_without_require_pass_command_a_hand_made_trajectory_is_tracked():
    loop = make_loop()
    assert pass_trajectory(loop).accepted


def test_a_direct_setpoint_cannot_drop_a_held_trajectory():
    """Issue 37: one Float64 0.0 on ~/setpoint dropped the pass's trajectory."""
    loop = make_loop(trigger="measurement")
    assert pass_trajectory(loop, start_s=0.5, length_s=1.0).accepted
    plant = LockStep(loop)
    refused = loop.on_setpoint(0.0)  # pending (no time yet)
    assert not refused.accepted and "trajectory of job pass 0 is held" in refused.reason
    plant.run_until(1.0)
    assert not loop.on_setpoint(0.0).accepted  # running
    plant.run_until(1.4)
    assert plant.at(1.4)[1] == pytest.approx(20.0, abs=1.0)
    assert loop.report.counters["refused_setpoint"] == 2 and "setpoint 0 N refused" in loop.report.faults["setpoint"]
    plant.run_until(1.6)  # over: a jog may follow
    assert loop.on_setpoint(5.0).accepted and loop.trajectory is None


@pytest.mark.parametrize("ahead_s", [0.3, 0.04])
def test_one_wrench_stamped_ahead_is_not_a_clock_jump(ahead_s):
    """Issue 37: one wrench stamped +0.3 s (inside the old 1 s window) was taken as the next
    state, the plant's own then as a jump back: the trajectory dropped. Now a stamp beyond
    max_stamp_step_s (50 ms) is refused and not answered; one within it is answered, and so
    is the plant's own state after it (late): lock-step goes on, the trajectory is kept."""
    loop = make_loop(trigger="measurement")
    assert pass_trajectory(loop, start_s=0.5, length_s=10.0).accepted
    plant = LockStep(loop)
    plant.run_until(1.0)
    answer = loop.on_measurement(0.0, plant.time_ns + round(ahead_s * S))
    assert (answer is None) == (ahead_s > 0.05)
    plant.run_until(2.0)  # every state of the plant answered (LockStep.step asserts it)
    assert loop.trajectory is not None and plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0)
    counters = loop.report.counters
    assert counters["clock_jumps"] == 0 and "clock_jump" not in loop.report.faults
    assert counters["rejected_stamp"] == (1 if ahead_s > 0.05 else 0)
    assert counters["late_stamps"] == (0 if ahead_s > 0.05 else 1)


def test_max_force_cannot_exceed_the_cells_f_max():
    with pytest.raises(ValueError, match="the cell's F_max 60 N"):
        ForceLoopSettings(**{**CELL, "max_force_n": 61.0})
    loop = make_loop()
    assert "F_max is 60 N" in loop.settings.ceiling_refusal(10_000.0)
    assert loop.settings.ceiling_refusal(math.nan) and not loop.settings.ceiling_refusal(45.0)
    with pytest.raises(ValueError):
        loop.update(max_force_n=10_000.0)
    loop.update(max_force_n=45.0)
    assert loop.settings.max_force_n == 45.0
    with pytest.raises(ValueError, match="cannot change while the loop runs"):
        loop.update(kp_mm_per_n=1.0)


def test_after_an_overload_the_loop_backs_off_so_the_plant_can_reset():
    """Issue 37: the plant tripped at 152 N and stayed at 0 N, the controller pushing on into
    the retracted table. The work rises 1.5 mm under a 60 N pass: the plant's overload trips;
    the loop retracts at once and holds, the trip resets, and the next pass runs."""
    loop = make_loop(trigger="measurement")
    limits = ForceAxisLimits(travel_mm=(-5.0, 2.0), overload_n=150.0)
    assert pass_trajectory(loop, start_s=0.2, force_n=60.0, length_s=10.0).accepted
    plant = LockStep(loop, limits=limits)
    plant.run_until(1.0)
    assert plant.at(1.0)[1] == pytest.approx(60.0, abs=2.0)
    plant.table.surface_mm = -1.5
    plant.run_until(1.5)
    assert limits.trips == 1 and loop.report.counters["overloads"] == 1
    # the sensor saw 117 N of the 150 N spike, then no force: the trip, seen in part
    assert "contact lost right after 117 N" in loop.report.faults["overload"] and loop.trajectory is None
    assert plant.at(1.5) == (-2.0, 0.0) and not limits.tripped  # retracted: the plant's trip reset
    assert not pass_trajectory(loop, start_s=2.0, force_n=60.0).accepted  # the same pass again: no
    plant.table.surface_mm = None
    assert pass_trajectory(loop, start_s=2.0, force_n=40.0, length_s=2.0, pass_index=1).accepted  # the next
    assert "overload" not in loop.report.faults
    plant.run_until(3.0)
    assert plant.at(3.0)[1] == pytest.approx(40.0, abs=2.0) and limits.trips == 1


def test_a_force_far_above_the_ceiling_for_long_backs_off_too():
    loop = make_loop(trigger="measurement", overload_n=1000.0)
    for k in range(1, 11):
        loop.on_measurement(95.0, k * PERIOD_NS)  # > 1.5 x 60 N for 50 ms
    assert loop.backed_off is not None and "1.5 x max_force_n" in loop.report.faults["overload"]


def test_a_jog_re_arms_after_an_overload_only_once_its_setpoints_paused():
    loop = make_loop(trigger="measurement")
    loop.on_measurement(0.0, 1 * S)
    assert loop.on_setpoint(20.0).accepted
    loop.on_measurement(200.0, 1 * S + PERIOD_NS)
    assert loop.backed_off is not None
    assert not loop.on_setpoint(20.0).accepted  # the stream goes on: held retracted
    for k in range(2, 200):  # 1 s without setpoints
        assert loop.on_measurement(0.0, 1 * S + k * PERIOD_NS).position_mm == -2.0
    assert loop.on_setpoint(20.0).accepted and loop.backed_off is None


def test_the_force_controller_node_reads_the_cell_not_the_plant():
    """Issue 38: the node imported plant.force_table for its K_x and contact defaults. It
    takes F_max and K_x = K_theta / R^2 from config/cell.yaml, the table's contact and
    overload trip from config/plant.yaml (one source each), and imports no plant module."""
    import ast
    from pathlib import Path

    from hex_control.grinding.config import cell_value
    from hex_control.ros.nodes import force_controller

    tree = ast.parse(Path(force_controller.__file__).read_text())
    modules = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    modules += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert not [m for m in modules if m.startswith("hex_control.plant")]
    defaults = {name: spec.default for name, spec in force_controller.PARAMETERS.items()}
    assert defaults["max_force_n"] == cell_value("process.force_max_n") == 60.0
    assert defaults["stiffness_n_per_mm"] == pytest.approx(ForceTableParameters().stiffness_n_per_mm)
    assert (defaults["contact_mm"], defaults["overload_n"]) == (0.0, 150.0)


def test_a_stop_ends_the_pass_in_flight_and_the_force_ramps_to_zero():
    """Issue 37 item 7: after a cancel the pass already commanded was ground to the end. The
    sequence planner sends the pass again with ``stop``; the loop drops its trajectory and
    ramps the command to the retract stop (no watchdog fault: nothing failed), and a
    trajectory of that pass that comes later is refused."""
    loop = make_loop(require_pass_command=True)
    loop.on_pass_command("job", 0)
    assert pass_trajectory(loop, start_s=0.5, length_s=10.0).accepted
    plant = LockStep(loop)
    plant.run_until(2.0)
    assert plant.at(2.0)[1] == pytest.approx(20.0, abs=1.0)
    assert loop.on_pass_command("job", 1, stop=True) is None and loop.trajectory is not None  # not this pass
    loop.on_pass_command("job", 0, stop=True)
    assert loop.trajectory is None and loop.report.counters["passes_stopped"] == 1
    plant.run_until(3.0)
    assert plant.at(2.6) == (-2.0, 0.0)  # the whole range in ramp_down_s (0.5 s)
    assert "watchdog" not in loop.report.faults and loop.report.counters["watchdog_trips"] == 0
    late = pass_trajectory(loop, start_s=3.5)
    assert not late.accepted and "stopped" in late.reason


def test_the_end_of_a_pass_is_not_a_watchdog_fault():
    """Issue 40 item 6: the controller stayed at WARN 'stale setpoint' after every normal job."""
    loop = make_loop()
    assert pass_trajectory(loop, start_s=0.5, length_s=1.0).accepted
    plant = LockStep(loop)
    plant.run_until(2.5)
    assert plant.at(1.4)[1] == pytest.approx(20.0, abs=1.0)
    assert plant.at(2.1) == (-2.0, 0.0)  # over at 1.5 s, ramped down in 0.5 s
    assert loop.report.counters["watchdog_trips"] == 0
    assert "watchdog" not in loop.report.faults and loop.report.state == "idle"
