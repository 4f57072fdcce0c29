"""The part's local figures (seed 002 section 3: within 0.1 mm of the parent everywhere)."""

import numpy as np
import pytest

from hex_control.grinding.contour import Contour
from hex_control.grinding.part_quality import TOLERANCE_MM, part_quality


def test_a_gouge_at_one_end_is_found_where_it_is_while_the_mean_looks_perfect():
    x = np.linspace(0.0, 300.0, 601)
    parent = 0.001 * (x - 150.0)
    d = np.where(x > 285.0, -0.45 * np.sin(np.pi * (x - 285.0) / 15.0), 0.0) + np.where(x < 20.0, 0.3, 0.0)
    q = part_quality(Contour(x, parent + d, parent), end_zone_mm=15.0)
    assert q.gouge_mm == pytest.approx(0.45, abs=2e-3) and q.gouge_x_mm == pytest.approx(292.5, abs=0.5)
    assert q.highest_mm == pytest.approx(0.3) and q.highest_x_mm < 20.0
    assert q.ends_gouge_mm == pytest.approx(q.gouge_mm) and q.max_deviation_mm == pytest.approx(0.45, abs=2e-3)
    assert not q.within(TOLERANCE_MM)
    # RMS against the integral: 0.3^2 over 20 mm (trapezoid ends) and 0.45^2/2 over 15 mm
    expected = np.sqrt((0.09 * 19.75 + 0.45**2 * 7.5) / 300.0)
    assert q.rms_mm == pytest.approx(expected, rel=0.02)
    assert q.ends_rms_mm > q.rms_mm  # all of it lies in the ends (30 mm of 300)


def test_a_part_within_the_band_and_a_desired_contour_other_than_the_parent():
    x = np.linspace(0.0, 100.0, 201)
    z = 0.05 * np.sin(x / 7.0)
    q = part_quality(Contour(x, z), end_zone_mm=10.0)
    assert q.within() and q.gouge_mm == pytest.approx(0.05, abs=1e-3)
    assert q.rms_mm == pytest.approx(0.05 / np.sqrt(2), rel=0.05)
    lifted = part_quality(Contour(x, z), 10.0, desired_mm=-0.2)
    assert lifted.gouge_mm == 0.0 and lifted.highest_mm == pytest.approx(0.25, abs=1e-3)


def test_end_zones_longer_than_half_the_bead_are_refused():
    x = np.linspace(0.0, 10.0, 11)
    with pytest.raises(ValueError, match="end zone"):
        part_quality(Contour(x, np.zeros_like(x)), end_zone_mm=6.0)
    with pytest.raises(ValueError, match="end zone"):
        part_quality(Contour(x, np.zeros_like(x)), end_zone_mm=float("nan"))
