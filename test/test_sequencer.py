"""The sequence planner's core (ROS-free, milliseconds but for the policy solves): a job from goal
to end, resume from its log, redelivered results, the K1 prediction awaited, Quit Now, DONE;
and what it refuses (issue 37): results not of the pass in flight or not matching the
plant's scans, FAULTED passes said in the job's end, goals for another bead, a pass overdue."""

from __future__ import annotations

import dataclasses
import json
import math
import threading
from pathlib import Path

import numpy as np
import pytest
import yaml

from hex_control.config import config_file
from hex_control.grinding.contour import weld_bead
from hex_control.grinding.job import read_log
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.sequencer import (
    ABORTED_PASS,
    COMPLETED_PASS,
    FAULTED_PASS,
    REJECTED_PASS,
    GoalRequest,
    PassReport,
    Sequencer,
    SequencerSettings,
    SolveAbandoned,
    contour_height_mm,
)
from hex_control.grinding.stochastic import CutDepthModel

CONFIG = yaml.safe_load(config_file("sequence_planner.yaml").read_text())
PROCESS, MODEL = GrindingProcess(), CutDepthModel()
_POLICIES = {}  # (goal, process) -> solution: each policy solved once per session


class Rig:
    """A Sequencer with the solves done at once, and a plant stand-in that answers each
    command with a cut drawn from the stochastic model (and, with ``bead``, scans)."""

    def __init__(self, tmp_path, seed=0, predictor=False, bead=None, **settings):
        self.settings = SequencerSettings(tmp_path / "jobs", **settings)
        self.heard = predictor
        self.core = Sequencer(self.settings, CONFIG, predictor_heard=lambda: self.heard)
        self.rng = np.random.default_rng(seed)
        self.now = 0.0
        self.commands: list[dict] = []  # every command sent (not resends)
        self.resent: list[dict] = []
        self.finished = None
        self.stamp_ns = 0
        self.bead = bead  # the part on the plant (a Contour), scanned after every pass
        self.passes_scanned = 0

    def do(self, out):
        for values, resend in out.commands:
            (self.resent if resend else self.commands).append(values)
        if out.finished is not None:
            self.finished = out.finished
        if out.solve is not None:
            key = repr((dataclasses.replace(out.solve.goal, job_id="k"), out.solve.process, out.solve.charges))
            if key not in _POLICIES:
                _POLICIES[key] = self.core.solve(out.solve)
            self.do(self.core.on_solved(_POLICIES[key], self.now))
        return out

    @property
    def health(self):
        return self.core.health

    def start(self, token="goal", **goal):
        values = {"job_id": "job", "bead_height_mm": 1.0, "bead_width_mm": 12.5, "bead_length_mm": 300.0,
                  "deadline_s": 100.0, **goal}
        request = GoalRequest(**values)
        self.core.check_goal(request)
        return self.do(self.core.accept(request, token, self.now))

    def scan(self, passes, job_id="job", stamp_ns=None):
        contour = self.bead
        return self.do(self.core.on_scan(job_id, passes, contour.x_mm, contour.z_mm, parent_mm=contour.parent_mm,
                                         width_mm=12.5,
                                         stamp_ns=self.stamp_ns if stamp_ns is None else stamp_ns, now_s=self.now))

    def result(self, command=None, cut=None, status=COMPLETED_PASS, source=None, scan=True, **values):
        """Answer ``command`` (the latest) with a drawn cut (or ``cut``); the plant scans first."""
        c = command or self.commands[-1]
        if cut is None:
            cut = MODEL.sample(c["cut_depth_mm"], MODEL.std_mm(PROCESS, c["normal_force_n"], c["feed_speed_mm_s"]),
                               self.rng)
        self.now += 1.0
        self.stamp_ns += 10 * 10**9
        if self.bead is not None and scan and status != REJECTED_PASS:  # the part as the pass left it
            self.bead = dataclasses.replace(self.bead, z_mm=self.bead.z_mm - cut)
            self.scan(c["pass_index"] + 1)
        report = PassReport(**{"job_id": c["job_id"], "pass_index": c["pass_index"], "status": status,
                               "measured_cut_depth_mm": cut, "removed_volume_mm3": cut * 12.5 * 300.0,
                               "duration_s": c["pass_duration_s"], "stamp_ns": self.stamp_ns, **values})
        return self.do(self.core.on_result(report, source, self.now))

    def run(self, stop_after=math.inf):
        while self.finished is None and len(self.commands) <= stop_after:
            self.result()


