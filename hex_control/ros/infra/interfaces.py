"""What the nodes agree on: the QoS of the shared topics, stamps, and the conversions of
the messages that several nodes read (Contour, ToolPath, the strut JointTrajectory).

- ``LATCHED``: configuration-like state whose latest value a late joiner needs (a pass
  command, a force trajectory, the contour): reliable, transient-local, depth 1.
- ``RESULTS``: pass results, kept by their publisher (depth 10) so that one sent while
  the sequence planner restarts still arrives; receivers ignore results they have seen.
  ``TELEMETRY`` (the plant's batched state) is kept the same way, 100 deep.
- Streams (measurements, commands, setpoints) use reliable, volatile, depth 100.

A pass's tool path and strut trajectory are handed over whole, latched (DESIGN.md 4.1), at
most ``MAX_PATH_SAMPLES`` samples (1000 s at the 5 ms control period).
"""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from hex_control.grinding.contour import MAX_CONTOUR_POINTS, Contour
from hex_control.grinding.part_quality import PartQuality
from hex_control.plant.strut_trajectory import StrutTrajectory
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import PartQuality as PartQualityMsg
from hex_control_msgs.msg import ToolPath

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
RESULTS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: the plant's batched state: kept ten sim seconds (100 batches), so that an observer whose
#: executor is busy for a while (recording, under load) still sees every period
TELEMETRY = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
STREAM = 100
MAX_PATH_SAMPLES = 200_000
#: a contour's length at most (its points: grinding.contour.MAX_CONTOUR_POINTS): planning a
#: pass costs time in proportion to the length
MAX_CONTOUR_LENGTH_MM = 2_000.0
#: a contour's heights and parent at most this far from the bead frame (a bead stands a few
#: mm): a contour of 1e300 mm made the final contour's search loop for ever, and of 1e307 mm
#: an infinite plan
MAX_CONTOUR_HEIGHT_MM = 1_000.0
PATH_FIELDS = ("x_mm", "y_mm", "z_mm", "roll_rad", "pitch_rad", "yaw_rad")


def stamp_s(stamp) -> float:
    """A header stamp in s. Unlike rclpy's Time.from_msg it does not raise on a negative
    stamp: the caller decides what a bad one means."""
    return stamp.sec + stamp.nanosec * 1e-9


