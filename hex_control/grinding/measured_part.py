"""The part as measured in the sequence planner's decisions (issue 42).

The thesis plans on the mean material X (seed 002 section 5.1); the buyer judges every
point: "ground smooth with the parent material", within 0.1 mm (section 3). Three things
here bring the scan into the decision, each cheap beside the SDP (milliseconds):

- **The force the plans reach, before the first plan** (:func:`prior_force_limit_n`). The
  pass planner guards every pass: no point may need more than F_max, so on a rippled bead
  an F_max pass of the static model (eq. 4.6) is planned shallower. The SDP's F_max is
  the force whose cut the planner does plan (``coefficients.achievable_mean_force_n``,
  learned from each plan); before the first plan it is estimated from the scanned bead:
  the static guard (:func:`static_guard_fraction`, the larger of the planner's two
  families, a shallower level top or the local cut capped) times ``dynamic_guard_factor``,
  what the dynamic model's overshoot takes on top (the planner's depth over the static
  estimate, 0.85-0.89 on beads of 0.8-1.4 mm with 0.05 mm ripple at 6-75 mm/s).
- **The local state at the end** (:func:`finishing_pass`). A pass is a level top (eq.
  6.2): what it leaves standing is the level, a deterministic function of the scan and the
  mean depth, not a random walk of its own -- so it needs no second SDP state (301 x 301
  states would square the 0.2 s solve), only a rule where the mean-state policy is blind:
  when the policy would end the job (or let its last pass leave a point) above
  ``band_mm`` while a pass still fits, the planner grinds a level top at ``band_mm -
  margin_mm`` over the parent, at a feed slow enough that the highest point's cut needs no
  more than the force the plans reach, the fastest such feed that fits (or the slowest that
  fits; a deepened last pass only if one can).
- Gouges below the band are reported, not repaired: no pass puts material back.

Units: mm, N, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.contour import Contour, final_contour, positive_area
from hex_control.grinding.model import GrindingProcess


@dataclass(frozen=True)
class PartRule:
    """The buyer's band and the planner's use of it (config ``measured_part``)."""

    band_mm: float = 0.1  # every point within +-band of the parent (seed 002 section 3)
    margin_mm: float = 0.03  # a finishing pass aims this far inside the band (the local cut's variation)
    dynamic_guard_factor: float = 0.88  # the planner's depth over the static guard's estimate
    outlook_rollouts: int = 256  # seeded jobs on the planner's model for the expected end state

    def __post_init__(self):
        if not (0 < self.band_mm and 0 <= self.margin_mm < self.band_mm):
            raise ValueError(f"need band_mm > 0 and 0 <= margin_mm < band_mm, got {self.band_mm}, {self.margin_mm}")
        if not 0 < self.dynamic_guard_factor <= 1:
            raise ValueError(f"dynamic_guard_factor must be in (0, 1], got {self.dynamic_guard_factor}")
        if not 1 <= int(self.outlook_rollouts) <= 100_000:
            raise ValueError(f"outlook_rollouts must be in [1, 100000], got {self.outlook_rollouts}")

    @property
    def target_mm(self) -> float:
        """The level a finishing pass leaves over the parent."""
        return self.band_mm - self.margin_mm


@dataclass(frozen=True)
class LocalState:
    highest_mm: float  # highest point above the parent
    highest_x_mm: float
    lowest_mm: float  # lowest point (negative: a gouge below the parent)
    outside_mm: float  # length of bead outside +-band


class Profile:
    """A scanned profile: heights above the parent (mm) along x (mm)."""

    def __init__(self, x_mm, z_mm, parent_mm=()):
        parent = np.asarray(parent_mm, float) if len(parent_mm) else None
        self.contour = Contour(np.asarray(x_mm, float), np.asarray(z_mm, float), parent)
        self.height_mm = self.contour.z_mm - self.contour.parent_mm

    @property
    def x_mm(self) -> np.ndarray:
        return self.contour.x_mm

    @property
    def mean_mm(self) -> float:
        return float(np.trapezoid(self.height_mm, self.x_mm) / self.contour.length_mm)

    def local_state(self, band_mm: float) -> LocalState:
        h, x = self.height_mm, self.x_mm
        i = int(np.argmax(h))
        outside = np.abs(h) > band_mm
        segment = np.diff(x)
        length = float(np.sum(segment * (outside[1:] | outside[:-1])))  # segments with an end outside
        return LocalState(float(h[i]), float(x[i]), float(np.min(h)), length)

    def coarse(self, points: int = 2001) -> Profile:
        """The profile on at most ``points`` even positions (a scan may have 10^5): for the
        guard's estimate, whose bisections would otherwise take seconds."""
        if self.x_mm.size <= points:
            return self
        x = np.linspace(self.x_mm[0], self.x_mm[-1], points)
        return Profile(x, np.interp(x, self.x_mm, self.contour.z_mm), np.interp(x, self.x_mm, self.contour.parent_mm))

    def level_depth_mm(self, level_mm: float) -> float:
        """The mean cut (mm) of a level top at ``level_mm`` over the parent (eq. 6.1-6.2)."""
        return positive_area(self.x_mm, self.height_mm - level_mm) / self.contour.length_mm

    def level_of_depth_mm(self, depth_mm: float) -> float:
        """The level (mm over the parent) a level top of mean cut ``depth_mm`` leaves."""
        top = float(np.max(self.height_mm))
        if depth_mm <= 0:
            return top
        low = top - depth_mm - 1.0
        while self.level_depth_mm(low) < depth_mm:
            low = top - 2 * (top - low)
        high = top
        for _ in range(60):
            middle = (low + high) / 2
            low, high = (middle, high) if self.level_depth_mm(middle) > depth_mm else (low, middle)
        return (low + high) / 2