def test_a_job_runs_to_the_policys_end_each_pass_once(tmp_path):
    rig = Rig(tmp_path)
    rig.start()
    rig.run()
    token, result, job_ended = rig.finished
    assert token == "goal" and job_ended and result["reason"] in ("done", "quit")
    assert [c["pass_index"] for c in rig.commands] == list(range(result["passes"])) and result["passes"] >= 2
    assert abs(result["material_remaining_mm"]) < 0.3 and math.isfinite(result["total_charge"])
    assert rig.health.counts["solves"] == 1 and rig.health.counts[f"jobs_{result['reason']}"] == 1


def test_the_commands_are_the_policys_decisions_bit_for_bit(tmp_path):
    """The refactor keeps the happy path: each command is the job's decision at the state the
    measured cuts left, with the cut depth of the process model's K1 (same floats)."""
    rig = Rig(tmp_path, seed=4)
    rig.start()
    rig.run()
    x, t = 1.0, 100.0
    for c, record in zip(rig.commands, [r for r in read_log(tmp_path / "jobs" / "job.jsonl") if r["type"] == "result"]):
        assert (c["material_remaining_mm"], c["time_remaining_s"]) == (x, t)
        assert c["cut_depth_mm"] == float(dataclasses.replace(PROCESS, bead_width_mm=12.5, bead_length_mm=300.0)
                                          .cut_depth_mm(c["normal_force_n"], c["feed_speed_mm_s"]))
        assert c["specific_energy_j_mm3"] == PROCESS.specific_energy_j_mm3
        x, t = x - record["cut_mm"], t - record["duration_s"]
    assert [c["stamp_ns"] for c in rig.commands] == [10 * 10**9 * k for k in range(len(rig.commands))]


def test_a_restarted_planner_resumes_without_repeating_or_skipping_a_pass(tmp_path):
    first = Rig(tmp_path, seed=3)
    first.start(bead_height_mm=1.9, deadline_s=120.0, process_yaml="reset_time_s: 5.0")
    first.run(stop_after=2)  # passes 0, 1 measured, pass 2 commanded: then the planner dies
    assert [c["pass_index"] for c in first.commands] == [0, 1, 2] and first.finished is None
    second = Rig(tmp_path, seed=3)
    second.rng = first.rng
    out = second.do(second.core.resume(second.now))
    assert second.health.counts["resumed_jobs"] == 1 and second.core.token is None
    assert out.commands[0][0] == {**first.commands[2], "stamp_ns": 0}  # the same pass, awaited again
    second.result(cut=0.25)
    second.run()
    passes = [c["pass_index"] for c in second.commands]
    assert passes == list(range(2, 2 + len(passes))) and second.finished[1]["passes"] == passes[-1] + 1
    for c in first.commands + second.commands:  # the goal's own t_R kept over the restart
        assert c["pass_duration_s"] - 300.0 / c["feed_speed_mm_s"] == pytest.approx(5.0, abs=1e-6)
    assert second.finished[2] and second.finished[0] is None  # a resumed job: on ~/job_result only


def test_a_redelivered_or_foreign_result_is_ignored_and_counted(tmp_path):
    rig = Rig(tmp_path)
    rig.start()
    first = rig.commands[0]
    rig.result()
    assert rig.core.job.state.passes == 1 and len(rig.commands) == 2
    rig.result(command=first)  # pass 0's result again (a restarted plant says its last again)
    rig.result(command={**rig.commands[-1], "job_id": "another"})
    rig.result(command={**rig.commands[-1], "pass_index": 7})
    assert rig.core.job.state.passes == 1 and len(rig.commands) == 2
    assert rig.health.counts["ignored_results"] == 3


