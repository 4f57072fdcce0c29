"""The job state machine and its log (ROS-free): decisions, results, restart, policy ends."""

import json

import numpy as np
import pytest

from hex_control.grinding.job import DONE, GrindingJob, JobGoal, read_model, unfinished_logs
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.sdp import Charges, solve
from hex_control.grinding.stochastic import CutDepthModel

PROCESS = GrindingProcess()
POLICY = solve(PROCESS)
MODEL = CutDepthModel()


def run(job, rng, stop_after=None):
    while (decision := job.decide()) is not None:
        if stop_after is not None and job.state.passes >= stop_after:
            return decision
        cut = MODEL.sample(PROCESS.cut_depth_mm(decision["force_n"], decision["feed_mm_s"]),
                           MODEL.std_mm(PROCESS, decision["force_n"], decision["feed_mm_s"]), rng)
        job.apply_result(decision["pass_index"], cut, decision["duration_s"])
    return None


def test_a_job_runs_to_the_policys_end(tmp_path):
    job = GrindingJob(JobGoal("j1", 1.0, 12.5, 300.0, 40.0), POLICY, Charges(), tmp_path / "j1.jsonl")
    run(job, np.random.default_rng(0))
    assert job.finished and job.state.passes >= 1
    assert job.state.end["charge"] == pytest.approx(job.final_charge())
    kinds = [json.loads(line)["type"] for line in (tmp_path / "j1.jsonl").read_text().splitlines()]
    assert kinds[0] == "goal" and kinds[-1] == "end" and kinds.count("result") == job.state.passes


def test_restart_resumes_without_repeating_a_pass(tmp_path):
    """Stop after two passes with the third decided; a fresh object from the log continues
    at the measured state and awaits that same pass."""
    path = tmp_path / "j2.jsonl"
    job = GrindingJob(JobGoal("j2", 1.9, 12.5, 300.0, 120.0), POLICY, Charges(), path)  # ~7 passes
    pending = run(job, np.random.default_rng(1), stop_after=2)
    assert unfinished_logs(tmp_path) == [path]
    resumed = GrindingJob.resume(path, POLICY, Charges())
    assert resumed.state.passes == 2
    assert resumed.state.material_mm == job.state.material_mm
    assert resumed.decide() == pending  # the same pass, not a new one
    run(resumed, np.random.default_rng(2))
    indices = [r["pass_index"] for r in resumed.state.history]
    assert indices == list(range(len(indices)))
    assert unfinished_logs(tmp_path) == []


def test_model_updates_are_logged_and_read_back_without_changing_the_state(tmp_path):
    path = tmp_path / "j5.jsonl"
    job = GrindingJob(JobGoal("j5", 1.9, 12.5, 300.0, 120.0), POLICY, Charges(), path)
    assert read_model(path) is None
    pending = run(job, np.random.default_rng(1), stop_after=1)
    job.update_model(10.4, 10.0, 60.0, 60.0)
    job.update_model(12.1, 12.1, 48.0, 50.0)
    assert read_model(path) == {"type": "model", "specific_energy_j_mm3": 12.1, "solved_with_j_mm3": 12.1,
                                "force_max_n": 48.0, "solved_force_max_n": 50.0}
    resumed = GrindingJob.resume(path, POLICY, Charges())
    assert resumed.state == job.state and resumed.decide() == pending


def test_torn_last_line_is_ignored(tmp_path):
    path = tmp_path / "j3.jsonl"
    job = GrindingJob(JobGoal("j3", 0.5, 12.5, 300.0, 30.0), POLICY, Charges(), path)
    job.decide()
    with open(path, "a") as log:
        log.write('{"type": "result", "pass_ind')
    assert GrindingJob.resume(path, POLICY, Charges()).state.pending is not None


def test_already_within_tolerance_is_done_at_once(tmp_path):
    job = GrindingJob(JobGoal("j4", 0.01, 12.5, 300.0, 30.0), POLICY, Charges(), tmp_path / "j4.jsonl")
    assert job.decide() is None and job.state.end["reason"] == DONE and job.final_charge() == 0.0


@pytest.mark.parametrize("field, value", [("material_mm", -1.0), ("deadline_s", 0.0), ("bead_width_mm", float("nan"))])
def test_bad_goals_are_refused(field, value):
    values = {"job_id": "x", "material_mm": 1.0, "bead_width_mm": 12.5, "bead_length_mm": 300.0, "deadline_s": 30.0}
    with pytest.raises(ValueError, match=field):
        JobGoal(**{**values, field: value})


def test_result_for_the_wrong_pass_is_refused(tmp_path):
    job = GrindingJob(JobGoal("j5", 1.0, 12.5, 300.0, 40.0), POLICY, Charges(), tmp_path / "j5.jsonl")
    decision = job.decide()
    with pytest.raises(ValueError, match="no pending pass"):
        job.apply_result(decision["pass_index"] + 1, 0.1, 6.0)
    with pytest.raises(ValueError, match="finite"):
        job.apply_result(decision["pass_index"], float("nan"), 6.0)
