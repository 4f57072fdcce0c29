"""Dynamics of the 3-PRU head of seed 001 section 2.2, by the principle of virtual work.

Bodies: the platform (mass M_p, inertia I_p in the platform frame, centre of mass at the
platform origin), three rockers (m_r, I_r about the rocker's centre of mass -- its midpoint
-- in the rocker frame: x along the revolute axis n_i, z along the rocker from slider to
platform joint, y = z x x) and three sliders (m_s, moving along the vertical rails).

Inverse dynamics (2.2.1): with the D'Alembert wrenches of the platform
    F_p = [f_ext + M_p g - M_p a_p ;  n_ext - I Omega_p - omega_p x (I omega_p)]
and of each rocker F_i = [m_r g - m_r a_Gi ; -I_r Omega_i - omega_i x (I_r omega_i)],
virtual work  dL^T (tau - m_s L'' - m_s g) + dq^T (J_p^T F_p + sum J_i^T F_i) = 0  gives

    tau = J^-T (-J_p^T F_p - sum J_i^T F_i) + m_s (L'' + g)

where J = dL/dq and J_p, J_i map q' to the bodies' twists. The seed's formula leaves the
sliders' weight out (m_s L'' only); the rails are vertical, so it belongs in and is here.
The twists' Jacobians are analytic (parasitic motion by the implicit-function theorem);
their time derivatives along q' are central differences over ``time_step_s``.

The same balance written J^T tau = M(q) q'' + h(q, q') (``generalized_dynamics``) gives
the forward dynamics of 2.2.2, q'' = M^-1 (J^T tau - h), integrated in time, and the
actuator-space form tau = A q'' + b (A = J^-T M, b = J^-T h) the controllers use.

Units: mm, kg, s, rad; forces are returned in N (1 N = 1000 kg mm/s^2).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from hex_control.kinematics.pru3 import (
    _INDEPENDENT,
    _PARASITIC,
    Pru3Geometry,
    _as_q,
    _joint_jacobians,
    inverse_kinematics,
    velocity_jacobian,
)
from hex_control.kinematics.rotation import rotation_derivatives, rotation_matrix

KG_MM_S2_PER_N = 1000.0


@dataclass(frozen=True)
class Pru3Inertia:
    """Seed 001 section 4.2 (AL-6061-T6 parts from CAD)."""

    platform_mass_kg: float = 1.9158
    platform_inertia_kg_mm2: tuple = (4533.4, 4533.4, 8867.2)
    rocker_mass_kg: float = 0.5522
    rocker_inertia_kg_mm2: tuple = (5464.7, 565.4, 323.6)
    slider_mass_kg: float = 1.3764
    gravity_mm_s2: float = 9806.65  # along -z


def _vee(skew: np.ndarray) -> np.ndarray:
    return np.stack([skew[..., 2, 1] - skew[..., 1, 2], skew[..., 0, 2] - skew[..., 2, 0],
                     skew[..., 1, 0] - skew[..., 0, 1]], axis=-1) / 2


@dataclass(frozen=True)
class BodyJacobians:
    """Position-level quantities and the Jacobians from q' = (z', alpha', beta') to each
    body's velocity and angular velocity, batched over N configurations."""

    rotation: np.ndarray  # (N, 3, 3) platform orientation
    rocker_axes: np.ndarray  # (N, 3, 3, 3) rocker frame [i, world axis, (x, y, z)]
    platform_v: np.ndarray  # (N, 3, 3)
    platform_w: np.ndarray  # (N, 3, 3)
    rocker_v: np.ndarray  # (N, 3, 3, 3) [i, xyz, q] of the rocker's centre of mass
    rocker_w: np.ndarray  # (N, 3, 3, 3)
    sliders: np.ndarray  # (N, 3, 3) dL/dq


