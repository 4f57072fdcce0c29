"""Disk face / contour geometry of the dynamic model (seed 002 6.5, Fig. 6-7 types)."""

import math

import numpy as np
import pytest

from hex_control.grinding.contact import (
    FACE,
    MULTIPLE,
    NO_CONTACT,
    TIP,
    DiskPose,
    clip_below,
    contact_patch,
    contact_patch_sampled,
    contact_patch_scan,
)

THETA = math.radians(20.0)
R = 85.0


def _pose(tip_x, tip_z, theta=THETA):
    return DiskPose(tip_x + R * math.cos(theta), tip_z + R * math.sin(theta), theta, R)


def _flat(height, x_end=200.0, spacing=0.5):
    x = np.arange(0.0, x_end + spacing / 2, spacing)
    return x, np.full_like(x, height)


FIG_6_7 = {
    # 1) the disk above the contour
    NO_CONTACT: (_flat(1.0), _pose(50.0, 1.5)),
    # 2) a patch from the tip up the face: the tip 0.4 mm into a flat bead
    TIP: (_flat(1.0), _pose(50.0, 0.6)),
    # 3) a bump ahead of the tip, the tip itself clear of the surface
    FACE: ((np.array([0.0, 60.0, 61.0, 63.0, 64.0, 200.0]), np.array([0.0, 0.0, 8.0, 8.0, 0.0, 0.0])),
           _pose(50.0, 1.0)),
    # 4) two bumps under the face
    MULTIPLE: ((np.array([0.0, 55.0, 56.0, 57.0, 70.0, 71.0, 73.0, 74.0, 200.0]),
                np.array([0.0, 0.0, 5.0, 0.0, 0.0, 9.0, 9.0, 0.0, 0.0])), _pose(50.0, 1.0)),
}


@pytest.mark.parametrize("kind", list(FIG_6_7))
def test_each_patch_type_of_fig_6_7_against_brute_force(kind):
    (x, z), pose = FIG_6_7[kind]
    exact = contact_patch(x, z, pose)
    sampled = contact_patch_sampled(x, z, pose)
    assert exact.kind == sampled.kind == kind
    assert exact.patches == sampled.patches == {NO_CONTACT: 0, TIP: 1, FACE: 1, MULTIPLE: 2}[kind]
    step = R / 200_000  # the sampling's resolution along the face
    assert exact.length_mm == pytest.approx(sampled.length_mm, abs=4 * step * (1 + exact.patches))
    assert exact.centroid_mm == pytest.approx(sampled.centroid_mm, abs=1e-3)
    scanned = contact_patch_scan(x, z, pose)
    assert scanned.length_mm == pytest.approx(exact.length_mm, rel=1e-12)


def test_tip_patch_length_and_centroid_by_hand():
    """The tip 0.4 mm into a flat bead: the patch runs 0.4 / sin(theta) up the face from
    the tip, its centroid half that short of R."""
    (x, z), pose = FIG_6_7[TIP]
    patch = contact_patch(x, z, pose)
    length = 0.4 / math.sin(THETA)
    assert patch.length_mm == pytest.approx(length, rel=1e-6)
    assert patch.centroid_mm == pytest.approx(R - length / 2, abs=1e-6)  # TOUCH_MM shifts it
    assert patch.area_mm2(12.5) == pytest.approx(12.5 * length, rel=1e-6)


def test_random_contours_match_brute_force():
    rng = np.random.default_rng(4)
    for _ in range(20):
        x = np.cumsum(rng.uniform(0.2, 3.0, 120))
        z = rng.normal(0.0, 1.0, x.size)
        theta = rng.uniform(0.1, 0.6)
        pose = _pose(rng.uniform(x[5], x[40]), rng.normal(0.0, 0.5), theta)
        exact, sampled = contact_patch(x, z, pose), contact_patch_sampled(x, z, pose)
        assert exact.patches == sampled.patches
        assert exact.length_mm == pytest.approx(sampled.length_mm, abs=R / 200_000 * (4 + 2 * exact.patches))


def test_clip_below_truncates_exactly_and_inserts_the_crossings():
    x, z = np.array([0.0, 10.0, 20.0]), np.array([0.0, 2.0, 0.0])
    parent = np.zeros(3)
    cut_x, cut_z = np.array([5.0, 15.0]), np.array([1.0, 1.0])
    new_x, new_z, (new_parent,) = clip_below(x, z, cut_x, cut_z, (parent,))
    assert np.all(np.diff(new_x) > 0) and new_parent.shape == new_x.shape
    samples = np.linspace(0.0, 20.0, 2001)
    inside = (samples >= 5) & (samples <= 15)
    wanted = np.where(inside, np.minimum(np.interp(samples, x, z), 1.0), np.interp(samples, x, z))
    np.testing.assert_allclose(np.interp(samples, new_x, new_z), wanted, atol=1e-12)
    # a cutter above the contour leaves it untouched
    same = clip_below(x, z, cut_x, np.array([5.0, 5.0]))
    assert same[0] is x and same[1] is z


def test_a_face_clear_of_the_whole_contour_touches_nothing_and_cuts_nothing():
    """The early exits (tip above the highest point: the approach and the reset move) give
    what the full computation gives: no patch, and the contour untouched."""
    from hex_control.grinding.contact import DiskPose, clip_below, contact_patch, contact_patch_sampled

    x = np.linspace(0.0, 60.0, 601)
    z = 1.0 + 0.05 * np.sin(x)
    for lift in (1e-6, 0.01, 20.0):
        pose = DiskPose(30.0, z.max() + lift + 85.0 * np.sin(0.35), 0.35, 85.0)
        assert pose.tip_z_mm > z.max()
        assert contact_patch(x, z, pose).length_mm == 0.0 == contact_patch_sampled(x, z, pose, 20_001).length_mm
        cut_x, cut_z, _ = clip_below(x, z, np.array([pose.tip_x_mm, pose.centre_x_mm]),
                                     np.array([pose.tip_z_mm, pose.centre_z_mm]))
        assert np.array_equal(cut_x, x) and np.array_equal(cut_z, z)
