"""Digital PI of the force loop (seed 002 eq. 7.4-7.6)."""

import math

import numpy as np
import pytest

from hex_control.control.pi import TustinPI


def test_difference_equation_is_the_tustin_discretization():
    """Eq. 7.6 realizes python-control's Tustin discretization of K_p + K_I/s: its impulse
    response equals the reference transfer function's difference equation to 1e-12, and the
    step responses match."""
    import control  # here, not at every worker's collection: 1 s with the matplotlib it loads
    kp, ki, t = 0.004, 0.03, 1 / 60
    reference = control.sample_system(control.tf([kp, ki], [1, 0]), t, method="tustin")
    num, den = (np.squeeze(v) for v in control.tfdata(reference))
    assert len(num) == len(den) == 2  # first order: den[0] u_k + den[1] u_k-1 = num . (e_k, e_k-1)
    pi = TustinPI(kp, ki, t)
    impulse = [pi.step(1.0 if k == 0 else 0.0) for k in range(50)]
    u_prev, e_prev, expected = 0.0, 0.0, []
    for k in range(50):
        e = 1.0 if k == 0 else 0.0
        u = (num[0] * e + num[1] * e_prev - den[1] * u_prev) / den[0]
        expected.append(u)
        u_prev, e_prev = u, e
    np.testing.assert_allclose(impulse, expected, atol=1e-12)
    pi = TustinPI(kp, ki, t)
    steps = [pi.step(1.0) for _ in range(50)]
    _, reference_step = control.step_response(reference, T=np.arange(50) * t)
    np.testing.assert_allclose(steps, np.squeeze(reference_step), atol=1e-12)


def test_limits_anti_windup_and_bumpless_gain_change():
    pi = TustinPI(0.01, 0.5, 0.01, output_min=-1.0, output_max=1.0)
    for _ in range(2000):
        out = pi.step(10.0)  # saturates
    assert out == 1.0
    recovered = [pi.step(-1.0) for _ in range(10)]
    assert recovered[-1] < 1.0  # no long wind-up to unwind: the output leaves the limit at once
    held = pi.step(0.0)
    pi.set_gains(0.02, 0.25)
    assert pi.step(0.0) == pytest.approx(held)
    pi.reset(0.3)
    assert pi.step(0.0) == pytest.approx(0.3)
    assert pi.step(0.0, feed_forward=0.1) == pytest.approx(0.4)
    with pytest.raises(ValueError):
        pi.step(math.nan)
    with pytest.raises(ValueError):
        TustinPI(-1.0, 0.0, 0.01)
