"""The pass planner's core (seed 002 ch. 6): which command is planned on which contour,
and the checks that keep a plan off the parent surface. No ROS here: the node
(:mod:`hex_control.ros.nodes.pass_planner`) converts messages to :class:`PassRequest` and
:class:`Scan`, runs :meth:`PassSession.plan` on a worker thread, asks the kinematics
node whether the path is reachable, and publishes what a :class:`Verdict` says.

Which command on which contour: a command for pass k is planned on the latest contour
after k passes (the same job, or a contour without a job id). One command waits for its
contour at a time: of two, the one for an earlier pass of the same job is refused as
superseded, so every command ends exactly once (planned or refused). A command already
answered or in hand (a latched re-delivery, the sequence planner sending it again) is
ignored. A command whose contour has not come within ``contour_wait_s`` is refused. A
stop (the job ended with that pass in flight) is never planned: a pass of that key not yet
published is refused as stopped, and nothing else happens (the force controller retracts).

Part-safety invariant (issue 37 item 1), whatever the command says:
- the command is checked against the scan it is planned on: feed within [feed_min,
  feed_max], its force within [0, F_max] (the cell's), its K1 plausible, and its cut depth
  no more than the material left over the parent (the scan's mean height above it): a
  deeper cut is capped to that, and the plan says so;
- the plan's own simulated final contour and the disk tip's path never run more than
  PARENT_TOLERANCE_MM below the parent (the desired final contour): a plan that does is
  planned again over a desired shape raised by its dip, at most PARENT_RETRIES times, and
  refused if it still dips;
- its peak force stays within F_max.

Units: mm, s, N, J/mm^3.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.coefficients import plausible_specific_energy
from hex_control.grinding.config import PassPlannerConfig
from hex_control.grinding.contour import Contour
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.pass_plan import ForcePlan, PlanningError, SearchStart, plan_forces
from hex_control.grinding.tool_path import ToolPath, pass_tool_path

PARENT_TOLERANCE_MM = 1e-3  # how far a plan's simulation may touch below the parent (numerical touch)
PARENT_RETRIES = 3  # plans over a raised shape before a dipping plan is refused
FORCE_TOLERANCE = 1e-9  # relative: F_max itself is a valid command


@dataclass(frozen=True)
class PassRequest:
    """A PassCommand's content: the pass's mean cut depth (mm), feed (mm/s), the K1 its depth
    was computed with (J/mm^3; 0 = the config's) and the normal force decided on (N)."""

    job_id: str
    pass_index: int
    cut_depth_mm: float
    feed_mm_s: float
    specific_energy_j_mm3: float = 0.0
    normal_force_n: float = 0.0
    stop: bool = False  # the job ended with this pass in flight: never plan it (the controller retracts)

    @property
    def key(self) -> tuple[str, int]:
        return self.job_id, self.pass_index

    def supersedes(self, old: PassRequest) -> bool:
        """A command for another job, or a later pass of the same one, replaces a waiting
        one; an earlier pass of the same job (a late re-delivery from a restarted writer)
        does not."""
        return self.job_id != old.job_id or self.pass_index > old.pass_index


@dataclass(frozen=True)
class Scan:
    """A contour as it arrived: after ``pass_index`` passes of ``job_id`` ('' = any job),
    the plant time it was scanned at (s), the bead width (mm; <= 0 = the config's), and the
    contour, or None and the reason it is malformed."""

    job_id: str
    pass_index: int
    stamp_s: float
    bead_width_mm: float
    contour: Contour | None
    error: str = ""

    def serves(self, request: PassRequest) -> bool:
        return self.pass_index == request.pass_index and (not self.job_id or self.job_id == request.job_id)


@dataclass(frozen=True)
class PlannedPass:
    """A plan ready to publish: the force plan, the tool path, the process it was planned
    with, the scan's plant time (s), its status message (the note: '' = planned as asked) and
    values, and what the part-safety checks changed ('' = nothing)."""

    plan: ForcePlan
    path: ToolPath
    process: GrindingProcess
    contour_s: float
    note: str
    values: dict
    safety: str = ""
    planning_s: float = 0.0  # wall time the planning took (s; not in ``values``: the status stays deterministic)

    def summary(self) -> str:
        """One line for the log: the depth planned, the pass's duration, the planning's cost."""
        count = self.plan.simulations
        return (f"{self.plan.planned_depth_mm:.4f} mm in {self.plan.time_s[-1]:.2f} s ({count} simulation"
                f"{'s' if count > 1 else ''}, {self.planning_s:.2f} s wall)")


@dataclass(frozen=True)
class Verdict:
    """How a command ended: ``planned`` (None if refused), the reason or the plan's note, the
    diagnostics counter to add (``planned`` or ``rejected_<kind>``), and a diagnostics fault to
    raise for a while, (name, message), if the command was refused or changed for the part's
    safety (None otherwise)."""

    request: PassRequest
    planned: PlannedPass | None
    reason: str
    counter: str
    fault: tuple[str, str] | None = None

    @property
    def refused(self) -> bool:
        return self.planned is None


def refusal(request: PassRequest, reason: str, kind: str) -> Verdict:
    return Verdict(request, None, reason, f"rejected_{kind}",
                   ("refused", f"pass {request.pass_index} of job {request.job_id!r} refused: {reason}"))


def accepted(request: PassRequest, planned: PlannedPass) -> Verdict:
    fault = ("part_safety", f"pass {request.pass_index} of job {request.job_id!r}: {planned.safety}") \
        if planned.safety else None
    return Verdict(request, planned, planned.note, "planned", fault)


def material_left_mm(contour: Contour) -> float:
    """The scan's mean height above the parent surface (mm): the material a job may remove."""
    return contour.area_above(contour.parent_mm) / contour.length_mm


def parent_dip(plan: ForcePlan, contour: Contour) -> tuple[float, float]:
    """(mm, x mm): how far the plan's simulated final contour or its disk tip path cuts below
    the parent surface at worst (<= 0: nowhere), and where, over the scanned ``contour``'s
    span. What lay below the parent before the pass (an earlier gouge) is not the plan's:
    the floor is the lower of the parent and the scan."""
    final = plan.final
    depth = np.minimum(final.parent_mm, contour.height_at(final.x_mm)) - final.z_mm
    worst, at = float(np.max(depth)), float(final.x_mm[int(np.argmax(depth))])
    if plan.tip_x_mm is not None:
        x, z = np.asarray(plan.tip_x_mm, float), np.asarray(plan.tip_z_mm, float)
        over = (x >= contour.x_mm[0]) & (x <= contour.x_mm[-1])
        if np.any(over):
            floor = np.minimum(np.interp(x[over], contour.x_mm, contour.parent_mm), contour.height_at(x[over]))
            tip = floor - z[over]
            i = int(np.argmax(tip))
            if tip[i] > worst:
                worst, at = float(tip[i]), float(x[over][i])
    return worst, at


def checked_positions(path: ToolPath) -> np.ndarray:
    """The path positions TestPose checks (mm, machine frame): one sample in ten, and the last."""
    return np.vstack([path.positions_mm[::10], path.positions_mm[-1:]])


#: a path starts at least this long (s) after where a lock-step plant stands after a scan: the
#: input shaper starts a shaped path its lag early (ZVD: half a period of the structural mode,
#: 0.1 s at the shipped machines' 5 Hz), and as much again to spare
SHAPER_LAG_MARGIN_S = 0.2


def pass_start_s(contour_s: float, clock_s: float, start_delay_s: float, plan_ahead_s: float = 0.0) -> float:
    """When the pass's path starts (s, plant clock): ``start_delay_s`` after the scan it was
    planned on while the node's clock is within ``plan_ahead_s`` of that scan, else after the
    clock. In lock-step the plant runs on at most ``plan_ahead_s`` after a scan while the
    planners plan, then stands (plant/lockstep.py): so the start, and the delay charged for
    planning, are the same at any load. The delay is at least ``plan_ahead_s`` and
    :data:`SHAPER_LAG_MARGIN_S` more, or the plan could come after its path had begun."""
    start_delay_s = max(start_delay_s, plan_ahead_s + SHAPER_LAG_MARGIN_S if plan_ahead_s > 0 else 0.0)
    return (contour_s if clock_s <= contour_s + plan_ahead_s + 1e-9 else clock_s) + start_delay_s


class PassSession:
    """The pass planner's state between messages: the latest scan, the command waiting for
    its contour (and since when, s of a monotonic clock the caller keeps), the one being
    planned, the one whose path is being checked for reach, and the commands answered."""

    def __init__(self, config: PassPlannerConfig, contour_wait_s: float = 5.0, check_reach: bool = False, *,
                 contact_search=None, warm_start: bool = True):
        """``contact_search``, ``warm_start``: the pass planner's kernel and whether each
        guarded search starts from the last one, the first from the config's ``search_start``
        (``pass_plan.plan_pass``); the benchmark's baseline passes the old kernel and no warm
        start."""
        self.config, self.contour_wait_s, self.check_reach = config, contour_wait_s, check_reach
        self.contact_search, self.warm_starts = contact_search, warm_start
        self.scan: Scan | None = None
        self.pending: PassRequest | None = None
        self.pending_since = 0.0
        self.planning: PassRequest | None = None
        self.checking: tuple[PassRequest, PlannedPass, float] | None = None  # (command, plan, since s)
        self.answered: set[tuple[str, int]] = set()
        self.stopped: set[tuple[str, int]] = set()  # stopped while being planned
        # the last guarded search's end: the next search starts from it (pass_plan.plan_pass), the
        # first from the configured typical one; written only in planned(), between plans, so the
        # worker reads a settled value
        self.warm_start: SearchStart | None = config.search_start if warm_start else None
        self.planning_s = 0.0  # wall time spent planning, all commands (s): the clock stands still meanwhile
        self.plans = 0  # commands planned (plans and refusals)

    # -- inputs --------------------------------------------------------------------------
    def on_scan(self, scan: Scan) -> None:
        self.scan = scan

    def in_hand(self, request: PassRequest) -> bool:
        """Answered already, or waiting, being planned or being checked: a re-delivery (a stop
        only once answered, or stopped already while being planned)."""
        held = [self.pending, self.planning, self.checking[0] if self.checking else None]
        if request.stop:
            return request.key in self.answered or request.key in self.stopped
        return request.key in self.answered or any(r is not None and r.key == request.key for r in held)

    def on_stop(self, request: PassRequest) -> list[Verdict]:
        """A stop: the pass of its key, if waiting or being checked, ends here as stopped
        (returned); one being planned ends so when its plan comes; any other is left alone."""
        reason = f"stopped: job {request.job_id!r} ended before pass {request.pass_index} was planned"
        if self.pending is not None and self.pending.key == request.key:
            self.pending = None
            return [self._refuse(request, reason, "stopped")]
        if self.checking is not None and self.checking[0].key == request.key:
            self.checking = None
            return [self._refuse(request, reason, "stopped")]
        if self.planning is not None and self.planning.key == request.key:
            self.stopped.add(request.key)
        return []

    def on_command(self, request: PassRequest, now_s: float) -> list[Verdict]:
        """A new command (not :meth:`in_hand`): it waits for its contour; of two waiting, the
        older ends here as superseded (returned). A stop goes to :meth:`on_stop`."""
        if request.stop:
            return self.on_stop(request)
        refused = []
        if self.pending is not None:  # one command waits for its contour at a time
            older, newer = (self.pending, request) if request.supersedes(self.pending) else (request, self.pending)
            refused.append(self._refuse(older, f"superseded by pass {newer.pass_index} of job {newer.job_id!r} "
                                               "before its contour came", "superseded"))
            if older is request:
                return refused
        self.pending, self.pending_since = request, now_s
        return refused

    def contour_for(self, request: PassRequest) -> Scan | None:
        return self.scan if self.scan is not None and self.scan.serves(request) else None

    def next_to_plan(self) -> tuple[PassRequest, Scan] | None:
        """The waiting command and its scan, if it can be planned now (it is then being
        planned: hand it to :meth:`plan`, then its outcome to :meth:`planned`)."""
        if self.pending is None or self.planning is not None or self.checking is not None:
            return None
        scan = self.contour_for(self.pending)
        if scan is None:
            return None
        self.planning, self.pending = self.pending, None
        return self.planning, scan

    def expired(self, now_s: float) -> Verdict | None:
        """The waiting command refused if its contour has not come within contour_wait_s (not
        while another is being planned)."""
        if self.pending is None or self.planning is not None or self.contour_for(self.pending) is not None \
                or now_s - self.pending_since <= self.contour_wait_s:
            return None
        request, self.pending = self.pending, None
        latest = "none" if self.scan is None else f"the one after {self.scan.pass_index} passes"
        return self._refuse(request, f"no contour for pass {request.pass_index} (latest: {latest})", "no_contour")

    # -- planning (thread-safe: reads only the immutable config) ---------------------------
    def plan(self, request: PassRequest, scan: Scan) -> PlannedPass | Verdict:
        """Check the command against the scan, plan it and check the plan against the parent;
        a refusal (a Verdict) if any check fails."""
        start = time.perf_counter()
        try:
            planned = self._plan(request, scan)
        except (PlanningError, ValueError, ArithmeticError) as exc:  # ArithmeticError: FloatingPointError and kin
            return refusal(request, str(exc), "unplannable")
        return dataclasses.replace(planned, planning_s=time.perf_counter() - start)

    def _plan(self, request: PassRequest, scan: Scan) -> PlannedPass:
        config = self.config
        depth, feed = request.cut_depth_mm, request.feed_mm_s
        if not all(math.isfinite(v) for v in (depth, feed)):
            raise PlanningError(f"non-finite command: cut depth {depth!r} mm, feed {feed!r} mm/s")
        nominal = config.model.process.specific_energy_j_mm3
        specific_energy_j_mm3 = request.specific_energy_j_mm3 or nominal
        if not plausible_specific_energy(specific_energy_j_mm3, nominal):
            raise PlanningError(f"implausible K1 {specific_energy_j_mm3!r} J/mm^3 (the config's is {nominal:g})")
        if scan.contour is None:
            raise PlanningError(f"bad contour: {scan.error}")
        if not (math.isfinite(scan.stamp_s) and scan.stamp_s >= 0):  # the pass would start at that time
            raise PlanningError(f"bad contour: stamp {scan.stamp_s!r} s")
        process = dataclasses.replace(config.model.process, specific_energy_j_mm3=specific_energy_j_mm3)
        if not (process.feed_min_mm_s <= feed <= process.feed_max_mm_s):
            raise PlanningError(f"feed speed {feed!r} mm/s outside [{process.feed_min_mm_s}, {process.feed_max_mm_s}]")
        force_max_n = process.force_max_n
        if not 0.0 <= request.normal_force_n <= force_max_n * (1 + FORCE_TOLERANCE):
            raise PlanningError(f"commanded force {request.normal_force_n!r} N outside [0, F_max {force_max_n:g} N]")
        if not depth > 0:
            raise PlanningError(f"cut depth must be finite and > 0 mm, got {depth!r}")
        contour = scan.contour
        left = material_left_mm(contour)
        if not left > 0:
            raise PlanningError(f"no material left over the parent on the scan after {scan.pass_index} passes")
        notes = []
        if depth > left:
            notes.append(f"cut depth capped from {depth:.4f} mm to the {left:.4f} mm left over the parent")
            depth = left
        if scan.bead_width_mm > 0:
            process = dataclasses.replace(process, bead_width_mm=scan.bead_width_mm)
        model = dataclasses.replace(config.model, process=process)
        plan, raised = self._plan_above_parent(contour, model, depth, feed, notes)
        if float(np.max(plan.force_n, initial=0.0)) > force_max_n * (1 + FORCE_TOLERANCE):
            raise PlanningError(f"the plan needs {float(np.max(plan.force_n)):.1f} N, more than F_max "
                                f"{force_max_n:g} N")
        path = pass_tool_path(config.frame, plan.time_s, plan.centre_x_mm, plan.height_mm, config.path)
        if not all(np.all(np.isfinite(a)) for a in (plan.force_n, path.positions_mm, [plan.planned_depth_mm])):
            raise PlanningError("the plan is not finite (a contour of absurd heights?)")
        note = "; ".join(filter(None, [*notes, plan.reason]))
        values = {"planned_cut_depth_mm": plan.planned_depth_mm, "duration_s": float(plan.time_s[-1]),
                  "peak_force_n": float(np.max(plan.force_n)), "path_samples": int(path.time_s.size),
                  "specific_energy_j_mm3": process.specific_energy_j_mm3, "simulations": plan.simulations,
                  "requested_cut_depth_mm": request.cut_depth_mm, "material_left_mm": left,
                  "shape_raised_mm": raised}
        return PlannedPass(plan, path, process, scan.stamp_s, note, values, "; ".join(notes))

    def _plan_above_parent(self, contour: Contour, model, depth: float, feed: float, notes: list):
        """The plan, and how far (mm) its desired shape had to be raised over the parent so
        that its simulation stays within PARENT_TOLERANCE_MM of it (a finishing pass whose
        controller overshoots at a bead end)."""
        config, raised, warm_start = self.config, 0.0, self.warm_start
        for attempt in range(PARENT_RETRIES + 1):
            shape = None if raised == 0 else contour.parent_mm + raised
            if raised > 0:  # no more than what is left over the raised shape
                above = contour.area_above(shape) / contour.length_mm
                if not above > 0:
                    break
                depth = min(depth, above)
            plan = plan_forces(contour, model, depth, feed, config.planner, control=config.control, gains=config.gains,
                               step_mm=config.step_mm, compliance=config.compliance, shape_mm=shape,
                               warm_start=warm_start, contact_search=self.contact_search)
            warm_start = plan.warm_start or warm_start
            dip, at = parent_dip(plan, contour)
            if dip <= PARENT_TOLERANCE_MM:
                if raised > 0:
                    notes.append(f"desired shape raised {raised:.4f} mm over the parent (the simulated pass "
                                 f"cut below it)")
                return plan, raised
            raised += dip + PARENT_TOLERANCE_MM
        raise PlanningError(f"the plan cuts {dip:.4f} mm below the parent at x = {at:.1f} mm, even with its "
                            f"desired shape raised {raised - dip - PARENT_TOLERANCE_MM:.4f} mm")

    # -- after planning ------------------------------------------------------------------
    def planned(self, outcome: PlannedPass | Verdict, now_s: float) -> Verdict | None:
        """The plan of the command being planned: a Verdict (planned or refused), or None
        while its path waits for the reachability check."""
        request, self.planning = self.planning, None
        self.plans += 1
        if isinstance(outcome, PlannedPass):
            self.planning_s += outcome.planning_s
            if self.warm_starts:
                self.warm_start = outcome.plan.warm_start or self.warm_start
        if request.key in self.stopped:
            self.stopped.discard(request.key)
            return self._refuse(request, f"stopped: job {request.job_id!r} ended while pass {request.pass_index} "
                                         "was being planned", "stopped")
        if isinstance(outcome, Verdict):
            return self._answer(outcome)
        if self.check_reach:
            self.checking = (request, outcome, now_s)
            return None
        return self._answer(accepted(request, outcome))

    def reach_overdue(self, now_s: float) -> bool:
        return self.checking is not None and now_s - self.checking[2] > self.contour_wait_s

    def reach_answer(self, first_unreachable_index: int) -> Verdict:
        """TestPose's answer on :func:`checked_positions` of the path being checked."""
        request, planned, _ = self.checking
        self.checking = None
        if first_unreachable_index >= 0:
            x, y, z = checked_positions(planned.path)[first_unreachable_index]
            return self._refuse(request, f"path pose ({x:.1f}, {y:.1f}, {z:.1f}) mm (machine frame) is out of the "
                                         "machine's reach", "unreachable")
        return self._answer(accepted(request, planned))

    def reach_failed(self, reason: str) -> Verdict:
        request, self.checking = self.checking[0], None
        return self._refuse(request, reason, "unchecked")

    def _refuse(self, request: PassRequest, reason: str, kind: str) -> Verdict:
        return self._answer(refusal(request, reason, kind))

    def _answer(self, verdict: Verdict) -> Verdict:
        self.answered.add(verdict.request.key)
        return verdict
