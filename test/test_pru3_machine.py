"""The 3-PRU head as the plant's machine: seed 001's dynamics under the slider drives."""

import numpy as np
import pytest

from hex_control.kinematics.pru3 import Pru3Geometry, inverse_kinematics, velocity_jacobian
from hex_control.kinematics.pru3_dynamics import Pru3Inertia, actuator_dynamics, simulate
from hex_control.plant.machine import Machine, MachineParameters
from hex_control.plant.pru3_machine import Pru3Machine, _exponential

GEOMETRY, INERTIA = Pru3Geometry(), Pru3Inertia()
PARAMETERS = MachineParameters(struts=3, participation=1 / 3)
TILT_Q = np.array([215.0, 0.08, -0.05])  # z mm, alpha rad, beta rad


def _run(machine, commands_m, steps):
    lengths, deflection = [], []
    for _ in range(steps):
        machine.step(commands_m)
        lengths.append(machine.lengths_m.copy())
        deflection.append(machine.deflection_mm)
    return np.array(lengths), np.array(deflection)


def test_computed_torque_drive_is_the_generic_servo():
    """With the model exact, CTC cancels the dynamics: each slider answers a step as the
    generic second-order servo (30 Hz, zeta 0.9) and shakes the 5 Hz mode the same way."""
    pru3 = Pru3Machine(drive="ctc")
    generic = Machine(PARAMETERS)
    start = pru3.lengths_m
    generic.reset(start)
    command = inverse_kinematics(GEOMETRY, TILT_Q).lengths_mm[0] / 1000.0
    lengths, deflection = _run(pru3, command, 400)
    expected_lengths, expected_deflection = _run(generic, command, 400)
    step_mm = np.abs(command - start).max() * 1000.0
    assert step_mm > 5.0
    # holding J for 5 ms of a 16 mm step taken at full servo bandwidth (peak ~1 m/s): 0.4 %
    assert np.abs(lengths - expected_lengths).max() * 1000.0 < 5e-3 * step_mm
    assert np.abs(deflection - expected_deflection).max() < 2e-2 * np.abs(expected_deflection).max()
    np.testing.assert_allclose(pru3.pose_q, TILT_Q, atol=1e-4)


def test_link_space_pd_matches_adaptive_integration_of_the_unheld_dynamics():
    """Holding M, h and J for a 5 ms period against solve_ivp (RK45, rtol 1e-9) of the same
    drive law evaluated continuously: the sliders' paths agree to 0.5 % of a 16 mm step."""
    machine = Pru3Machine(drive="lspd")
    q0 = machine.pose_q.copy()
    command_mm = inverse_kinematics(GEOMETRY, TILT_Q).lengths_mm[0]
    kp, kv = machine.kp_n_per_mm, machine.kv_n_s_per_mm

    def drive(_t, q, q_dot):
        lengths = inverse_kinematics(GEOMETRY, q).lengths_mm[0]
        _, bias = actuator_dynamics(GEOMETRY, INERTIA, q, q_dot)
        return kp * (command_mm - lengths) - kv * velocity_jacobian(GEOMETRY, q)[0] @ q_dot + bias[0]

    times, q_ref, _ = simulate(GEOMETRY, INERTIA, q0, np.zeros(3), drive, duration_s=0.1, sample_s=0.005, rtol=1e-9,
                               atol=1e-9)
    reference_mm = inverse_kinematics(GEOMETRY, q_ref).lengths_mm
    lengths, _ = _run(machine, command_mm / 1000.0, 100)
    held_mm = np.vstack([machine_start_mm(q0), lengths[4::5] * 1000.0])
    move_mm = np.abs(command_mm - reference_mm[0]).max()
    assert np.abs(held_mm - reference_mm).max() < 5e-3 * move_mm
    assert np.abs(reference_mm[-1] - command_mm).max() < 0.01 * move_mm  # and it got there


def machine_start_mm(q):
    return inverse_kinematics(GEOMETRY, q).lengths_mm[0]


def test_link_space_pd_couples_the_sliders_and_holds_a_tilt_against_gravity():
    """One slider's step moves the others while the platform's inertia couples them (the
    generic servo keeps them apart); bias compensation leaves no sag at rest."""
    machine = Pru3Machine(drive="lspd")
    start = machine.lengths_m
    lengths, _ = _run(machine, start + np.array([2e-3, 0.0, 0.0]), 40)
    assert np.abs(lengths[:, 1:] - start[1:]).max() * 1000.0 > 5e-3  # µm-level coupling
    command = inverse_kinematics(GEOMETRY, TILT_Q).lengths_mm[0] / 1000.0
    _run(machine, command, 600)
    assert np.abs(machine.lengths_m - command).max() * 1000.0 < 1e-6
    assert np.abs(machine.speeds_m_s).max() < 1e-9


def test_bad_input_is_refused():
    machine = Pru3Machine()
    with pytest.raises(ValueError, match="3 finite"):
        machine.step([0.1, np.nan, 0.1])
    with pytest.raises(ValueError, match="drive"):
        Pru3Machine(drive="pid")
    with pytest.raises(ValueError, match="whole number"):
        Pru3Machine(step_s=1e-3, refresh_s=0.0025)
    with pytest.raises(ValueError, match="stroke"):
        machine.check_command([0.05, 0.05, 0.12])
    with pytest.raises(ValueError, match="tilt|rocker geometry"):  # in stroke, out of reach
        machine.check_command([0.0, 0.1, 0.1])
    machine.check_command(inverse_kinematics(GEOMETRY, TILT_Q).lengths_mm[0] / 1000.0)
    with pytest.raises(FloatingPointError, match="workspace"):
        _run(machine, [0.5, 0.5, 0.5], 200)  # sliders 500 mm up: the rockers cannot reach


def test_scaled_taylor_exponential_matches_scipy():
    from scipy.linalg import expm

    block = np.random.default_rng(1).normal(size=(12, 12)) * 20.0
    np.testing.assert_allclose(_exponential(block), expm(block), rtol=1e-9, atol=1e-9 * np.abs(expm(block)).max())


def test_on_a_feed_stage_the_fourth_joint_is_the_stage():
    geometry = Pru3Geometry(feed_stroke_mm=(-250.0, 450.0))
    machine = Pru3Machine(geometry)
    assert machine.p.struts == 4
    sliders = inverse_kinematics(geometry, TILT_Q).lengths_mm[0] / 1000.0
    command = np.append(sliders, 0.1)
    machine.check_command(command)
    with pytest.raises(ValueError, match="feed stage"):
        machine.check_command(np.append(sliders, 0.5))
    lengths, deflection = _run(machine, command, 800)
    np.testing.assert_allclose(lengths[-1], command, atol=1e-9)
    # the stage's own servo does not drive the mode: the same slider move rings it the same
    head = Pru3Machine()
    _, head_deflection = _run(head, sliders, 800)
    np.testing.assert_allclose(deflection, head_deflection, atol=1e-12)
