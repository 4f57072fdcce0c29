"""Node ``pass_planner``: a PassCommand and the latest contour in, the force trajectory and
the tool path out (seed 002 ch. 6). The behaviour -- which command on which contour, the
checks against the scan and the parent, the refusals -- is the core
:class:`hex_control.grinding.pass_session.PassSession`; this node converts messages, plans
on a worker thread, asks TestPose (``reachability_service``; '' = none) and publishes.

In: /grinding/pass_command, /grinding/contour (each from its owner). Out: /grinding/force_trajectory,
/motion/tool_path_raw, ~/status ("received", then planned or why not), /grinding/pass_result (REJECTED)."""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.node import Node

from hex_control.grinding.config import load_pass_planner_config
from hex_control.grinding.pass_session import PassRequest, PassSession, Scan, Verdict, pass_start_s
from hex_control.kinematics import load_machine
from hex_control.plant.lockstep import PLAN_AHEAD_S
from hex_control.ros.infra import interfaces as ifc
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.message_info import foreign_publishers, info_subscription
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import POLL_S, in_background, run_node, wake, wall_timer
from hex_control.ros.nodes.pass_planner_messages import (
    force_trajectory_message,
    reach_request,
    rejected_result,
    tool_path_message,
)
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceTrajectory, PassCommand, PassResult, ToolPath
from hex_control_msgs.srv import TestPose

RESEND_S = 2.0  # a TestPose request unanswered this long (wall s) is sent again
FAULT_HOLD_S = 10.0  # a refusal or a part-safety change is a WARN this long (wall s)

PARAMETERS = {
    "config": Spec("pass_planner.yaml", "pass planner YAML (config/): disk model, planner, control, path"),
    "contour_wait_s": Spec(5.0, "wall time a command waits for its contour (or the reachability check for "
                           "its answer) before it is refused", 0.01, 3600.0),
    "start_delay_s": Spec(0.6, "scan (or node clock, if over plan_ahead_s later) to the path's start (s): the "
                          "planning time charged between passes", 0.0, 60.0, read_only=False),
    "plan_ahead_s": Spec(PLAN_AHEAD_S, "the plant's: sim s it runs on after a scan while this node plans", 0.0, 60.0),
    "reachability_service": Spec("kinematics/test_pose", "TestPose service for every pass's path; '' = none"),
    "machine_file": Spec("", "machine YAML whose bead_frame (if any) places the bead; '' = the config's"),
    "command_owner": Spec("sequence_planner", "node whose PassCommands are planned (relative to the namespace); "
                          "'' = the first heard (hand use)"),
    "contour_owner": Spec("plant", "node whose contours are planned on; '' = the first heard (hand use)"),
}


