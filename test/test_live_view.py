"""The live view's state and bounds without ROS (hex_control.recording.live_view)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from hex_control.grinding.bead_outline import MAX_CONTOUR_POINTS, MAX_OUTLINE_POINTS
from hex_control.recording.live_view import (
    LiveView,
    contour_points,
    contour_refusal,
    force_samples,
    json_number,
    seconds_to_ns,
)


def test_times_and_numbers_are_json_safe():
    assert seconds_to_ns(1.5) == 1_500_000_000 and seconds_to_ns(-3.0) == 0
    assert json_number(math.nan) is None and json_number(math.inf) is None and json_number(2) == 2.0


def test_a_batch_and_a_contour_are_cut_to_a_plots_worth_with_their_ends():
    time_s = np.arange(10 * MAX_OUTLINE_POINTS) * 0.005
    samples = force_samples(time_s, np.full(time_s.size, 40.0))
    assert len(samples) == MAX_OUTLINE_POINTS
    assert samples[0] == (0, 40.0) and samples[-1][0] == seconds_to_ns(time_s[-1])
    assert force_samples([0.0, 0.005, 0.01], [5.0, math.nan]) == [(0, 5.0), (5_000_000, None)]  # none past the end
    x = np.linspace(0.0, 300.0, 3 * MAX_OUTLINE_POINTS)
    points = contour_points(x, x * 0.0, [])
    assert len(points["x_mm"]) == MAX_OUTLINE_POINTS and points["x_mm"][-1] == 300.0 and points["parent_mm"] == []


def test_a_contour_beyond_the_limit_or_with_unlike_arrays_is_refused():
    assert contour_refusal(10, 10, 0) is None and contour_refusal(10, 10, 10) is None
    assert "refused" in contour_refusal(MAX_CONTOUR_POINTS + 1, MAX_CONTOUR_POINTS + 1, 0)
    assert contour_refusal(10, 9, 0) and contour_refusal(10, 10, 3)


def test_the_state_keeps_time_forward_the_first_contour_and_the_table_in_order():
    view = LiveView()
    view.heard(5)
    view.heard(3)
    assert view.time_ns == 5  # never backwards
    first, later, again = (SimpleNamespace(pass_index=k) for k in (0, 2, 0))
    view.contour(first)
    view.contour(later)
    assert (view.first_contour, view.last_contour) == (first, later)
    view.contour(again)  # a new job's pass 0 is the first again
    assert view.first_contour is again
    view.row("job", 1, {"F_N": 40.0, "J": math.nan})
    view.row("job", 0, {"status": "completed", "burn": False})
    view.row("job", 1, {"status": "completed"})
    assert view.table() == {"rows": [{"job": "job", "pass": 0, "status": "completed", "burn": False},
                                     {"job": "job", "pass": 1, "F_N": 40.0, "J": None, "status": "completed"}]}
