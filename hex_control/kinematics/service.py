"""What the kinematics node does, without ROS (issue 38): inverse kinematics and TestPose
of many poses, forward kinematics, the workspace, a pass's tool path to strut lengths, and
the checks of a jogging setpoint.

Plain in, plain out. A pose is a row (x, y, z mm, roll, pitch, yaw rad); joint positions
are mm. Each answer carries ``outcome``, the name of the KinematicsErrorCode constant the
node sends (``SUCCESS``, ``INVALID_INPUT``, ...), and the ``reason`` a request was refused.
The relays (tool path, setpoint) answer with the joint positions to send or None, the
diagnostics counter to add and, if refused, why.

Every request is bounded before any work (issue 37 item 6): at most ``max_poses`` poses
(:func:`KinematicsCore.pose_count_refusal`, which the node asks before it converts a
request's poses), ``MAX_SLICES`` slice heights and ``MAX_SECTORS`` sectors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.config import config_file
from hex_control.kinematics.machine_kind import ConstraintCheck, MachineKind
from hex_control.kinematics.rotation import rpy_from_quaternion
from hex_control.kinematics.stewart import ForwardKinematicsError
from hex_control.kinematics.workspace import compute_workspace, cross_section

#: poses per IK / TestPose request. Measured on this 2-core machine near idle (kinematics
#: node, NIST hexapod, request and answer through rclpy): 40,000-50,000 poses/s end to end
#: (the vectorized IK alone: 300,000-500,000 poses/s; the rest is message conversion), so
#: 25,000 poses cost 0.5-0.65 s a round trip, inside the 1 s a request may cost, and above
#: the 20,001 poses of the pass planner's TestPose of its longest path (200,000 samples,
#: one in ten and the last).
MAX_POSES = 25_000
MAX_SECTORS = 50_000
MAX_SLICES = 100  # slice heights per workspace request: about 30 ms each here
DEFAULT_SECTORS = 1250  # a workspace request's 0 = this many sectors
DEFAULT_RESOLUTION_MM = 1.0  # and its 0 resolution


@dataclass(frozen=True)
class KinematicsSettings:
    """The kinematics node's parameters (their descriptions are the node's)."""

    machine_file: str = str(config_file("machines/nist_ingersoll.yaml"))
    quaternion_tolerance: float = 1e-3  # |1 - |q|| above which a setpoint orientation is malformed
    max_poses: int = MAX_POSES
    setpoint_owner: str = "input_shaper"  # relative node names, resolved in the node's namespace
    tool_path_owner: str = "input_shaper"


@dataclass(frozen=True)
class PoseAnswer:
    """IK / TestPose of n poses: the machine's constraint check of each (None if refused)
    and the index of the first unreachable pose (-1: none)."""

    outcome: str
    check: ConstraintCheck | None = None
    first_unreachable: int = -1
    reason: str = ""


@dataclass(frozen=True)
class ForwardAnswer:
    outcome: str
    pose: np.ndarray | None = None  # (6,) mm, rad
    iterations: int = 0
    residual_mm: float = 0.0
    reason: str = ""


@dataclass(frozen=True)
class WorkspaceAnswer:
    outcome: str
    volume_mm3: float = 0.0
    center_pose: np.ndarray | None = None  # (6,): the centre found, at the requested orientation
    boundary_mm: np.ndarray | None = None  # (sectors, 3)
    limiting_constraint: tuple[str, ...] = ()  # per boundary point: "I" .. "IV" or ""
    slice_area_mm2: tuple[float, ...] = ()
    reason: str = ""


@dataclass(frozen=True)
class Relay:
    """A relay's verdict: joint positions to send (mm; None = nothing), the counter to add."""

    positions_mm: np.ndarray | None
    counter: str
    reason: str = ""


