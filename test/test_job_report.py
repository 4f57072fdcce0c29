"""The job report's pieces that do not need a graph: the strut plot's labels, the statistics."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import pytest

from hex_control.grinding.job_report import JobRecord, job_statistics, strut_figure


@pytest.mark.parametrize("names, labels", [
    (["strut_0", "strut_1", "strut_2", "feed_x"], ["strut_0", "strut_1", "strut_2", "feed_x"]),  # 3-PRU
    ([], ["strut_0", "strut_1", "strut_2", "strut_3"]),  # a record without names
])
def test_strut_plot_labels_each_joint_by_the_plants_name(names, labels):
    record = JobRecord(struts=[(0.0, 0.01, 0.02, 0.03, 0.10), (0.05, 0.011, 0.021, 0.031, 0.11)], strut_names=names)
    fig = strut_figure(record)
    try:
        ax = fig.axes[0]
        assert [t.get_text() for t in ax.get_legend().get_texts()] == labels
        assert ax.lines[3].get_ydata()[1] == pytest.approx(110.0)  # m -> mm
    finally:
        plt.close(fig)


def _summary(reason, x_mm, charge, expected=0.5, burn=False):
    return {"outcome": {"reason": reason, "material_remaining_mm": x_mm, "total_charge": charge, "passes": 4},
            "expected_penalty_at_start": expected, "ended_as_intended": reason in ("done", "quit"),
            "burn": burn, "stall": False}


def test_statistics_count_the_band_and_compare_the_charge_with_j():
    summaries = [_summary("done", 0.01, 0.0), _summary("done", -0.002, 1.0), _summary("quit", 0.04, 2.0, burn=True)]
    stats = job_statistics(summaries, tolerance_mm=0.025)
    assert stats["jobs"] == 3 and stats["ended_as_intended"] == 3
    assert stats["reasons"] == {"done": 2, "quit": 1, "aborted": 0}
    assert (stats["overground"], stats["inside_tolerance_band"], stats["burns"]) == (1, 1, 1)
    assert stats["charge_mean"] == pytest.approx(1.0)
    assert stats["charge_standard_error"] == pytest.approx(1.0 / math.sqrt(3))  # sample std 1
    assert stats["charge_minus_expected_in_standard_errors"] == pytest.approx(0.5 * math.sqrt(3))
    assert stats["jobs_charged"] == 2