def static_guard_fraction(profile: Profile, process: GrindingProcess, feed_mm_s: float) -> float:
    """The fraction of an F_max pass's mean cut (eq. 4.6) that the pass planner's force guard
    leaves on this bead by the static model: the larger of a level top lowered until its
    deepest local cut is the F_max cut, and the F_max cut with the local cut capped there
    (the planner's two families, ``pass_plan.plan_pass``)."""
    depth = float(process.cut_depth_mm(process.force_max_n, feed_mm_s))
    if not depth > 0:
        return 1.0
    depth = min(depth, max(profile.mean_mm, 1e-9))
    length, width = profile.contour.length_mm, process.bead_width_mm
    level = final_contour(profile.contour, depth, width)
    local = profile.contour.z_mm - level.tip_mm
    shallower = positive_area(profile.x_mm, local - (float(np.max(local)) - depth)) / length
    capped = final_contour(profile.contour, depth, width, max_cut_mm=depth).removed_mm3 / (width * length)
    return float(min(max(shallower, capped) / depth, 1.0))


def prior_force_limit_n(profile: Profile, process: GrindingProcess, feeds_mm_s, rule: PartRule) -> float:
    """The force (N) whose static cut the pass planner can plan on this bead, before any plan
    of it is heard: numerator(F) = fraction x numerator(F_max), the fraction the static guard's
    mean over ``feeds_mm_s`` times the rule's dynamic factor."""
    coarse = profile.coarse()
    fraction = rule.dynamic_guard_factor * float(np.mean([static_guard_fraction(coarse, process, v)
                                                          for v in feeds_mm_s]))
    wanted = fraction * float(process.removal_numerator(process.force_max_n))
    return process.force_for_numerator_n(wanted) if wanted > 0 else process.zero_cut_force_n()


def force_for_cut_n(process: GrindingProcess, cut_mm: float, feed_mm_s: float) -> float:
    """The normal force (N) of mean cut ``cut_mm`` at ``feed_mm_s`` (eq. 4.6 inverted), within F_max."""
    wanted = cut_mm * feed_mm_s
    if wanted >= float(process.removal_numerator(process.force_max_n)):
        return process.force_max_n
    return process.force_for_numerator_n(wanted) if wanted > 0 else process.zero_cut_force_n()