class KinematicsCore:
    """The kinematics node's requests and relays on one machine (``load_machine``'s pair)."""

    def __init__(self, machine: MachineKind, document: dict, settings: KinematicsSettings = KinematicsSettings()):
        if settings.max_poses < 1 or not settings.quaternion_tolerance > 0:
            raise ValueError(f"max_poses {settings.max_poses} must be >= 1 and quaternion_tolerance "
                             f"{settings.quaternion_tolerance} > 0")
        self.machine, self.document, self.settings = machine, document, settings
        self.joint_names = list(machine.joint_names)
        self.strut_count = len(self.joint_names)

    # -- many poses ---------------------------------------------------------------------------
    def pose_count_refusal(self, count: int) -> str:
        """Why a request of ``count`` poses is refused ('' = it is not): asked before the
        poses are converted, so an oversized request costs nothing more."""
        if count > self.settings.max_poses:
            return f"{count} poses exceed the limit of {self.settings.max_poses} per request"
        return ""

    def _checked(self, rows) -> tuple[ConstraintCheck | None, str]:
        rows = np.asarray(rows, float)
        refusal = self.pose_count_refusal(len(rows))
        if refusal:
            return None, refusal
        rows = rows.reshape(-1, 6)
        if not np.all(np.isfinite(rows)):
            return None, "non-finite pose field"
        if not len(rows):  # the machines' checks want at least one pose
            return ConstraintCheck(np.zeros((0, self.strut_count)), np.zeros((0, 4), bool), np.zeros((0, 4))), ""
        return self.machine.constraint_check(rows), ""

    def inverse(self, rows) -> PoseAnswer:
        """IK of n poses (n, 6): SUCCESS even when some are unreachable (read the check)."""
        check, reason = self._checked(rows)
        if check is None:
            return PoseAnswer("INVALID_INPUT", reason=reason)
        return PoseAnswer("SUCCESS", check, _first(check.reachable))

    def test_pose(self, rows) -> PoseAnswer:
        """TestPose: SUCCESS if every pose is reachable, UNREACHABLE otherwise."""
        answer = self.inverse(rows)
        if answer.outcome == "SUCCESS" and answer.first_unreachable >= 0:
            return PoseAnswer("UNREACHABLE", answer.check, answer.first_unreachable)
        return answer

    # -- one pose from joint positions ---------------------------------------------------------
    def forward(self, positions_mm, guess, tolerance_mm: float = 0.0, max_iterations: int = 0) -> ForwardAnswer:
        """The pose these joint positions (mm) hold, solved from ``guess`` (6,) (all zeros:
        the machine's own start); 0 tolerance / iterations = 1e-9 mm / 50."""
        lengths, guess = np.asarray(positions_mm, float), np.asarray(guess, float)
        if (lengths.shape != (self.strut_count,) or guess.shape != (6,) or not np.all(np.isfinite(lengths))
                or not np.all(np.isfinite(guess)) or not tolerance_mm >= 0 or max_iterations < 0):
            return ForwardAnswer("INVALID_INPUT", reason=f"need {self.strut_count} finite joint positions, a finite "
                                                         f"guess and a tolerance >= 0")
        try:
            pose, used, residual = self.machine.forward_pose(lengths, guess, tolerance_mm or 1e-9,
                                                             max_iterations or 50)
        except ForwardKinematicsError as exc:
            return ForwardAnswer("SINGULAR" if exc.reason == "singular" else "NO_CONVERGENCE", reason=str(exc))
        except ValueError as exc:
            return ForwardAnswer("SINGULAR" if "singular" in str(exc) else "NO_CONVERGENCE", reason=str(exc))
        return ForwardAnswer("SUCCESS", np.asarray(pose, float), int(used), float(residual))

    # -- the workspace at one orientation ------------------------------------------------------
    def workspace(self, orientation_rad, slice_heights_mm=(), sector_count: int = 0,
                  resolution_mm: float = 0.0) -> WorkspaceAnswer:
        """Volume, boundary and slice areas at ``orientation_rad`` (roll, pitch, yaw);
        0 sectors / resolution = ``DEFAULT_SECTORS`` / ``DEFAULT_RESOLUTION_MM``."""
        if not self.machine.maps_workspace:
            return WorkspaceAnswer("UNSUPPORTED_MACHINE", reason="this machine kind has no 6-DOF workspace")
        orientation = np.asarray(orientation_rad, float)
        heights = np.asarray(slice_heights_mm, float).reshape(-1)
        sectors, eps = sector_count or DEFAULT_SECTORS, resolution_mm or DEFAULT_RESOLUTION_MM
        if (orientation.shape != (3,) or not np.all(np.isfinite(orientation)) or not np.all(np.isfinite(heights))
                or heights.size > MAX_SLICES or not 18 <= sectors <= MAX_SECTORS or not (0.01 <= eps <= 100.0)
                or np.any(np.abs(orientation) > math.pi)):
            return WorkspaceAnswer("INVALID_INPUT", reason=f"need a finite orientation within pi, at most "
                                   f"{MAX_SLICES} finite heights, 18 to {MAX_SECTORS} sectors, 0.01 to 100 mm")
        n_phi = max(3, round(math.sqrt(sectors / 2)))
        cube = self.document.get("workspace", {}).get("search_cube_mm")
        if cube is None:
            cube = [(c - 1000.0, c + 1000.0) for c in self.machine.home_pose[:3]]
        try:
            result = compute_workspace(self.machine, orientation, cube, 2 * n_phi, n_phi, eps_mm=eps)
        except ValueError as exc:  # e.g. nothing reachable at this orientation
            return WorkspaceAnswer("UNREACHABLE", reason=str(exc))
        areas = tuple(cross_section(self.machine, orientation, z, result.center_mm[:2], 180,
                                    eps_mm=eps)[0] for z in heights)
        sets = self.machine.constraint_sets
        return WorkspaceAnswer("SUCCESS", result.volume_mm3, np.concatenate([result.center_mm, orientation]),
                               result.boundary_mm.reshape(-1, 3),
                               tuple(sets[s] if s >= 0 else "" for s in result.limiting_set.ravel()), areas)

    # -- relays to the plant ------------------------------------------------------------------
    def strut_trajectory(self, rows) -> Relay:
        """A pass's whole tool path (n, 6) as joint positions (n, joints) mm, by one
        vectorized IK call; refused whole if one pose is out of reach (DESIGN.md 4.1)."""
        rows = np.asarray(rows, float)
        if rows.ndim != 2 or rows.shape[1] != 6 or not np.all(np.isfinite(rows)):
            return Relay(None, "rejected_paths", f"need finite poses (n, 6), got shape {rows.shape}")
        positions_mm, reachable = self.machine.joint_positions_mm(rows)
        if not reachable.all():
            k = int(np.flatnonzero(~reachable)[0])
            return Relay(None, "refused_unreachable_paths", f"sample {k} {rows[k].round(3).tolist()} is out of reach")
        return Relay(positions_mm, "paths")

    def setpoint(self, position_m, quaternion_xyzw) -> Relay:
        """A jogging setpoint (position m, orientation as a unit quaternion, REP 103) as one
        strut command (joints,) mm; refused if malformed or out of reach."""
        values = np.concatenate([np.asarray(position_m, float).reshape(-1), np.asarray(quaternion_xyzw, float)])
        if (values.shape != (7,) or not np.all(np.isfinite(values))
                or abs(1.0 - np.linalg.norm(values[3:])) > self.settings.quaternion_tolerance):
            return Relay(None, "rejected_malformed", "malformed setpoint refused (non-finite or non-unit quaternion)")
        with np.errstate(over="ignore"):
            row = np.concatenate([values[:3] * 1000.0, rpy_from_quaternion(*values[3:])])
        if not np.all(np.isfinite(row)):  # finite in m, not in mm (1e306 m)
            return Relay(None, "rejected_malformed", "setpoint beyond any range in mm")
        check = self.machine.constraint_check(row[None])
        if not check.reachable[0]:
            return Relay(None, "refused_unreachable", f"unreachable setpoint refused: {row.round(3).tolist()}")
        return Relay(check.positions_mm[0], "commands")


def _first(flags: np.ndarray) -> int:
    """Index of the first False in ``flags``, or -1."""
    bad = np.flatnonzero(~np.asarray(flags, bool))
    return int(bad[0]) if bad.size else -1