def test_the_decision_waits_for_the_k1_predicted_from_the_pass_just_measured(tmp_path):
    rig = Rig(tmp_path, predictor=True)
    rig.start()
    rig.result(specific_energy_j_mm3=11.0)
    assert len(rig.commands) == 1  # waits for the prediction stamped like the result
    rig.do(rig.core.on_prediction(11.5, rig.stamp_ns - 1, rig.now))  # another result's: not it
    assert len(rig.commands) == 1
    rig.do(rig.core.on_prediction(12.0, rig.stamp_ns, rig.now))
    second = rig.commands[1]
    assert second["specific_energy_j_mm3"] == 12.0
    k1 = dataclasses.replace(PROCESS, specific_energy_j_mm3=12.0, bead_width_mm=12.5, bead_length_mm=300.0)
    assert second["cut_depth_mm"] == float(k1.cut_depth_mm(second["normal_force_n"], second["feed_speed_mm_s"]))
    # a predictor on the graph is waited for however busy the machine (its answer decides the
    # job); one that is gone holds the decision for prediction_wait_s, a stuck one prediction_stall_s
    rig.result(specific_energy_j_mm3=12.0)
    assert len(rig.commands) == 2
    rig.do(rig.core.tick(rig.now + 1.0))
    rig.do(rig.core.tick(rig.now + 30.0))
    assert len(rig.commands) == 2
    rig.heard = False
    rig.do(rig.core.tick(rig.now + 30.0))
    assert len(rig.commands) == 3 and rig.health.counts["prediction_timeouts"] == 1
    rig.heard = True
    rig.result(specific_energy_j_mm3=12.5)
    rig.do(rig.core.tick(rig.now + 59.0))
    assert len(rig.commands) == 3
    rig.do(rig.core.tick(rig.now + 61.0))
    assert len(rig.commands) == 4 and rig.health.counts["prediction_timeouts"] == 2
    # a result without a measured K1 (nan: nothing removed) waits for nothing
    rig.result(specific_energy_j_mm3=math.nan)
    assert len(rig.commands) == 5 or rig.finished is not None


def test_a_moved_k1_re_solves_and_implausible_ones_are_refused(tmp_path):
    rig = Rig(tmp_path)
    rig.start(bead_height_mm=1.5, deadline_s=120.0)
    for k1 in (10.2, 12.0, math.nan, 1e3):  # within 5 %, beyond, broken, 100x
        rig.do(rig.core.on_prediction(k1, 0, rig.now))
    assert rig.health.counts["solves"] == 2 and rig.health.counts["rejected_predictions"] == 2
    assert rig.core.model_update.solved_with == 12.0


def test_a_force_guarded_plan_lowers_the_force_of_the_passes_after_it(tmp_path):
    from hex_control.grinding.coefficients import achievable_mean_force_n

    rig = Rig(tmp_path)
    rig.start(bead_height_mm=1.5, deadline_s=120.0)
    first = rig.commands[0]
    assert first["normal_force_n"] == pytest.approx(PROCESS.force_max_n)
    planned = 0.76 * first["cut_depth_mm"]
    rig.do(rig.core.on_trajectory("job", 0, [0.0, 60.0, 40.0], planned))
    assert rig.health.counts["solves"] == 2
    rig.result(cut=planned)
    limit = achievable_mean_force_n(PROCESS, first["normal_force_n"], first["cut_depth_mm"], planned, 60.0)
    assert 40.0 < limit < 50.0 and 0.0 < rig.commands[1]["normal_force_n"] <= limit + 1e-9
    rig.do(rig.core.on_trajectory("job", 1, [], planned))  # a plan with no force says nothing
    assert rig.health.counts["unused_trajectories"] == 1


