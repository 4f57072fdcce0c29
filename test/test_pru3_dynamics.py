"""Dynamics of the 3-PRU head (seed 001 section 2.2): virtual work against an independent
Lagrangian built from positions alone, inverse against forward dynamics, statics."""

import math

import numpy as np
import pytest

from hex_control.kinematics.pru3 import Pru3Geometry, inverse_kinematics, velocity_jacobian
from hex_control.kinematics.pru3_dynamics import (
    Pru3Inertia,
    actuator_dynamics,
    forward_dynamics,
    inverse_dynamics,
    simulate,
)
from hex_control.kinematics.rotation import rotation_matrix

GEOMETRY, INERTIA = Pru3Geometry(), Pru3Inertia()
OMEGA = 4 * math.pi  # rad/s, seed section 4.2


def seed_trajectory(t):
    """z = 220 mm, alpha = 0.15 cos(4 pi t), beta = 0.15 sin(4 pi t) (seed 4.2)."""
    t = np.atleast_1d(np.asarray(t, float))
    c, s = np.cos(OMEGA * t), np.sin(OMEGA * t)
    q = np.stack([np.full_like(t, 220.0), 0.15 * c, 0.15 * s], -1)
    q_dot = np.stack([0 * t, -0.15 * OMEGA * s, 0.15 * OMEGA * c], -1)
    q_ddot = np.stack([0 * t, -0.15 * OMEGA**2 * c, -0.15 * OMEGA**2 * s], -1)
    return q, q_dot, q_ddot


# -- an independent Lagrangian: positions only, every derivative a finite difference ------

def _frames(q):
    """Positions and orientations of every body at q (one configuration)."""
    pose = inverse_kinematics(GEOMETRY, q)
    full, joints, lengths = pose.full[0], pose.joints_mm[0], pose.lengths_mm[0]
    sliders = np.column_stack([GEOMETRY.rails_mm[:, :2], lengths])
    u = (joints - sliders) / GEOMETRY.rocker_length_mm
    n = GEOMETRY.plane_normals
    rockers = [np.column_stack([n[k], np.cross(u[k], n[k]), u[k]]) for k in range(3)]
    return full[:3], rotation_matrix(*full[3:]), (joints + sliders) / 2, rockers, lengths


def _kinetic(q, q_dot, eps=1e-5):
    ahead, behind, now = _frames(q + eps * q_dot), _frames(q - eps * q_dot), _frames(q)
    rate = [(a - b) / (2 * eps) if isinstance(a, np.ndarray) else [(x - y) / (2 * eps) for x, y in zip(a, b)]
            for a, b in zip(ahead, behind)]

    def spin(rotation, rotation_rate):
        w = rotation_rate @ rotation.T
        return np.array([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]]) / 2

    w_p = spin(now[1], rate[1])
    energy = 0.5 * INERTIA.platform_mass_kg * rate[0] @ rate[0] \
        + 0.5 * w_p @ now[1] @ np.diag(INERTIA.platform_inertia_kg_mm2) @ now[1].T @ w_p
    for k in range(3):
        w = spin(now[3][k], rate[3][k])
        frame = now[3][k]
        energy += 0.5 * INERTIA.rocker_mass_kg * rate[2][k] @ rate[2][k] \
            + 0.5 * w @ frame @ np.diag(INERTIA.rocker_inertia_kg_mm2) @ frame.T @ w
    return energy + 0.5 * INERTIA.slider_mass_kg * rate[4] @ rate[4]


def _potential(q):
    p, _, rockers, _, lengths = _frames(q)
    return INERTIA.gravity_mm_s2 * (INERTIA.platform_mass_kg * p[2] + INERTIA.rocker_mass_kg * rockers[:, 2].sum()
                                    + INERTIA.slider_mass_kg * lengths.sum())


