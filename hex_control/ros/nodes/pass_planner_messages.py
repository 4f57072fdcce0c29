"""The pass planner node's messages: a planned pass's force trajectory and tool path, a
refused pass's result, and the reachability request of a path (mm, rad, s of plant time)."""

from __future__ import annotations

import math

import numpy as np

from hex_control.grinding.pass_session import PassRequest, checked_positions
from hex_control.ros.infra import interfaces as ifc
from hex_control_msgs.msg import ForceTrajectory, PassResult, ToolPath, ToolPose
from hex_control_msgs.srv import TestPose


def force_trajectory_message(request: PassRequest, planned, start_s: float) -> ForceTrajectory:
    """The pass's force trajectory, stamped where its grinding starts (its path starts at ``start_s``)."""
    plan, path = planned.plan, planned.path
    msg = ForceTrajectory(job_id=request.job_id, pass_index=request.pass_index,
                          feed_speed_mm_s=request.feed_mm_s, planned_cut_depth_mm=float(plan.planned_depth_mm),
                          path_start_s=-float(path.grind_start_s),
                          path_end_s=float(path.time_s[-1] - path.grind_start_s),
                          time_from_start_s=plan.time_s.tolist(), x_mm=plan.centre_x_mm.tolist(),
                          normal_force_n=plan.force_n.tolist(),
                          planned_final_contour=ifc.contour_to_message(
                              plan.final, request.job_id, request.pass_index + 1, planned.process.bead_width_mm))
    msg.header.stamp = ifc.time_msg(start_s + path.grind_start_s)
    msg.header.frame_id = "bead"
    return msg


def tool_path_message(request: PassRequest, path, start_s: float, orientation_rpy_deg) -> ToolPath:
    """The pass's tool path from ``start_s``, at the bead frame's orientation (deg)."""
    orientation = np.broadcast_to(np.radians(orientation_rpy_deg), path.positions_mm.shape)
    return ifc.tool_path_message(ifc.time_msg(start_s), request.job_id, request.pass_index,
                                 path.time_s[1] - path.time_s[0], np.hstack([path.positions_mm, orientation]))


def rejected_result(request: PassRequest, reason: str, stamp_s: float) -> PassResult:
    """The REJECTED result of a pass the planner cannot plan (nothing was ground)."""
    result = PassResult(job_id=request.job_id, pass_index=request.pass_index, status=PassResult.REJECTED,
                        reason=reason, specific_energy_j_mm3=math.nan,
                        part_quality=ifc.part_quality_message(None, math.nan))
    result.header.stamp = ifc.time_msg(stamp_s)
    return result


def reach_request(path, orientation_rpy_deg) -> TestPose.Request:
    """TestPose of the path's checked positions, at the bead frame's orientation (deg)."""
    roll, pitch, yaw = (float(a) for a in np.radians(orientation_rpy_deg))
    return TestPose.Request(poses=[ToolPose(x_mm=float(x), y_mm=float(y), z_mm=float(z), roll_rad=roll,
                                            pitch_rad=pitch, yaw_rad=yaw) for x, y, z in checked_positions(path)])
