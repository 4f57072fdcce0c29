"""When a pass begins and ends on the plant, and what is reported about it (DESIGN.md
section 4, plant: the profile scanner, burn and stall, faults).

A pass is announced by its force trajectory: the grinding phase and the whole tool path
(approach to the end of the reset move) in plant time. It begins when its path begins. It
ends when the path is over *and* the machine has settled after the reset move (structural
deflection and strut speeds below their limits, or ``max_settle_s`` later): the measured
duration therefore includes the real settle time of the reset move, which is what the
sequence planner's t_R should be. Then the cell is scanned and the pass reported.

A pass is ABORTED when the force commands stop for longer than ``command_timeout_s`` while
the disk should be grinding (the controller died or its watchdog retracted the table): its
removal is still what the scan measured, so the planner continues from the real state.

Units: s, mm, m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.plant.grinding_cell import GrindingCell, PassMeasurement


@dataclass(frozen=True)
class ScheduledPass:
    job_id: str
    pass_index: int
    path_start_s: float  # plant time of the path's first sample
    grind_start_s: float
    grind_end_s: float
    path_end_s: float  # last sample of the reset move

    def __post_init__(self):
        times = (self.path_start_s, self.grind_start_s, self.grind_end_s, self.path_end_s)
        if not (all(math.isfinite(t) for t in times) and list(times) == sorted(times)):
            raise ValueError(f"pass times must be finite and in order, got {times}")


@dataclass(frozen=True)
class PassReport:
    measurement: PassMeasurement
    aborted: bool
    reason: str
    start_s: float
    end_s: float  # when the machine had settled

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


class PassMonitor:
    def __init__(self, cell: GrindingCell, settle_deflection_mm: float = 0.01, settle_speed_m_s: float = 1e-5,
                 max_settle_s: float = 10.0, command_timeout_s: float = 0.1):
        self.cell = cell
        self.settle_deflection_mm, self.settle_speed_m_s = settle_deflection_mm, settle_speed_m_s
        self.max_settle_s, self.command_timeout_s = max_settle_s, command_timeout_s
        self.scheduled: ScheduledPass | None = None
        self.running: ScheduledPass | None = None
        self.lost_commands_s = 0.0
        self.reported: set[tuple[str, int]] = set()

    def schedule(self, scheduled: ScheduledPass) -> bool:
        """Take a pass announcement; False for one already running or reported (a latched
        re-delivery) or while another pass runs."""
        key = (scheduled.job_id, scheduled.pass_index)
        if key in self.reported or self.running is not None and (self.running.job_id, self.running.pass_index) == key:
            return False
        if self.running is not None:
            raise ValueError(f"pass {key} announced while pass {self.running.pass_index} of "
                             f"{self.running.job_id!r} is still running")
        self.scheduled = scheduled
        return True

    def on_period(self, time_s: float, deflection_mm: float, strut_speeds_m_s, command_age_s: float):
        """Call after every control period; returns a PassReport when a pass has ended."""
        if self.scheduled is not None and time_s >= self.scheduled.path_start_s:
            self.running, self.scheduled = self.scheduled, None
            self.cell.start_pass(self.running.job_id, self.running.pass_index)
            self.lost_commands_s = 0.0
        p = self.running
        if p is None:
            return None
        if p.grind_start_s <= time_s <= p.grind_end_s and command_age_s > self.command_timeout_s:
            self.lost_commands_s = max(self.lost_commands_s, command_age_s)
        if time_s < p.path_end_s:
            return None
        speeds = np.abs(np.asarray(strut_speeds_m_s if strut_speeds_m_s is not None else [0.0], float))
        settled = abs(deflection_mm) <= self.settle_deflection_mm and speeds.max() <= self.settle_speed_m_s
        if not settled and time_s < p.path_end_s + self.max_settle_s:
            return None
        self.running = None
        self.reported.add((p.job_id, p.pass_index))
        aborted = self.lost_commands_s > 0
        reason = f"force commands lost for {self.lost_commands_s:.2f} s while grinding" if aborted else ""
        if not settled:
            reason = (reason + "; " if reason else "") + f"machine not settled {self.max_settle_s:g} s after the reset"
        return PassReport(self.cell.finish_pass(), aborted, reason, p.path_start_s, time_s)