def _mass_matrix(q):
    e = np.eye(3)
    t = [_kinetic(q, e[k]) for k in range(3)]
    m = np.diag([2 * v for v in t])
    for j in range(3):
        for k in range(j + 1, 3):
            m[j, k] = m[k, j] = _kinetic(q, e[j] + e[k]) - t[j] - t[k]
    return m


def _lagrangian_torque(q, q_dot, q_ddot, h=1e-3, eps=1e-4):
    """tau = J^-T (d/dt(M q') - dT/dq + dV/dq), J = dL/dq, all by central differences."""
    m = _mass_matrix(q)
    m_dot = (_mass_matrix(q + eps * q_dot) - _mass_matrix(q - eps * q_dot)) / (2 * eps)
    dt_dq, dv_dq, jac = np.zeros(3), np.zeros(3), np.zeros((3, 3))
    for k in range(3):
        step = h * np.eye(3)[k]
        dm = (_mass_matrix(q + step) - _mass_matrix(q - step)) / (2 * h)
        dt_dq[k] = 0.5 * q_dot @ dm @ q_dot
        dv_dq[k] = (_potential(q + step) - _potential(q - step)) / (2 * h)
        jac[:, k] = (_frames(q + step)[4] - _frames(q - step)[4]) / (2 * h)
    generalized = m @ q_ddot + m_dot @ q_dot - dt_dq + dv_dq
    return np.linalg.solve(jac.T, generalized) / 1000.0  # kg mm/s^2 -> N


@pytest.mark.parametrize("t", [0.0, 0.07, 0.19])
def test_virtual_work_matches_an_independent_lagrangian(t):
    q, q_dot, q_ddot = (a[0] for a in seed_trajectory(t))
    virtual_work = inverse_dynamics(GEOMETRY, INERTIA, q, q_dot, q_ddot)[0]
    lagrangian = _lagrangian_torque(q, q_dot, q_ddot)
    print(f"\nt = {t} s: virtual work {virtual_work} N, Lagrangian {lagrangian} N")
    np.testing.assert_allclose(virtual_work, lagrangian, atol=2e-3)  # N, of ~25 N


def test_off_centre_configuration_with_an_external_wrench_balances_statically():
    """At rest with an external force the slider forces balance it and gravity: the virtual
    power of tau equals minus that of the loads for any virtual motion."""
    q = np.array([[200.0, 0.2, -0.1]])
    force, moment = np.array([3.0, -2.0, 15.0]), np.array([100.0, 50.0, -20.0])
    tau = inverse_dynamics(GEOMETRY, INERTIA, q, np.zeros((1, 3)), np.zeros((1, 3)), external_force_n=force,
                           external_moment_n_mm=moment)[0]
    lengths = lambda x: inverse_kinematics(GEOMETRY, x).lengths_mm[0]  # noqa: E731
    for direction in np.eye(3):
        h = 1e-5
        ahead, behind = q[0] + h * direction, q[0] - h * direction
        d_lengths = (lengths(ahead) - lengths(behind)) / (2 * h)
        d_potential = (_potential(ahead) - _potential(behind)) / (2 * h) / 1000.0
        full_a, full_b = inverse_kinematics(GEOMETRY, ahead).full[0], inverse_kinematics(GEOMETRY, behind).full[0]
        d_position = (full_a[:3] - full_b[:3]) / (2 * h)
        rate = (rotation_matrix(*full_a[3:]) - rotation_matrix(*full_b[3:])) / (2 * h)
        w = rate @ rotation_matrix(*inverse_kinematics(GEOMETRY, q).full[0, 3:]).T
        d_angle = np.array([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]]) / 2
        external_power = force @ d_position + moment @ d_angle
        assert tau @ d_lengths == pytest.approx(d_potential - external_power, abs=1e-5)


