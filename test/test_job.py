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


def test_passes_not_run_as_planned_are_said_in_the_end_and_survive_a_restart(tmp_path):
    """Issue 37 item 2: an aborted or faulted pass is re-decided from what the scanner
    measured; the job's end message and log record name each, with its reason."""
    path = tmp_path / "j6.jsonl"
    job = GrindingJob(JobGoal("j6", 1.9, 12.5, 300.0, 120.0), POLICY, Charges(), path)
    decision = job.decide()
    job.apply_result(decision["pass_index"], 0.05, decision["duration_s"], status="faulted", reason="cut short")
    decision = job.decide()
    job.apply_result(decision["pass_index"], 0.0, 1.0, completed=False)  # the old call: aborted, no reason
    with pytest.raises(ValueError, match="unknown pass status"):
        job.apply_result(job.decide()["pass_index"], 0.1, 1.0, status="fine")
    resumed = GrindingJob.resume(path, POLICY, Charges())
    assert resumed.state.not_as_planned == [(0, "faulted", "cut short"), (1, "aborted", "")]
    run(resumed, np.random.default_rng(3))
    end = resumed.state.end
    assert end["reason"] in (DONE, "quit") and end["message"].startswith("policy ends the job; 2 of ")
    assert "passes not as planned: pass 0 faulted (cut short), pass 1 aborted" in end["message"]
    assert end["not_as_planned"] == [[0, "faulted", "cut short"], [1, "aborted", ""]]


def test_a_log_written_before_the_status_field_reads_back(tmp_path):
    path = tmp_path / "j7.jsonl"
    job = GrindingJob(JobGoal("j7", 1.0, 12.5, 300.0, 40.0), POLICY, Charges(), path)
    decision = job.decide()
    job.apply_result(decision["pass_index"], 0.2, decision["duration_s"], completed=False)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    for record in lines:
        record.pop("status", None), record.pop("reason", None)
    path.write_text("".join(json.dumps(r) + "\n" for r in lines))
    assert GrindingJob.resume(path, POLICY, Charges()).state.not_as_planned == [(0, "aborted", "")]