class PassPlannerNode(Node):
    READY_PARAMETERS = ("config", "machine_file")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("pass_planner", **kwargs)
        declare_parameters(self, PARAMETERS)
        machine_file = self.get_parameter("machine_file").value
        self.config = load_pass_planner_config(self.get_parameter("config").value,
                                               load_machine(machine_file)[1] if machine_file else None)
        service = self.get_parameter("reachability_service").value
        self.core = PassSession(self.config, self.get_parameter("contour_wait_s").value, bool(service))
        self.diagnostics = Diagnostics(self)
        self.planning = None  # the worker's future
        self.reach, self.reach_sent_at = None, 0.0  # the pending TestPose future, when it went out (wall s)
        self.reach_client = self.create_client(TestPose, service) if service else None
        self.trajectory_pub = self.create_publisher(ForceTrajectory, "grinding/force_trajectory", ifc.LATCHED)
        self.status_pub = self.create_publisher(DiagnosticStatus, "~/status", ifc.LATCHED)
        self.result_pub = self.create_publisher(PassResult, "grinding/pass_result", ifc.RESULTS)
        self.path_pub = self.create_publisher(ToolPath, "motion/tool_path_raw", ifc.LATCHED)
        for msg_type, topic, callback, name, owner in (
                (PassCommand, "grinding/pass_command", self._on_command, "pass_command", "command_owner"),
                (ContourMsg, "grinding/contour", self._on_contour, "contour", "contour_owner")):
            info_subscription(self, msg_type, topic, callback, ifc.LATCHED, diagnostics=self.diagnostics, name=name,
                              owner_node=self.get_parameter(owner).value)
        wall_timer(self, POLL_S, self._poll)

    def _on_contour(self, msg: ContourMsg) -> None:
        try:
            contour, error = ifc.contour_from_message(msg), ""
        except ValueError as exc:  # refused with the command it was meant for
            contour, error = None, str(exc)
        self.core.on_scan(Scan(msg.job_id, msg.pass_index, ifc.stamp_s(msg.header.stamp), msg.bead_width_mm, contour,
                               error))
        self.diagnostics.count("contours")
        self._try_plan()

    def _on_command(self, msg: PassCommand) -> None:
        request = PassRequest(msg.job_id, int(msg.pass_index), float(msg.cut_depth_mm), float(msg.feed_speed_mm_s),
                              float(msg.specific_energy_j_mm3), float(msg.normal_force_n), bool(msg.stop))
        if self.core.in_hand(request):
            self.diagnostics.count("redelivered")  # latched, or the sequence planner sending it again
            return
        self.diagnostics.count("stops" if request.stop else "commands")
        self.get_logger().info(f"pass {msg.pass_index} of job {msg.job_id!r}: " + ("stop" if request.stop else
                               f"cut {msg.cut_depth_mm:.4f} mm at {msg.feed_speed_mm_s:.2f} mm/s, "
                               f"K1 {msg.specific_energy_j_mm3:g} J/mm^3"))
        if not request.stop:
            self._status(request, DiagnosticStatus.OK, "received", {})  # the sequence planner's acknowledgement
        for verdict in self.core.on_command(request, time.monotonic()):  # a transport wait: wall time
            self._end(verdict)
        if self.core.checking is None and self.reach is not None:  # its pass was stopped
            self.reach_client.remove_pending_request(self.reach)
            self.reach = None
        self._try_plan()

    def _try_plan(self) -> None:
        if (ready := self.core.next_to_plan()) is not None:
            self.planning = in_background(self.core.plan, *ready, then=(self, self._poll))

    def _poll(self) -> None:
        self._end(self.core.expired(now := time.monotonic()))
        if self.planning is not None and self.planning.done():
            future, self.planning = self.planning, None
            self._end(self.core.planned(future.result(), now))  # None: its path is checked first
            self.diagnostics.set("planning_wall_s", f"{self.core.planning_s:.3f}")  # sim time stood still meanwhile
            self._try_plan()
        if self.core.checking is not None:
            self._check_reach()

    def _check_reach(self) -> None:
        """TestPose on the path being checked: sent when the service is ready, again after RESEND_S
        (Fast DDS drops a response to a client it has not matched yet); given up after contour_wait_s."""
        name, now = self.reach_client.srv_name, time.monotonic()
        if self.reach is not None and self.reach.done():
            future, self.reach = self.reach, None
            self._end(self.core.reach_answer(future.result().first_unreachable_index))
            self._try_plan()
        elif self.core.reach_overdue(now):
            if self.reach is not None:
                self.reach_client.remove_pending_request(self.reach)
            self._end(self.core.reach_failed(f"reachability service {name} "
                                             + ("did not answer" if self.reach else "unavailable")))
            self.reach = None
            self._try_plan()
        elif self.reach is not None and now - self.reach_sent_at > RESEND_S:
            self.reach_client.remove_pending_request(self.reach)
            self.reach = None
            self.diagnostics.count("reachability_resent")
        elif self.reach is None and self.reach_client.service_is_ready():
            request = reach_request(self.core.checking[1].path, self.config.frame.orientation_rpy_deg)
            self.reach, self.reach_sent_at = self.reach_client.call_async(request), now
            self.reach.add_done_callback(lambda _future: wake(self, self._poll))  # not at the next poll

    def _end(self, verdict: Verdict | None) -> None:
        if verdict is None:
            return
        self.diagnostics.count(verdict.counter)
        if verdict.fault:
            self.diagnostics.fault(*verdict.fault, hold_s=FAULT_HOLD_S)
        request = verdict.request
        if verdict.refused:
            self.get_logger().warn(f"pass {request.pass_index} of job {request.job_id!r} refused: {verdict.reason}")
            self._status(request, DiagnosticStatus.ERROR, verdict.reason, {})
            scan = self.core.scan
            self.result_pub.publish(rejected_result(request, verdict.reason,
                                                    self._plant_time_s(scan.stamp_s if scan is not None else 0.0)))
        else:
            self._publish(request, verdict.planned)

    def _plant_time_s(self, scanned_s: float) -> float:
        """The node's sim clock (s), unless /clock has a publisher besides the plant: then
        ``scanned_s``, a scan's owner-checked stamp (a forged clock times no pass and stamps
        no result), counted and said in a WARN."""
        strangers = foreign_publishers(self, "/clock", self.get_parameter("contour_owner").value)
        if not strangers:
            return self.get_clock().now().nanoseconds * 1e-9
        self.diagnostics.count("foreign_clock")
        self.diagnostics.fault("clock_owner", f"/clock also from {', '.join(strangers)}: plant time from the scan",
                               hold_s=FAULT_HOLD_S)
        return scanned_s

    def _publish(self, request: PassRequest, planned) -> None:
        start_s = pass_start_s(planned.contour_s, self._plant_time_s(planned.contour_s),
                               self.get_parameter("start_delay_s").value, self.get_parameter("plan_ahead_s").value)
        self.trajectory_pub.publish(force_trajectory_message(request, planned, start_s))
        self.path_pub.publish(tool_path_message(request, planned.path, start_s, self.config.frame.orientation_rpy_deg))
        self.get_logger().info(f"pass {request.pass_index} of job {request.job_id!r} planned: {planned.summary()}")
        self._status(request, DiagnosticStatus.WARN if planned.note else DiagnosticStatus.OK,
                     planned.note or "planned", planned.values)

    def _status(self, request: PassRequest, level: int, message: str, values: dict) -> None:
        pairs = {"job_id": request.job_id, "pass_index": request.pass_index, **values}
        self.status_pub.publish(DiagnosticStatus(level=level, name=self.get_fully_qualified_name(), message=message,
                                                 values=[KeyValue(key=k, value=str(v)) for k, v in pairs.items()]))


def main(args=None) -> int:
    return run_node(PassPlannerNode, args)


if __name__ == "__main__":
    main()
