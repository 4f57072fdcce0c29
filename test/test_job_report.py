"""The job report's pieces that do not need a graph: the strut plot's labels, the statistics."""

from __future__ import annotations

import json
import math

import pytest

from hex_control.grinding.job_report import (
    JobRecord,
    job_statistics,
    load_job_summaries,
    specific_energy_by_pass,
    write_report,
)


@pytest.mark.parametrize("names, labels", [
    (["strut_0", "strut_1", "strut_2", "feed_x"], ["strut_0", "strut_1", "strut_2", "feed_x"]),  # 3-PRU
    ([], ["strut_0", "strut_1", "strut_2", "strut_3"]),  # a record without names
])
def test_strut_plot_labels_each_joint_by_the_plants_name(names, labels):
    import matplotlib.pyplot as plt  # not at every worker's collection: 0.35 s

    from hex_control.grinding.job_plots import strut_figure

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


def test_batches_run_apart_are_pooled_from_their_report_directories(tmp_path):
    batches = {"a": [_summary("done", 0.01, 0.0), _summary("done", 0.02, 1.0)], "b": [_summary("quit", 0.04, 2.0)]}
    for batch, summaries in batches.items():
        for k, summary in enumerate(summaries):
            (tmp_path / batch / f"job_{k:03d}").mkdir(parents=True)
            (tmp_path / batch / f"job_{k:03d}" / "job.json").write_text(json.dumps(summary))
    single = tmp_path / "single"
    single.mkdir()
    (single / "job.json").write_text(json.dumps(_summary("aborted", 0.3, 5.0)))
    pooled = load_job_summaries([tmp_path / "a", tmp_path / "b", single])
    assert [s["outcome"]["total_charge"] for s in pooled] == [0.0, 1.0, 2.0, 5.0]
    assert job_statistics(pooled, 0.025)["reasons"] == {"done": 2, "quit": 1, "aborted": 1}
    with pytest.raises(ValueError, match="no job.json"):
        load_job_summaries([tmp_path])


def test_each_k1_prediction_is_matched_to_the_pass_result_it_follows():
    record = JobRecord(results={0: {"specific_energy_j_mm3": 8.3, "stamp_s": 21.84},
                                1: {"specific_energy_j_mm3": 12.9, "stamp_s": 29.68},
                                2: {"specific_energy_j_mm3": math.nan, "stamp_s": 37.52}},  # nothing removed
                       # out of order; a stray one
                       k1_predictions=[(29.68, 10.8, 0.7), (21.84, 8.6, 0.2), (5.0, 99.0, 1.0)])
    rows = specific_energy_by_pass(record)
    assert [r[:2] for r in rows[:2]] == [(0, 8.3), (1, 12.9)]
    assert [r[2:] for r in rows[:2]] == [(8.6, 0.2), (10.8, 0.7)]
    assert math.isnan(rows[2][1]) and math.isnan(rows[2][2])  # the predictor refused the NaN
    for result in record.results.values():
        result.update(burn=False, stall=False)
    assert record.summary()["dulling_detected_after_pass"] == 1  # the first P(dulls) above one half


def test_report_of_a_record_writes_its_json_and_k1_plot(tmp_path):
    result = {"specific_energy_j_mm3": 8.3, "stamp_s": 21.84, "burn": False, "stall": False}
    record = JobRecord(results={0: result}, k1_predictions=[(21.84, 8.6, 0.05)],
                       outcome={"reason": "done", "total_charge": 0.0})
    summary = write_report(record, tmp_path)
    assert summary["passes"][0]["specific_energy_j_mm3"] == 8.3
    assert json.loads((tmp_path / "job.json").read_text())["ended_as_intended"]
    assert (tmp_path / "specific_energy.png").stat().st_size > 10_000
    assert not (tmp_path / "contours.png").exists()  # nothing recorded, nothing drawn
    assert "outlook_at_start" not in summary  # no feedback recorded: nothing said
    without = tmp_path / "without_plots"
    assert write_report(record, without, plots=False) == summary  # --no-plots: the same summary, no PNG
    assert (without / "job.json").read_text() == (tmp_path / "job.json").read_text()
    assert not list(without.glob("*.png"))


def test_the_first_feedbacks_word_on_the_deadline_is_in_the_summary():
    command = {"expected_penalty": 0.4, "deadline_reachable": False, "expected_final_material_mm": 0.2,
               "planner_note": "deadline out of reach: ..."}
    record = JobRecord(commands={0: command}, results={0: {"burn": False, "stall": False, "specific_energy_j_mm3": 9.0,
                                                           "stamp_s": 10.0}},
                       outcome={"reason": "quit", "total_charge": 0.5})
    assert record.summary()["outlook_at_start"] == {"deadline_reachable": False, "expected_final_material_mm": 0.2,
                                                    "planner_note": "deadline out of reach: ..."}


def test_the_finished_parts_are_judged_by_their_worst_points_not_their_mean():
    """Issue 20: the statistics say how deep the worst gouge went and how many parts lie
    in the buyer's +-0.1 mm band (seed 002 section 3); jobs from before the scans count not."""
    def part(gouge, deviation):
        return {"gouge_mm": gouge, "ends_gouge_mm": gouge, "highest_mm": deviation, "rms_mm": deviation / 3,
                "max_deviation_mm": max(gouge, deviation)}
    summaries = [{**_summary("done", 0.01, 0.0), "part_quality": part(0.02, 0.05)},
                 {**_summary("done", 0.01, 0.0), "part_quality": part(0.45, 0.2)},
                 _summary("quit", 0.04, 2.0)]
    stats = job_statistics(summaries, tolerance_mm=0.025)
    assert stats["parts_scanned"] == 2 and stats["parts_within_tolerance"] == 1
    assert stats["parts_gouged_beyond_tolerance"] == 1
    assert stats["gouge_mm"] == {"mean": pytest.approx(0.235), "worst": 0.45}
    assert stats["highest_mm"]["worst"] == 0.2
    # issue 42: a part outside the band with time for the fastest pass left (300/75 + 2 s) is counted
    goal = {"bead_length_mm": 300.0, "reset_time_s": 2.0}
    late = {**summaries[1], "goal": goal, "outcome": {**summaries[1]["outcome"], "time_remaining_s": 6.5}}
    early = {**summaries[1], "goal": goal, "outcome": {**summaries[1]["outcome"], "time_remaining_s": 5.5}}
    assert job_statistics([late, early, summaries[0]], 0.025)["parts_outside_with_a_pass_left"] == 1


