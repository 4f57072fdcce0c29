"""The kinematics node's message conversions: ToolPose rows in, ConstraintReports out, fast
enough for a request of ``max_poses`` poses to cost well under a second."""

from __future__ import annotations

import array
from operator import attrgetter

import numpy as np

from hex_control.ros.infra.interfaces import PATH_FIELDS
from hex_control_msgs.msg import ConstraintReport, ToolPose

_POSE = attrgetter(*PATH_FIELDS)  # a ToolPose's fields, in a row's order
_SLOTS = tuple("_" + name for name in ConstraintReport.get_fields_and_field_types())
_FAST = set(ConstraintReport.__slots__) == {*_SLOTS, "_check_fields"}  # the layout _report fills


def pose_rows(poses) -> np.ndarray:
    """The poses (n, 6): x, y, z mm, roll, pitch, yaw rad."""
    return np.array(list(map(_POSE, poses)), float).reshape(-1, 6)


def _arrays(values: np.ndarray | None, n: int) -> list[array.array]:
    if values is None:
        return [array.array("d") for _ in range(n)]
    blob, width = np.ascontiguousarray(values, float).tobytes(), 8 * values.shape[1]
    return [array.array("d", blob[i:i + width]) for i in range(0, len(blob), width)]


def _report(values) -> ConstraintReport:
    """One report from its field values: rosidl's constructor and setters cost 30 us a
    report, 0.75 s of a 25,000-pose answer; filling the slots 4 us (same message, tested)."""
    if not _FAST:
        return ConstraintReport(**dict(zip((s[1:] for s in _SLOTS), values)))
    report = ConstraintReport.__new__(ConstraintReport)
    report._check_fields = False
    for slot, value in zip(_SLOTS, values):
        setattr(report, slot, value)
    return report


def constraint_reports(check) -> list[ConstraintReport]:
    """One ConstraintReport per pose of a ConstraintCheck (joint positions unknown: 0)."""
    n = len(check.satisfied)
    return list(map(_report, zip(check.reachable.tolist(), *check.satisfied.T.tolist(), *check.margins.T.tolist(),
                                 _arrays(np.nan_to_num(check.positions_mm, nan=0.0), n),
                                 _arrays(check.platform_joint_angles_rad, n), _arrays(check.base_joint_angles_rad, n))))


def tool_pose(row) -> ToolPose:
    return ToolPose(**{name: float(value) for name, value in zip(PATH_FIELDS, row)})
