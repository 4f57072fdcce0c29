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


# -- the incremental kernel (issue 39 item 1) ---------------------------------------------------

from hex_control.grinding import contact as contact_module  # noqa: E402
from hex_control.grinding.contact import LiveContour, clip_region  # noqa: E402
from hex_control.grinding.contact_reference import clip_below_reference, contact_patch_reference  # noqa: E402
from hex_control.grinding.contour import Contour  # noqa: E402

#: the compiled kernel (_contact_c.c) and the Python one it was made from, on few points in
#: plain floats and on many in numpy
KERNELS = pytest.mark.parametrize("kernel", ["compiled", "plain floats", "numpy"])


def _use(monkeypatch, kernel: str) -> None:
    assert contact_module._compiled is not None, "setup.py builds the compiled kernel: it must load"
    if kernel != "compiled":
        monkeypatch.setattr(contact_module, "_compiled", None)
        monkeypatch.setattr(contact_module, "SCALAR_POINTS", 40 if kernel == "plain floats" else -1)


def _truth(x, z, cut_x, cut_z, samples):
    """min(contour, cutter) over the cutter's span, the contour elsewhere, sampled."""
    inside = (samples >= max(cut_x[0], x[0])) & (samples <= min(cut_x[-1], x[-1]))
    return np.where(inside, np.minimum(np.interp(samples, x, z), np.interp(samples, cut_x, cut_z)),
                    np.interp(samples, x, z))


@KERNELS
def test_a_crossing_next_to_a_cutter_vertex_above_the_contour_is_exact(monkeypatch, kernel):
    """A falling contour crosses the cutter's first segment at x = 4.36 mm, and the cutter's
    vertex at x = 6 lies above the contour. The old truncation interpolated the depth across
    that vertex and put the crossing at 1.55 mm (up to 0.17 mm too low); the new one merges
    every cutter vertex in the span and is exact."""
    _use(monkeypatch, kernel)
    x, z = np.array([0.0, 10.0]), np.array([1.0, 0.0])
    cut_x, cut_z = np.array([0.0, 6.0, 12.0]), np.array([0.6, 0.55, 3.0])
    samples = np.linspace(0.0, 10.0, 10001)
    new_x, new_z, _ = clip_below(x, z, cut_x, cut_z)
    np.testing.assert_allclose(np.interp(samples, new_x, new_z), _truth(x, z, cut_x, cut_z, samples), atol=1e-12)
    assert 6.0 not in new_x  # the vertex above the contour helped find the crossing, and was dropped
    old_x, old_z, _ = clip_below_reference(x, z, cut_x, cut_z)
    assert np.max(np.abs(np.interp(samples, old_x, old_z) - _truth(x, z, cut_x, cut_z, samples))) > 0.15


@KERNELS
def test_random_truncations_are_exact_and_keep_x_increasing(monkeypatch, kernel):
    _use(monkeypatch, kernel)
    rng = np.random.default_rng(39)
    for _ in range(200):
        x = np.cumsum(rng.uniform(0.05, 1.0, 60))
        z = rng.normal(0.0, 0.3, x.size)
        # as the stepper's cutters: from on or above the contour, through a vertex anywhere, to
        # above it all (a cutter ending under the contour would leave a vertical step)
        cut_x = np.sort(rng.uniform(x[0] - 2, x[-1] + 2, 3))
        cut_z = np.array([np.interp(cut_x[0], x, z) + rng.uniform(0.0, 0.3), rng.normal(0.0, 0.4), 2.0])
        new_x, new_z, _ = clip_below(x, z, cut_x, cut_z, top_mm=float(z.max()) + rng.uniform(0, 1))
        assert np.all(np.diff(new_x) > 0)
        samples = np.linspace(x[0], x[-1], 4001)
        np.testing.assert_allclose(np.interp(samples, new_x, new_z), _truth(x, z, cut_x, cut_z, samples), atol=1e-9)


@KERNELS
def test_the_narrowed_contact_search_is_the_whole_face_search(monkeypatch, kernel):
    """Only the face below the contour's top is visited (and in plain floats when few points
    lie there): the same patch as the old search over the whole face, to float tolerance."""
    _use(monkeypatch, kernel)
    rng = np.random.default_rng(7)
    for _ in range(300):
        x = np.cumsum(rng.uniform(0.02, 1.0, 400))
        z = rng.normal(0.0, 0.5, x.size)
        pose = _pose(rng.uniform(x[5], x[200]), rng.normal(0.0, 0.6), rng.uniform(0.1, 0.6))
        new, old = contact_patch(x, z, pose, top_mm=float(z.max())), contact_patch_reference(x, z, pose)
        assert (new.patches, new.kind) == (old.patches, old.kind)
        assert new.length_mm == pytest.approx(old.length_mm, rel=1e-9, abs=1e-12)
        assert new.centroid_mm == pytest.approx(old.centroid_mm, rel=1e-9, abs=1e-12)


