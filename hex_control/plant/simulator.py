"""The simulated hardware as one object: the force table (with the grinder's compliance,
runout and sensor), the machine's struts and, when given, the workpiece being ground
(``GrindingCell``, placed by a ``ToolLocator``), advanced together one control period at a
time at a fixed internal step; strut commands reach the servos through the machine's speed
and acceleration limits, when given. The cell grinds once per period with the tool where the
struts (and the structural mode) put it, and tells the table where the work surface is.
Units: mm and N for the force axis, m for struts, s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hex_control.plant.force_table import ForceTable, ForceTableParameters
from hex_control.plant.grinding_cell import GrindingCell
from hex_control.plant.limits import StrutRateLimiter
from hex_control.plant.machine import Machine, MachineParameters
from hex_control.plant.pru3_machine import Pru3Machine
from hex_control.plant.tool_locator import ToolLocator


@dataclass(frozen=True)
class PlantSnapshot:
    time_s: float
    force_n: float  # true normal force
    measured_force_n: float  # what the force sensor reports
    table_position_mm: float
    table_command_mm: float  # the force-axis command held over the period that ended here
    disk_frequency_hz: float
    strut_lengths_m: np.ndarray | None  # None until the first strut command
    strut_speeds_m_s: np.ndarray | None
    deflection_mm: float
    centre_mm: tuple[float, float] | None  # disk centre (x, H) in the bead frame, with a cell


class PlantSimulator:
    def __init__(self, table: ForceTableParameters = ForceTableParameters(),
                 machine: MachineParameters | Machine | Pru3Machine = MachineParameters(),
                 step_s: float = 1e-3, seed: int = 0, *, table_start_mm: float = -1.0, cell: GrindingCell | None = None,
                 locator: ToolLocator | None = None, strut_limiter: StrutRateLimiter | None = None):
        if (cell is None) != (locator is None):
            raise ValueError("a grinding cell needs a tool locator, and the other way round")
        self.step_s = step_s
        self.table = ForceTable(table, step_s=step_s, seed=seed)
        self.table.reset(table_start_mm)
        # parameters: the generic strut servos; a built machine (e.g. the 3-PRU head) as is
        self.machine = Machine(machine, step_s=step_s) if isinstance(machine, MachineParameters) else machine
        if self.machine.step_s != step_s:
            raise ValueError("the machine must step at the plant's internal step")
        self._machine_ready = False
        self.force_command_mm = table_start_mm
        self.strut_commands_m = None  # the struts' targets; the servos get them through the limiter
        self.strut_limiter = strut_limiter
        self.time_s = 0.0
        self.cell, self.locator = cell, locator
        self.centre_mm = None
        if cell is not None:
            self.table.surface_mm = math.inf  # nothing to touch until the tool is placed

    def command_struts(self, lengths_m) -> None:
        """Hold these strut commands; the first ever also places the struts there (at rest)."""
        lengths = np.asarray(lengths_m, float).reshape(-1)
        if lengths.shape != (self.machine.p.struts,) or not np.all(np.isfinite(lengths)):
            raise ValueError(f"need {self.machine.p.struts} finite strut lengths (m)")
        if not self._machine_ready:
            self.machine.reset(lengths)
            if self.strut_limiter is not None:
                self.strut_limiter.reset(lengths)
            self._machine_ready = True
        self.strut_commands_m = lengths

    def advance(self, duration_s: float, force_command_mm: float,
                measured: Callable[[float, float], None] | None = None) -> PlantSnapshot:
        """Hold the force-axis command for ``duration_s`` (a whole number of internal steps).
        ``measured(time_s, measured_force_n)`` is called as soon as the force table has
        stepped, before the machine and the workpiece are: the sensor's reading at the
        period's end does not depend on them (the table sees the work surface the last
        period left), so a controller can compute its answer meanwhile."""
        steps = round(duration_s / self.step_s)
        if steps < 1 or abs(steps * self.step_s - duration_s) > 1e-9:
            raise ValueError("duration must be a whole number of internal steps")
        self.force_command_mm = force_command_mm
        struts = self.strut_commands_m
        if self._machine_ready and self.strut_limiter is not None:
            struts = self.strut_limiter.command(struts, duration_s)
        # the table and the machine do not touch within a period: each runs its steps at once
        self.table.advance(force_command_mm, steps)
        self.time_s += steps * self.step_s
        if measured is not None:
            measured(self.time_s, self.table.measured_n)
        if self._machine_ready:
            self.machine.advance(struts, steps)
        if self.cell is not None and self._machine_ready:
            self.centre_mm = self.locator.centre_mm(self.machine.lengths_m, self.machine.deflection_mm)
            self.table.surface_mm = self.cell.advance(duration_s, self.centre_mm, self.table.position_mm)
        return self.snapshot()

    def snapshot(self) -> PlantSnapshot:
        ready = self._machine_ready
        return PlantSnapshot(self.time_s, self.table.force_n, self.table.measured_n, self.table.position_mm,
                             self.force_command_mm, self.table.disk_frequency_hz,
                             self.machine.lengths_m if ready else None, self.machine.speeds_m_s if ready else None,
                             self.machine.deflection_mm, self.centre_mm)