def test_the_last_scan_is_the_part_and_a_refused_pass_has_none(tmp_path):
    nan = dict.fromkeys(("gouge_mm", "highest_mm", "max_deviation_mm"), math.nan)
    scanned = {"gouge_mm": 0.03, "gouge_x_mm": 8.0, "highest_mm": 0.34, "highest_x_mm": 4.0, "max_deviation_mm": 0.34}
    base = {"specific_energy_j_mm3": 8.3, "stamp_s": 1.0, "burn": False, "stall": False}
    record = JobRecord(results={0: {**base, "part_quality": scanned}, 1: {**base, "part_quality": nan}},
                       outcome={"reason": "done", "total_charge": 0.0})
    summary = record.summary()
    assert summary["part_quality"] == scanned and not summary["part_within_tolerance"]
    assert JobRecord(results={0: base}).part_quality is None


def test_the_plan_is_held_against_what_the_plant_cut_per_pass():
    passes = [{"status": "completed", "cut_depth_mm": 0.5, "pass_planner_cut_depth_mm": None,
               "measured_cut_depth_mm": 0.45},
              {"status": "completed", "cut_depth_mm": 0.5, "pass_planner_cut_depth_mm": 0.2,
               "measured_cut_depth_mm": 0.22},
              {"status": "aborted", "cut_depth_mm": 0.5, "measured_cut_depth_mm": 0.1}]  # not a pass as planned
    error = job_statistics([{**_summary("done", 0.01, 0.0), "passes": passes}], 0.025)["cut_depth_error_mm"]
    assert error["passes"] == 2 and error["mean_absolute"] == pytest.approx(0.035)
    assert error["mean_absolute_relative"] == pytest.approx(0.1) and error["mean_relative"] == pytest.approx(0.0)


def test_report_keeps_every_scan_as_a_profile_the_pass_planner_reads(tmp_path):
    """The scans go to profiles/after_pass_N.csv, which `hexctl pass --contour` reads back."""
    import numpy as np

    from hex_control.grinding.contour import Contour, weld_bead

    bead = weld_bead(60.0, 1.0, seed=2)
    ground = Contour(bead.x_mm, np.minimum(bead.z_mm, 0.4), bead.parent_mm)
    result = {"specific_energy_j_mm3": 9.0, "stamp_s": 10.0, "burn": False, "stall": False}
    record = JobRecord(results={0: result}, contours={0: (bead, 12.5), 1: (ground, 12.5)},
                       outcome={"reason": "done", "total_charge": 0.0})
    write_report(record, tmp_path)
    assert sorted(p.name for p in (tmp_path / "profiles").iterdir()) == ["after_pass_0.csv", "after_pass_1.csv"]
    back = Contour.from_csv(tmp_path / "profiles" / "after_pass_1.csv")
    assert np.allclose(back.z_mm, ground.z_mm) and np.allclose(back.parent_mm, ground.parent_mm)
    assert (tmp_path / "contours.png").stat().st_size > 10_000


def test_a_job_with_faulted_passes_is_never_a_clean_end(tmp_path):
    """Issue 37 item 2: the plant's FAULTED (or ABORTED) passes are listed in job.json with
    their reason, and such a job is not 'ended_clean' even when its policy ended it DONE."""
    base = {"specific_energy_j_mm3": 9.0, "stamp_s": 10.0, "burn": False, "stall": False}
    record = JobRecord(results={0: {**base, "status": "faulted", "reason": "cut short: 0.05 of 0.31 mm"},
                                1: {**base, "status": "completed", "reason": ""},
                                2: {**base, "status": "aborted", "reason": "watchdog"}},
                       events=[("result", 0), ("result", 1), ("result", 2)],
                       outcome={"reason": "done", "total_charge": 0.0,
                                "message": "policy ends the job; 2 of 3 passes not as planned: ..."})
    summary = json.loads(json.dumps(write_report(record, tmp_path)))
    assert summary["ended_as_intended"] and not summary["ended_clean"]
    assert summary["passes_not_as_planned"] == [
        {"pass": 0, "status": "faulted", "reason": "cut short: 0.05 of 0.31 mm"},
        {"pass": 2, "status": "aborted", "reason": "watchdog"}]
    assert json.loads((tmp_path / "job.json").read_text())["passes_not_as_planned"][0]["status"] == "faulted"
    clean = JobRecord(results={0: {**base, "status": "completed"}}, events=[("result", 0)],
                      outcome={"reason": "done", "total_charge": 0.0}).summary()
    assert clean["ended_clean"] and clean["passes_not_as_planned"] == []
    stats = job_statistics([{**_summary("done", 0.01, 0.0), "passes_not_as_planned": summary["passes_not_as_planned"]},
                            _summary("done", 0.0, 0.0)], 0.025)
    assert stats["jobs_with_passes_not_as_planned"] == 1 and stats["passes_faulted"] == 1