def test_the_live_contour_is_the_contour_cut_in_full_whatever_the_order(monkeypatch):
    """LiveContour cuts near the tool without copying the rest, moves points to its done
    part behind the tool and back when a cut reaches behind it, grows when its gap is used
    up, and drops points a cut laid on a straight line: the same polyline, to 1e-9 mm, as
    truncating the whole arrays every time, its parent interpolated alike."""
    monkeypatch.setattr(LiveContour, "SPARE", 8)  # grow often
    rng = np.random.default_rng(5)
    x = np.linspace(0.0, 100.0, 401)
    contour = Contour(x, 1.0 + 0.1 * np.sin(x) + rng.normal(0, 0.02, x.size), 0.001 * (x - 50) ** 2)
    live = LiveContour(contour)
    full_x, full_z, full_p = contour.x_mm, contour.z_mm, contour.parent_mm
    tip = 2.0
    for step in range(600):
        # as the stepper's cutters: from the last tip (on the contour) to the new one and up the face
        last = tip if step % 50 else tip - rng.uniform(2.0, 6.0)  # now and then a jump back
        tip = last + rng.uniform(0.05, 0.3)
        cut_x = np.array([last, tip, tip + 30.0])
        cut_z = np.array([np.interp(last, full_x, full_z), 0.95 + rng.normal(0, 0.02) - 0.2 * (step % 50 == 0), 12.0])
        live.clip(cut_x, cut_z)
        full_x, full_z, (full_p,) = clip_below(full_x, full_z, cut_x, cut_z, (full_p,))
    got = live.contour
    assert np.all(np.diff(got.x_mm) > 0) and got.x_mm.size < full_x.size
    samples = np.linspace(0.0, 100.0, 20001)
    np.testing.assert_allclose(got.height_at(samples), np.interp(samples, full_x, full_z), atol=1e-9)
    np.testing.assert_allclose(np.interp(samples, got.x_mm, got.parent_mm), np.interp(samples, full_x, full_p),
                               atol=1e-9)


def test_clip_region_names_the_points_it_replaces():
    x, z = np.linspace(0.0, 10.0, 11), np.full(11, 1.0)
    lo, hi, new_x, new_z = clip_region(x, z, np.array([3.5, 6.5]), np.array([0.5, 0.5]))
    assert (lo, hi) == (4, 7) and new_x[0] == 3.5 and new_x[-1] == 6.5 and np.all(new_z == 0.5)
    assert clip_region(x, z, np.array([3.5, 6.5]), np.array([1.5, 1.5])) is None


def test_the_compiled_kernel_is_the_python_one_to_the_last_bit_on_few_points(monkeypatch):
    """_contact_c.c runs the plain-float algorithm for any number of points: on the few
    points a step visits its patches and cuts are the Python kernel's exactly, on many they
    differ from numpy's pairwise sums by rounding only."""
    rng = np.random.default_rng(39)
    cases = []
    for _ in range(300):
        x = np.cumsum(rng.uniform(0.05, 1.0, 60))
        z = rng.normal(0.0, 0.3, x.size)
        pose = _pose(rng.uniform(x[5], x[40]), rng.normal(0.0, 0.4), rng.uniform(0.1, 0.6))
        cut_x = np.sort(rng.uniform(x[0] - 2, x[-1] + 2, 3))
        cut_z = np.array([np.interp(cut_x[0], x, z) + rng.uniform(0.0, 0.3), rng.normal(0.0, 0.4), 2.0])
        cases.append((x, z, pose, cut_x, cut_z, float(z.max()) + rng.uniform(0, 1)))

    def run():
        return [(contact_patch(x, z, pose, top_mm=top), clip_region(x, z, cut_x, cut_z, top))
                for x, z, pose, cut_x, cut_z, top in cases]

    compiled = run()
    _use(monkeypatch, "plain floats")
    few = run()
    monkeypatch.setattr(contact_module, "SCALAR_POINTS", -1)
    many = run()
    cuts = 0
    for (patch, region), (patch_few, region_few), (patch_many, region_many) in zip(compiled, few, many):
        assert patch == patch_few
        assert (patch.patches, patch.kind) == (patch_many.patches, patch_many.kind)
        assert patch.length_mm == pytest.approx(patch_many.length_mm, rel=1e-12, abs=1e-15)
        assert (region is None) == (region_few is None) == (region_many is None)
        if region is not None:
            cuts += 1
            assert region[:2] == region_few[:2] == region_many[:2]
            for got, want in zip(region[2:], region_few[2:]):
                assert np.array_equal(got, want)
            for got, want in zip(region[2:], region_many[2:]):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert cuts > 100  # most of the cutters cut