def finishing_pass(profile: Profile, process: GrindingProcess, rule: PartRule, *, time_left_s: float,
                   feeds_mm_s, durations_s, reason: str, min_depth_mm: float = 0.0,
                   only_able: bool = False) -> dict | None:
    """A level top at ``rule.target_mm`` over the parent (mean cut at least ``min_depth_mm``):
    the fastest of the policy's feeds whose pass fits in ``time_left_s`` and whose highest
    point's cut needs no more than the force the plans reach (``process.force_max_n``), else
    (unless ``only_able``) the slowest that fits; None if none fits or nothing stands above
    the target."""
    state = profile.local_state(rule.band_mm)
    depth = max(profile.level_depth_mm(rule.target_mm), min_depth_mm)
    if not depth > 0:
        return None
    deepest = state.highest_mm - profile.level_of_depth_mm(depth)  # the highest point's cut (mm)
    reach = float(process.removal_numerator(process.force_max_n))  # mm^2/s: cut x feed at that force
    fits = [(v, d) for v, d in zip(feeds_mm_s, durations_s) if d <= time_left_s + 1e-9]
    able = [(v, d) for v, d in fits if deepest * v <= reach]
    if not able and (only_able or not fits):
        return None
    feed, duration = max(able) if able else min(fits)
    return {"action": "grind", "force_n": force_for_cut_n(process, depth, feed), "feed_mm_s": float(feed),
            "duration_s": float(duration), "cut_depth_mm": float(depth),
            "finish": f"{reason}: highest point +{state.highest_mm:.3f} mm at x = {state.highest_x_mm:.0f} mm; "
                      f"a level top at +{rule.target_mm:.3f} mm ({depth:.4f} mm mean cut)"}


def amend_decision(decision: dict, *, profile: Profile | None, process: GrindingProcess, rule: PartRule,
                   time_remaining_s: float, stage_time_s: float, feeds_mm_s, durations_s) -> dict:
    """The policy's decision at the measured state, with the local state in it: an end (or a
    wait) while a point stands above the band and a pass fits becomes a finishing pass; a
    last pass (none fits after it) whose level would leave a point above the band is
    deepened to the finishing level (or slowed: the guard caps the highest point's cut at
    what the force the plans reach cuts at its feed). Otherwise the decision as it was."""
    if profile is None:
        return decision
    state = profile.local_state(rule.band_mm)
    if state.highest_mm <= rule.band_mm:
        return decision
    shortest = min(durations_s)
    if decision["action"] != "grind":
        amended = finishing_pass(profile, process, rule, time_left_s=stage_time_s, feeds_mm_s=feeds_mm_s,
                                 durations_s=durations_s, reason=f"the policy would {decision['action']}")
        return {**decision, **amended} if amended is not None else decision
    cut = float(process.cut_depth_mm(decision["force_n"], decision["feed_mm_s"]))
    if (stage_time_s - decision["duration_s"] >= shortest - 1e-9
            or highest_after_mm(profile, process, cut, decision["feed_mm_s"]) <= rule.band_mm):
        return decision  # another pass fits after it, or it takes the highest point into the band
    amended = finishing_pass(profile, process, rule, time_left_s=stage_time_s, feeds_mm_s=feeds_mm_s,
                             durations_s=durations_s, reason="the last pass's level would leave a point high",
                             min_depth_mm=cut, only_able=True)
    return {**decision, **amended} if amended is not None else decision


def highest_after_mm(profile: Profile, process: GrindingProcess, cut_mm: float, feed_mm_s: float) -> float:
    """The highest point (mm over the parent) a level top of mean cut ``cut_mm`` at ``feed_mm_s``
    leaves: its level, or where the guard caps the highest point's cut at what the force the
    plans reach cuts at that feed (``process.force_max_n``), whichever is higher."""
    reach_mm = float(process.removal_numerator(process.force_max_n)) / feed_mm_s
    return max(profile.level_of_depth_mm(cut_mm), float(np.max(profile.height_mm)) - reach_mm)


def pass_durations_s(process: GrindingProcess, feeds_mm_s, time_step_s: float) -> list[float]:
    """Each feed's pass duration (s) as the policy plans it: L/V + t_R, up to whole stages."""
    return [math.ceil((process.bead_length_mm / v + process.reset_time_s) / time_step_s - 1e-9) * time_step_s
            for v in feeds_mm_s]