def test_a_plan_capped_to_the_material_left_does_not_lower_the_force(tmp_path):
    """The pass planner caps a cut deeper than the material left (issue 37 item 1); a plan
    that removes all that is left says nothing of the force its plans can reach."""
    rig = Rig(tmp_path)
    rig.start(bead_height_mm=1.5, deadline_s=120.0)
    material = rig.commands[0]["material_remaining_mm"]
    rig.core.command["cut_depth_mm"] = 1.5 * material  # as a policy that overgrinds on purpose would ask
    rig.do(rig.core.on_trajectory("job", 0, [0.0, 60.0, 40.0], material))
    assert rig.health.counts["solves"] == 1 and rig.core.model_update.solved_force_max_n == PROCESS.force_max_n
    rig.do(rig.core.on_trajectory("job", 0, [0.0, 60.0, 40.0], 0.76 * material))  # short of what is left
    assert rig.health.counts["solves"] == 2


def test_a_bead_too_high_for_the_deadline_ends_by_quit_now(tmp_path):
    """3.5 mm of bead in 60 s: beyond the configured material grid (2 mm) and beyond what the
    deadline allows. The grid grows to hold the job, the policy grinds hard and quits with
    material left, and its promised penalty is that of the true start state (the clamped
    grid would have promised C(2 mm) - about 2 units less)."""
    from hex_control.grinding.config import parse_planner_config
    from hex_control.grinding.sdp import solve

    rig = Rig(tmp_path)
    rig.start(bead_height_mm=3.5, deadline_s=60.0)
    rig.run()
    _, result, _ = rig.finished
    assert result["reason"] == "quit" and result["material_remaining_mm"] > 1.5 and result["time_remaining_s"] >= 0
    assert result["passes"] == len(rig.commands) >= 1
    process, charges, grid, _ = parse_planner_config(CONFIG)
    # the policy's model: the cut of a pass planned on the estimated K1 (issue 42 item 2)
    process, cut_model = rig.core.as_planned(dataclasses.replace(process, bead_width_mm=12.5, bead_length_mm=300.0)), \
        rig.core.policy_model
    promised = solve(process, charges, grid.covering(60.0, 3.5), cut_model).lookup(60.0, 3.5)["expected_penalty"]
    clamped = solve(process, charges, grid, cut_model).lookup(60.0, 3.5)["expected_penalty"]
    assert rig.commands[0]["expected_penalty"] == pytest.approx(promised, rel=1e-9) and promised > clamped + 1.0


def test_a_bead_within_the_tolerance_is_done_at_once(tmp_path):
    rig = Rig(tmp_path)
    rig.start(bead_height_mm=0.01, deadline_s=30.0)
    assert rig.commands == [] and rig.finished[1]["reason"] == "done" and rig.finished[1]["passes"] == 0


def test_commands_are_resent_until_the_pass_planner_has_them(tmp_path):
    rig = Rig(tmp_path, command_resend_s=1.5)
    rig.start()
    rig.do(rig.core.tick(1.0))
    assert rig.resent == []
    rig.do(rig.core.tick(1.6))
    rig.do(rig.core.tick(3.2))
    assert len(rig.resent) == 2 and rig.resent[0] == rig.commands[0] and rig.health.counts["commands_resent"] == 2
    rig.do(rig.core.on_pass_planner_status("job", "0", False, "received", 3.3))
    rig.do(rig.core.tick(10.0))
    assert len(rig.resent) == 2


def test_cancel_during_the_solve_and_during_the_job(tmp_path):
    rig = Rig(tmp_path)
    request = GoalRequest(job_id="c1", bead_height_mm=1.0, bead_width_mm=12.5, bead_length_mm=300.0, deadline_s=100)
    out = rig.core.accept(request, "g1", 0.0)
    with pytest.raises(ValueError, match="still solving"):  # a second goal meanwhile
        rig.core.check_goal(dataclasses.replace(request, job_id="c2"))
    assert rig.core.cancel("another goal") is None
    cancelled = rig.core.cancel("g1")
    assert cancelled.finished[0] == "g1" and cancelled.finished[1]["reason"] == "cancelled"
    assert "policy was solved" in cancelled.finished[1]["message"]
    with pytest.raises(SolveAbandoned):  # the solve stops at its first stage block
        rig.core.solve(out.solve)
    # a solve that ended before it saw the cancel: its policy is dropped
    rig.do(rig.core.on_solved(rig.core.solve(dataclasses.replace(out.solve, abandoned=threading.Event())), 0.0))
    assert rig.commands == [] and rig.core.job is None
    rig.start(token="g3")
    rig.result()
    out = rig.core.cancel("g3")
    assert out.finished[1]["reason"] == "cancelled" and out.finished[1]["passes"] == 1
    # the pass in flight is stopped (issue 37: it was ground to the end): its command again, stop set
    assert out.commands == [({**rig.commands[1], "stop": True}, True)] and rig.health.counts["passes_stopped"] == 1
    assert rig.core.cancel("g3") is None


