"""The sequence planner node's message conversions: PassCommand, PassResult, the pass
planner's status and GrindBead goals to and from the core's plain values (stamps in ns)."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus

from hex_control.grinding.sequencer import GoalRequest, PassReport
from hex_control.ros.infra.diagnostics import ERROR
from hex_control_msgs.msg import PassCommand, PassResult


def command_message(values: dict) -> PassCommand:
    """A PassCommand of the core's command values (its plant-time stamp in ns)."""
    command = PassCommand(**{k: v for k, v in values.items() if k != "stamp_ns"})
    command.header.stamp.sec, command.header.stamp.nanosec = divmod(values["stamp_ns"], 10**9)
    return command


def stamp_ns(stamp) -> int:
    """A ROS stamp in ns."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def pass_report(m: PassResult) -> PassReport:
    """The core's view of a PassResult."""
    return PassReport(m.job_id, m.pass_index, m.status, m.reason, m.measured_cut_depth_mm, m.removed_volume_mm3,
                      m.duration_s, m.specific_energy_j_mm3, m.burn_detected, stamp_ns(m.header.stamp))


def planner_status(m: DiagnosticStatus) -> tuple:
    """(job id, pass index, refused, message) of the pass planner's status."""
    values = {pair.key: pair.value for pair in m.values}
    return values.get("job_id"), values.get("pass_index", ""), m.level == ERROR, m.message


def goal_request(g) -> GoalRequest:
    """The core's GoalRequest of a GrindBead goal."""
    return GoalRequest(g.job_id, tuple(g.bead.x_mm), tuple(g.bead.z_mm), tuple(g.bead.parent_mm),
                       g.bead.bead_width_mm, g.bead_height_mm, g.bead_width_mm, g.bead_length_mm, g.deadline_s,
                       g.charges_yaml, g.process_yaml)
