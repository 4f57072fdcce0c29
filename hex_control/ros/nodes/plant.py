"""Node ``plant``: the simulated hardware and the source of ``/clock`` -- every other node
runs on sim time (use_sim_time:=true). The behaviour is the ROS-free
:class:`hex_control.plant.core.PlantCore` (the lock-step gate: :mod:`hex_control.plant.lockstep`;
a pass's verdict: :mod:`hex_control.plant.pass_verdict`); this node reads its parameters
(:mod:`hex_control.ros.nodes.plant_setup`), converts messages (:mod:`hex_control.ros.nodes.plant_messages`)
and holds the timers.

Modes (``mode``): ``lockstep`` steps on each force command that answers the last state (and,
with a workpiece, only while a pass runs or is covered); a silent controller makes it run free
on the wall clock after ``lockstep_timeout_s``. ``realtime`` steps every control period of wall
time over ``real_time_factor``, a late tick stepping the periods it owes. ``end_time_s`` > 0
stops the run there; ``report_file`` gets the loop's timing as JSON every second.

Command ownership (:mod:`hex_control.plant.command_owner`, docs/graph.md threat model): each
input obeys one node, named relative to the plant's namespace: ``force_command_owner``
(force_controller), ``strut_command_owner`` (kinematics), ``force_trajectory_owner``
(pass_planner), ``controller_status_owner`` (force_controller); '' = the first publisher
heard. Others are refused and counted (``foreign_*``; lost on the way: ``lost_*``).

With ``grinding`` the plant holds the workpiece (a bead, or the part as last scanned in
``workpiece_file``, saved before each scan and result is published and when a pass begins):
passes are announced by their force trajectories; after each the scanner publishes the contour
and the pass result, COMPLETED, ABORTED or FAULTED with the reason.

Topics: see docs/graph.md; in: plant/force_axis_command, plant/strut_command, plant/strut_trajectory,
grinding/force_trajectory, force_controller/status; out: clock, plant/wrench, plant/telemetry,
plant/strut_states, (debug_streams) plant/true_wrench, plant/deflection, plant/tool_centre,
(grinding) grinding/contour, grinding/pass_result.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.node import Node
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from hex_control.plant.workpiece_store import StoredWorkpiece, save_workpiece
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import (
    LATCHED,
    RESULTS,
    contour_to_message,
    stamp_s,
    strut_trajectory_from_message,
    time_msg,
)
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.messages import fill_message, to_primitive
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import run_node, wall_timer
from hex_control.ros.nodes.plant_messages import (
    NodeEvents,
    PlantStreams,
    announced_pass,
    pass_result_message,
    stamp_ns,
)
from hex_control.ros.nodes.plant_setup import PARAMETERS, build_core
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceAxisCommand, ForceTrajectory, PassResult

PRELOAD = ("scipy.linalg", "numpy.random")  # imported at start (servo discretization, draws): node_forks.py


class PlantNode(Node):
    READY_PARAMETERS = ("mode", "machine_file", "seed", "grinding")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("plant", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = self.p
        self.diagnostics = Diagnostics(self)
        self.core, self.workpiece = build_core(p, self, NodeEvents(self.get_logger(), self.diagnostics))
        period_s = p("control_period_s")
        self.streams = PlantStreams(self, self.core.strut_names, period_s, p("clock_period_s"),
                                    telemetry_period_s=p("telemetry_period_s"), debug_streams=p("debug_streams"),
                                    grinding=self.workpiece is not None)
        self.measurement, self.state, self.hold = self.streams.measurement, self.streams.state, self.streams.hold
        for topic, msg_type, callback, qos, owner, name in (
                ("plant/force_axis_command", ForceAxisCommand, self._on_force_command, 100, "force_command_owner",
                 "force_command"),
                ("plant/strut_command", JointState, self._on_strut_command, 100, "strut_command_owner",
                 "strut_command"),
                ("plant/strut_trajectory", JointTrajectory, self._on_strut_trajectory, LATCHED,
                 "strut_command_owner", "strut_trajectory")):
            info_subscription(self, msg_type, topic, callback, qos, diagnostics=self.diagnostics, name=name,
                              owner_node=self._owner(owner))
        if self.workpiece is not None:
            if p("workpiece_file") and os.path.isfile(p("workpiece_file")):
                self.get_logger().info(f"took up the workpiece of {p('workpiece_file')}: {self.workpiece.passes} "
                                       f"passes of job {self.workpiece.job_id or '(none)'}")
            self.contour_publisher = self.create_publisher(ContourMsg, "grinding/contour", LATCHED)
            self.result_publisher = self.create_publisher(PassResult, "grinding/pass_result", RESULTS)
            info_subscription(self, ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, LATCHED,
                              diagnostics=self.diagnostics, name="force_trajectory",
                              owner_node=self._owner("force_trajectory_owner"))
            if p("controller_status_topic"):
                info_subscription(self, DiagnosticStatus, p("controller_status_topic"), self._on_controller_status,
                                  LATCHED, diagnostics=self.diagnostics, name="controller_status",
                                  owner_node=self._owner("controller_status_owner"))
            self.contour_publisher.publish(self._contour_message(self.core.sim.cell.contour, self.workpiece.job_id,
                                                                 self.workpiece.passes))
            if self.workpiece.last_result is not None:  # the same message again, in case nobody had taken it in
                self.result_publisher.publish(fill_message(PassResult(), self.workpiece.last_result))
        tick_s = period_s / p("real_time_factor")  # wall s
        if p("mode") == "realtime":
            self.create_timer(tick_s, self.core.realtime_tick)
        else:  # the free run's timer runs only while a step is due (else 200 idle wakeups/s)
            self.free_run_timer = self.create_timer(tick_s, self._free_run, autostart=False)
            wall_timer(self, self.core.watchdog_period_s(p("lockstep_timeout_s")), self._watchdog)
        wall_timer(self, 1.0, self._report)
        self.core.publish_state()

    def p(self, name: str):
        return self.get_parameter(name).value

    def _watchdog(self) -> None:
        if self.core.watchdog_tick(self.p("lockstep_timeout_s")) and self.free_run_timer.is_canceled():
            self.free_run_timer.reset()

    def _free_run(self) -> None:
        if not self.core.free_run():
            self.free_run_timer.cancel()

    def _owner(self, parameter: str) -> str:
        """The owner's fully qualified name: a relative name is the plant's namespace's node."""
        name = self.p(parameter)
        return name if not name or name.startswith("/") else self.get_namespace().rstrip("/") + "/" + name

    def _contour_message(self, contour, job_id: str, passes: int) -> ContourMsg:
        msg = contour_to_message(contour, job_id, passes, self.core.sim.cell.width_mm)
        msg.header.stamp = time_msg(self.core.sim.time_s)  # the pass planner starts the next pass from here
        return msg

    # -- inputs ----------------------------------------------------------------------------
    def _on_force_command(self, msg: ForceAxisCommand) -> None:
        self.core.on_force_command(msg.position_mm, stamp_ns(msg.header.stamp))

    def _on_strut_command(self, msg: JointState) -> None:
        self.core.on_strut_command(list(msg.name), list(msg.position), stamp_s(msg.header.stamp))

    def _on_strut_trajectory(self, msg: JointTrajectory) -> None:
        try:
            trajectory = strut_trajectory_from_message(msg, self.core.strut_names)
        except ValueError as error:
            self.core.refuse("rejected_strut_trajectory", f"strut trajectory rejected: {error}")
            return
        self.core.on_strut_trajectory(trajectory)

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        try:
            scheduled = announced_pass(msg)
        except ValueError as error:
            self.core.refuse("rejected_trajectory", f"force trajectory rejected: {error}")
            return
        self.core.on_pass_announced(scheduled)

    def _on_controller_status(self, msg: DiagnosticStatus) -> None:
        self.core.on_controller_status(msg.message, {pair.key: pair.value for pair in msg.values})

    # -- outputs (PlantOutputs; measurement, state and hold are the streams') ---------------
    def pass_started(self, scheduled) -> None:
        if self.p("workpiece_file"):  # which pass was under way, should the plant stop before its scan
            self.workpiece = replace(self.workpiece, started=(scheduled.job_id, scheduled.pass_index,
                                                              scheduled.path_start_s))
            save_workpiece(self.p("workpiece_file"), self.workpiece)

    def pass_ended(self, report) -> None:
        m = report.measurement
        self.contour_publisher.publish(self._contour_message(m.contour_after, m.job_id, m.pass_index + 1))
        result = pass_result_message(report, self.p("end_zone_mm"), self.core.sim.time_s)
        if self.p("workpiece_file"):  # on disk before anyone hears of it
            self.workpiece = StoredWorkpiece(m.job_id, m.pass_index + 1, m.contour_after, to_primitive(result))
            save_workpiece(self.p("workpiece_file"), self.workpiece)
        self.result_publisher.publish(result)

    def _report(self) -> None:
        report = self.core.loop_report()
        for name, value in report.items():
            self.diagnostics.set(name, f"{value:.4g}")
        path = self.p("report_file")
        if path:
            with open(path + ".tmp", "w") as stream:
                json.dump(report, stream)
            os.replace(path + ".tmp", path)


def main(args=None) -> int:
    return run_node(PlantNode, args)


if __name__ == "__main__":
    main()
