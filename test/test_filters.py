"""Roll-off filters for the force loop (the thesis's untried recommendation, section 8.3)."""

import math

import numpy as np
import pytest

from hex_control.control.filters import low_pass, notch


def test_low_pass_has_its_cutoff_exactly_and_unit_dc_gain():
    period = 1 / 200
    filt = low_pass(8.0, period)
    assert abs(filt.response(0.0, period)) == pytest.approx(1.0)
    assert abs(filt.response(8.0, period)) == pytest.approx(1 / math.sqrt(2), rel=1e-3)  # zeta 0.707
    assert abs(filt.response(35.0, period)) < 0.06  # the runout band is cut by > 25 dB


def test_low_pass_equals_python_controls_prewarped_tustin():
    import control  # here, not at every worker's collection: 1 s with the matplotlib it loads
    period, cutoff = 1 / 200, 8.0
    w = 2 * math.pi * cutoff
    reference = control.sample_system(control.tf([w * w], [1, 2 * 0.707 * w, w * w]), period,
                                      method="tustin", prewarp_frequency=w)
    freqs = np.array([0.5, 3.0, 8.0, 20.0, 60.0])
    expected = np.squeeze(reference(np.exp(1j * 2 * np.pi * freqs * period)))
    np.testing.assert_allclose(low_pass(cutoff, period).response(freqs, period), expected, rtol=1e-9)


def test_notch_removes_its_frequency_and_passes_the_rest():
    period = 1 / 500
    filt = notch(35.0, period, quality=2.0)
    assert abs(filt.response(35.0, period)) < 1e-9
    assert abs(filt.response(1.0, period)) == pytest.approx(1.0, abs=2e-3)
    t = np.arange(0, 2.0, period)
    out = np.array([filt.step(x) for x in np.sin(2 * np.pi * 35.0 * t)])
    assert np.max(np.abs(out[len(t) // 2:])) < 0.01  # the sinusoid is gone once the transient decays


def test_steady_start_and_bad_parameters():
    filt = low_pass(8.0, 1 / 200)
    filt.reset(3.0)
    assert [round(filt.step(3.0), 12) for _ in range(5)] == [3.0] * 5
    with pytest.raises(ValueError):
        low_pass(150.0, 1 / 200)  # above Nyquist
    with pytest.raises(ValueError):
        filt.step(math.nan)
