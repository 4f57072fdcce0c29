"""Node ``pass_planner``: the middle tier -- a PassCommand and the latest contour in, the
force trajectory and the tool path out (seed 002 ch. 6; library
:mod:`hex_control.grinding.pass_plan`).

Topics:
    /grinding/pass_command     (PassCommand, latched)       in
    /grinding/contour          (Contour, latched)           in   the profile after pass k
    /grinding/force_trajectory (ForceTrajectory, latched)   out  for the force controller
    /motion/tool_path_raw      (ToolPath, latched)          out  the pass's whole tool path,
                                                                 for the input shaper
    ~/status                   (DiagnosticStatus, latched)  out  per command: OK "received",
                                                                 then OK + summary, or ERROR +
                                                                 the reason it was refused
    /grinding/pass_result      (PassResult)                 out  REJECTED + the reason, for a
                                                                 refused command
    /diagnostics

A pass starts ``start_delay_s`` after the later of the plant time of the contour it was
planned on and this node's clock: in lock-step the plant's clock stands still between passes
(it waits for the pass's trajectories), so that delay is the planning time the job is
charged, the same at any machine load; in real time it is the margin the trajectories have
to reach the plant.

Before a path is sent, its poses (one sample in ten, and the last) are checked with the
kinematics node's TestPose (``reachability_service``; '' = no check): a path the machine
cannot reach is refused with the offending pose, before anything moves.

The force is planned with the K1 the command carries: the one the sequence planner
computed its cut depth with (the pass-rate predictor's, for a dulling disk that needs
more force per mm of cut); 0 means the config's. A K1 more than PLAUSIBLE_K1_FACTOR
(10) times off the config's is refused.

A command for pass k is planned on the contour after k passes (``pass_index`` k and the
same job, or a contour without a job id). If none has arrived within ``contour_wait_s``
the command is refused. Planning runs in a worker thread; nothing is published for a
command until its whole plan exists, and nothing at all for a refused one. A command
already answered or in hand (a latched re-delivery, or the sequence planner sending it
again) is ignored and counted (``redelivered``); each new one is logged when it arrives and when it is planned. One
command waits for its contour at a time: of two, the one for an earlier pass of the same job
is refused as superseded, so every command ends exactly once (planned or refused).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.node import Node

from hex_control.grinding.coefficients import plausible_specific_energy
from hex_control.grinding.config import load_pass_planner_config
from hex_control.grinding.pass_plan import PlanningError, plan_forces
from hex_control.grinding.tool_path import pass_tool_path
from hex_control.kinematics import load_machine
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import (
    LATCHED,
    RESULTS,
    contour_from_message,
    contour_to_message,
    part_quality_message,
    stamp_s,
    time_msg,
    tool_path_message,
)
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control.nodes.runtime import in_background, run_node, wall_timer
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceTrajectory, PassCommand, PassResult, ToolPath, ToolPose
from hex_control_msgs.srv import TestPose

RESEND_S = 2.0  # a TestPose request unanswered this long (wall s) is sent again

PARAMETERS = {
    "config": Spec("pass_planner.yaml", "pass planner YAML (config/): disk model, planner, control, path"),
    "contour_wait_s": Spec(5.0, "wall time a command waits for its contour (or the reachability check for "
                           "its answer) before it is refused", 0.01, 3600.0),
    "start_delay_s": Spec(0.6, "from the later of the contour's plant time and the node clock to the start "
                          "of the pass's path (s): the planning time charged between passes", 0.0, 60.0,
                          read_only=False),
    "reachability_service": Spec("kinematics/test_pose", "TestPose service for the path of every pass; "
                                 "'' = no check"),
    "machine_file": Spec("", "machine YAML whose bead_frame (if any) places the bead; '' = the config's"),
}


class PassPlannerNode(Node):
    READY_PARAMETERS = ("config", "machine_file")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("pass_planner", **kwargs)
        declare_parameters(self, PARAMETERS)
        machine_file = self.get_parameter("machine_file").value
        self.config = load_pass_planner_config(self.get_parameter("config").value,
                                               load_machine(machine_file)[1] if machine_file else None)
        self.diagnostics = Diagnostics(self)
        self.contour: ContourMsg | None = None
        self.pending: PassCommand | None = None
        self.pending_since = None
        self.answered: set[tuple[str, int]] = set()
        self.planning = None  # (command, future, plant time of its contour s)
        self.checking = None  # (command, (plan, path, process, contour s), TestPose future or None, since)
        self.check_sent_at = 0.0  # when the pending TestPose request went out (wall s)
        service = self.get_parameter("reachability_service").value
        self.reach_client = self.create_client(TestPose, service) if service else None

        self.trajectory_pub = self.create_publisher(ForceTrajectory, "grinding/force_trajectory", LATCHED)
        self.status_pub = self.create_publisher(DiagnosticStatus, "~/status", LATCHED)
        self.result_pub = self.create_publisher(PassResult, "grinding/pass_result", RESULTS)
        self.path_pub = self.create_publisher(ToolPath, "motion/tool_path_raw", LATCHED)
        self.create_subscription(PassCommand, "grinding/pass_command", self._on_command, LATCHED)
        self.create_subscription(ContourMsg, "grinding/contour", self._on_contour, LATCHED)
        wall_timer(self, 0.02, self._poll)

    # -- inputs --------------------------------------------------------------------------
    def _on_contour(self, msg: ContourMsg) -> None:
        self.contour = msg
        self.diagnostics.count("contours")
        self._try_plan()

    def _on_command(self, msg: PassCommand) -> None:
        key = _key(msg)
        in_hand = [entry[0] for entry in (self.planning, self.checking) if entry] + [self.pending]
        if key in self.answered or any(c is not None and _key(c) == key for c in in_hand):
            self.diagnostics.count("redelivered")  # latched, or the sequence planner sending it again
            return
        self.diagnostics.count("commands")
        self.get_logger().info(f"pass {msg.pass_index} of job {msg.job_id!r}: cut {msg.cut_depth_mm:.4f} mm "
                               f"at {msg.feed_speed_mm_s:.2f} mm/s, K1 {msg.specific_energy_j_mm3:g} J/mm^3")
        self._status(msg, DiagnosticStatus.OK, "received", {})  # the sequence planner's acknowledgement
        if self.pending is not None:  # one command waits for its contour at a time: the older one ends here
            older, newer = (self.pending, msg) if _supersedes(msg, self.pending) else (msg, self.pending)
            self._refuse(older, f"superseded by pass {newer.pass_index} of job {newer.job_id!r} before its "
                                "contour came", "superseded")
            if older is msg:
                return
        self.pending, self.pending_since = msg, time.monotonic()  # a transport wait: wall time
        self._try_plan()

    def _contour_for(self, command: PassCommand) -> ContourMsg | None:
        c = self.contour
        if c is None or c.pass_index != command.pass_index or (c.job_id and c.job_id != command.job_id):
            return None
        return c

    def _try_plan(self) -> None:
        if self.pending is None or self.planning is not None or self.checking is not None:
            return
        contour = self._contour_for(self.pending)
        if contour is None:
            return
        command, self.pending = self.pending, None
        self.planning = (command, in_background(self._plan, command, contour), stamp_s(contour.header.stamp))

    # -- planning (worker thread: library calls only) ------------------------------------
    def _plan(self, command: PassCommand, contour_msg: ContourMsg):
        values = (command.cut_depth_mm, command.feed_speed_mm_s)
        if not all(math.isfinite(v) for v in values):
            raise PlanningError(f"non-finite command: cut depth {values[0]!r} mm, feed {values[1]!r} mm/s")
        nominal = self.config.model.process.specific_energy_j_mm3
        specific_energy_j_mm3 = command.specific_energy_j_mm3 or nominal
        if not plausible_specific_energy(specific_energy_j_mm3, nominal):
            raise PlanningError(f"implausible K1 {specific_energy_j_mm3!r} J/mm^3 (the config's is {nominal:g})")
        try:
            contour = contour_from_message(contour_msg)
        except ValueError as exc:
            raise PlanningError(f"bad contour: {exc}") from None
        config = self.config
        process = dataclasses.replace(config.model.process, specific_energy_j_mm3=specific_energy_j_mm3)
        if contour_msg.bead_width_mm > 0:
            process = dataclasses.replace(process, bead_width_mm=contour_msg.bead_width_mm)
        model = dataclasses.replace(config.model, process=process)
        plan = plan_forces(contour, model, command.cut_depth_mm, command.feed_speed_mm_s, config.planner,
                           config.control, config.gains, config.step_mm, config.compliance)
        path = pass_tool_path(config.frame, plan.time_s, plan.centre_x_mm, plan.height_mm, config.path)
        return plan, path, process

    def _poll(self) -> None:
        if self.pending is not None and self.planning is None and self._contour_for(self.pending) is None:
            waited = time.monotonic() - self.pending_since
            if waited > self.get_parameter("contour_wait_s").value:
                command, self.pending = self.pending, None
                latest = "none" if self.contour is None else f"the one after {self.contour.pass_index} passes"
                self._refuse(command, f"no contour for pass {command.pass_index} (latest: {latest})", "no_contour")
        if self.checking is not None:
            self._check_reach()
        if self.planning is None or not self.planning[1].done():
            return
        command, future, contour_s = self.planning
        self.planning = None
        try:
            plan, path, process = future.result()
        except (PlanningError, ValueError, FloatingPointError) as exc:
            self._refuse(command, str(exc), "unplannable")
        else:
            planned = (plan, path, process, contour_s)
            if self.reach_client is None:
                self._publish(command, *planned)
            else:
                self.checking = (command, planned, None, time.monotonic())
                self._check_reach()
        self._try_plan()

    def _check_reach(self) -> None:
        command, planned, future, since = self.checking
        path = planned[1]
        if future is None:
            if self.reach_client.service_is_ready():
                roll, pitch, yaw = (float(a) for a in np.radians(self.config.frame.orientation_rpy_deg))
                request = TestPose.Request(poses=[
                    ToolPose(x_mm=float(x), y_mm=float(y), z_mm=float(z), roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw)
                    for x, y, z in _checked_positions(path)])
                self.checking = (command, planned, self.reach_client.call_async(request), since)
                self.check_sent_at = time.monotonic()
            elif time.monotonic() - since > self.get_parameter("contour_wait_s").value:
                self.checking = None
                self._refuse(command, f"reachability service {self.reach_client.srv_name} unavailable", "unchecked")
            return
        if not future.done():
            if time.monotonic() - since > self.get_parameter("contour_wait_s").value:
                self.reach_client.remove_pending_request(future)
                self.checking = None
                self._refuse(command, f"reachability service {self.reach_client.srv_name} did not answer", "unchecked")
            elif time.monotonic() - self.check_sent_at > RESEND_S:
                # Fast DDS drops a response to a client it has not matched yet: ask again
                self.reach_client.remove_pending_request(future)
                self.checking = (command, planned, None, since)
                self.diagnostics.count("reachability_resent")
            return
        self.checking = None
        index = future.result().first_unreachable_index
        if index >= 0:
            x, y, z = _checked_positions(path)[index]
            self._refuse(command, f"path pose ({x:.1f}, {y:.1f}, {z:.1f}) mm (machine frame) is out of the "
                                  "machine's reach", "unreachable")
        else:
            self._publish(command, *planned)
        self._try_plan()

    # -- outputs -------------------------------------------------------------------------
    def _refuse(self, command: PassCommand, reason: str, kind: str) -> None:
        self.answered.add(_key(command))
        self.diagnostics.count(f"rejected_{kind}")
        self.get_logger().warn(f"pass {command.pass_index} of job {command.job_id!r} refused: {reason}")
        self._status(command, DiagnosticStatus.ERROR, reason, {})
        result = PassResult(job_id=command.job_id, pass_index=command.pass_index, status=PassResult.REJECTED,
                            reason=reason, specific_energy_j_mm3=math.nan,
                            part_quality=part_quality_message(None, math.nan))
        result.header.stamp = self.get_clock().now().to_msg()
        self.result_pub.publish(result)

    def _publish(self, command: PassCommand, plan, path, process, contour_s: float) -> None:
        self.answered.add(_key(command))
        start_s = max(contour_s, self.get_clock().now().nanoseconds * 1e-9) + self.get_parameter("start_delay_s").value
        msg = ForceTrajectory(job_id=command.job_id, pass_index=command.pass_index,
                              feed_speed_mm_s=float(command.feed_speed_mm_s),
                              planned_cut_depth_mm=float(plan.planned_depth_mm),
                              path_start_s=-float(path.grind_start_s),
                              path_end_s=float(path.time_s[-1] - path.grind_start_s),
                              time_from_start_s=plan.time_s.tolist(), x_mm=plan.centre_x_mm.tolist(),
                              normal_force_n=plan.force_n.tolist(),
                              planned_final_contour=contour_to_message(plan.final, command.job_id,
                                                                       command.pass_index + 1,
                                                                       process.bead_width_mm))
        msg.header.stamp = time_msg(start_s + path.grind_start_s)
        msg.header.frame_id = "bead"
        self.trajectory_pub.publish(msg)
        orientation = np.broadcast_to(np.radians(self.config.frame.orientation_rpy_deg), path.positions_mm.shape)
        self.path_pub.publish(tool_path_message(time_msg(start_s), command.job_id, command.pass_index,
                                                path.time_s[1] - path.time_s[0],
                                                np.hstack([path.positions_mm, orientation])))
        self.diagnostics.count("planned")
        self.get_logger().info(f"pass {command.pass_index} of job {command.job_id!r} planned: "
                               f"{plan.planned_depth_mm:.4f} mm in {plan.time_s[-1]:.2f} s "
                               f"({plan.simulations} simulation{'s' if plan.simulations > 1 else ''})")
        summary = {"planned_cut_depth_mm": plan.planned_depth_mm, "duration_s": float(plan.time_s[-1]),
                   "peak_force_n": float(np.max(plan.force_n)), "path_samples": int(path.time_s.size),
                   "specific_energy_j_mm3": process.specific_energy_j_mm3, "simulations": plan.simulations}
        self._status(command, DiagnosticStatus.WARN if plan.reason else DiagnosticStatus.OK,
                     plan.reason or "planned", summary)

    def _status(self, command: PassCommand, level: int, message: str, values: dict) -> None:
        pairs = {"job_id": command.job_id, "pass_index": command.pass_index, **values}
        self.status_pub.publish(DiagnosticStatus(level=level, name=self.get_fully_qualified_name(), message=message,
                                                 values=[KeyValue(key=k, value=str(v)) for k, v in pairs.items()]))


def _checked_positions(path) -> np.ndarray:
    """The path positions TestPose checks (mm): one sample in ten, and the last."""
    return np.vstack([path.positions_mm[::10], path.positions_mm[-1:]])


def _supersedes(new: PassCommand, old: PassCommand) -> bool:
    """A command for another job, or a later pass of the same one, replaces a waiting one;
    an earlier pass of the same job (a late re-delivery from a restarted writer) does not."""
    return new.job_id != old.job_id or new.pass_index > old.pass_index


def _key(command: PassCommand) -> tuple[str, int]:
    return command.job_id, command.pass_index


def main(args=None) -> int:
    return run_node(PassPlannerNode, args)


if __name__ == "__main__":
    main()