def body_jacobians(geometry: Pru3Geometry, q) -> BodyJacobians:
    q = _as_q(q)
    pose = inverse_kinematics(geometry, q)
    full = pose.full
    joint_jac = _joint_jacobians(geometry, full)  # dP_i/du, u = (x, y, z, alpha, beta, gamma)
    normals = geometry.plane_normals
    c = np.einsum("ki,nkiu->nku", normals, joint_jac)
    g = np.zeros((len(q), 6, 3))  # du/dq with the parasitic motion
    g[:, _INDEPENDENT, :] = np.eye(3)
    g[:, _PARASITIC, :] = -np.linalg.solve(c[:, :, _PARASITIC], c[:, :, _INDEPENDENT])
    rotation = rotation_matrix(full[:, 3], full[:, 4], full[:, 5])
    spin = np.stack([_vee(d @ np.swapaxes(rotation, -1, -2))
                     for d in rotation_derivatives(full[:, 3], full[:, 4], full[:, 5])], axis=-1)  # (N, 3, 3)
    sliders = velocity_jacobian(geometry, q, pose)
    joint_q = np.einsum("nkiu,nuq->nkiq", joint_jac, g)  # dP_i/dq
    slider_q = np.zeros_like(joint_q)
    slider_q[:, :, 2, :] = sliders  # S_i = (rail_i, L_i): only z moves
    rocker = pose.joints_mm - np.concatenate([np.broadcast_to(geometry.rails_mm[:, :2], pose.horizontal_mm.shape),
                                              pose.lengths_mm[..., None]], axis=-1)
    u = rocker / geometry.rocker_length_mm  # unit vector slider -> platform joint
    du = (joint_q - slider_q) / geometry.rocker_length_mm
    n = np.broadcast_to(normals, u.shape)
    rate = np.einsum("nki,nkiq->nkq", n, np.cross(u[..., None], du, axis=2))  # phi_i' per q'
    axes = np.stack([n, np.cross(u, n), u], axis=-1)
    return BodyJacobians(rotation, axes, g[:, :3, :], spin @ g[:, 3:, :], (joint_q + slider_q) / 2,
                         n[..., None] * rate[:, :, None, :], sliders)


def generalized_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot, external_force_n=None,
                         *, external_moment_n_mm=None, time_step_s: float = 1e-6):
    """The virtual-work balance J^T tau = M(q) q'' + h(q, q') in the platform coordinates:
    M (N, 3, 3) in kg (mm, rad units), h (N, 3) in kg mm/s^2 per coordinate, and J = dL/dq.

    Each body's D'Alembert wrench [f_applied - m a ; n_applied - I Omega - omega x I omega]
    is projected on its Jacobian; with a = J_b q'' + J_b' q' the q''-part gives M and the
    rest (J_b' q' by central differences along the motion, gravity, the external wrench)
    gives h. The sliders add m_s J^T (L'' + g)."""
    q, q_dot = _as_q(q), _as_q(q_dot)
    n = len(q)
    stacked = body_jacobians(geometry, np.concatenate([q, q + time_step_s * q_dot, q - time_step_s * q_dot]))
    j = BodyJacobians(*(getattr(stacked, f.name)[:n] for f in fields(BodyJacobians)))

    def bias(name):  # J_b' q'
        _, ahead, behind = np.split(getattr(stacked, name), 3)
        return np.einsum("n...q,nq->n...", (ahead - behind) / (2 * time_step_s), q_dot)

    gravity = np.array([0.0, 0.0, inertia.gravity_mm_s2])  # the reversed weight per kg: +z
    transpose = lambda a: np.swapaxes(a, -1, -2)  # noqa: E731

    # platform (centre of mass at its origin), with the external wrench
    mass, rotation = inertia.platform_mass_kg, j.rotation
    spatial = rotation @ np.diag(inertia.platform_inertia_kg_mm2) @ transpose(rotation)
    omega = np.einsum("niq,nq->ni", j.platform_w, q_dot)
    m_gen = mass * transpose(j.platform_v) @ j.platform_v + transpose(j.platform_w) @ spatial @ j.platform_w
    force = mass * (bias("platform_v") + gravity)
    moment = np.einsum("nij,nj->ni", spatial, bias("platform_w")) \
        + np.cross(omega, np.einsum("nij,nj->ni", spatial, omega))
    if external_force_n is not None:
        force = force - np.asarray(external_force_n, float) * KG_MM_S2_PER_N
    if external_moment_n_mm is not None:
        moment = moment - np.asarray(external_moment_n_mm, float) * KG_MM_S2_PER_N
    h = np.einsum("niq,ni->nq", j.platform_v, force) + np.einsum("niq,ni->nq", j.platform_w, moment)

    # rockers (centre of mass at the midpoint, inertia in the rocker frame)
    spatial = j.rocker_axes @ np.diag(inertia.rocker_inertia_kg_mm2) @ transpose(j.rocker_axes)
    omega = np.einsum("nkiq,nq->nki", j.rocker_w, q_dot)
    m_gen = m_gen + inertia.rocker_mass_kg * np.einsum("nkiq,nkip->nqp", j.rocker_v, j.rocker_v) \
        + np.einsum("nkiq,nkij,nkjp->nqp", j.rocker_w, spatial, j.rocker_w)
    force = inertia.rocker_mass_kg * (bias("rocker_v") + gravity)
    moment = np.einsum("nkij,nkj->nki", spatial, bias("rocker_w")) \
        + np.cross(omega, np.einsum("nkij,nkj->nki", spatial, omega))
    h = h + np.einsum("nkiq,nki->nq", j.rocker_v, force) + np.einsum("nkiq,nki->nq", j.rocker_w, moment)

    # sliders along the vertical rails
    m_gen = m_gen + inertia.slider_mass_kg * transpose(j.sliders) @ j.sliders
    h = h + inertia.slider_mass_kg * np.einsum("niq,ni->nq", j.sliders, bias("sliders") + inertia.gravity_mm_s2)
    return m_gen, h, j.sliders


