"""Where the machine holds the grinder: forward kinematics of the actual strut lengths, in
the bead's plane (DESIGN.md section 4, plant). The structural mode's deflection moves the
tool along the bead's normal, so a ringing machine grinds a ringing surface.

Units: strut lengths in m (as on /plant/strut_states), positions in mm.
"""

from __future__ import annotations

import numpy as np

from hex_control.grinding.tool_path import BeadFrame
from hex_control.kinematics.machine_kind import MachineKind


class ToolLocator:
    """``centre_mm(lengths_m, deflection_mm)`` -> (x along the bead, H above it), warm-
    started from the previous pose (the machine moves little in one control period)."""

    def __init__(self, machine: MachineKind, frame: BeadFrame):
        self.machine, self.frame = machine, frame
        self.tracker = machine.tool_tracker()

    def position_mm(self, lengths_m) -> np.ndarray:
        return self.tracker.tool_position_mm(np.asarray(lengths_m, float) * 1000.0)

    def centre_mm(self, lengths_m, deflection_mm: float = 0.0) -> tuple[float, float]:
        offset = self.position_mm(lengths_m) - np.asarray(self.frame.origin_mm)
        return float(offset @ np.asarray(self.frame.along)), float(offset @ np.asarray(self.frame.up)) + deflection_mm