def test_a_cancelled_goals_solve_stops_counted_and_the_next_goal_is_taken(tmp_path):
    """A cancelled goal's solve burned its CPU to the end (8 s for the largest goal); it now
    stops at its next block of stages, and the next goal need not wait for it."""
    rig = Rig(tmp_path)
    request = GoalRequest(job_id="c1", bead_height_mm=1.0, bead_width_mm=12.5, bead_length_mm=300.0, deadline_s=100)
    out = rig.core.accept(request, "g1", 0.0)
    rig.core.cancel("g1")
    with pytest.raises(SolveAbandoned, match="c1 is no longer wanted") as stopped:
        rig.core.solve(out.solve)
    rig.do(rig.core.on_solved(stopped.value, 0.0))
    assert rig.commands == [] and rig.health.counts.get("abandoned_solves") == 1
    assert "solves" not in rig.health.counts and rig.core.solving is None
    rig.core.check_goal(dataclasses.replace(request, job_id="c2"))  # not "still solving"


def test_a_failed_solve_rejects_the_goal(tmp_path):
    rig = Rig(tmp_path)
    request = GoalRequest(job_id="f", bead_height_mm=1.0, bead_width_mm=12.5, bead_length_mm=300.0, deadline_s=100)
    rig.core.accept(request, "g", 0.0)
    out = rig.core.on_solved(ValueError("no grid"), 0.0)
    assert out.finished == ("g", {**out.finished[1], "reason": "rejected"}, False)
    assert "no policy could be solved: no grid" in out.finished[1]["message"]


# -- issue 37: what the core refuses ------------------------------------------------------------
@pytest.mark.parametrize("values, reason", [
    ({"deadline_s": 0.0}, "deadline_s"),
    ({"bead_width_mm": -2.0}, "bead_width_mm"),
    ({"bead_length_mm": math.inf}, "bead_length_mm"),
    ({"deadline_s": 40000.0}, "deadline_s 40000 s is beyond this planner's max_deadline_s (1800 s)"),
    ({"bead_height_mm": 500.0}, "material_mm 500 mm is beyond this planner's max_material_mm (20 mm)"),
    ({"x_mm": (0.0, 100.0, 200.0), "z_mm": (1.0, math.nan, 1.0)}, "non-finite"),
    ({"x_mm": (0.0, 100.0), "z_mm": (1.0, 1.0), "parent_mm": (0.0,)}, "equally long"),
    ({"process_yaml": "[1, 2"}, "flow sequence"),
])
def test_invalid_goals_are_refused_at_goal_response_with_the_reason(tmp_path, values, reason):
    rig = Rig(tmp_path)
    request = GoalRequest(**{"bead_height_mm": 1.0, "bead_width_mm": 12.5, "bead_length_mm": 300.0,
                             "deadline_s": 50.0, **values})
    with pytest.raises(ValueError, match=reason.replace("(", r"\(").replace(")", r"\)")):
        rig.core.check_goal(request)
    assert rig.health.counts["rejected_goals"] == 1 and reason.split(" (")[0] in rig.health.faults["goal"][1]


