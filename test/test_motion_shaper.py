"""The input shaper's behaviour without ROS (hex_control.shaping.motion_shaper): the stream's
staircase, a run-time change without a jump, refused samples, a path shaped whole, the
choices refused and the optimized design handed out."""

import math

import numpy as np
import pytest

from hex_control.kinematics.rotation import quaternion_from_rpy
from hex_control.shaping.motion_shaper import MotionShaper, ShaperChoice, design_problem, refusal
from hex_control.shaping.shapers import design

ZVD_10HZ = ShaperChoice("zvd", 10.0, 0.0, 0.05, (4.25, 5.0, 7.5))


def same(a, b) -> bool:
    return np.array_equal(a.amplitudes, b.amplitudes) and np.array_equal(a.times_s, b.times_s)


def joints(**changes) -> MotionShaper:
    return MotionShaper(ShaperChoice(**{**ZVD_10HZ.__dict__, **changes}), 0.01, True, pose_stream=False)


def test_a_step_becomes_the_zvd_staircase_on_every_channel():
    shaper = joints()
    first = [shaper.step([v, 2 * v]) for v in [0.0] * 5 + [1.0] * 20]
    x = [round(float(s[0]), 12) for s in first]
    assert sorted(set(x)) == [0.0, 0.25, 0.75, 1.0]  # ZVD at 10 Hz: 0, 50, 100 ms
    assert x.index(0.25) == 5 and x.index(0.75) == 10 and x.index(1.0) == 15
    np.testing.assert_allclose([s[1] for s in first], 2 * np.array([s[0] for s in first]))


def test_a_run_time_change_has_no_jump_and_a_bad_sample_is_refused_without_a_trace():
    shaper = joints()
    ramp = np.minimum(np.arange(200) * 0.01, 1.0)
    out = [shaper.step([v]) for v in ramp[:80]]
    assert shaper.apply(ShaperChoice("ei", 7.0, 0.0, 0.05, ())) is None
    assert (shaper.label, shaper.changes) == ("ei", 1) and same(shaper.shaper, design("ei", 7.0, 0.0, 0.05))
    assert shaper.step([math.nan]) is None and shaper.step([]) is None
    out += [shaper.step([v]) for v in ramp[80:]]
    output = np.array(out).ravel()
    assert np.max(np.abs(np.diff(output))) <= 0.0101 and output[-1] == pytest.approx(1.0)
    plain = joints(shaper="ei", frequency_hz=7.0)  # the refused samples left nothing behind:
    steady = [plain.step([1.0]) for _ in range(30)]  # a shaper at rest on 1.0 gives 1.0
    assert steady[-1] == pytest.approx(1.0)


def test_a_pose_stream_keeps_a_unit_quaternion():
    shaper = MotionShaper(ZVD_10HZ, 0.01, True, pose_stream=True)
    out = [shaper.step([0.1 * k, 0.0, -2.0, *quaternion_from_rpy(0.0, 0.0, 0.2 * (k >= 3))]) for k in range(8)]
    assert all(abs(np.linalg.norm(s[3:]) - 1.0) < 1e-12 for s in out)
    assert out[7][0] == pytest.approx(0.25 * 0.7 + 0.5 * 0.2)  # ZVD: 0.25, 0.5 (50 ms), 0.25 (100 ms)
    assert out[7][1:3] == pytest.approx([0.0, -2.0])


def test_a_whole_path_is_longer_by_the_delay_and_starts_the_lag_early():
    shaper = joints()
    step = np.array([0.0] * 5 + [1.0] * 20)
    rows = np.column_stack([(k + 1) * step for k in range(6)])
    shaped, start_s = shaper.shape_path(rows, 0.01, 12.0)
    assert start_s == pytest.approx(11.95)  # half the ZVD's 0.1 s
    assert shaped.shape == (35, 6)  # ten more samples, at rest
    assert shaped[5, 0] == pytest.approx(0.25) and shaped[10, 0] == pytest.approx(0.75)
    assert shaped[15:, 0] == pytest.approx(1.0)
    np.testing.assert_allclose(shaped[:, 5], 6 * shaped[:, 0])
    assert shaper.shape_path(rows, 0.01, 0.02)[1] == 0.0  # never before 0


def test_choices_are_checked_and_an_optimized_one_is_handed_out_to_design():
    assert refusal(ZVD_10HZ) == ""
    assert "frequency" in refusal(ShaperChoice("zvd", -1.0, 0.0, 0.05, ()))
    assert refusal(ShaperChoice("optimized", 5.0, 0.0, 0.05, ())) == "optimized_frequencies_hz must be positive"
    assert refusal(ShaperChoice("optimized", 5.0, 0.0, 0.05, (0.0, 5.0))) != ""
    optimized = ShaperChoice("optimized", 5.0, 0.02, 0.05, (8.5, 10.0, 15.0))
    shaper = MotionShaper(optimized, 0.01, True, pose_stream=False)
    assert same(shaper.shaper, design("zvd", 5.0, 0.02)) and shaper.changes == 0  # until the design is in
    problem = shaper.apply(optimized)
    assert problem == design_problem(optimized) and shaper.label == "optimized (designing)"
    assert problem.frequencies_hz == (8.5, 10.0, 15.0) and problem.impulses == 5
    assert problem.max_delay_s == pytest.approx(1.5 / 8.5)
    designed = design("zv", 9.0, 0.0)
    shaper.switch(designed, "optimized (criterion 1.00e-03)")
    assert shaper.shaper is designed and (shaper.label, shaper.changes) == ("optimized (criterion 1.00e-03)", 1)
    with pytest.raises(ValueError, match="sample_period_s"):
        MotionShaper(ZVD_10HZ, 0.0, True, pose_stream=False)
