"""What the input-shaper node does, without ROS (issue 38): shape a pass's whole tool path
and a stream of samples with the shaper in use, and change the shaper at run time.

- A path (n, 6: x, y, z mm, roll, pitch, yaw rad) is shaped as six channels at its own
  sample period, the way the online filter would stream it (:func:`shape_whole`): longer by
  the shaper's delay, so it ends at rest, and started the shaper's lag early (s), so it is
  on time where it moves at constant velocity (DESIGN.md 4.1).
- The stream: one sample per message at ``sample_period_s``; a pose is seven channels
  (position and quaternion, renormalized after shaping -- adequate for the small rotations
  of a reset move), joint positions one channel each. A non-finite or empty sample is refused.
- The shaper (kind, frequency Hz, damping, V_tol, the modes of an optimized design) may
  change at run time: the stream fades from the old shaper to the new one, without a jump.
  An ``optimized`` shaper is designed by differential evolution; :meth:`apply` hands the
  problem back for the caller to solve off its event loop, :meth:`switch` takes the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.shaping.filter import ShaperFilter, shape_whole
from hex_control.shaping.optimize import DesignProblem
from hex_control.shaping.shapers import Shaper, design


@dataclass(frozen=True)
class ShaperChoice:
    """The shaper parameters a node may change live."""

    shaper: str  # a closed-form kind (hex_control.shaping.shapers.SHAPERS) or "optimized"
    frequency_hz: float
    damping: float
    vibration_tolerance: float  # residual vibration the EI shapers allow (fraction)
    optimized_frequencies_hz: tuple[float, ...]  # the modes an optimized shaper is designed over


def closed_form(choice: ShaperChoice) -> Shaper:
    return design(choice.shaper, choice.frequency_hz, choice.damping, choice.vibration_tolerance)


def design_problem(choice: ShaperChoice) -> DesignProblem:
    """An optimized shaper's problem: five impulses, at most 1.5 periods of the lowest mode."""
    frequencies = tuple(float(f) for f in choice.optimized_frequencies_hz)
    return DesignProblem(frequencies_hz=frequencies, impulses=5, max_delay_s=1.5 * (1.0 / min(frequencies)))


def refusal(choice: ShaperChoice) -> str:
    """Why this choice cannot be used ('' = it can)."""
    try:
        if choice.shaper == "optimized":
            if not choice.optimized_frequencies_hz or min(choice.optimized_frequencies_hz) <= 0:
                raise ValueError("optimized_frequencies_hz must be positive")
        else:
            closed_form(choice)
    except (ValueError, TypeError) as exc:
        return str(exc)
    return ""


class MotionShaper:
    """Shapes paths and one sample stream with the shaper in use (``shaper``, ``label``)."""

    def __init__(self, choice: ShaperChoice, sample_period_s: float, interpolate: bool, pose_stream: bool):
        if not sample_period_s > 0:
            raise ValueError(f"sample_period_s must be > 0, got {sample_period_s!r}")
        self.sample_period_s, self.interpolate, self.pose_stream = sample_period_s, interpolate, pose_stream
        self._filter: ShaperFilter | None = None
        # while an optimized design runs, the ZVD at the design frequency shapes
        optimized = choice.shaper == "optimized"
        self.shaper = design("zvd", choice.frequency_hz, choice.damping) if optimized else closed_form(choice)
        self.label = choice.shaper
        self.changes = 0

    def apply(self, choice: ShaperChoice) -> DesignProblem | None:
        """Take a new (checked) choice: a closed form at once; an optimized design's problem
        is returned for the caller to solve, and the label says it is being designed."""
        if choice.shaper == "optimized":
            self.label = "optimized (designing)"
            return design_problem(choice)
        self.switch(closed_form(choice), choice.shaper)
        return None

    def switch(self, shaper: Shaper, label: str) -> None:
        """Shape with ``shaper`` from now on (the stream fades over to it)."""
        self.shaper, self.label = shaper, label
        if self._filter is not None:
            self._filter.set_shaper(shaper)
        self.changes += 1

    def shape_path(self, rows, period_s: float, start_s: float) -> tuple[np.ndarray, float]:
        """(shaped rows, their start s): longer by the shaper's delay, the lag earlier (>= 0)."""
        shaped, lag_s = shape_whole(self.shaper, period_s, np.asarray(rows, float), self.interpolate)
        return shaped, max(0.0, start_s - lag_s)

    def step(self, values) -> np.ndarray | None:
        """The shaped sample, or None for a non-finite or empty one (refused, nothing kept)."""
        values = np.asarray(values, float).reshape(-1)
        if values.size == 0 or not np.all(np.isfinite(values)):
            return None
        if self._filter is None or self._filter.channels != values.size:
            self._filter = ShaperFilter(self.shaper, self.sample_period_s, values.size, self.interpolate)
        shaped = self._filter.step(values)
        if self.pose_stream:
            return np.concatenate([shaped[:3], shaped[3:] / (np.linalg.norm(shaped[3:]) or 1.0)])
        return shaped
