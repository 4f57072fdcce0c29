"""Node ``sequence_planner``: the GrindBead action, one pass at a time. The job logic is
:class:`hex_control.grinding.sequencer.Sequencer`; this node reads its settings, converts messages,
solves policies off the executor thread and serves ``~/grind_bead`` (a refused goal: REJECT, the
reason in the log and /diagnostics; a resumed job reports on ``~/job_feedback``, ``~/job_result``).
Out: grinding/pass_command (latched). In, each from its one node: grinding/pass_result (plant;
REJECTED: pass_planner), grinding/contour (plant's scans), grinding/force_trajectory and
pass_planner/status (pass_planner), load_predictor/pass/prediction (K1, J/mm^3)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import yaml
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node

from hex_control.config import config_file
from hex_control.grinding.sdp import NUMERICS, import_numerics
from hex_control.grinding.sequencer import Sequencer, SequencerSettings
from hex_control.ros.infra.diagnostics import ERROR, WARN, Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, RESULTS
from hex_control.ros.infra.message_info import info_subscription, owner_publishes
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import POLL_S, in_background, run_node, wall_timer
from hex_control.ros.nodes.sequence_planner_messages import (
    command_message,
    goal_request,
    pass_report,
    planner_status,
    stamp_ns,
)
from hex_control_msgs.action import GrindBead
from hex_control_msgs.msg import Contour, ForceTrajectory, LoadPrediction, PassCommand, PassResult

PRELOAD = (*NUMERICS, "numpy.random")  # imported at start (import_numerics, the draws): node_forks.py

REASONS = {"done": GrindBead.Result.DONE, "quit": GrindBead.Result.QUIT, "cancelled": GrindBead.Result.CANCELLED,
           "aborted": GrindBead.Result.ABORTED, "rejected": GrindBead.Result.REJECTED}
D = SequencerSettings(Path())  # the defaults: one source
PARAMETERS = {
    "planner_config": Spec(str(config_file("sequence_planner.yaml")), "YAML: charges, grid, cut model"),
    "job_dir": Spec(os.path.expanduser("~/.local/state/hex_control/jobs"), "the job logs a restart resumes from"),
    **{name: Spec(getattr(D, name), text, low, high, read_only=not live) for name, text, low, high, live in (
        ("resolve_threshold", "relative change of K1 or of the force the plans reach that triggers a re-solve",
         0.0, 10.0, True),
        ("pass_timeout_s", "wall time to wait for a pass result before aborting the job", 1.0, 86_400.0, True),
        ("command_resend_s", "wall time after which a pass command the pass planner has not acknowledged on "
         "/pass_planner/status is published again (a lost delivery); 0 = never", 0.0, 3600.0, True),
        ("prediction_wait_s", "wall time a decision waits for the K1 prediction from the pass just measured once "
         "no predictor publishes; 0 = decide at once", 0.0, 600.0, True),
        ("prediction_stall_s", "wall time it waits while the predictor publishes: late is not lost", 0.0, 3600.0, True),
        ("max_deadline_s", "longest goal deadline accepted: the policy solve grows with it (40000 s took 152 s and "
         "1 GB on the executor thread)", 1.0, 86_400.0, False),
        ("max_material_mm", "highest mean bead height accepted, for the same reason", 0.01, 1000.0, False),
        ("overdue_factor", "a pass is overdue (WARN; ERROR at 3x) this many times its planned duration plus "
         "overdue_margin_s (wall s) after its command", 1.0, 1000.0, True),
        ("overdue_margin_s", "see overdue_factor", 0.0, 3600.0, True),
        ("goal_length_tolerance_mm", "a goal's bead length off the scanned bead's by more than this (and 2 %) is "
         "rejected", 0.0, 1000.0, False),
        ("goal_height_tolerance_mm", "the same for the mean height (and 25 %)", 0.0, 100.0, False),
        ("max_overgrind_mm", "a result removing more than the material plus this is refused", 0.0, 100.0, False),
        ("scan_tolerance_mm", "a result's cut off the removal of the plant's scans by more than this is refused",
         0.0, 10.0, False),
        ("k1_estimate_cv", "relative error of the K1 the passes are planned on (issue 42); 0 = K1 known", 0.0, 1.0,
         False))},
}


class SequencePlannerNode(Node):
    READY_PARAMETERS = ("planner_config", "job_dir")  # in its start-up line
    def __init__(self, **kwargs):
        super().__init__("sequence_planner", **kwargs)
        declare_parameters(self, PARAMETERS)
        self.diagnostics = _Health(self)
        config = yaml.safe_load(Path(self.get_parameter("planner_config").value).read_text()) or {}
        self.core = Sequencer(self._settings(), config, health=self.diagnostics,
                              log=lambda level, text: getattr(self.get_logger(), level)(text),
                              predictor_heard=lambda: owner_publishes(self, "load_predictor/pass/prediction",
                                                                      "load_predictor/pass", latched=True))
        self.add_post_set_parameters_callback(lambda _: setattr(self.core, "settings", self._settings()))
        self.results, self.solving = {}, None  # goal uuid -> its Result; the Future of the policy being solved
        self.command_pub = self.create_publisher(PassCommand, "grinding/pass_command", LATCHED)
        # kept (the last 10): an observer matching late (a restart) still learns every pass commanded
        self.feedback_pub = self.create_publisher(GrindBead.Feedback, "~/job_feedback", RESULTS)
        self.result_pub = self.create_publisher(GrindBead.Result, "~/job_result", LATCHED)
        now, core = time.monotonic, self.core
        # the publisher of a result is not handed to the callback: a REJECTED one is confirmed
        # by the pass planner's refusal on its status instead (source None)
        for msg_type, topic, on, qos, name, owner in (
                (PassResult, "grinding/pass_result", lambda m, source: core.on_result(pass_report(m), source, now()),
                 RESULTS, "result", ("plant", "pass_planner")),
                (Contour, "grinding/contour", lambda m: core.on_scan(
                    m.job_id, m.pass_index, m.x_mm, m.z_mm, parent_mm=m.parent_mm, width_mm=m.bead_width_mm,
                    stamp_ns=stamp_ns(m.header.stamp), now_s=now()), LATCHED, "contour", "plant"),
                (DiagnosticStatus, "pass_planner/status",
                 lambda m: core.on_pass_planner_status(*planner_status(m), now()), LATCHED, "pass_planner_status",
                 "pass_planner"),
                (LoadPrediction, "load_predictor/pass/prediction", lambda m: core.on_prediction(
                    m.prediction, stamp_ns(m.header.stamp), now()), RESULTS, "prediction", "load_predictor/pass"),
                (ForceTrajectory, "grinding/force_trajectory", lambda m: core.on_trajectory(
                    m.job_id, m.pass_index, m.normal_force_n, m.planned_cut_depth_mm), LATCHED, "trajectory",
                 "pass_planner")):
            info_subscription(self, msg_type, topic, lambda *m, on=on: self._do(on(*m)), qos,
                              diagnostics=self.diagnostics,
                              name=name, owner_node=owner, with_source=msg_type is PassResult)
        self.server = ActionServer(self, GrindBead, "~/grind_bead", execute_callback=self._execute,
                                   goal_callback=self._on_goal, handle_accepted_callback=lambda handle: self._do(
                                       self.core.accept(goal_request(handle.request), handle, now())),
                                   cancel_callback=self._on_cancel)
        wall_timer(self, 1.0, lambda: self._do(self.core.tick(now())))
        wall_timer(self, POLL_S, self._poll_solve)
        self._do(self.core.resume(now()))
        in_background(import_numerics)  # before a goal comes, not in its first solve

    def _settings(self) -> SequencerSettings:
        return SequencerSettings.from_parameters(lambda name: self.get_parameter(name).value)

    def _do(self, out) -> None:
        """Send what the core decided."""
        for values, _ in out.commands:
            self.command_pub.publish(command_message(values))
        for make in out.feedback:  # each new command's; the first says if the deadline can be met
            values = make()
            feedback = GrindBead.Feedback(command=command_message(values["command"]),
                                          **{k: v for k, v in values.items() if k != "command"})
            self.feedback_pub.publish(feedback)
            if (handle := self.core.token) is not None and handle.is_active:
                handle.publish_feedback(feedback)
        if out.solve is not None:
            self.solving = in_background(self.core.solve, out.solve, then=(self, self._poll_solve))
        if out.finished is not None:
            handle, values, job_ended = out.finished
            result = GrindBead.Result(**{**values, "reason": REASONS[values["reason"]]})
            if job_ended:
                self.result_pub.publish(result)
            if handle is not None:
                self.results[bytes(handle.goal_id.uuid)] = result
                if handle.status == GoalStatus.STATUS_ACCEPTED:
                    handle.execute()

    def _poll_solve(self) -> None:
        if self.solving is None or not self.solving.done():
            return
        future, self.solving = self.solving, None
        self._do(self.core.on_solved(future.exception() or future.result(), time.monotonic()))

    def _on_goal(self, request) -> GoalResponse:
        try:
            self.core.check_goal(goal_request(request))  # a refusal is counted, logged and in /diagnostics
            return GoalResponse.ACCEPT
        except ValueError:
            return GoalResponse.REJECT

    def _execute(self, goal_handle):
        result = self.results.pop(bytes(goal_handle.goal_id.uuid))
        if goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            (goal_handle.succeed if result.reason in (GrindBead.Result.DONE, GrindBead.Result.QUIT) else
             goal_handle.abort)()
        return result

    def _on_cancel(self, goal_handle):
        out = self.core.cancel(goal_handle)
        if out is None:
            return CancelResponse.REJECT
        self._do(out)  # executes the goal now, so that the cancel can complete it
        return CancelResponse.ACCEPT


class _Health(Diagnostics):  # /diagnostics, taking the core's fault levels ("warn", "error")
    def fault(self, name: str, message: str, level="warn", hold_s: float | None = None) -> None:
        super().fault(name, message, {"warn": WARN, "error": ERROR}.get(level, level), hold_s)


def main(args=None) -> int:
    return run_node(SequencePlannerNode, args)


if __name__ == "__main__":
    main()