def test_a_goal_for_another_bead_than_the_scanned_one_is_refused(tmp_path):
    """The README's goal (60 mm, 0.8 mm) on a plant holding its default 300 mm bead ran 9 s
    late with 0.35 mm left (issue 37); it is refused now, and the goals that name the bead
    on the machine pass."""
    rig = Rig(tmp_path, bead=weld_bead(300.0, 1.0, 12.0, ripple_mm=0.05, seed=0))  # the plant's default
    rig.scan(0, job_id="")
    readme = GoalRequest(bead_height_mm=0.8, bead_width_mm=10.0, bead_length_mm=60.0, deadline_s=30.0)
    with pytest.raises(ValueError, match="bead_length_mm 60 mm is not the scanned bead's 300 mm"):
        rig.core.check_goal(readme)
    assert "300 mm" in rig.health.faults["goal"][1]  # /diagnostics says why
    with pytest.raises(ValueError, match="far from the scanned bead's mean height 0.968"):
        rig.core.check_goal(dataclasses.replace(readme, bead_length_mm=300.0, bead_height_mm=1.9))
    assert rig.health.counts["rejected_goals"] == 2
    bead = rig.bead  # the demo's goal: the scanned profile itself
    rig.core.check_goal(GoalRequest(x_mm=tuple(bead.x_mm), z_mm=tuple(bead.z_mm), parent_mm=tuple(bead.parent_mm),
                                    bead_width_mm=12.5, deadline_s=60.0))
    rig.core.check_goal(dataclasses.replace(readme, bead_length_mm=300.0, bead_height_mm=1.0))  # the nominal
    # the README's own goal against a plant holding a 60 mm bead of 0.8 mm (issue 37's cell)
    small = Rig(tmp_path, bead=weld_bead(60.0, 0.8, 12.0, ripple_mm=0.05, seed=0))
    small.scan(0, job_id="")
    small.core.check_goal(readme)


def test_the_goals_height_is_the_mean_above_the_parent():
    x, z, parent = (0.0, 10.0, 20.0), (2.0, 3.0, 2.0), (1.0, 1.0, 1.0)
    assert contour_height_mm(x, z, parent) == (20.0, 1.5)
    assert contour_height_mm(x, z) == (20.0, 2.5)


def test_a_forged_result_that_the_scans_contradict_is_refused(tmp_path):
    """Issue 37: one forged PassResult (0.8 mm cut) ended the job DONE at X = 0 with the part
    0.50 mm high. Against the plant's scans the forged cut is refused; the true one counts."""
    rig = Rig(tmp_path, bead=weld_bead(300.0, 1.0, 12.0, ripple_mm=0.05, seed=0))
    rig.scan(0, job_id="")
    x0 = contour_height_mm(rig.bead.x_mm, rig.bead.z_mm)[1]
    rig.start(bead_height_mm=x0)
    command = rig.commands[0]
    rig.bead = dataclasses.replace(rig.bead, z_mm=rig.bead.z_mm - 0.3)  # the plant ground 0.3 mm
    rig.scan(1)
    forged = PassReport("job", 0, COMPLETED_PASS, "", x0, x0 * 12.5 * 300.0, 8.0, stamp_ns=10**9)
    rig.do(rig.core.on_result(forged, None, 1.0))
    assert rig.core.job.state.passes == 0 and rig.health.counts["rejected_results"] == 1
    assert "the plant's scans show 0.3000 mm removed" in rig.health.faults["result"][1]
    true = PassReport("job", 0, COMPLETED_PASS, "", 0.3, 0.3 * 12.5 * 300.0, command["pass_duration_s"],
                      stamp_ns=10**9)
    rig.do(rig.core.on_result(true, None, 1.0))
    assert rig.core.job.state.passes == 1 and rig.core.job.state.material_mm == pytest.approx(x0 - 0.3)


def test_a_result_before_its_scan_waits_for_it(tmp_path):
    rig = Rig(tmp_path, bead=weld_bead(300.0, 1.0, 12.0, ripple_mm=0.05, seed=0))
    rig.scan(0, job_id="")
    rig.start(bead_height_mm=0.968)
    rig.result(cut=0.2, scan=False)  # the result's message beat the scan's
    assert rig.core.job.state.passes == 0 and len(rig.commands) == 1
    rig.do(rig.core.tick(rig.now + 3.0))
    assert "no plant scan after it" in rig.health.faults["held_result"][1]
    rig.bead = dataclasses.replace(rig.bead, z_mm=rig.bead.z_mm - 0.2)
    rig.scan(1)
    assert rig.core.job.state.passes == 1 and len(rig.commands) == 2
    rig.do(rig.core.tick(rig.now + 4.0))
    assert "held_result" not in rig.health.faults