def test_forward_dynamics_inverts_the_inverse():
    q, q_dot, q_ddot = seed_trajectory(np.linspace(0.0, 0.5, 7))
    tau = inverse_dynamics(GEOMETRY, INERTIA, q, q_dot, q_ddot)
    np.testing.assert_allclose(forward_dynamics(GEOMETRY, INERTIA, q, q_dot, tau), q_ddot, atol=1e-6)
    # the generalized mass matrix M = J^T A is symmetric positive definite
    a, _ = actuator_dynamics(GEOMETRY, INERTIA, q, q_dot)
    mass = np.swapaxes(velocity_jacobian(GEOMETRY, q), -1, -2) @ a
    np.testing.assert_allclose(mass, np.swapaxes(mass, -1, -2), rtol=1e-6, atol=1e-9)
    assert np.all(np.linalg.eigvalsh(mass) > 0)


def test_inverse_torques_drive_the_forward_dynamics_along_the_trajectory():
    """The seed's test motion, open loop: torques from inverse dynamics applied to the
    integrated forward dynamics reproduce the trajectory to integration tolerance."""
    q0, q_dot0, _ = (a[0] for a in seed_trajectory(0.0))

    def torque(t, _q, _q_dot):
        return inverse_dynamics(GEOMETRY, INERTIA, *seed_trajectory(t))[0]

    times, q, _ = simulate(GEOMETRY, INERTIA, q0, q_dot0, torque, duration_s=0.2, sample_s=0.01, rtol=1e-8, atol=1e-9)
    error = np.abs(q - seed_trajectory(times)[0]).max(axis=0)
    assert error[0] < 1e-6 and np.all(error[1:] < 1e-7)  # mm, rad


def test_at_rest_the_sliders_carry_the_whole_weight():
    tau = inverse_dynamics(GEOMETRY, INERTIA, [[220.0, 0.0, 0.0]], np.zeros((1, 3)), np.zeros((1, 3)))[0]
    weight = (INERTIA.platform_mass_kg + 3 * INERTIA.rocker_mass_kg + 3 * INERTIA.slider_mass_kg) * 9.80665
    assert tau.sum() == pytest.approx(weight, rel=1e-9)
    np.testing.assert_allclose(tau, tau[0], rtol=1e-9)  # symmetric


def test_integrated_forward_dynamics_balances_work_and_energy():
    """Power consistency of the integrated forward dynamics: the work the slider forces do,
    int tau . L' dt, equals the gain in kinetic plus potential energy, both computed by the
    independent position-only functions above (1 N mm = 1000 kg mm^2/s^2)."""
    q0 = np.array([220.0, 0.05, -0.03])
    hold = inverse_dynamics(GEOMETRY, INERTIA, q0[None], np.zeros((1, 3)), np.zeros((1, 3)))[0]
    phases = np.array([0.0, 2.1, 4.2])

    def torque(t, _q, _q_dot):  # N: the static hold plus a +-4 N wobble per slider
        return hold + 4.0 * np.sin(2 * math.pi * 3.0 * t + phases)

    times, q, q_dot = simulate(GEOMETRY, INERTIA, q0, np.zeros(3), torque, duration_s=0.3, sample_s=1e-4,
                               rtol=1e-10, atol=1e-10)
    slider_speeds = np.einsum("nij,nj->ni", velocity_jacobian(GEOMETRY, q), q_dot)  # mm/s
    power = np.einsum("ni,ni->n", np.array([torque(t, None, None) for t in times]), slider_speeds)  # N mm/s
    work = 1000.0 * np.trapezoid(power, times)  # kg mm^2/s^2
    gain = _kinetic(q[-1], q_dot[-1]) + _potential(q[-1]) - _potential(q[0])
    print(f"\nwork {work:.6g}, energy gain {gain:.6g} kg mm^2/s^2, moved {abs(q[-1] - q0).max():.3g}")
    assert abs(q[-1] - q0).max() > 1e-3  # it moved
    assert work == pytest.approx(gain, rel=2e-5)
    assert abs(gain) > 1e3
