"""Node ``sequence_planner``: the top tier -- the GrindBead action, one pass at a time.

Serves ``~/grind_bead`` (hex_control_msgs/action/GrindBead). For a goal it solves the SDP
policy for that bead (library :mod:`hex_control.grinding`), publishes the next
``PassCommand`` on /grinding/pass_command (latched), and after every ``PassResult`` on
/grinding/pass_result looks the policy up at the measured state (Fig. 5-7) until the
policy ends the job. Feedback per pass; the result says done / quit / cancelled /
aborted / rejected (bad goals are accepted and ended at once as REJECTED with the reason).

Every decision and result is appended to a job log in ``job_dir`` before it is acted on;
a restarted planner resumes an unfinished job from its log (the action client of the old
process is gone: the resumed job reports on ~/job_feedback and ~/job_result).
K1 estimates on /load_predictor/pass/prediction (LoadPrediction, J/mm^3) update the
process model and trigger a re-solve when they move more than ``resolve_threshold``.
The prediction made from pass k's measured K1 is the one for pass k+1: while a predictor
publishes, the decision after pass k waits for it (the prediction stamped like the pass
result; at most ``prediction_wait_s``), so that which K1 a pass is planned with does not
depend on which message arrives first. Each PassCommand carries that K1 down.
The pass planner's plan of each pass (/grinding/force_trajectory) says how much force its
plans can reach on the bead as it now is (its force guard keeps every point of a pass at
or below F_max, so on a rough bead the mean force stays lower); the policy is re-solved
with that as its F_max when it moves more than ``resolve_threshold``.
A command the pass planner has not acknowledged on /pass_planner/status (received,
planned or refused) within ``command_resend_s`` is published again until it does.

The job's time is logical: it advances by the measured pass durations (a waiting step
advances it by one stage), not by this node's clock.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path

import numpy as np
import yaml
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node

from hex_control.config import config_file
from hex_control.grinding.coefficients import PassModelUpdate
from hex_control.grinding.config import load_planner_config, parse_planner_config
from hex_control.grinding.job import (
    ABORTED,
    CANCELLED,
    DONE,
    QUIT,
    REJECTED,
    GrindingJob,
    JobGoal,
    new_job_id,
    read_goal,
    read_model,
    unfinished_logs,
)
from hex_control.grinding.sdp import solve
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import LATCHED, RESULTS
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control.nodes.runtime import in_background, run_node, wall_timer
from hex_control_msgs.action import GrindBead
from hex_control_msgs.msg import ForceTrajectory, LoadPrediction, PassCommand, PassResult

REASONS = {DONE: GrindBead.Result.DONE, QUIT: GrindBead.Result.QUIT, CANCELLED: GrindBead.Result.CANCELLED,
           ABORTED: GrindBead.Result.ABORTED, REJECTED: GrindBead.Result.REJECTED}
def goal_from_message(goal) -> JobGoal:
    """Validate a GrindBead goal into a JobGoal; ValueError with the reason otherwise."""
    contour = goal.bead
    if len(contour.x_mm) or len(contour.z_mm):
        x, z = list(contour.x_mm), list(contour.z_mm)
        if len(x) != len(z) or len(x) < 2:
            raise ValueError("bead contour needs equally long x_mm and z_mm with at least 2 points")
        if not all(math.isfinite(v) for v in x + z):
            raise ValueError("bead contour has non-finite points")
        if any(b <= a for a, b in zip(x, x[1:])):
            raise ValueError("bead contour x_mm must increase strictly")
        length = x[-1] - x[0]
        # mean height by the trapezoid rule: the state X of the thesis (4.7)
        height = sum((z0 + z1) / 2 * (x1 - x0) for x0, x1, z0, z1 in zip(x, x[1:], z, z[1:])) / length
    else:
        length, height = goal.bead_length_mm, goal.bead_height_mm
    width = goal.bead_width_mm or contour.bead_width_mm
    return JobGoal(goal.job_id or new_job_id(), float(height), float(width), float(length), float(goal.deadline_s))

PARAMETERS = {
    "planner_config": Spec(str(config_file("sequence_planner.yaml")), "sequence planner YAML: charges, grid, "
                           "cut model"),
    "job_dir": Spec(os.path.expanduser("~/.local/state/hex_control/jobs"), "directory of the job logs a "
                    "restarted planner resumes from"),
    "resolve_threshold": Spec(0.05, "relative change of K1 or of the force the plans reach that triggers a "
                              "re-solve", 0.0, 10.0, read_only=False),
    "pass_timeout_s": Spec(300.0, "wall time to wait for a pass result before aborting the job", 1.0, 86_400.0,
                           read_only=False),
    "command_resend_s": Spec(5.0, "wall time after which a pass command the pass planner has not acknowledged "
                             "on /pass_planner/status is published again (a lost delivery); 0 = never",
                             0.0, 3600.0, read_only=False),
    "prediction_wait_s": Spec(2.0, "wall time a decision waits for the K1 prediction from the pass just "
                              "measured, when a predictor publishes; 0 = decide at once", 0.0, 600.0,
                              read_only=False),
    "max_deadline_s": Spec(1800.0, "longest goal deadline accepted: the policy solve grows with it (40000 s "
                           "took 152 s and 1 GB on the executor thread); a longer one is rejected with the "
                           "reason", 1.0, 86_400.0),
    "max_material_mm": Spec(20.0, "highest mean bead height accepted, for the same reason", 0.01, 1000.0),
}


class SequencePlannerNode(Node):
    READY_PARAMETERS = ("planner_config", "job_dir")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("sequence_planner", **kwargs)
        declare_parameters(self, PARAMETERS)
        self.base_config = yaml.safe_load(Path(self.get_parameter("planner_config").value).read_text()) or {}
        _, self.charges, self.grid, self.cut_model = load_planner_config(
            self.get_parameter("planner_config").value)
        self.job_dir = Path(self.get_parameter("job_dir").value)
        self.diagnostics = Diagnostics(self)
        self.job: GrindingJob | None = None
        self.goal_handle = None
        self.results: dict[bytes, GrindBead.Result] = {}
        self.model_update: PassModelUpdate | None = None
        self.last_solve_ms = math.nan  # wall time of the latest policy solve
        self.solving = None  # (Future of the policy, then(process, policy) or None, goal handle) while solved
        self._advance_after_solve = False  # a decision waits for the policy being solved
        self._sent_at = None
        self._unacknowledged = None  # (the latest PassCommand until the pass planner has it, wall s sent)
        self._command = None  # the latest PassCommand sent
        self._awaited_stamp = None  # (stamp of the pass result whose K1 prediction is awaited, since)
        self._last_prediction_stamp = None
        self._result_stamp = TimeMsg()  # of the latest pass result applied (plant time)

        self.command_pub = self.create_publisher(PassCommand, "grinding/pass_command", LATCHED)
        # kept (the last 10 decisions): an observer that matches the planner late, as after its
        # restart, still learns every pass it commanded
        self.feedback_pub = self.create_publisher(GrindBead.Feedback, "~/job_feedback", RESULTS)
        self.result_pub = self.create_publisher(GrindBead.Result, "~/job_result", LATCHED)
        self.create_subscription(PassResult, "grinding/pass_result", self._on_result, RESULTS)
        self.create_subscription(LoadPrediction, "load_predictor/pass/prediction", self._on_prediction, 10)
        self.create_subscription(DiagnosticStatus, "pass_planner/status", self._on_pass_planner_status, LATCHED)
        self.create_subscription(ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, LATCHED)
        self.server = ActionServer(self, GrindBead, "~/grind_bead", execute_callback=self._execute,
                                   goal_callback=lambda _goal: GoalResponse.ACCEPT,
                                   handle_accepted_callback=self._on_accepted,
                                   cancel_callback=self._on_cancel)
        wall_timer(self, 1.0, self._watchdog)
        wall_timer(self, 0.02, self._poll_solve)
        self._resume()

    # -- jobs ------------------------------------------------------------------------------
    def _solve(self, goal: JobGoal, process, charges):
        """The goal's policy (library only: it runs on a worker thread); (process, policy, ms)."""
        process = dataclasses.replace(process, bead_width_mm=goal.bead_width_mm,
                                      bead_length_mm=goal.bead_length_mm)
        start = time.perf_counter()
        policy = solve(process, charges, self.grid.covering(goal.deadline_s, goal.material_mm), self.cut_model)
        return process, policy, 1000 * (time.perf_counter() - start)

    def _solved(self, solution) -> tuple:
        process, policy, self.last_solve_ms = solution
        self.diagnostics.set("last_solve_ms", f"{self.last_solve_ms:.1f}")
        self.diagnostics.count("solves")
        return process, policy

    def _policy_for(self, goal: JobGoal, process):
        """Solve here and now: only at start-up, before any callback can run."""
        return self._solved(self._solve(goal, process, self.charges))

    def _solve_then(self, goal: JobGoal, process, then, goal_handle=None) -> None:
        """Solve off the executor thread (a long deadline takes seconds), then ``then(process,
        policy)`` on it; meanwhile the node answers, and decisions wait (_advance)."""
        self.solving = (in_background(self._solve, goal, process, self.charges), then, goal_handle)

    def _poll_solve(self) -> None:
        if self.solving is None or not self.solving[0].done():
            return
        (future, then, goal_handle), self.solving = self.solving, None
        try:
            solution = self._solved(future.result())
        except (ValueError, ArithmeticError, MemoryError) as exc:  # what waited for the policy ends here
            self._advance_after_solve = False
            if goal_handle is not None:
                self.goal_handle = None
                self._reject(goal_handle, f"no policy could be solved: {exc}")
            elif self.job is not None and not self.job.finished:
                self.job.end(ABORTED, f"the policy could not be re-solved: {exc}")
                self._finish()
            return
        if then is not None:  # None: its goal was cancelled meanwhile
            then(*solution)
        if self._advance_after_solve:
            self._advance_after_solve = False
            if self.job is not None and not self.job.finished:
                self._advance()

    def _configured(self, overrides: dict):
        """(process, charges) of the node's configuration with a goal's overrides on top."""
        config = {**self.base_config, **{k: {**self.base_config.get(k, {}), **v} for k, v in overrides.items()}}
        process, charges, _, _ = parse_planner_config(config)
        return process, charges

    def _resume(self) -> None:
        logs = unfinished_logs(self.job_dir) if self.job_dir.is_dir() else []
        if not logs:
            return
        goal = read_goal(logs[-1])
        process, self.charges = self._configured(goal.config_overrides)
        self.model_update = PassModelUpdate(process, self.get_parameter("resolve_threshold").value)
        if model := read_model(logs[-1]):  # plan with the estimates the job had before the restart
            self.model_update.restore(model["specific_energy_j_mm3"], model["solved_with_j_mm3"],
                                      model.get("force_max_n"), model.get("solved_force_max_n"))
        _, policy = self._policy_for(goal, self.model_update.solved_process)
        self.job = GrindingJob.resume(logs[-1], policy, self.charges)
        self.get_logger().info(f"resumed job {goal.job_id} at pass {self.job.state.passes} "
                               f"(t = {self.job.state.time_remaining_s:.1f} s, "
                               f"X = {self.job.state.material_mm:.3f} mm)")
        self.diagnostics.count("resumed_jobs")
        self._advance()

    def _on_accepted(self, goal_handle) -> None:
        if self.job is not None and not self.job.finished:
            self._reject(goal_handle, f"job {self.job.goal.job_id} is still running")
            return
        if self.solving is not None:
            self._reject(goal_handle, "the planner is still solving a policy")
            return
        try:
            overrides = {name: yaml.safe_load(text) for name, text in
                         (("charges", goal_handle.request.charges_yaml), ("process", goal_handle.request.process_yaml))}
            goal = dataclasses.replace(goal_from_message(goal_handle.request),
                                       config_overrides={k: v for k, v in overrides.items() if v})
            self._check_bounds(goal)
            process, charges = self._configured(goal.config_overrides)
        except (ValueError, TypeError, yaml.YAMLError) as exc:
            self._reject(goal_handle, str(exc))
            return
        self.charges = charges
        self.goal_handle = goal_handle
        self._advance_after_solve = True
        self._solve_then(goal, process, lambda process, policy: self._start(goal, process, policy), goal_handle)

    def _start(self, goal: JobGoal, process, policy) -> None:
        self.job = GrindingJob(goal, policy, self.charges, self.job_dir / f"{goal.job_id}.jsonl")
        self.model_update = PassModelUpdate(process, self.get_parameter("resolve_threshold").value)
        self.get_logger().info(f"job {goal.job_id}: X0 = {goal.material_mm:.3f} mm, deadline {goal.deadline_s:g} s, "
                               f"policy solved in {self.last_solve_ms:.0f} ms")

    def _check_bounds(self, goal: JobGoal) -> None:
        """Bounded work: a goal whose policy would take unbounded time and memory is refused."""
        for value, name, unit in ((goal.deadline_s, "max_deadline_s", "s"),
                                  (goal.material_mm, "max_material_mm", "mm")):
            limit = self.get_parameter(name).value
            if value > limit:
                raise ValueError(f"{name.removeprefix('max_')} {value:g} {unit} is beyond this planner's {name} "
                                 f"({limit:g} {unit})")

    def _reject(self, goal_handle, reason: str) -> None:
        self.diagnostics.count("rejected_goals")
        self.get_logger().warning(f"goal rejected: {reason}")
        self.results[bytes(goal_handle.goal_id.uuid)] = GrindBead.Result(
            reason=GrindBead.Result.REJECTED, message=reason)
        goal_handle.execute()

    def _advance(self) -> None:
        if self.solving is not None:  # decide on the policy being solved
            self._advance_after_solve = True
            return
        decision = self.job.decide()
        if decision is None:
            self._finish()
            return
        command = PassCommand()
        command.header.stamp = self._result_stamp  # the plant time of the state decided on
        command.job_id = self.job.goal.job_id
        command.pass_index = decision["pass_index"]
        command.normal_force_n = decision["force_n"]
        command.feed_speed_mm_s = decision["feed_mm_s"]
        process = self.model_update.process  # one K1 for the cut depth here and the force downstream
        command.cut_depth_mm = float(process.cut_depth_mm(decision["force_n"], decision["feed_mm_s"]))
        command.specific_energy_j_mm3 = float(process.specific_energy_j_mm3)
        command.pass_duration_s = decision["duration_s"]
        command.material_remaining_mm = decision["material_mm"]
        command.time_remaining_s = decision["time_remaining_s"]
        command.expected_penalty = decision["expected_penalty"]
        self.command_pub.publish(command)
        self._command = command
        self._sent_at = time.monotonic()
        self._unacknowledged = (command, self._sent_at)
        feedback = GrindBead.Feedback(pass_index=command.pass_index,
                                      material_remaining_mm=command.material_remaining_mm,
                                      time_remaining_s=command.time_remaining_s,
                                      expected_penalty=command.expected_penalty, command=command)
        self.feedback_pub.publish(feedback)
        if self.goal_handle is not None and self.goal_handle.is_active:
            self.goal_handle.publish_feedback(feedback)

    def _result_message(self) -> GrindBead.Result:
        end, state = self.job.state.end, self.job.state
        return GrindBead.Result(reason=REASONS[end["reason"]], message=end["message"], passes=state.passes,
                                material_remaining_mm=state.material_mm, time_remaining_s=state.time_remaining_s,
                                lateness_s=max(0.0, -state.time_remaining_s), total_charge=end["charge"])

    def _finish(self) -> None:
        self._awaited_stamp = None  # a cancel while a prediction was awaited
        result = self._result_message()
        self.result_pub.publish(result)
        self.diagnostics.count(f"jobs_{self.job.state.end['reason']}")
        self.get_logger().info(f"job {self.job.goal.job_id} ended: {self.job.state.end['reason']}, "
                               f"{result.passes} passes, charge {result.total_charge:.4f}")
        self._sent_at = self._unacknowledged = None
        if self.goal_handle is not None:
            self.results[bytes(self.goal_handle.goal_id.uuid)] = result
            handle, self.goal_handle = self.goal_handle, None
            if handle.status == GoalStatus.STATUS_ACCEPTED:
                handle.execute()

    def _execute(self, goal_handle):
        result = self.results.pop(bytes(goal_handle.goal_id.uuid))
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif result.reason in (GrindBead.Result.DONE, GrindBead.Result.QUIT):
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def _on_cancel(self, goal_handle):
        if self.goal_handle is not goal_handle:
            return CancelResponse.REJECT
        if self.solving is not None and self.solving[2] is goal_handle:  # before its job began
            self.solving = (self.solving[0], None, None)  # the solve runs out; its policy is dropped
            self._advance_after_solve, self.goal_handle = False, None
            self.results[bytes(goal_handle.goal_id.uuid)] = GrindBead.Result(
                reason=GrindBead.Result.CANCELLED, message="cancelled while its policy was solved")
            goal_handle.execute()
            return CancelResponse.ACCEPT
        if self.job is None or self.job.finished:
            return CancelResponse.REJECT
        self.job.end(CANCELLED, "cancelled by the client")
        self._finish()  # executes the goal now, so that the cancel can complete it
        return CancelResponse.ACCEPT

    # -- inputs ----------------------------------------------------------------------------
    def _on_result(self, msg: PassResult) -> None:
        job = self.job
        pending = job.state.pending if job is not None else None
        if pending is None or msg.job_id != job.goal.job_id or msg.pass_index != pending["pass_index"]:
            self.diagnostics.count("ignored_results")
            return
        if msg.status == PassResult.REJECTED:  # the pass planner cannot plan it: nothing was ground
            # the first pass refused (e.g. the bead is out of the machine's reach): the goal is
            # what cannot be done; later: the job cannot go on
            reason = REJECTED if msg.pass_index == 0 else ABORTED
            self.job.end(reason, f"pass {msg.pass_index} rejected: {msg.reason}")
            self._finish()
            return
        values = (msg.measured_cut_depth_mm, msg.duration_s)
        if not all(math.isfinite(v) for v in values) or msg.duration_s < 0 or abs(msg.measured_cut_depth_mm) > 100:
            self.diagnostics.count("rejected_results")
            self.get_logger().warning(f"pass result with invalid values {values} rejected")
            return
        job.apply_result(msg.pass_index, msg.measured_cut_depth_mm, msg.duration_s, msg.status == PassResult.COMPLETED)
        self._unacknowledged = None
        self._result_stamp = msg.header.stamp
        if msg.burn_detected:  # until a pass without
            self.diagnostics.fault("burn", f"burn reported on pass {msg.pass_index}")
        else:
            self.diagnostics.clear("burn")
        stamp = _stamp_ns(msg.header.stamp)
        if (self.get_parameter("prediction_wait_s").value > 0 and stamp != self._last_prediction_stamp
                and self.model_update.plausible(msg.specific_energy_j_mm3)
                and self.count_publishers("load_predictor/pass/prediction") > 0):
            self._awaited_stamp = (stamp, time.monotonic())
            return
        self._advance()

    def _on_pass_planner_status(self, msg: DiagnosticStatus) -> None:
        values = {pair.key: pair.value for pair in msg.values}
        if self._unacknowledged and (values.get("job_id"), values.get("pass_index")) == (
                self._unacknowledged[0].job_id, str(self._unacknowledged[0].pass_index)):
            self._unacknowledged = None  # received, planned or refused: the pass planner has it

    def _on_prediction(self, msg: LoadPrediction) -> None:
        if self.model_update is None or self.job is None or self.job.finished:
            return
        if not self.model_update.plausible(msg.prediction):
            self.diagnostics.count("rejected_predictions")
        else:
            self.model_update.observe(msg.prediction)
            self._model_changed()
        self._last_prediction_stamp = _stamp_ns(msg.header.stamp)
        if self._awaited_stamp and self._awaited_stamp[0] == self._last_prediction_stamp:
            self._awaited_stamp = None
            self._advance()

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        command = self._command
        if (self.job is None or self.job.finished or command is None or msg.job_id != command.job_id
                or msg.pass_index != command.pass_index):
            return
        forces = np.asarray(msg.normal_force_n, float)
        peak = float(np.max(forces)) if forces.size else math.nan  # NaN if any is: refused below
        try:
            self.model_update.observe_plan(command.normal_force_n, command.cut_depth_mm, msg.planned_cut_depth_mm, peak)
        except ValueError as exc:  # a plan with no force, or a command that cuts nothing
            self.diagnostics.count("unused_trajectories")
            self.get_logger().debug(f"plan of pass {msg.pass_index} says nothing about the force limit: {exc}")
            return
        self._model_changed()

    def _model_changed(self) -> None:
        """Log the process model; re-solve when it moved (after the solve running, if one is)."""
        update = self.model_update
        self.job.update_model(update.process.specific_energy_j_mm3, update.solved_with, update.process.force_max_n,
                              update.solved_force_max_n)
        if update.needs_solve and self.solving is None:
            self._solve_then(self.job.goal, update.process, self._resolved)

    def _resolved(self, process, policy) -> None:
        if self.job is None or self.job.finished:
            return
        self.job.policy = policy
        self.model_update.mark_solved(process)
        self.get_logger().info(f"K1 now {process.specific_energy_j_mm3:.3f} J/mm^3, force limit "
                               f"{process.force_max_n:.1f} N: policy re-solved in {self.last_solve_ms:.0f} ms")
        self._model_changed()

    def _watchdog(self) -> None:
        if self._awaited_stamp and time.monotonic() - self._awaited_stamp[1] > self.get_parameter(
                "prediction_wait_s").value:
            self._awaited_stamp = None
            self.diagnostics.count("prediction_timeouts")
            self.get_logger().warning("no K1 prediction for the pass just measured: deciding without it")
            self._advance()
        if self._sent_at is None or self.job is None or self.job.finished:
            return
        resend_s = self.get_parameter("command_resend_s").value
        if self._unacknowledged and resend_s > 0 and time.monotonic() - self._unacknowledged[1] > resend_s:
            command = self._unacknowledged[0]
            self.command_pub.publish(command)  # the pass planner ignores a command it already has
            self._unacknowledged = (command, time.monotonic())
            self.diagnostics.count("commands_resent")
            self.get_logger().warning(f"pass {command.pass_index} not acknowledged by the pass planner after "
                                      f"{resend_s:g} s: command sent again")
        if time.monotonic() - self._sent_at > self.get_parameter("pass_timeout_s").value:
            self.job.end(ABORTED, "no pass result before the timeout")
            self._finish()


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def main(args=None) -> int:
    return run_node(SequencePlannerNode, args)


if __name__ == "__main__":
    main()