@pytest.mark.parametrize("values, words", [
    ({"measured_cut_depth_mm": math.nan}, "invalid values"),
    ({"duration_s": -1.0}, "invalid values"),
    ({"measured_cut_depth_mm": -0.2, "removed_volume_mm3": -750.0}, "negative removal -0.2000 mm"),
    ({"measured_cut_depth_mm": 3.5, "removed_volume_mm3": 13125.0}, "beyond the 1.0000 mm of material plus 2 mm"),
    ({"removed_volume_mm3": 0.0}, "removed volume 0.0 mm^3 is not the cut"),
    ({"removed_volume_mm3": math.inf}, "removed volume inf"),
    ({"stamp_ns": -1}, "before its command"),
    ({"status": 9}, "unknown status 9"),
])
def test_a_result_whose_numbers_cannot_be_a_pass_is_refused(tmp_path, values, words):
    rig = Rig(tmp_path)
    rig.start()
    c = rig.commands[0]
    report = PassReport(**{"job_id": "job", "pass_index": 0, "measured_cut_depth_mm": 0.3,
                           "removed_volume_mm3": 0.3 * 12.5 * 300.0, "duration_s": c["pass_duration_s"],
                           "stamp_ns": 0, **values})
    rig.do(rig.core.on_result(report, "plant", 1.0))
    assert rig.core.job.state.passes == 0 and rig.health.counts["rejected_results"] == 1
    assert words in rig.health.faults["result"][1]
    rig.result()  # the true one still counts
    assert rig.core.job.state.passes == 1


def test_a_result_stamped_before_its_command_is_refused_unless_the_plant_restarted(tmp_path):
    rig = Rig(tmp_path, bead=weld_bead(300.0, 1.0, 12.0, ripple_mm=0.05, seed=0))
    rig.scan(0, job_id="")
    rig.start(bead_height_mm=0.968)
    rig.result()  # stamped 10 s: pass 1's command carries 10 s
    assert rig.commands[1]["stamp_ns"] == 10 * 10**9
    rig.stamp_ns = 0  # the plant restarts: its clock from zero, the part as it last scanned it
    rig.scan(1, stamp_ns=2 * 10**8)
    assert rig.health.counts["plant_clock_restarts"] == 1
    rig.result()  # stamped 10 s on the new clock: after the restarted plant's scan
    assert rig.core.job.state.passes == 2 and "rejected_results" not in rig.health.counts


def test_a_rejection_counts_only_from_the_pass_planner(tmp_path):
    rig = Rig(tmp_path)
    rig.start()
    rig.result(status=REJECTED_PASS, source="plant", reason="forged")
    assert rig.finished is None and rig.health.counts["rejected_results"] == 1
    assert "not by the pass planner" in rig.health.faults["result"][1]
    # publisher unknown: held until the pass planner's status says it refused that pass
    rig.result(status=REJECTED_PASS, reason="out of reach")
    assert rig.finished is None
    rig.do(rig.core.on_pass_planner_status("job", "0", True, "out of reach", rig.now))
    assert rig.finished[1]["reason"] == "rejected" and "pass 0 rejected: out of reach" in rig.finished[1]["message"]


def test_a_later_pass_rejected_by_the_pass_planner_aborts_the_job(tmp_path):
    rig = Rig(tmp_path)
    rig.start()
    rig.result()
    rig.do(rig.core.on_pass_planner_status("job", "1", True, "unplannable", rig.now))  # refusal first
    out = rig.result(status=REJECTED_PASS, reason="unplannable")
    assert rig.finished[1]["reason"] == "aborted" and rig.finished[1]["passes"] == 1
    assert out.commands == []  # nothing of a refused pass runs: nothing to stop


