"""Force table model and the PI force loop (seed 002 section 7.2-7.3)."""

import math

import control
import numpy as np
import pytest

from hex_control.control.force_law import PIForceLaw
from hex_control.control.pi import TustinPI
from hex_control.plant.force_table import ForceTable, ForceTableParameters, simulate_force_loop

LINEAR = ForceTableParameters(stiction_n=0.0, contact_mm=-1.0)  # always in contact, no stiction


def test_compliance_is_k_theta_over_r_squared():
    """Eq. 7.1b: 6e5 N mm/rad on an 85 mm disk is 83.04 N/mm."""
    assert ForceTableParameters().stiffness_n_mm == pytest.approx(6e5 / 85**2)


def test_position_loop_poles_and_unit_gain():
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
    period = 0.005
    kp, ki = 0.002, 0.05  # mm/N, mm/(N s)
    k = LINEAR.stiffness_n_mm
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
    play = 4.8 / table.p.stiffness_n_mm
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
    assert np.max(forces) == pytest.approx(p.stiffness_n_mm * 0.02, rel=0.02)


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
    from hex_control.nodes.force_controller import PARAMETERS

    parameters = {name: spec.default for name, spec in PARAMETERS.items()}
    assert set(FORCE_LAWS) == {"pi", "energy_optimal"} == set(PARAMETERS["law"].choices)
    pi = make_force_law("pi", parameters, 0.005, (-2.0, 2.0))
    assert isinstance(pi, PIForceLaw) and pi.pi.kp == parameters["kp_mm_per_n"]
    assert isinstance(make_force_law("energy_optimal", parameters, 0.005, (-2.0, 2.0)), EnergyForceLaw)
    with pytest.raises(ValueError, match="law must be one of pi, energy_optimal"):
        make_force_law("bang_bang", parameters, 0.005, (-2.0, 2.0))
