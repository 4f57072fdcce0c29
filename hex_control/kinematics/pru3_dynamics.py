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

Forward dynamics (2.2.2): tau = A(q) q'' + b(q, q') in actuator space (A from unit
accelerations, b at zero acceleration), so q'' = A^-1 (tau - b), integrated in time.

Units: mm, kg, s, rad; forces are returned in N (1 N = 1000 kg mm/s^2).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from scipy.integrate import solve_ivp

from hex_control.kinematics.pru3 import (_INDEPENDENT, _PARASITIC, Pru3Geometry, _as_q, _joint_jacobians,
                                         inverse_kinematics, velocity_jacobian)
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
    sliders = velocity_jacobian(geometry, q)
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


def _motion(geometry, q, q_dot, q_ddot, time_step_s):
    """Jacobians at q, and every body's velocity J q' and acceleration J q'' + J' q' (J' q'
    by central differences of J along the motion, q -/+ time_step_s q')."""
    n = len(q)
    stacked = body_jacobians(geometry, np.concatenate([q, q + time_step_s * q_dot, q - time_step_s * q_dot]))
    now = BodyJacobians(*(getattr(stacked, f.name)[:n] for f in fields(BodyJacobians)))
    velocity, acceleration = {}, {}
    for name in ("platform_v", "platform_w", "rocker_v", "rocker_w", "sliders"):
        jacobian, ahead, behind = np.split(getattr(stacked, name), 3)
        rate = (ahead - behind) / (2 * time_step_s)
        velocity[name] = np.einsum("n...q,nq->n...", jacobian, q_dot)
        acceleration[name] = np.einsum("n...q,nq->n...", jacobian, q_ddot) + np.einsum("n...q,nq->n...", rate, q_dot)
    return now, velocity, acceleration


def inverse_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot, q_ddot, external_force_n=None,
                     external_moment_n_mm=None, time_step_s: float = 1e-6) -> np.ndarray:
    """Slider forces tau (N, 3) in N for the motion (q, q', q''), rows of (z mm, alpha rad,
    beta rad) and their rates; the external wrench on the platform (N, N mm, world frame)
    acts at the platform origin."""
    q, q_dot, q_ddot = _as_q(q), _as_q(q_dot), _as_q(q_ddot)
    j, v, a = _motion(geometry, q, q_dot, q_ddot, time_step_s)
    gravity = np.array([0.0, 0.0, -inertia.gravity_mm_s2])
    external_f = np.zeros(3) if external_force_n is None else np.asarray(external_force_n, float) * KG_MM_S2_PER_N
    external_n = np.zeros(3) if external_moment_n_mm is None \
        else np.asarray(external_moment_n_mm, float) * KG_MM_S2_PER_N

    # platform: D'Alembert wrench at its centre of mass
    mass = inertia.platform_mass_kg
    world_inertia = j.rotation @ np.diag(inertia.platform_inertia_kg_mm2) @ np.swapaxes(j.rotation, -1, -2)
    omega = v["platform_w"]
    force = external_f + mass * gravity - mass * a["platform_v"]
    moment = external_n - np.einsum("nij,nj->ni", world_inertia, a["platform_w"]) \
        - np.cross(omega, np.einsum("nij,nj->ni", world_inertia, omega))
    generalized = np.einsum("niq,ni->nq", j.platform_v, force) + np.einsum("niq,ni->nq", j.platform_w, moment)

    # rockers
    rocker_inertia = j.rocker_axes @ np.diag(inertia.rocker_inertia_kg_mm2) @ np.swapaxes(j.rocker_axes, -1, -2)
    omega = v["rocker_w"]
    force = inertia.rocker_mass_kg * (gravity - a["rocker_v"])
    moment = -np.einsum("nkij,nkj->nki", rocker_inertia, a["rocker_w"]) \
        - np.cross(omega, np.einsum("nkij,nkj->nki", rocker_inertia, omega))
    generalized += np.einsum("nkiq,nki->nq", j.rocker_v, force) + np.einsum("nkiq,nki->nq", j.rocker_w, moment)

    # dL^T (tau - m_s (L'' + g)) + dq^T Q = 0 with dL = J dq
    tau = np.linalg.solve(np.swapaxes(j.sliders, -1, -2), -generalized[..., None])[..., 0]
    tau += inertia.slider_mass_kg * (a["sliders"] + inertia.gravity_mm_s2)
    return tau / KG_MM_S2_PER_N


def actuator_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot):
    """tau = A(q) q'' + b(q, q'): A (N, 3, 3) in N s^2 per (mm, rad), b (N, 3) in N."""
    q, q_dot = _as_q(q), _as_q(q_dot)
    n = len(q)
    accelerations = np.concatenate([np.zeros_like(q)] + [np.broadcast_to(unit, q.shape) for unit in np.eye(3)])
    tau = inverse_dynamics(geometry, inertia, np.tile(q, (4, 1)), np.tile(q_dot, (4, 1)), accelerations)
    b = tau[:n]
    return np.stack([tau[(k + 1) * n:(k + 2) * n] - b for k in range(3)], axis=-1), b


def forward_dynamics(geometry: Pru3Geometry, inertia: Pru3Inertia, q, q_dot, tau_n) -> np.ndarray:
    """q'' = A^-1 (tau - b) (seed 2.2.2) for one configuration or a batch."""
    a, b = actuator_dynamics(geometry, inertia, q, q_dot)
    return np.linalg.solve(a, (np.atleast_2d(tau_n) - b)[..., None])[..., 0]


def simulate(geometry: Pru3Geometry, inertia: Pru3Inertia, q0, q_dot0, torque, duration_s: float,
             sample_s: float = 1e-3, rtol: float = 1e-9, atol: float = 1e-9):
    """Integrate the forward dynamics from (q0, q'0) under ``torque(t, q, q') -> tau`` (N)
    with an adaptive Runge-Kutta (RK45); returns (times, q, q') sampled every sample_s."""
    def rates(t, state):
        q, q_dot = state[:3], state[3:]
        return np.concatenate([q_dot, forward_dynamics(geometry, inertia, q, q_dot, torque(t, q, q_dot))[0]])

    times = np.arange(0.0, duration_s + sample_s / 2, sample_s)
    solution = solve_ivp(rates, (0.0, times[-1]), np.concatenate([q0, q_dot0]), t_eval=times, rtol=rtol,
                         atol=atol, method="RK45")
    if not solution.success:
        raise RuntimeError(f"forward dynamics failed: {solution.message}")
    return solution.t, solution.y[:3].T, solution.y[3:].T