def test_faulted_and_aborted_passes_are_re_decided_from_the_scan_and_said_in_the_end(tmp_path):
    """Issue 37 item 2: a pass that ran but not as planned (FAULTED, with its reason) is what
    the scanner measured: the state is re-decided from there; the job's end says which passes
    did not run as planned, in its message and its log, never a plain 'done'."""
    rig = Rig(tmp_path, seed=2)
    rig.start()
    first = rig.commands[0]
    rig.result(cut=0.05, status=FAULTED_PASS, reason="cut short: 0.05 of 0.31 mm")
    second = rig.commands[1]
    assert second["material_remaining_mm"] == pytest.approx(1.0 - 0.05)  # decided from the measured state
    assert second["time_remaining_s"] == pytest.approx(100.0 - first["pass_duration_s"])
    assert rig.health.counts["passes_faulted"] == 1 and "pass 0 faulted" in rig.health.faults["last_pass"][1]
    rig.result(status=ABORTED_PASS, reason="watchdog")
    rig.run()
    _, result, _ = rig.finished
    assert result["reason"] in ("done", "quit")
    assert (f"2 of {result['passes']} passes not as planned: pass 0 faulted (cut short: 0.05 of 0.31 mm), "
            "pass 1 aborted (watchdog)") in result["message"]
    log = read_log(tmp_path / "jobs" / "job.jsonl")
    assert log[-1]["not_as_planned"] == [[0, "faulted", "cut short: 0.05 of 0.31 mm"], [1, "aborted", "watchdog"]]
    assert [r["status"] for r in log if r["type"] == "result"][:2] == ["faulted", "aborted"]
    assert json.dumps(log[-1])  # plain JSON


def test_a_pass_overdue_warns_then_errs_then_ends_the_job_aborted(tmp_path):
    """Issue 37: an invalid command stalled the job >= 240 s with every diagnostic at OK."""
    rig = Rig(tmp_path, pass_timeout_s=240.0, command_resend_s=0.0)
    rig.start()
    planned = rig.commands[0]["pass_duration_s"]
    due = 3.0 * planned + 10.0
    rig.do(rig.core.tick(due - 1.0))
    assert "overdue" not in rig.health.faults
    rig.do(rig.core.tick(due + 5.0))
    level, text = rig.health.faults["overdue"]
    assert level == "warn" and f"pass 0 outstanding {due + 5.0:.0f} s, 5 s past its due {due:.0f} s" in text
    rig.do(rig.core.tick(3 * due + 1.0))
    assert rig.health.faults["overdue"][0] == "error"
    out = rig.do(rig.core.tick(241.0))
    assert out.commands == [({**rig.commands[0], "stop": True}, True)]  # the stalled pass ended
    _, result, _ = rig.finished
    assert result["reason"] == "aborted" and "pass 0 outstanding 241 s" in result["message"]
    assert "no pass result before the timeout (240 s)" in result["message"]
    assert rig.health.faults["overdue"] == ("error", "job ended: pass 0 had no result after 241 s")


def test_a_pass_result_clears_the_overdue_fault(tmp_path):
    rig = Rig(tmp_path, command_resend_s=0.0)
    rig.start()
    rig.now = 200.0
    rig.do(rig.core.tick(rig.now))
    assert "overdue" in rig.health.faults
    rig.result()
    assert "overdue" not in rig.health.faults


def test_settings_from_the_nodes_parameters_take_0_as_the_configured_cut_model():
    defaults = SequencerSettings(Path("jobs"))
    settings = SequencerSettings.from_parameters(lambda name: {"job_dir": "jobs", "k1_estimate_cv": 0.0}.get(
        name, getattr(defaults, name)))
    assert settings == dataclasses.replace(defaults, k1_estimate_cv=None) and isinstance(settings.job_dir, Path)
    assert SequencerSettings.from_parameters(lambda name: str(defaults.job_dir) if name == "job_dir"
                                             else getattr(defaults, name)) == defaults


def test_the_health_report_says_whether_a_k1_predictor_is_heard(tmp_path):
    """The job session starts a job once the planner hears its predictor (grind_job's
    wait_until_ready): a planner that had not found it yet decided pass 1 without its K1."""
    rig = Rig(tmp_path)
    rig.core.tick(0.0)
    assert rig.health.values["k1_predictor"] == "none"
    rig.heard = True
    rig.core.tick(1.0)
    assert rig.health.values["k1_predictor"] == "heard"