def time_msg(seconds: float) -> TimeMsg:
    """A stamp on the nanosecond grid (seconds >= 0)."""
    ns = round(seconds * 1e9)
    return TimeMsg(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def contour_from_message(msg: ContourMsg) -> Contour:
    """The contour; ValueError if malformed or beyond MAX_CONTOUR_POINTS, MAX_CONTOUR_LENGTH_MM or
    MAX_CONTOUR_HEIGHT_MM."""
    if len(msg.x_mm) > MAX_CONTOUR_POINTS:
        raise ValueError(f"{len(msg.x_mm)} points exceed the limit of {MAX_CONTOUR_POINTS}")
    if len(msg.x_mm) >= 2 and not abs(msg.x_mm[-1] - msg.x_mm[0]) <= MAX_CONTOUR_LENGTH_MM:
        raise ValueError(f"a length of {msg.x_mm[-1] - msg.x_mm[0]:g} mm exceeds the limit of "
                         f"{MAX_CONTOUR_LENGTH_MM:g} mm")
    for name in ("z_mm", "parent_mm"):
        values = getattr(msg, name)
        if len(values) and not float(np.max(np.abs(values))) <= MAX_CONTOUR_HEIGHT_MM:
            raise ValueError(f"{name} beyond +-{MAX_CONTOUR_HEIGHT_MM:g} mm of the bead frame")
    parent = list(msg.parent_mm) or None
    return Contour(np.asarray(msg.x_mm, float), np.asarray(msg.z_mm, float),
                   None if parent is None else np.asarray(parent, float))


def contour_to_message(contour: Contour, job_id: str, pass_index: int, width_mm: float) -> ContourMsg:
    return ContourMsg(job_id=job_id, pass_index=pass_index, bead_width_mm=float(width_mm),
                      x_mm=contour.x_mm.tolist(), z_mm=contour.z_mm.tolist(), parent_mm=contour.parent_mm.tolist())


def part_quality_message(quality: PartQuality | None, end_zone_mm: float) -> PartQualityMsg:
    """The figures of one scan; all NaN for ``None`` (nothing scanned)."""
    fields = PartQualityMsg.get_fields_and_field_types()
    values = dict.fromkeys(fields, float("nan")) if quality is None else quality.as_dict()
    return PartQualityMsg(**{name: float(values[name]) for name in fields if name != "end_zone_mm"},
                          end_zone_mm=float(end_zone_mm))


def tool_path_rows(msg: ToolPath) -> np.ndarray:
    """The path's poses (n, 6): x, y, z mm, roll, pitch, yaw rad; ValueError if malformed."""
    columns = [getattr(msg, name) for name in PATH_FIELDS]
    n = len(columns[0])
    if not 2 <= n <= MAX_PATH_SAMPLES or any(len(c) != n for c in columns):
        raise ValueError(f"need 2 to {MAX_PATH_SAMPLES} samples in each of {', '.join(PATH_FIELDS)}, "
                         f"got {[len(c) for c in columns]}")
    if not (np.isfinite(msg.sample_period_s) and 1e-4 <= msg.sample_period_s <= 1.0):
        raise ValueError(f"sample_period_s must be 0.1 ms to 1 s, got {msg.sample_period_s!r}")
    if msg.header.stamp.sec < 0:
        raise ValueError("negative start stamp")
    rows = np.column_stack([np.asarray(c, float) for c in columns])
    if not np.all(np.isfinite(rows)):
        raise ValueError("non-finite path sample")
    return rows


def tool_path_message(stamp: TimeMsg, job_id: str, pass_index: int, period_s: float, rows: np.ndarray) -> ToolPath:
    """The poses ``rows`` (n, 6: x, y, z mm, roll, pitch, yaw rad) every ``period_s`` from ``stamp``."""
    msg = ToolPath(job_id=job_id, pass_index=pass_index, sample_period_s=float(period_s))
    msg.header.stamp, msg.header.frame_id = stamp, "machine"
    for k, name in enumerate(PATH_FIELDS):
        setattr(msg, name, rows[:, k].tolist())
    return msg


def joint_trajectory_message(stamp: TimeMsg, names: list[str], period_s: float,
                             positions: np.ndarray) -> JointTrajectory:
    """Positions (n, joints) every ``period_s`` from ``stamp``."""
    ns = np.round(np.arange(len(positions)) * period_s * 1e9).astype(np.int64)
    msg = JointTrajectory(joint_names=list(names))
    msg.header.stamp, msg.header.frame_id = stamp, "base"
    msg.points = [JointTrajectoryPoint(positions=row, time_from_start=DurationMsg(sec=int(t // 1_000_000_000),
                                                                                   nanosec=int(t % 1_000_000_000)))
                  for row, t in zip(positions.tolist(), ns.tolist())]
    return msg


def strut_trajectory_from_message(msg: JointTrajectory, names: list[str]) -> StrutTrajectory:
    """The plant's StrutTrajectory (columns in ``names`` order, which the message may list in
    any order); ValueError if malformed."""
    if sorted(msg.joint_names) != sorted(names):
        raise ValueError(f"joint names {list(msg.joint_names)} are not the machine's {names}")
    if not 1 <= len(msg.points) <= MAX_PATH_SAMPLES:
        raise ValueError(f"need 1 to {MAX_PATH_SAMPLES} points, got {len(msg.points)}")
    if msg.header.stamp.sec < 0:
        raise ValueError("negative start stamp")
    if any(len(p.positions) != len(names) for p in msg.points):
        raise ValueError(f"every point needs {len(names)} positions")
    order = [list(msg.joint_names).index(name) for name in names]
    positions = np.array([p.positions for p in msg.points], float)[:, order]
    times = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in msg.points], float)
    return StrutTrajectory(stamp_s(msg.header.stamp), times, positions)
