"""ITAE gain tuning by simulation (seed 001 section 3.2)."""

import numpy as np
import pytest

from hex_control.control.itae import itae
from hex_control.plant.force_table import ForceTableParameters
from hex_control.studies.tuning import step_itae, tune_pi_itae

LINEAR = ForceTableParameters(stiction_n=0.0, contact_mm=-1.0)


def test_itae_definition():
    t = np.arange(5) * 0.5
    assert itae(t, [1, 1, 1, 1, 1]) == pytest.approx((0 + 0.5 + 1 + 1.5 + 2) * 0.5)
    with pytest.raises(ValueError):
        itae([0.0], [1.0])


def test_tuned_gains_beat_the_initial_ones_and_stay_stable():
    before = step_itae(0.002, 0.05, LINEAR, 0.005, 20.0, duration_s=3.0)
    kp, ki, after = tune_pi_itae(LINEAR, 0.005, 20.0, 3.0)
    assert after < 0.5 * before
    assert kp > 0 and ki > 0
    # the tuned loop still settles: the ITAE over twice the time grows only a little
    assert step_itae(kp, ki, LINEAR, 0.005, 20.0, duration_s=6.0) < 1.5 * after
