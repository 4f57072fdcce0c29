"""The reset time t_R the sequence planner plans with, measured on the simulated machine
(DESIGN.md section 4: shaping the reset moves lets the machine settle sooner).

A pass's duration is L / V_f + t_R (seed 002 eq. 5.6). Everything in a pass's path that
is not grinding -- the approach, the retract, the reset move back and the time the
structure then needs to stop ringing -- is t_R. ``measure_reset_time`` runs one pass's path
(at constant height, the grinding phase at ``feed_mm_s``) through an optional input
shaper, the machine's inverse kinematics and the strut/structural-mode model, and measures
when the deflection has settled inside ``settle_mm`` for good.

Units: mm, s (strut lengths m inside the machine model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.grinding.tool_path import BeadFrame, PathTiming, pass_tool_path
from hex_control.kinematics.machine_kind import MachineKind
from hex_control.plant.drives import make_drive
from hex_control.plant.machine import MachineParameters
from hex_control.shaping.filter import ShaperFilter
from hex_control.shaping.shapers import Shaper


@dataclass(frozen=True)
class ResetTime:
    reset_time_s: float  # t_R: pass duration minus L / V_f
    path_s: float  # the commanded path, shaper delay included
    settle_s: float  # after the path's end until the deflection stays inside the band
    peak_deflection_mm: float  # after the path's end


def _lengths_m(machine, positions_mm: np.ndarray, orientation_rpy_rad) -> np.ndarray:
    poses = np.column_stack([positions_mm, np.tile(orientation_rpy_rad, (len(positions_mm), 1))])
    return machine.joint_positions_mm(poses)[0] / 1000.0


def pass_strut_lengths_m(machine: MachineKind, frame: BeadFrame, length_mm: float,
                         feed_mm_s: float, height_mm: float, *, timing: PathTiming = PathTiming(),
                         shaper: Shaper | None = None) -> np.ndarray:
    """The strut (or slider and feed) commands (m), one row per path sample, of one pass's
    path at constant height: approach, grinding at ``feed_mm_s``, retract and reset, through
    ``shaper`` if given (its delay appended, holding the end)."""
    if not (length_mm > 0 and feed_mm_s > 0):
        raise ValueError("need a positive length and feed")
    grind_t = np.linspace(0.0, length_mm / feed_mm_s, 101)
    path = pass_tool_path(frame, grind_t, np.linspace(0.0, length_mm, 101), np.full(101, height_mm), timing)
    positions = path.positions_mm
    if shaper is not None:
        shaping = ShaperFilter(shaper, timing.sample_period_s, channels=3)
        shaping.reset(positions[0])
        tail = round(shaping.delay_s / timing.sample_period_s)
        padded = np.vstack([positions, np.repeat(positions[-1:], tail, axis=0)])
        positions = np.array([shaping.step(p) for p in padded])
    rpy = np.radians(frame.orientation_rpy_deg)
    return _lengths_m(machine, positions, rpy)


def measure_reset_time(machine: MachineKind, frame: BeadFrame, length_mm: float,
                       feed_mm_s: float, height_mm: float, *, timing: PathTiming = PathTiming(),
                       parameters: MachineParameters = MachineParameters(), shaper: Shaper | None = None,
                       settle_mm: float = 0.01, step_s: float = 1e-3, max_settle_s: float = 30.0) -> ResetTime:
    if not settle_mm > 0:
        raise ValueError("need a positive settle band")
    lengths = pass_strut_lengths_m(machine, frame, length_mm, feed_mm_s, height_mm, timing=timing, shaper=shaper)
    end = lengths[-1]
    model = make_drive(machine, parameters, step_s, timing.sample_period_s)  # the plant's own model of it
    model.reset(lengths[0])
    per_sample = round(timing.sample_period_s / step_s)
    for row in lengths:
        for _ in range(per_sample):
            model.step(row)
    path_s = len(lengths) * timing.sample_period_s
    # a freely decaying mode whose peaks stayed inside the band for two periods stays inside
    deflection, last_outside, quiet_s = [], 0.0, 2.0 / parameters.mode_frequency_hz
    for k in range(round(max_settle_s / step_s)):
        model.step(end)
        deflection.append(model.deflection_mm)
        if abs(model.deflection_mm) > settle_mm:
            last_outside = (k + 1) * step_s
        elif (k + 1) * step_s - last_outside > quiet_s:
            break
    settle = last_outside
    return ResetTime(path_s + settle - length_mm / feed_mm_s, path_s, settle,
                     float(np.max(np.abs(deflection))) if deflection else 0.0)


def calibrate_reset_time(bead_length_mm: float, feed_mm_s: float = 20.0,
                         machine_file: str = "machines/nist_ingersoll.yaml") -> dict[str, ResetTime]:
    """t_R measured on the plant's machine model (``machine_file`` under config/), with the
    input shaper's default (ZVD at the structural mode) and without: what the sequence
    planner plans with. Keys "unshaped" and "zvd"; ``feed_mm_s`` the grinding phase's feed."""
    from hex_control.config import config_file, load_cell_configuration
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.kinematics import load_machine
    from hex_control.shaping.shapers import design

    parameters = MachineParameters(**load_cell_configuration(machine=config_file(machine_file)).structure)
    machine, document = load_machine(config_file(machine_file))
    config = load_pass_planner_config("pass_planner.yaml", document)
    height = config.model.radius_mm * np.sin(config.model.relaxed_angle_rad) + 1.0
    shaper = design("zvd", parameters.mode_frequency_hz, parameters.mode_damping)
    return {name: measure_reset_time(machine, config.frame, bead_length_mm, feed_mm_s, height, timing=config.path,
                                     parameters=parameters, shaper=s)
            for name, s in (("unshaped", None), ("zvd", shaper))}


def reset_time_lines(reset: dict, bead_length_mm: float, deadline_s: float) -> list[str]:
    """What :func:`calibrate_reset_time`'s ``reset`` means for a job: each t_R, and how many of
    the fastest passes (at the cell's ``process.feed_max_mm_s``) fit in ``deadline_s`` with and
    without the shaper."""
    from hex_control.config import cell_configuration

    lines = [f"reset time t_R ({name}): {r.reset_time_s:.2f} s (settle {r.settle_s:.2f} s after the path, "
             f"peak deflection {r.peak_deflection_mm:.3f} mm)" for name, r in reset.items()]
    shortest = bead_length_mm / cell_configuration().value("process.feed_max_mm_s")
    unshaped, shaped = reset["unshaped"].reset_time_s, reset["zvd"].reset_time_s
    lines.append(f"shaping buys {unshaped - shaped:.2f} s a pass: {int(deadline_s // (shortest + unshaped))} -> "
                 f"{int(deadline_s // (shortest + shaped))} fastest passes fit in {deadline_s:g} s")
    return lines
