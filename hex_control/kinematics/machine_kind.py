"""What every machine kind answers (issue 22): the nodes, the plant, the tool locator and
the reset-time measurement ask a machine these and never its type. A new kind is one
module with a geometry class that has them, its entry in ``MACHINE_TYPES``
(:mod:`hex_control.kinematics`) and a machine YAML; the plant moves its joints with the
drive it names (:mod:`hex_control.plant.drives`). Outside the machine modules no code
switches on a kind's class or name (test/test_machine_kinds.py scans for it).

Units: mm and rad; joint positions in mm (lengths, slider and stage positions).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

#: the names of the four constraint sets of a ConstraintCheck's columns (seed 000 part 1,
#: 4.1): joint strokes, platform joints, base joints, strut distances
CONSTRAINT_SETS = ("I", "II", "III", "IV")


@dataclass(frozen=True)
class ConstraintCheck:
    """Inverse kinematics of n tool poses and the machine's constraints, as TestPose reports
    them (seed 000 part 1, 4.1): four sets -- joint strokes, platform joints, base joints,
    strut distances -- each with a margin (limit minus value, positive inside: mm, rad,
    rad, mm). A set a machine does not have holds with an infinite margin."""

    positions_mm: np.ndarray  # (n, joints)
    satisfied: np.ndarray  # (n, 4) bool
    margins: np.ndarray  # (n, 4)
    platform_joint_angles_rad: np.ndarray | None = None  # (n, joints), where the machine has them
    base_joint_angles_rad: np.ndarray | None = None

    @property
    def reachable(self) -> np.ndarray:
        return self.satisfied.all(axis=1)


class JointPositionsFromConstraints:
    """``joint_positions_mm`` as the kinds give it: their ``constraint_check``'s positions and
    reachability, so that the two never disagree."""

    def joint_positions_mm(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """(joint positions (n, joints) mm, reachable (n,)) of n poses (x, y, z mm, roll,
        pitch, yaw rad)."""
        check = self.constraint_check(poses)
        return check.positions_mm, check.reachable


class ToolTracker(Protocol):
    def tool_position_mm(self, positions_mm) -> np.ndarray:
        """The tool point (3,) mm where these joint positions hold it, solved from the last."""


class MachineKind(Protocol):
    name: str
    plant_drive: str  # the drive that moves its joints in the plant (hex_control.plant.drives.PLANT_DRIVES)
    maps_workspace: bool  # whether the workspace search (seed 000, a 6-DOF TestPose) applies
    constraint_sets: tuple[str, ...]  # names of ConstraintCheck's columns (CONSTRAINT_SETS)

    @property
    def home_pose(self) -> np.ndarray:
        """The machine's start: a tool pose (6,) (x, y, z mm, roll, pitch, yaw rad)."""

    @property
    def joint_names(self) -> list[str]: ...

    @property
    def joint_speed_max_mm_s(self) -> np.ndarray: ...

    @property
    def joint_acceleration_max_mm_s2(self) -> np.ndarray: ...

    def joint_positions_mm(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """(joint positions (n, joints) mm, reachable (n,)) of n poses (x, y, z mm, roll,
        pitch, yaw rad)."""

    def constraint_check(self, poses) -> ConstraintCheck: ...

    def check_joint_positions_mm(self, positions_mm) -> None:
        """Raise ValueError unless these joint positions are within the machine's limits."""

    def check_joint_trajectory_mm(self, positions_mm) -> None:
        """:meth:`check_joint_positions_mm` of every row (n, joints) at once (a pass's whole
        trajectory); the ValueError names the first row out of limits."""

    def forward_pose(self, positions_mm, guess, tolerance_mm: float,
                     max_iterations: int) -> tuple[np.ndarray, int, float]:
        """(tool pose (6,), iterations, residual mm) whose joints are at ``positions_mm``,
        solved from ``guess`` (a pose; all zeros: the machine's own start)."""

    def tool_tracker(self) -> ToolTracker: ...
