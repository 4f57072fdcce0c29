"""Continuous linear models in sampled form: a transfer function in controller canonical
state space, and its zero-order-hold discretization.

Both are ``scipy.signal``'s (``tf2ss``, ``cont2discrete(method="zoh")``) to the last bit
(test_force_loop.py), without importing scipy.signal: it is 0.4 s of a node's start, and
the plant builds its table and machine from these at every start; scipy.linalg is imported
by the first hold, so that a module that only may discretize (the energy-optimal law, in
the force controller that runs PI) costs nothing at start. Units are the model's.
"""

from __future__ import annotations

import numpy as np


def controller_canonical(num, den) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) of a strictly proper ``num`` / ``den`` (``den[0]`` = 1), one input and output:
    A's first row is -den[1:], B = e_1, C the numerator's coefficients over the states."""
    num, den = np.asarray(num, float), np.asarray(den, float)
    order = len(den) - 1
    num = np.concatenate([np.zeros(order + 1 - len(num)), num])
    a = np.vstack([-den[1:], np.eye(order - 1, order)])
    return a, np.eye(order, 1), num[1:] - num[0] * den[1:]


def zero_order_hold(a, b, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(A_d, B_d) of x' = A x + B u with u held over each ``dt_s``: the exponential of
    [[A, B], [0, 0]] dt (Van Loan 1978). ``b`` is (n, m)."""
    from scipy.linalg import expm

    a, b = np.asarray(a, float), np.asarray(b, float)
    n, m = b.shape
    held = expm(dt_s * np.block([[a, b], [np.zeros((m, n + m))]]))[:n]
    return held[:, :n], held[:, n:]
