"""The pass planner (seed 002 sections 6.1 and 6.6, and 8.3 item 3).

Planning by simulation (6.6): the final contour that removes the sequence planner's volume
(6.1) gives the desired tip trajectory; a simulated controller (eq. 6.17, or the relaxed-
angle variant) grinds the contour in the dynamic model so that the tip follows it; the
simulated normal force along the pass is the force trajectory for the force controller.
Force and stall guard: no point of a pass needs more than F_max or the grinder's allowed
fraction of its power (80 %); a pass that would is re-planned with a shallower level top
or with its local cut capped, whichever keeps more, and one that removes less says why.

The static planner (8.3 item 3) is the fast fallback for a flexible disk: removal rate
from the cross-section to be removed times the feed, force from the power law, the
spring's deflection from the compliance table.

Units: mm, s, N, rad, W.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.contour import Contour, FinalContour, final_contour, positive_area
from hex_control.grinding.dynamic import (
    DiskModel,
    ForceSchedule,
    HeightControl,
    PassSimulation,
    RelaxedAngleControl,
    simulate_pass,
)
from hex_control.grinding.model import WATT, GrindingProcess

CONTROLS = ("height", "relaxed_angle")


class PlanningError(ValueError):
    """A pass command that cannot be planned; the message is the reason."""


@dataclass(frozen=True)
class PassPlan:
    requested_depth_mm: float
    planned_depth_mm: float  # the target's mean cut: smaller than requested when a guard cut it
    feed_mm_s: float
    target: FinalContour  # the desired final contour and tip trajectory (6.1)
    simulation: PassSimulation  # the controlled pass (6.6): force, height, power histories
    reason: str  # why the depth was reduced ('' if it was not)
    simulations: int = 1  # dynamic simulations it took (more than one: the guard searched)
    warm_start: SearchStart | None = None  # what the guard's search found, to start the next one from

    @property
    def time_s(self) -> np.ndarray:
        return self.simulation.history["time_s"]

    @property
    def force_n(self) -> np.ndarray:
        return self.simulation.history["force_n"]

    @property
    def centre_x_mm(self) -> np.ndarray:
        return self.simulation.history["centre_x_mm"]

    @property
    def height_mm(self) -> np.ndarray:
        return self.simulation.history["height_mm"]

    def summary(self) -> dict:
        h = self.simulation.history
        return {"requested_depth_mm": self.requested_depth_mm, "planned_depth_mm": self.planned_depth_mm,
                "feed_mm_s": self.feed_mm_s, "duration_s": float(h["time_s"][-1]),
                "wanted_volume_mm3": self.target.removed_mm3, "simulated_volume_mm3": self.simulation.removed_mm3,
                "peak_force_n": self.simulation.peak_force_n, "peak_power_w": self.simulation.peak_power_w,
                "max_cut_mm": self.target.max_cut_mm, "multiple_patch_steps": self.simulation.multiple_patch_steps,
                "reason": self.reason,
                "simulations": self.simulations}


FAMILIES = ("level", "capped")  # the guard's two ways to re-plan a pass (plan_pass)


@dataclass(frozen=True)
class SearchStart:
    """Where the guard's search ended, as a warm start for the next pass's: the guard's
    ``family`` ('level' or 'capped') and the found parameter over the first guess of the
    search (the guess as if the peak load were proportional to the deepest local cut), and
    the load its last secant met at a zero parameter (the load is affine in the parameter
    near the edge, not proportional: the zero-cut force, and N sinking as the cap falls)."""

    family: str
    guess_scale: float
    intercept_load: float = 0.0

    def __post_init__(self):
        if self.family not in FAMILIES:
            raise ValueError(f"search start family must be one of {FAMILIES}, got {self.family!r}")
        if not (math.isfinite(self.guess_scale) and self.guess_scale > 0):
            raise ValueError(f"search start guess_scale must be finite and > 0, got {self.guess_scale!r}")
        if not (math.isfinite(self.intercept_load) and 0 <= self.intercept_load < 1):
            raise ValueError(f"search start intercept_load must be in [0, 1), got {self.intercept_load!r}")


def typical_search_start(ends: list[SearchStart]) -> SearchStart:
    """The start a job's first guarded search takes (the pass planner's ``search_start``):
    the median of searches' ends in their most common family, guess scale and intercept
    each. A job's first pass has no search of its own to start from, and the searches of
    like passes end alike (0.80-0.86 and 0.02-0.25 over the demo's beads and feeds), so a
    first search started there takes two to three simulations instead of four or five."""
    if not ends:
        raise ValueError("no search ends to take a typical start from")
    families = [end.family for end in ends]
    family = max(FAMILIES, key=families.count)
    same = [end for end in ends if end.family == family]
    return SearchStart(family, float(np.median([end.guess_scale for end in same])),
                       float(np.median([end.intercept_load for end in same])))


def plan_pass(contour: Contour, model: DiskModel, cut_depth_mm: float, feed_mm_s: float,
              control: str = "height", *, step_mm: float = 0.1, shape_mm=None, gains: tuple[float, float] | None = None,
              depth_tolerance: float = 0.02, max_simulations: int = 12, warm_start: SearchStart | None = None,
              contact_search=None) -> PassPlan:
    """Plan one pass of mean cut depth ``cut_depth_mm`` at ``feed_mm_s`` on ``contour``.
    ``gains``: (G1, G2) of the controller chosen by ``control`` (its defaults if None).

    Force and stall guard: no point of the pass may need more than F_max, nor more than
    ``power_fraction`` of the grinder's power. The sequence planner's F_N <= F_max holds
    for the mean cut; a level top (eq. 6.2) on a rippled bead cuts the crests deeper than
    the mean, several times deeper on a shallow pass, and fast passes overshoot in the
    dynamic model. A pass over a limit is re-planned one of two ways, whichever the static
    estimate says removes more: a shallower level top (best when the excess is small), or
    the requested volume with the local cut capped (``final_contour``'s ``max_cut_mm``;
    best on shallow passes, where only the crests are cut). Its parameter is searched to
    ``depth_tolerance`` of the limit or of its own range by the secant on the peak load vs
    the parameter, kept inside a bracket (bisection when it leaves it); the load is nearly
    affine in either, so two or three simulations do. At most ``max_simulations`` in all.
    A plan that removes less than asked says why in ``reason``.

    ``warm_start`` (the last pass's ``PassPlan.warm_start``): when the search is in the same
    family, its first guess is scaled as the last search's had to be, and its second step
    takes the load as affine in the parameter through the last search's intercept instead
    of proportional (the load at a zero cap is about a quarter of the limit: the zero-cut
    force, and N sinking as the cap falls; proportional steps landed 2-4 % over the limit),
    so that on a job's like passes it lands within the tolerance sooner: a simulation or two
    fewer. The plan is still the search's, within ``depth_tolerance`` of the
    limit; which point of that band it ends on depends on the start. ``contact_search``:
    :func:`simulate_pass`'s (None: the incremental kernel).
    """
    if control not in CONTROLS:
        raise PlanningError(f"control must be one of {CONTROLS}, got {control!r}")
    if not (math.isfinite(cut_depth_mm) and cut_depth_mm > 0):
        raise PlanningError(f"cut depth must be finite and > 0 mm, got {cut_depth_mm!r}")
    process = model.process
    if not (math.isfinite(feed_mm_s) and process.feed_min_mm_s <= feed_mm_s <= process.feed_max_mm_s):
        raise PlanningError(f"feed speed {feed_mm_s!r} mm/s outside [{process.feed_min_mm_s}, "
                            f"{process.feed_max_mm_s}]")
    limit_w = process.power_fraction * process.max_power_w
    width, length = process.bead_width_mm, contour.length_mm

    def simulate(target):
        controller = HeightControl if control == "height" else RelaxedAngleControl
        drive = controller(model, contour.x_mm, target.tip_mm, contour.x_mm[0], **controller.gain_keywords(gains))
        simulation = simulate_pass(contour, model, drive, feed_mm_s, step_mm=step_mm, contact_search=contact_search)
        load = max(simulation.peak_force_n / process.force_max_n, simulation.peak_power_w / limit_w)
        return (target, simulation), load

    def level_top(depth):
        return final_contour(contour, depth, width, shape_mm)

    def capped(cap):
        return final_contour(contour, cut_depth_mm, width, shape_mm, max_cut_mm=cap)

    first = level_top(cut_depth_mm)
    best, load = simulate(first)
    if load <= 1:
        return _as_simulated(PassPlan(cut_depth_mm, cut_depth_mm, feed_mm_s, *best, ""), width * length,
                             depth_tolerance)
    first_simulation = best[1]
    aim = 1 - depth_tolerance / 2  # just under the limit, so that a secant lands feasible
    deepest = float(np.max(contour.z_mm - first.tip_mm))  # the level top's deepest local cut (mm)
    allowed = deepest * aim / load  # as if the peak load were proportional to the deepest cut
    shallower = positive_area(contour.x_mm, contour.z_mm - first.tip_mm - (deepest - allowed)) / length
    if shallower >= capped(allowed).removed_mm3 / (width * length):
        make, upper, guess, how, family = level_top, cut_depth_mm, shallower, "a shallower level top", "level"
    else:
        make, upper, guess, how, family = capped, deepest, allowed, "the local cut capped", "capped"
    first_guess = guess
    intercept = 0.0
    if warm_start is not None and warm_start.family == family:
        if 0 < warm_start.guess_scale * guess < upper:
            guess *= warm_start.guess_scale
        intercept = warm_start.intercept_load if 0 <= warm_start.intercept_load < aim else 0.0
    best_parameter = math.nan
    low, high, best, best_load = 0.0, upper, None, math.nan  # the bracket of the edge
    found_intercept = math.nan  # the load at a zero parameter on the latest secant
    last, previous = None, None  # (parameter, peak load) of the latest simulations in this family
    for simulations in range(2, max_simulations + 1):
        if last is None:
            middle = guess
        elif previous is None:  # as if the load were affine with the last search's intercept (0: proportional)
            middle = last[0] * (aim - intercept) / (last[1] - intercept) if last[1] > intercept else math.nan
        else:
            (p1, l1), (p0, l0) = last, previous
            middle = p1 + (aim - l1) * (p1 - p0) / (l1 - l0) if l1 != l0 else math.nan
        if not low < middle < high:  # the secant left the bracket (or the load is not monotone there)
            middle = (low + high) / 2
        candidate, candidate_load = simulate(make(middle))
        if candidate_load <= 1:
            low, best, best_load, best_parameter = middle, candidate, candidate_load, middle
        else:
            high = middle
        previous, last = last, (middle, candidate_load)
        if previous is not None and last[0] != previous[0]:
            slope = (last[1] - previous[1]) / (last[0] - previous[0])
            found_intercept = last[1] - slope * last[0]
        if best is not None and (high - low <= depth_tolerance * upper or 1 - best_load <= depth_tolerance):
            break
    if best is None:
        raise PlanningError(f"even {how} at {high:.3g} mm needs more than F_max {process.force_max_n:g} N or "
                            f"{limit_w:.0f} W ({process.power_fraction:.0%} of the grinder's "
                            f"{process.max_power_w:.0f} W)")
    target = best[0]
    planned = target.removed_mm3 / (width * length)
    found = SearchStart(family, best_parameter / first_guess,
                        found_intercept if 0 <= found_intercept < aim else 0.0)
    if planned >= cut_depth_mm * (1 - 1e-6):
        return _as_simulated(PassPlan(cut_depth_mm, cut_depth_mm, feed_mm_s, *best, "", simulations, found),
                             width * length, depth_tolerance)
    if math.isfinite(target.max_cut_mm):
        how = f"the local cut capped at {target.max_cut_mm:.3f} mm"
    return _as_simulated(PassPlan(cut_depth_mm, planned, feed_mm_s, *best,
                                  _reduced_because(process, first_simulation, limit_w)
                                  + f"; with {how}, depth reduced from {cut_depth_mm:.3f} to {planned:.3f} mm",
                                  simulations, found), width * length, depth_tolerance)


def _as_simulated(plan: PassPlan, area_mm2: float, tolerance: float) -> PassPlan:
    """The plan states the depth its own simulation removes when that differs from the
    target's by more than ``tolerance`` (relative): the height PI of eq. 6.17 closes its tip
    error at G2 / (1 + G1) (9.5 /s with the defaults), a time constant of 0.1 s, so after a
    steep bead end or a crest the tip lags its trajectory for about 0.1 s of feed: 0.5 mm at
    5 mm/s, 8 mm at 75 mm/s, where a rippled bead with steep ends is never long enough
    without one (7 % less than the target removed there). ``area_mm2`` is w L."""
    simulated = plan.simulation.removed_mm3 / area_mm2
    if abs(simulated - plan.planned_depth_mm) <= tolerance * plan.planned_depth_mm:
        return plan
    note = (f"its simulation removes {simulated:.4f} mm, not the target's {plan.planned_depth_mm:.4f} mm: "
            f"{simulated:.4f} mm planned")
    return dataclasses.replace(plan, planned_depth_mm=simulated, reason="; ".join(filter(None, (plan.reason, note))))


def _reduced_because(process: GrindingProcess, first: PassSimulation, limit_w: float) -> str:
    """Which limit the requested pass broke, and by how much."""
    force_n, power_w = first.peak_force_n, first.peak_power_w
    if power_w / limit_w > force_n / process.force_max_n:
        return (f"stall guard: the requested pass needs {power_w:.0f} W, more than {limit_w:.0f} W "
                f"({process.power_fraction:.0%} of the grinder's maximum)")
    return f"force guard: the requested pass needs {force_n:.0f} N, more than F_max {process.force_max_n:g} N"


def execute_plan(contour: Contour, model: DiskModel, plan: PassPlan, step_mm: float = 0.05, *,
                 contact_search=None) -> PassSimulation:
    """Grind ``contour`` under force control with the plan's force and height trajectories
    and the process ``model`` (which may differ from the one the plan assumed), at
    ``step_mm`` of feed per step or less: no step longer than a quarter of the force loop's
    time constant. (At 0.1 mm a rippled bead's landings were under-resolved: up to 11 %
    more than at 0.025 mm; at 0.05 mm within 1 % of it.)"""
    drive = ForceSchedule(model, plan.centre_x_mm, plan.height_mm, plan.force_n,
                          float(plan.simulation.history["angle_rad"][0]))
    step_mm = min(step_mm, plan.feed_mm_s * model.approach_time_constant_s / 4)
    return simulate_pass(contour, model, drive, plan.feed_mm_s, step_mm=step_mm, contact_search=contact_search)


# -- the static fallback (8.3 item 3) ------------------------------------------------------

@dataclass(frozen=True)
class Compliance:
    """Torque (N mm) against deflection (rad) of the grinder's support, a monotone table
    (6.7: the air hose made it nonlinear) or a line of stiffness K_S."""

    deflection_rad: np.ndarray
    torque_n_mm: np.ndarray

    def __post_init__(self):
        d, t = np.asarray(self.deflection_rad, float), np.asarray(self.torque_n_mm, float)
        if d.ndim != 1 or d.size < 2 or d.shape != t.shape or np.any(np.diff(d) <= 0) or np.any(np.diff(t) <= 0):
            raise ValueError("compliance table: need increasing deflections and torques of one length >= 2")
        object.__setattr__(self, "deflection_rad", d)
        object.__setattr__(self, "torque_n_mm", t)

    @classmethod
    def linear(cls, stiffness_n_mm_rad: float, max_deflection_rad: float = 0.2) -> Compliance:
        return cls(np.array([0.0, max_deflection_rad]), np.array([0.0, stiffness_n_mm_rad * max_deflection_rad]))

    def deflection_for(self, torque_n_mm):
        torque = np.asarray(torque_n_mm, float)
        if np.any(torque > self.torque_n_mm[-1]):
            raise PlanningError(f"torque {float(np.max(torque)):.0f} N mm beyond the compliance table")
        return np.interp(torque, self.torque_n_mm, self.deflection_rad)


@dataclass(frozen=True)
class StaticPassPlan:
    target: FinalContour
    x_mm: np.ndarray  # position along the bead (the target contour's points)
    time_s: np.ndarray  # x / V_f from the start
    removal_rate_mm3_s: np.ndarray
    force_n: np.ndarray  # 0 where nothing is to be removed
    deflection_rad: np.ndarray  # the spring's wind-up for that force (from the table)


def force_for_power(process: GrindingProcess, power_w):
    """Invert Pi = omega(F) R mu F with omega = omega_0 - beta R mu F (eq. 4.8): the smaller
    root, the one on the motor's stable side."""
    power = np.asarray(power_w, float) * WATT
    a = process.disk_radius_mm * process.friction_coefficient
    k = process.motor_beta_rad_s_per_n_mm * a
    if k == 0:
        return power / (process.disk_speed_rad_s * a)
    disc = (process.disk_speed_rad_s * a) ** 2 - 4 * k * a * power
    if np.any(disc < 0):
        raise PlanningError("the air motor cannot deliver that power at any force (it would stall)")
    return (process.disk_speed_rad_s * a - np.sqrt(disc)) / (2 * k * a)


def plan_pass_static(contour: Contour, process: GrindingProcess, compliance: Compliance, cut_depth_mm: float,
                     feed_mm_s: float, *, shape_mm=None) -> StaticPassPlan:
    """8.3 item 3: cross-section to remove w (Z_i - Z_f) along the bead times V_f is the
    removal rate Q(x); power K1 Q + K2; force from the power; deflection from the table."""
    if not (math.isfinite(cut_depth_mm) and cut_depth_mm > 0 and math.isfinite(feed_mm_s) and feed_mm_s > 0):
        raise PlanningError("need a finite cut depth > 0 mm and feed speed > 0 mm/s")
    target = final_contour(contour, cut_depth_mm, process.bead_width_mm, shape_mm)
    x = target.contour.x_mm
    section = process.bead_width_mm * np.maximum(contour.height_at(x) - target.contour.z_mm, 0.0)
    rate = section * feed_mm_s
    power = np.where(rate > 0, process.specific_energy_j_mm3 * rate + process.wasted_power_w, 0.0)
    force = force_for_power(process, power)
    return StaticPassPlan(target, x, (x - x[0]) / feed_mm_s, rate, force,
                          compliance.deflection_for(force * process.disk_radius_mm))


@dataclass(frozen=True)
class ForcePlan:
    """What the pass planner hands down, whichever planner made it: the normal force and
    the disk centre's (x, H) against time from the start of grinding, the predicted final
    contour, the depth planned and why it differs from the one requested; and the disk
    tip's path (x, z) the plan runs, for the part-safety check against the parent."""

    time_s: np.ndarray
    centre_x_mm: np.ndarray
    height_mm: np.ndarray
    force_n: np.ndarray
    final: Contour
    planned_depth_mm: float
    reason: str
    simulations: int = 1  # dynamic simulations the plan took (the stall guard's search)
    tip_x_mm: np.ndarray | None = None
    tip_z_mm: np.ndarray | None = None
    warm_start: SearchStart | None = None  # the guard's search's end (dynamic planner), for the next pass


def plan_forces(contour: Contour, model: DiskModel, cut_depth_mm: float, feed_mm_s: float, planner: str = "dynamic",
                *, control: str = "height", gains=None, step_mm: float = 0.1,
                compliance: Compliance | None = None, shape_mm=None, warm_start: SearchStart | None = None,
                contact_search=None) -> ForcePlan:
    """The dynamic planner (6.6) or the static one (8.3 item 3; the tool holds the tip on
    the final contour at the relaxed angle). ``shape_mm``: the desired final shape under the
    level top (the parent surface if None), as :func:`final_contour` takes it;
    ``warm_start``, ``contact_search``: :func:`plan_pass`'s."""
    if planner == "dynamic":
        plan = plan_pass(contour, model, cut_depth_mm, feed_mm_s, control, step_mm=step_mm, shape_mm=shape_mm,
                         gains=gains, warm_start=warm_start, contact_search=contact_search)
        h = plan.simulation.history
        return ForcePlan(plan.time_s, plan.centre_x_mm, plan.height_mm, plan.force_n, plan.simulation.final,
                         plan.planned_depth_mm, plan.reason, plan.simulations, h["tip_x_mm"], h["tip_z_mm"],
                         plan.warm_start)
    if planner != "static":
        raise PlanningError(f"planner must be 'dynamic' or 'static', got {planner!r}")
    plan = plan_pass_static(contour, model.process, compliance or Compliance.linear(model.spring_n_mm_rad),
                            cut_depth_mm, feed_mm_s, shape_mm=shape_mm)
    angle = model.relaxed_angle_rad
    return ForcePlan(plan.time_s, plan.x_mm + model.radius_mm * math.cos(angle),
                     plan.target.contour.z_mm + model.radius_mm * math.sin(angle), plan.force_n,
                     plan.target.contour, cut_depth_mm, "", 1, plan.x_mm, plan.target.contour.z_mm)
