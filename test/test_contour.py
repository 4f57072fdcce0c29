"""Contours and the final contour of seed 002 section 6.1 (eq. 6.1-6.2)."""

import math

import numpy as np
import pytest

from hex_control.grinding.contour import Contour, final_contour, positive_area, weld_bead


def _brute_area(x, d, samples=200_001):
    xs = np.linspace(x[0], x[-1], samples)
    return float(np.trapezoid(np.maximum(np.interp(xs, x, d), 0.0), xs))


def test_positive_area_is_exact_on_polylines():
    x = np.array([0.0, 1.0, 3.0, 4.0, 6.0])
    d = np.array([1.0, -1.0, 2.0, 2.0, -0.5])
    # triangles 0.25, 2*(2/3)... computed by hand: [0,1]: 0.25; [1,3]: 2*2^2/(2*3)=4/3; [3,4]: 2; [4,6]: 2*4/(2*2.5)=1.6
    assert positive_area(x, d) == pytest.approx(0.25 + 4 / 3 + 2.0 + 1.6, rel=1e-12)
    assert positive_area(x, d) == pytest.approx(_brute_area(x, d), rel=1e-6)


@pytest.mark.parametrize("depth", [0.1, 0.5, 1.2])
def test_final_contour_removes_the_volume_of_eq_6_1(depth):
    bead = weld_bead(seed=3)
    width = 10.0
    final = final_contour(bead, depth, width)
    wanted = depth * width * bead.length_mm  # eq. 6.1
    assert final.removed_mm3 == pytest.approx(wanted, rel=1e-6)
    x = final.contour.x_mm  # the initial x plus the crossings
    removed = width * positive_area(x, bead.height_at(x) - final.contour.z_mm)
    assert removed == pytest.approx(wanted, rel=1e-6)
    assert np.all(final.contour.z_mm <= bead.height_at(x) + 1e-12)
    np.testing.assert_allclose(final.tip_mm - bead.parent_mm, final.offset_mm)  # parallel to the parent


def test_final_contour_with_dips_below_the_desired_shape():
    """Eq. 6.2c: where the initial contour dips below z_f + N it is left alone, and the level
    drops further so that the volume still comes out."""
    x = np.linspace(0.0, 100.0, 201)
    z = np.full_like(x, 2.0)
    z[80:120] = -1.0  # a dip below the parent surface
    bead = Contour(x, z)
    final = final_contour(bead, 1.0, 8.0)
    assert final.removed_mm3 == pytest.approx(1.0 * 8.0 * 100.0, rel=1e-6)
    inside = (final.contour.x_mm > 42) & (final.contour.x_mm < 58)
    np.testing.assert_array_equal(final.contour.z_mm[inside], -1.0)
    assert final.offset_mm < 1.0  # lower than a dip-free bead would need (2 - 1 = 1 mm)


def test_curved_parent_and_explicit_shape():
    bead = weld_bead(parent_curvature_per_mm=1e-4, seed=1)
    final = final_contour(bead, 0.8, 12.0)
    assert final.removed_mm3 == pytest.approx(0.8 * 12.0 * bead.length_mm, rel=1e-6)
    flat = final_contour(bead, 0.8, 12.0, shape_mm=0.0)
    assert np.ptp(flat.tip_mm) == 0.0 and np.ptp(final.tip_mm) > 0.1


def test_generator_and_csv_round_trip(tmp_path):
    bead = weld_bead(length_mm=150.0, height_mm=3.0, ripple_mm=0.1, seed=0)
    assert bead.length_mm == pytest.approx(150.0)
    middle = bead.z_mm[(bead.x_mm > 20) & (bead.x_mm < 130)]
    assert np.mean(middle) == pytest.approx(3.0, abs=0.05) and 0.03 < np.std(middle) < 0.3
    assert bead.z_mm[0] == pytest.approx(0.0, abs=0.05) and bead.z_mm[-1] == pytest.approx(0.0, abs=0.05)
    path = tmp_path / "bead.csv"
    bead.to_csv(path)
    loaded = Contour.from_csv(path)
    np.testing.assert_allclose(loaded.z_mm, bead.z_mm)
    assert weld_bead(seed=0).z_mm.tolist() == bead.z_mm.tolist()


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="increasing"):
        Contour(np.array([0.0, 2.0, 1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        Contour(np.array([0.0, 1.0]), np.array([0.0, math.nan]))
    with pytest.raises(ValueError, match="cut depth"):
        final_contour(weld_bead(), -0.1, 10.0)


def test_positive_area_with_touching_zeros():
    """A segment from exactly 0 to a positive value counts once (a trapezoid, not twice)."""
    x = np.array([0.0, 1.0, 2.0])
    assert positive_area(x, np.array([0.0, 2.0, 0.0])) == pytest.approx(2.0)
    assert positive_area(x, np.array([-1.0, 0.0, -1.0])) == 0.0


def test_a_capped_cut_keeps_the_volume_and_cuts_nowhere_deeper_than_the_cap():
    """The force guard's final contour: no point cut deeper than the cap, the tip no
    steeper than its slope, eq. 6.1's volume kept, the level no lower than the cap over
    the parent (nor than eq. 6.2's), and eq. 6.2 as printed where the cap does not bind."""
    bead = weld_bead(length_mm=60.0, height_mm=1.0, end_ramp_mm=12.0, ripple_mm=0.15, seed=4)
    width, depth, cap = 12.5, 0.135, 0.25
    level = final_contour(bead, depth, width)
    assert np.max(bead.z_mm - level.tip_mm) > 2.5 * depth  # the level top cuts the crests deep
    capped = final_contour(bead, depth, width, max_cut_mm=cap, cap_slope=0.05)
    assert capped.removed_mm3 == pytest.approx(level.removed_mm3, rel=1e-6)
    cut = bead.z_mm - np.minimum(capped.tip_mm, bead.z_mm)
    assert np.max(cut) <= cap + 1e-9 and np.max(cut) > 0.9 * cap
    assert np.max(np.abs(np.diff(capped.tip_mm) / np.diff(bead.x_mm))) <= 0.05 + 1e-9
    assert capped.offset_mm < level.offset_mm and capped.offset_mm >= cap
    x = capped.contour.x_mm  # the envelope is the polyline whose area is the volume
    assert width * positive_area(x, bead.height_at(x) - capped.contour.z_mm) == pytest.approx(capped.removed_mm3,
                                                                                               rel=1e-6)
    loose = final_contour(bead, depth, width, max_cut_mm=10.0)
    np.testing.assert_array_equal(loose.tip_mm, level.tip_mm)


def test_a_cap_too_tight_for_the_volume_removes_less_and_keeps_the_level_off_the_parent():
    bead = weld_bead(length_mm=60.0, height_mm=1.0, end_ramp_mm=12.0, ripple_mm=0.15, seed=4)
    capped = final_contour(bead, 0.135, 12.5, max_cut_mm=0.05)
    assert capped.removed_mm3 < 0.135 * 12.5 * 60.0 and capped.offset_mm == pytest.approx(0.05)
    assert np.all(capped.tip_mm - bead.parent_mm >= 0.05 - 1e-12)
    with pytest.raises(ValueError, match="cap"):
        final_contour(bead, 0.135, 12.5, max_cut_mm=0.0)