def inverse_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot, q_ddot, *, external_force_n=None,
                     external_moment_n_mm=None, time_step_s: float = 1e-6) -> np.ndarray:
    """Slider forces tau (N, 3) in N for the motion (q, q', q''), rows of (z mm, alpha rad,
    beta rad) and their rates; the external wrench on the platform (N, N mm, world frame)
    acts at the platform origin. tau = J^-T (M q'' + h)."""
    m_gen, h, jac = generalized_dynamics(geometry, inertia, q, q_dot, external_force_n,
                                         external_moment_n_mm=external_moment_n_mm, time_step_s=time_step_s)
    load = np.einsum("nij,nj->ni", m_gen, _as_q(q_ddot)) + h
    return np.linalg.solve(np.swapaxes(jac, -1, -2), load[..., None])[..., 0] / KG_MM_S2_PER_N


def actuator_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot):
    """tau = A(q) q'' + b(q, q'): A = J^-T M (N, 3, 3) in N s^2 per (mm, rad), b = J^-T h (N)."""
    m_gen, h, jac = generalized_dynamics(geometry, inertia, q, q_dot)
    jt = np.swapaxes(jac, -1, -2)
    return np.linalg.solve(jt, m_gen) / KG_MM_S2_PER_N, np.linalg.solve(jt, h[..., None])[..., 0] / KG_MM_S2_PER_N


def forward_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot, tau_n) -> np.ndarray:
    """q'' = M^-1 (J^T tau - h) (seed 2.2.2) for one configuration or a batch."""
    m_gen, h, jac = generalized_dynamics(geometry, inertia, q, q_dot)
    drive = np.einsum("nji,nj->ni", jac, np.atleast_2d(tau_n) * KG_MM_S2_PER_N)
    return np.linalg.solve(m_gen, (drive - h)[..., None])[..., 0]


def simulate(geometry: Pru3Geometry, inertia: Pru3Inertia, q0, q_dot0, torque, *, duration_s: float,
             sample_s: float = 1e-3, rtol: float = 1e-9, atol: float = 1e-9):
    """Integrate the forward dynamics from (q0, q'0) under ``torque(t, q, q') -> tau`` (N)
    with an adaptive Runge-Kutta (RK45); returns (times, q, q') sampled every sample_s."""
    def rates(t, state):
        q, q_dot = state[:3], state[3:]
        return np.concatenate([q_dot, forward_dynamics(geometry, inertia, q, q_dot, torque(t, q, q_dot))[0]])

    from scipy.integrate import solve_ivp  # here: 0.3 s of the plant's start, which steps its own integrator

    times = np.arange(0.0, duration_s + sample_s / 2, sample_s)
    solution = solve_ivp(rates, (0.0, times[-1]), np.concatenate([q0, q_dot0]), t_eval=times, rtol=rtol,
                         atol=atol, method="RK45")
    if not solution.success:
        raise RuntimeError(f"forward dynamics failed: {solution.message}")
    return solution.t, solution.y[:3].T, solution.y[3:].T
