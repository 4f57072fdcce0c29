"""The pass's tool path (hex_control.grinding.tool_path): the run-on and run-off put every
change of feed off the bead, so the shaped path grinds the bead at the planned feed and
time from its first millimetre to its last (issue 20)."""

import numpy as np
import pytest

from hex_control.grinding.tool_path import BeadFrame, PathTiming, pass_tool_path
from hex_control.shaping.filter import shape_whole
from hex_control.shaping.shapers import design

FEED_MM_S = 51.8  # the demo's fastest feed
ZVD = design("zvd", 5.0, 0.02)  # config/input_shaper.yaml


def _shaped_against_planned(run_on_s: float):
    """(grinding-phase time s, shaped minus planned centre x mm) for a 150 mm pass at constant feed."""
    timing = PathTiming(run_on_s=run_on_s)
    t = np.linspace(0.0, 150.0 / FEED_MM_S, 301)
    x = 80.0 + FEED_MM_S * t
    path = pass_tool_path(BeadFrame(), t, x, np.full_like(t, 30.0), timing)
    shaped, lag_s = shape_whole(ZVD, timing.sample_period_s, path.positions_mm)
    when = np.arange(len(shaped)) * timing.sample_period_s - lag_s - path.grind_start_s
    grinding = (when >= 0.0) & (when <= t[-1])
    return when[grinding], shaped[grinding, 0] - np.interp(when[grinding], t, x)


def test_without_a_run_on_the_shaped_tool_creeps_over_the_bead_ends():
    """The old path started and stopped the feed on the bead: the shaper spreads each change
    of speed over 0.2 s centred on it, so the tool is off its plan by up to 1.3 mm (a quarter
    of the ZVD's lag at full feed) where the force trajectory presses as planned."""
    when, error = _shaped_against_planned(0.0)
    assert np.max(np.abs(error)) == pytest.approx(0.25 * 0.1 * FEED_MM_S, rel=0.05)
    ends = (when < 0.1) | (when > when[-1] - 0.1)
    assert np.max(np.abs(error[~ends])) < 1e-6  # in between it is on time


def test_with_a_run_on_the_shaped_tool_is_on_plan_over_the_whole_bead():
    when, error = _shaped_against_planned(PathTiming().run_on_s)
    assert when[0] == pytest.approx(0.0, abs=0.005) and when[-1] > 150.0 / FEED_MM_S - 0.005
    assert np.max(np.abs(error)) < 1e-6


def test_the_run_on_adds_its_time_on_both_sides_off_the_bead():
    t = np.linspace(0.0, 2.0, 41)
    plain = pass_tool_path(BeadFrame(), t, 80.0 + 20.0 * t, np.full_like(t, 30.0), PathTiming(run_on_s=0.0))
    run_on = pass_tool_path(BeadFrame(), t, 80.0 + 20.0 * t, np.full_like(t, 30.0), PathTiming(run_on_s=0.25))
    assert run_on.time_s[-1] == pytest.approx(plain.time_s[-1] + 0.5)
    assert run_on.grind_start_s == pytest.approx(plain.grind_start_s + 0.25)
    x = run_on.positions_mm[:, 0]
    assert x.min() == pytest.approx(80.0 - 20.0 * 0.25) and x.max() == pytest.approx(120.0 + 20.0 * 0.25)
    start = int(round(run_on.grind_start_s / 0.005))
    assert run_on.positions_mm[start - 50:start + 1, 2] == pytest.approx(30.0)  # at the pass's height
    with pytest.raises(ValueError):
        PathTiming(run_on_s=-0.1)
