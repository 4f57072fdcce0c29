"""Optimal control at the energy performance index (seed 004, section 2, eq. 1-10).

System (1): x = [q', q], x' = A x + D z + B u with
    A = [[-M^-1 L, -M^-1 K], [I, 0]],  B = [[-M^-1 B_u], [0]]   (the seed's sign convention).
Index (3): J = 1/2 (q' - qbar')^T Q1 M (q' - qbar') + 1/2 (q - qbar)^T Q2 K (q - qbar)
             + 1/2 u^T R u, with the desired displacement from K qbar = f0 (4).
Control (9), with the integral of Phi(t, tau) B over one sampling interval Delta (the
seed's discrete form, "within sampling time"), for a time-invariant model:
    G = int_0^Delta e^(A s) B ds                       (Van Loan: one matrix exponential)
    u = -(R + R^T)^-1 G^T [ T1^T (M^T Q1^T + Q1 M)(q' - qbar') + T2^T (K^T Q2^T + Q2 K)(q - qbar) ]
then each component clipped to its limit U_i (10). Units are the model's own.
"""

from __future__ import annotations

import numpy as np

from hex_control.control.discretize import zero_order_hold


def state_matrices(mass, damping, stiffness, input_matrix) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of eq. 1 for M q'' + L q' + K q = -B_u u (+ disturbances)."""
    m, l, k = (np.atleast_2d(np.asarray(v, float)) for v in (mass, damping, stiffness))
    bu = np.asarray(input_matrix, float).reshape(m.shape[0], -1)
    n = m.shape[0]
    m_inv = np.linalg.inv(m)
    a = np.block([[-m_inv @ l, -m_inv @ k], [np.eye(n), np.zeros((n, n))]])
    b = np.vstack([-m_inv @ bu, np.zeros((n, bu.shape[1]))])
    return a, b


def input_integral(a: np.ndarray, b: np.ndarray, horizon_s: float) -> np.ndarray:
    """int_0^h e^(A s) B ds: the zero-order hold's input matrix (Van Loan 1978)."""
    return zero_order_hold(a, b, horizon_s)[1]


class EnergyIndexController:
    """u(q, q', qbar, qbar') of eq. 9 with the limits of eq. 10."""

    def __init__(self, mass, damping, stiffness, input_matrix, *, q1, q2, r, horizon_s: float, limits=None):
        self.m = np.atleast_2d(np.asarray(mass, float))
        self.k = np.atleast_2d(np.asarray(stiffness, float))
        a, b = state_matrices(mass, damping, stiffness, input_matrix)
        if not horizon_s > 0:
            raise ValueError("horizon_s must be > 0")
        n = self.m.shape[0]
        q1, q2, r = (np.atleast_2d(np.asarray(v, float)) for v in (q1, q2, r))
        g = input_integral(a, b, horizon_s)
        weight = np.linalg.inv(r + r.T) @ g.T
        self._velocity_gain = weight[:, :n] @ (self.m.T @ q1.T + q1 @ self.m)
        self._position_gain = weight[:, n:] @ (self.k.T @ q2.T + q2 @ self.k)
        self.limits = None if limits is None else np.abs(np.asarray(limits, float)).reshape(-1)

    def desired_displacement(self, load) -> np.ndarray:
        """qbar from K qbar = f0 (eq. 4)."""
        return np.linalg.solve(self.k, np.atleast_1d(np.asarray(load, float)))

    def command(self, q, q_dot, q_bar=None, q_bar_dot=None) -> np.ndarray:
        q, q_dot = np.atleast_1d(np.asarray(q, float)), np.atleast_1d(np.asarray(q_dot, float))
        q_bar = np.zeros_like(q) if q_bar is None else np.atleast_1d(np.asarray(q_bar, float))
        q_bar_dot = np.zeros_like(q) if q_bar_dot is None else np.atleast_1d(np.asarray(q_bar_dot, float))
        u = -(self._velocity_gain @ (q_dot - q_bar_dot) + self._position_gain @ (q - q_bar))
        return u if self.limits is None else np.clip(u, -self.limits, self.limits)  # eq. 10


def simulate(mass, damping, stiffness, input_matrix, controller, *, q0, period_s: float, steps: int):
    """Sampled control (held over each period, exact discretization) from q(0) = q0, q'(0) = 0.
    Returns (q (steps, n), u (steps, m))."""
    a, b = state_matrices(mass, damping, stiffness, input_matrix)
    n = a.shape[0] // 2
    ad, bd = zero_order_hold(a, b, period_s)
    x = np.concatenate([np.zeros(n), np.atleast_1d(np.asarray(q0, float))])
    qs, us = [], []
    for _ in range(steps):
        u = np.zeros(b.shape[1]) if controller is None else controller.command(x[n:], x[:n])
        qs.append(x[n:].copy())
        us.append(u)
        x = ad @ x + bd @ u
    return np.array(qs), np.array(us)


def vibration_energy(mass, stiffness, q: np.ndarray, period_s: float) -> np.ndarray:
    """Kinetic + potential energy along a sampled trajectory (velocity by differences)."""
    m, k = np.atleast_2d(np.asarray(mass, float)), np.atleast_2d(np.asarray(stiffness, float))
    v = np.gradient(q, period_s, axis=0)
    return 0.5 * np.einsum("ti,ij,tj->t", v, m, v) + 0.5 * np.einsum("ti,ij,tj->t", q, k, q)
