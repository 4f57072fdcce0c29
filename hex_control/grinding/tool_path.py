"""The machine's path for one pass: approach, run-on, grind, run-off, retract and the reset
move back.

The pass planner works in the bead's plane (x along the bead, z up, mm); ``BeadFrame``
places that plane in the machine's frame. The tool point is the disk centre. Moves
between rests follow a cosine blend (zero velocity at both ends); the reset move is what
the input shaper shapes and what sets t_R.

Run-on and run-off: the tool reaches the feed speed ``run_on_s`` before the grinding phase
and keeps it ``run_on_s`` after, off the bead, at the phase's end heights. The input shaper
spreads every change of speed over its duration (ZVD at 5 Hz: 0.2 s, centred on the
change); started on the bead, the shaped tool would creep over the first and last
millimetres while the force trajectory, a function of time, pressed as planned for full
feed: a gouge at each end on the light finishing passes (issue 20).

Units: mm, s; orientation as a unit quaternion (x, y, z, w).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.kinematics.rotation import quaternion_from_rpy


@dataclass(frozen=True)
class BeadFrame:
    """Machine coordinates (mm) of the bead's x = 0, z = 0; unit vectors of the bead's x and
    z in the machine frame; the tool's fixed orientation (roll, pitch, yaw in deg)."""

    origin_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    along: tuple[float, float, float] = (1.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    orientation_rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        along, up = np.asarray(self.along, float), np.asarray(self.up, float)
        if not (np.all(np.isfinite(self.origin_mm)) and len(self.origin_mm) == 3):
            raise ValueError("origin_mm needs three finite values")
        if abs(np.linalg.norm(along) - 1) > 1e-6 or abs(np.linalg.norm(up) - 1) > 1e-6 or abs(along @ up) > 1e-6:
            raise ValueError("along and up must be orthogonal unit vectors")

    def positions_mm(self, x_mm, z_mm) -> np.ndarray:
        x, z = np.asarray(x_mm, float), np.asarray(z_mm, float)
        return np.asarray(self.origin_mm) + x[:, None] * np.asarray(self.along) + z[:, None] * np.asarray(self.up)

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        return quaternion_from_rpy(*np.radians(self.orientation_rpy_deg))


@dataclass(frozen=True)
class ToolPath:
    time_s: np.ndarray  # from the start of the approach
    positions_mm: np.ndarray  # (n, 3) in the machine frame
    quaternion_xyzw: np.ndarray  # the fixed tool orientation
    grind_start_s: float  # when the grinding phase begins (the force trajectory's t = 0)
    grind_end_s: float
    reset_start_s: float


def _blend(n: int) -> np.ndarray:
    """0 -> 1 with zero slope at both ends."""
    return (1 - np.cos(np.linspace(0.0, math.pi, n))) / 2


@dataclass(frozen=True)
class PathTiming:
    """How the path around a grinding phase is timed and sampled (s, mm)."""

    sample_period_s: float = 0.005
    approach_s: float = 1.0
    retract_mm: float = 20.0
    reset_s: float = 2.0
    run_on_s: float = 0.25  # at feed before and after the grinding phase: more than half the shaper's duration

    def __post_init__(self):
        if not (self.sample_period_s > 0 and self.approach_s > 0 and self.reset_s > 0 and self.retract_mm >= 0
                and self.run_on_s >= 0):
            raise ValueError("need positive sample period, approach and reset times, retract_mm >= 0 and "
                             "run_on_s >= 0")


def pass_tool_path(frame: BeadFrame, grind_time_s, centre_x_mm, height_mm,
                   timing: PathTiming = PathTiming()) -> ToolPath:
    """Rest ``retract_mm`` above the run-on's start, descend in ``approach_s``, run on at the
    phase's first height and mean feed for ``run_on_s``, follow the planned (x, H) of the
    grinding phase, run off as long at its last height, rise ``retract_mm`` in
    ``approach_s``, move back above the run-on's start in ``reset_s``; sampled every
    ``sample_period_s``."""
    t, x, h = (np.asarray(a, float) for a in (grind_time_s, centre_x_mm, height_mm))
    if not (t.ndim == 1 and t.size >= 2 and t.shape == x.shape == h.shape and np.all(np.diff(t) > 0)):
        raise ValueError("grinding phase: need increasing times with x and H of the same length")
    sample_period_s, approach_s, retract_mm, reset_s, run_on_s = (
        timing.sample_period_s, timing.approach_s, timing.retract_mm, timing.reset_s, timing.run_on_s)

    def samples(duration):
        return max(2, int(round(duration / sample_period_s)) + 1)

    n = samples(approach_s)
    grind_t = np.arange(0.0, t[-1] - t[0] + sample_period_s / 2, sample_period_s)
    grind_x, grind_z = np.interp(grind_t, t - t[0], x), np.interp(grind_t, t - t[0], h)
    r = int(round(run_on_s / sample_period_s))
    run = np.arange(r + 1) * sample_period_s * (x[-1] - x[0]) / (t[-1] - t[0])  # at the mean feed
    run_on_x, run_off_x = grind_x[0] - run[::-1], grind_x[-1] + run
    approach_x, approach_z = np.full(n, run_on_x[0]), h[0] + retract_mm * (1 - _blend(n))
    retract_x, retract_z = np.full(n, run_off_x[-1]), h[-1] + retract_mm * _blend(n)
    m = samples(reset_s)
    reset_x, reset_z = retract_x[-1] + (approach_x[0] - retract_x[-1]) * _blend(m), np.full(m, h[-1] + retract_mm)
    # join the phases without repeating the shared end points
    xs = np.concatenate([approach_x, run_on_x[1:], grind_x[1:], run_off_x[1:], retract_x[1:], reset_x[1:]])
    zs = np.concatenate([approach_z, np.full(r, h[0]), grind_z[1:], np.full(r, h[-1]), retract_z[1:],
                         reset_z[1:]])
    times = np.arange(xs.size) * sample_period_s
    grind_start = (n - 1 + r) * sample_period_s
    grind_end = grind_start + (grind_t.size - 1) * sample_period_s
    return ToolPath(times, frame.positions_mm(xs, zs), frame.quaternion_xyzw, grind_start, grind_end,
                    grind_end + (r + n - 1) * sample_period_s)
