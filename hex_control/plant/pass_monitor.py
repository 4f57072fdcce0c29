"""When a pass begins and ends on the plant, and what is reported about it (DESIGN.md
section 4, plant: the profile scanner, burn and stall, faults).

A pass is announced by its force trajectory: the grinding phase and the whole tool path
(approach to the end of the reset move) in plant time, and the plan (:class:`PassPlan`:
planned depth, desired force, tool position). It begins when its path begins. It ends when
the path is over *and* the machine has settled after the reset move (structural deflection
and strut speeds below their limits, or ``max_settle_s`` later): the measured duration
therefore includes the real settle time of the reset move, which is what the sequence
planner's t_R should be. Then the cell is scanned and the pass reported.

A pass is ABORTED when the force commands stop for longer than ``command_timeout_s`` while
the disk should be grinding (the controller died or its watchdog retracted the table): its
removal is still what the scan measured, so the planner continues from the real state.
Otherwise it is FAULTED when it was not ground as planned (:mod:`hex_control.plant.pass_verdict`:
force trajectory not followed, cut short, removal off the plan beyond the drawn variation,
run across a plant restart), and COMPLETED only when none of that holds.

Units: s, mm, m/s, N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hex_control.plant.grinding_cell import GrindingCell, PassMeasurement
from hex_control.plant.pass_verdict import PassPlan, PassTrace, judge_pass


@dataclass(frozen=True)
class ScheduledPass:
    job_id: str
    pass_index: int
    path_start_s: float  # plant time of the path's first sample
    grind_start_s: float
    grind_end_s: float
    path_end_s: float  # last sample of the reset move
    plan: PassPlan | None = field(default=None, compare=False)  # None: not judged against a plan

    def __post_init__(self):
        times = (self.path_start_s, self.grind_start_s, self.grind_end_s, self.path_end_s)
        if not (all(math.isfinite(t) for t in times) and list(times) == sorted(times)):
            raise ValueError(f"pass times must be finite and in order, got {times}")

    @classmethod
    def from_trajectory(cls, job_id: str, pass_index: int, *, grind_start_s: float, path_start_s: float,
                        path_end_s: float, time_s, force_n, x_mm, planned_cut_depth_mm: float) -> ScheduledPass:
        """A pass as its force trajectory announces it: the grinding phase starts at plant
        time ``grind_start_s``; path start and end and the samples' ``time_s`` count from it.
        ValueError for an empty or malformed trajectory or a negative stamp."""
        times = np.asarray(time_s, float).reshape(-1)
        if times.size == 0 or not grind_start_s >= 0:
            raise ValueError("empty trajectory or negative stamp")
        plan = PassPlan(planned_cut_depth_mm, grind_start_s + times, force_n, x_mm)
        return cls(job_id, pass_index, grind_start_s + path_start_s, grind_start_s, grind_start_s + float(times[-1]),
                   grind_start_s + path_end_s, plan)


@dataclass(frozen=True)
class PassReport:
    measurement: PassMeasurement
    aborted: bool
    reason: str
    start_s: float
    end_s: float  # when the machine had settled
    faulted: bool = False  # ran, but not as planned (reason says how)

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    @property
    def status(self) -> str:
        return "aborted" if self.aborted else "faulted" if self.faulted else "completed"


class PassMonitor:
    """``interrupted``: (job id, pass index, path start s) of a pass the plant before a
    restart had started and never scanned; the same plan run again ran across the restart."""

    def __init__(self, cell: GrindingCell, settle_deflection_mm: float = 0.01, settle_speed_m_s: float = 1e-5,
                 max_settle_s: float = 10.0, *, command_timeout_s: float = 0.1,
                 interrupted: tuple[str, int, float] | None = None):
        self.cell = cell
        self.settle_deflection_mm, self.settle_speed_m_s = settle_deflection_mm, settle_speed_m_s
        self.max_settle_s, self.command_timeout_s = max_settle_s, command_timeout_s
        self.interrupted = interrupted
        self.scheduled: ScheduledPass | None = None
        self.running: ScheduledPass | None = None
        self.trace: PassTrace | None = None
        self.lost_commands_s = 0.0
        self.unsimulated_periods = 0  # of the running pass: the part was not ground there
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

    def period_unsimulated(self) -> None:
        """A control period whose simulation failed after its measurement (the tool beyond
        the forward kinematics): the running pass, if any, did not run as planned."""
        if self.running is not None:
            self.unsimulated_periods += 1

    def on_period(self, time_s: float, deflection_mm: float, strut_speeds_m_s, command_age_s: float,
                  *, force_n: float = math.nan, centre_x_mm: float = math.nan):
        """Call after every control period (true normal force N, disk centre mm along the
        bead); returns a PassReport when a pass has ended."""
        if self.scheduled is not None and time_s >= self.scheduled.path_start_s:
            self.running, self.scheduled = self.scheduled, None
            self.cell.start_pass(self.running.job_id, self.running.pass_index)
            self.lost_commands_s, self.unsimulated_periods = 0.0, 0
            plan = self.running.plan
            self.trace = PassTrace(plan, self.cell.control_period_s) if plan is not None else None
        p = self.running
        if p is None:
            return None
        if p.grind_start_s <= time_s <= p.grind_end_s and command_age_s > self.command_timeout_s:
            self.lost_commands_s = max(self.lost_commands_s, command_age_s)
        if self.trace is not None:
            self.trace.add(time_s, force_n, centre_x_mm)
        if time_s < p.path_end_s:
            return None
        speeds = np.abs(np.asarray(strut_speeds_m_s if strut_speeds_m_s is not None else [0.0], float))
        settled = abs(deflection_mm) <= self.settle_deflection_mm and speeds.max() <= self.settle_speed_m_s
        if not settled and time_s < p.path_end_s + self.max_settle_s:
            return None
        self.running = None
        self.reported.add((p.job_id, p.pass_index))
        measurement = self.cell.finish_pass()
        aborted = self.lost_commands_s > 0
        reasons = [f"force commands lost for {self.lost_commands_s:.2f} s while grinding"] if aborted else []
        if not settled:
            reasons.append(f"machine not settled {self.max_settle_s:g} s after the reset")
        if self.unsimulated_periods:
            reasons.append(f"{self.unsimulated_periods} control period(s) not simulated (the tool beyond the "
                           "forward kinematics)")
        restarted = self.interrupted == (p.job_id, p.pass_index, p.path_start_s)
        verdict = judge_pass(self.trace, measurement.measured_cut_depth_mm, measurement.expected_removal_factor,
                             restarted)
        self.trace = None
        return PassReport(measurement, aborted, "; ".join(reasons + list(verdict.reasons)), p.path_start_s, time_s,
                          verdict.faulted or self.unsimulated_periods > 0)