def test_a_pass_simulated_with_the_compiled_kernel_is_the_python_kernels(monkeypatch):
    """A whole planned pass (600 RK4 steps, 3,000 contact searches, 600 cuts): the same
    histories and final contour, bit for bit, with the kernel compiled or not."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.contour import weld_bead
    from hex_control.grinding.dynamic import HeightControl, simulate_pass
    from hex_control.grinding.pass_plan import final_contour

    model = load_pass_planner_config("pass_planner.yaml").model
    bead = weld_bead(60.0, 0.8, 12.0, ripple_mm=0.05, seed=0)
    target = final_contour(bead, 0.2, model.process.bead_width_mm)

    def simulate():
        drive = HeightControl(model, bead.x_mm, target.tip_mm, bead.x_mm[0])
        return simulate_pass(bead, model, drive, 11.3, step_mm=0.1)

    compiled = simulate()
    _use(monkeypatch, "plain floats")
    python = simulate()
    assert compiled.history["time_s"].size > 500 and compiled.removed_mm3 > 0
    for name, values in python.history.items():
        assert np.array_equal(compiled.history[name], values), name
    assert np.array_equal(compiled.final.x_mm, python.final.x_mm)
    assert np.array_equal(compiled.final.z_mm, python.final.z_mm)


def test_the_compiled_kernel_refuses_malformed_buffers_and_survives_nan(monkeypatch):
    """The C kernel reads raw buffers: a wrong length or an empty one is a ValueError, not a
    read out of bounds; a cutter of NaN heights cuts nothing; a NaN pose touches nothing."""
    _use(monkeypatch, "compiled")
    kernel = contact_module._compiled
    x, z = np.linspace(0.0, 10.0, 11), np.full(11, 1.0)
    with pytest.raises(ValueError):
        kernel.contact_patch(x, z[:5], 5.0, 1.0, 0.3, 80.0, 1e-7, 1.0)
    with pytest.raises(ValueError):
        kernel.contact_patch(np.empty(0), np.empty(0), 5.0, 1.0, 0.3, 80.0, 1e-7, 1.0)
    with pytest.raises(ValueError):
        kernel.clip_region(x, z, b"1234567", b"1234567", 1.0, 1e-9)
    with pytest.raises(ValueError):
        kernel.clip_region(x, z, np.array([1.0, 2.0]), np.array([0.5]), 1.0, 1e-9)
    with pytest.raises(ValueError, match="contiguous"):  # the wrapper copies such arrays; the kernel refuses them
        kernel.clip_region(x, z, x[::2], z[::2], 1.0, 1e-9)
    misaligned = np.frombuffer(b"\0" * (8 * 11 + 1), offset=1)  # 11 float64 one byte off their alignment
    with pytest.raises(ValueError, match="aligned"):
        kernel.contact_patch(misaligned, z, 5.0, 1.0, 0.3, 80.0, 1e-7, 1.0)
    assert kernel.clip_region(x, z, np.array([3.0, 6.0]), np.full(2, np.nan), 1.0, 1e-9) is None
    # a NaN at the cutter's end (its last x, or a NaN height after its part below the top) made
    # the window negative: a heap overflow (helper attack, 2026-12-07); an x that does not rise, too
    long_x, long_z = np.arange(0.0, 100.0), np.ones(100)
    assert kernel.clip_region(long_x, long_z, np.array([4.5, np.nan]), np.full(2, 0.5), 1.0, 1e-9) is None
    assert kernel.clip_region(long_x, long_z, np.array([10.2, 10.5, 11.0]), np.array([0.5, np.nan, np.nan]), 1.0,
                              1e-9) is None
    assert kernel.clip_region(long_x[::-1].copy(), long_z, np.array([4.5, 6.5]), np.full(2, 0.5), 1.0, 1e-9) is None
    assert kernel.contact_patch(x, z, np.nan, np.nan, 0.3, 80.0, 1e-7, 1.0)[2] == 0
    # and the wrapper takes any numeric arrays, as the Python kernel does
    pose = _pose(4.0, 0.5)
    assert contact_patch(x.astype(np.float32), z.astype(int), pose, top_mm=1.0) == contact_patch(x, z, pose)


@KERNELS
def test_a_cutter_across_the_whole_contour_keeps_the_points_it_does_not_cut(monkeypatch, kernel):
    """Its span's ends are the contour's own first and last points and it has no vertex
    inside: nothing is added, and the numpy path then dropped every point below the cutter
    (the polyline it left cut through them), found against the compiled kernel."""
    _use(monkeypatch, kernel)
    x = np.linspace(0.0, 10.0, 11)
    z = np.where(np.arange(11) % 2 == 0, 0.2, 0.8)  # a zigzag across the cutter's height
    lo, hi, new_x, new_z = clip_region(x, z, np.array([-1.0, 11.0]), np.array([0.5, 0.5]))
    assert (lo, hi) == (0, 11)
    samples = np.linspace(0.0, 10.0, 2001)
    np.testing.assert_allclose(np.interp(samples, new_x, new_z), np.minimum(np.interp(samples, x, z), 0.5), atol=1e-12)
    assert set(x[z < 0.5]) <= set(new_x)
