"""Optimal control at the energy performance index (seed 004 eq. 1-10)."""

import numpy as np
import pytest

from hex_control.control.energy_optimal import (EnergyIndexController, input_integral, simulate,
                                                state_matrices, vibration_energy)

PERIOD = 0.002


def test_input_integral_is_the_zoh_input_matrix():
    from scipy.signal import cont2discrete

    a, b = state_matrices([[2.0]], [[0.1]], [[400.0]], [[1.0]])
    _, bd, *_ = cont2discrete((a, b, np.eye(2), np.zeros((2, 1))), PERIOD, method="zoh")
    np.testing.assert_allclose(input_integral(a, b, PERIOD), bd, atol=1e-14)


@pytest.mark.parametrize("system", ["1dof", "2dof"])
def test_reduces_vibration_energy_and_respects_the_limits(system):
    """A lightly damped 1-DOF (5 Hz, zeta 0.005) and a 2-DOF chain, released from a
    displacement: the law of eq. 9 removes the vibration energy far faster than the
    structure's own damping, and no command exceeds its limit (eq. 10)."""
    if system == "1dof":
        m, l, k, bu, q0 = [[1.0]], [[2 * 0.005 * 31.4]], [[31.4**2]], [[1.0]], [0.01]
    else:
        m = np.diag([1.0, 0.5])
        k = np.array([[2000.0, -1000.0], [-1000.0, 1000.0]])
        l, bu, q0 = 0.001 * k, np.array([[1.0], [0.0]]), [0.0, 0.01]
    n = np.atleast_2d(m).shape[0]
    limit = 0.3  # below the unconstrained peak command, so eq. 10 acts early on
    controller = EnergyIndexController(m, l, k, bu, q1=np.eye(n) * 1e3, q2=np.zeros((n, n)), r=np.eye(1),
                                       horizon_s=PERIOD, limits=[limit])
    steps = 2000
    free, _ = simulate(m, l, k, bu, None, q0, PERIOD, steps)
    controlled, commands = simulate(m, l, k, bu, controller, q0, PERIOD, steps)
    e_free = vibration_energy(m, k, free, PERIOD)
    e_controlled = vibration_energy(m, k, controlled, PERIOD)
    late = slice(steps * 3 // 4, None)
    assert e_controlled[late].mean() < 0.05 * e_free[late].mean()
    assert np.max(np.abs(commands)) <= limit + 1e-12
    assert np.any(np.abs(commands) == limit)  # the saturation was active at the start


def test_desired_displacement_and_tracking():
    """K qbar = f0 (eq. 4): with the position weight the state settles at qbar."""
    m, l, k, bu = [[1.0]], [[0.5]], [[400.0]], [[-1.0]]
    controller = EnergyIndexController(m, l, k, bu, q1=[[10.0]], q2=[[50.0]], r=[[1e-3]], horizon_s=PERIOD)
    q_bar = controller.desired_displacement([8.0])
    assert q_bar == pytest.approx([0.02])
    u_at_target = controller.command(q_bar, [0.0], q_bar, [0.0])
    assert u_at_target == pytest.approx([0.0])
    assert controller.command([0.0], [0.0], q_bar, [0.0])[0] != 0.0
