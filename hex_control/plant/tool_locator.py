"""Where the machine holds the grinder: forward kinematics of the actual strut lengths, in
the bead's plane (DESIGN.md section 4, plant). The structural mode's deflection moves the
tool along the bead's normal, so a ringing machine grinds a ringing surface.

Units: strut lengths in m (as on /plant/strut_states), positions in mm.
"""

from __future__ import annotations

import numpy as np

from hex_control.grinding.tool_path import BeadFrame
from hex_control.kinematics import Pru3Geometry, StewartGeometry
from hex_control.kinematics import pru3 as pru3_kinematics
from hex_control.kinematics.stewart import TrackingForwardKinematics


class ToolLocator:
    """``centre_mm(lengths_m, deflection_mm)`` -> (x along the bead, H above it), warm-
    started from the previous pose (the machine moves little in one control period)."""

    def __init__(self, machine: StewartGeometry | Pru3Geometry, frame: BeadFrame):
        self.machine, self.frame = machine, frame
        self.is_pru3 = isinstance(machine, Pru3Geometry)
        if self.is_pru3:
            self.guess = np.asarray((200.0, 0.0, 0.0), float)
        else:
            self.forward = TrackingForwardKinematics(machine)

    def position_mm(self, lengths_m) -> np.ndarray:
        lengths_mm = np.asarray(lengths_m, float) * 1000.0
        if self.is_pru3:  # sliders, then the feed stage if any
            q, _ = pru3_kinematics.forward_kinematics(self.machine, lengths_mm[:3], self.guess, tolerance_mm=1e-7)
            self.guess = q
            pose = pru3_kinematics.inverse_kinematics(self.machine, q)
            return pru3_kinematics.tool_positions_mm(pose, lengths_mm[3] if len(lengths_mm) > 3 else 0.0)[0]
        return self.forward.solve(lengths_mm)[:3]

    def centre_mm(self, lengths_m, deflection_mm: float = 0.0) -> tuple[float, float]:
        offset = self.position_mm(lengths_m) - np.asarray(self.frame.origin_mm)
        return float(offset @ np.asarray(self.frame.along)), float(offset @ np.asarray(self.frame.up)) + deflection_mm
