"""The sequence planner's job logic, ROS-free: the top tier of seed 002 (section 3.3, Fig. 5-7).

A :class:`Sequencer` runs one grinding job at a time. For a goal it asks for the SDP policy
(the node solves it off its executor thread: :meth:`Sequencer.solve` is pure), commands the
pass the policy decides, and after every pass result looks the policy up at the measured
state until the policy ends the job. Every decision and result goes to the job log
(:class:`~hex_control.grinding.job.GrindingJob`) before it is acted on; a restarted planner
resumes an unfinished job from its log (:meth:`Sequencer.resume`), awaiting the pass it
had decided rather than deciding another.

The prediction made from pass k's measured K1 is the one for pass k+1: while a predictor
publishes, the decision after pass k waits for it (the prediction stamped like the pass
result), however late it comes on a loaded machine: it decides the job. A predictor gone
from the graph holds it ``prediction_wait_s``, a silent one on it ``prediction_stall_s``
(wall s). Each command carries that K1 down. A plan's force
(the pass planner's force trajectory) re-solves the policy with the force the plans reach.

A job's result is the truth (issue 37): every input is checked against what this tier
asked for and against the plant's scans.

- A pass result counts only for the pass in flight (job id and pass index of the command
  issued), stamped not before that command (a plant scan of the part before the pass,
  stamped earlier, marks a restarted plant clock); REJECTED only from the pass planner
  (the publisher's node when the transport tells it, else the pass planner's own refusal
  on its status topic); its numbers finite and consistent (no negative removal, no more
  than the material plus ``max_overgrind_mm``, volume = depth x w x L); and its removal
  equal to that of the plant's scans before and after the pass (the result is held until
  the scan after it arrives). A refused result is counted and said in a fault; the job
  waits for the true one.
- ABORTED and FAULTED passes are what the scanner measured: the state is re-decided from
  there, and the job's end message and log say which passes did not run as planned, and why.
- A goal is checked when it arrives: invalid values, bounds, and the bead it names against
  the plant's latest scan (length, mean height); a refused goal never starts.
- A job that ends with a pass in flight (cancelled, aborted) sends that pass's command again
  with ``stop`` set: the force controller retracts instead of grinding it to the end.
- A pass outstanding past its due time (planned duration x ``overdue_factor`` +
  ``overdue_margin_s``) is a WARN fault naming the pass and how late, ERROR past three
  times that, and ends the job ABORTED after ``pass_timeout_s``.

Times: the job's time is logical (measured pass durations); the watchdogs take the
caller's monotonic wall clock ``now_s``. Units: mm, N, s; stamps in ns of the plant clock.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from hex_control.config import config_file
from hex_control.grinding.coefficients import PassModelUpdate
from hex_control.grinding.config import parse_planner_config
from hex_control.grinding.job import (
    ABORTED,
    CANCELLED,
    REJECTED,
    GrindingJob,
    JobGoal,
    new_job_id,
    read_goal,
    read_model,
    unfinished_logs,
)
from hex_control.grinding.measured_part import (
    PartRule,
    Profile,
    amend_decision,
    pass_durations_s,
    prior_force_limit_n,
)
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.outlook import outlook
from hex_control.grinding.sdp import build_controls, solve
from hex_control.grinding.stochastic import CutDepthModel, planned_on_estimate

# PassResult.status, as on the wire
COMPLETED_PASS, ABORTED_PASS, REJECTED_PASS, FAULTED_PASS = 0, 1, 2, 3
STATUS_NAMES = {COMPLETED_PASS: "completed", ABORTED_PASS: "aborted", REJECTED_PASS: "rejected",
                FAULTED_PASS: "faulted"}
_KEPT_SCANS = 16  # the plant's latest scans kept (a job's passes before and after the one in flight)
#: the error of the planner's K1 (the pass-rate predictor's) against the level it estimates,
#: relative: the predictor's after the job's first pass (a 0.98, W 0.5, V 2.25 from its
#: stationary start: 13 %; 10 % after two passes, 8 % steady); the policy's cut model is then
#: ``stochastic.planned_on_estimate``'s (issue 42 item 2)
K1_ESTIMATE_CV = 0.13


@dataclass(frozen=True)
class SequencerSettings:
    """The sequence planner's parameters (the node's, one for one; wall times in s)."""

    job_dir: Path
    resolve_threshold: float = 0.05  # relative move of K1 or of the plans' force that re-solves
    pass_timeout_s: float = 300.0  # a pass outstanding this long ends the job ABORTED
    command_resend_s: float = 5.0  # an unacknowledged command is sent again after this; 0 = never
    prediction_wait_s: float = 2.0  # a decision waits this long for the K1 of the pass just measured, once
    # no predictor publishes; while one does, up to prediction_stall_s: an answer late on a loaded
    # machine is still the answer (deciding without it made a seeded job depend on the load)
    prediction_stall_s: float = 60.0
    max_deadline_s: float = 1800.0  # bounded work: the solve grows with the deadline
    max_material_mm: float = 20.0
    overdue_factor: float = 3.0  # a pass is overdue after factor x planned duration + margin
    overdue_margin_s: float = 10.0
    goal_length_tolerance_mm: float = 2.0  # a goal's bead length against the scanned (or 2 %)
    goal_height_tolerance_mm: float = 0.25  # a goal's mean height against the scanned (or 25 %)
    max_overgrind_mm: float = 2.0  # no pass removes more than the material plus this (the force axis's travel)
    scan_tolerance_mm: float = 1e-3  # a result's removal against the scans' (mm of mean height)
    k1_estimate_cv: float | None = K1_ESTIMATE_CV  # None: the configured cut model, the thesis's

    @classmethod
    def from_parameters(cls, value: Callable[[str], object]) -> SequencerSettings:
        """The settings from the node's parameters, one per field (``value(name)``): ``job_dir``
        a path, a ``k1_estimate_cv`` of 0 the configured cut model (None)."""
        values = {f.name: value(f.name) for f in dataclasses.fields(cls)}
        return cls(**values | {"job_dir": Path(values["job_dir"]), "k1_estimate_cv": values["k1_estimate_cv"] or None})


def policy_cut_model(cut_model: CutDepthModel, estimate_cv: float | None) -> tuple[CutDepthModel, float]:
    """The cut model the policy is solved with and the factor its K1 is divided by: a pass
    planned on the estimated K1 (``stochastic.planned_on_estimate``), or the configured model
    as it is (``estimate_cv`` None)."""
    return (cut_model, 1.0) if estimate_cv is None else planned_on_estimate(cut_model, estimate_cv)


@dataclass(frozen=True)
class GoalRequest:
    """A GrindBead goal's values (empty contour lists: the bead is given by its height)."""

    job_id: str = ""
    x_mm: tuple = ()
    z_mm: tuple = ()
    parent_mm: tuple = ()
    contour_width_mm: float = 0.0
    bead_height_mm: float = 0.0
    bead_width_mm: float = 0.0
    bead_length_mm: float = 0.0
    deadline_s: float = 0.0
    charges_yaml: str = ""
    process_yaml: str = ""


@dataclass(frozen=True)
class PassReport:
    """A PassResult's values (status as on the wire; stamp in ns of the plant clock)."""

    job_id: str
    pass_index: int
    status: int = COMPLETED_PASS
    reason: str = ""
    measured_cut_depth_mm: float = 0.0
    removed_volume_mm3: float = math.nan  # nan: not reported (not checked)
    duration_s: float = 0.0
    specific_energy_j_mm3: float = math.nan
    burn_detected: bool = False
    stamp_ns: int = 0


@dataclass(frozen=True)
class Scan:
    """A plant scan: the profile after ``passes`` passes of ``job_id`` ('' = not yet a job's)."""

    job_id: str
    passes: int
    length_mm: float
    height_mm: float  # mean height above the parent: the state X (thesis 4.7)
    width_mm: float
    stamp_ns: int


@dataclass(frozen=True)
class SolveRequest:
    goal: JobGoal
    process: Any  # GrindingProcess
    charges: Any  # Charges
    #: set when nobody will use the policy (its goal was cancelled): the solve stops at its next stage block
    abandoned: threading.Event = field(default_factory=threading.Event, compare=False)


class SolveAbandoned(Exception):
    """A solve stopped because its goal was cancelled (``SolveRequest.abandoned``)."""


@dataclass
class Outputs:
    """What the node sends after a call: commands (PassCommand values; resends and stops go
    without feedback), the job's end (its goal token and GrindBead.Result values), a policy
    to solve off the executor thread."""

    commands: list = field(default_factory=list)  # (values dict, a resend or stop: bool)
    #: of each new command, a call that returns its GrindBead.Feedback values (its values under
    #: "command"); the first says whether the deadline can be reached and the expected end
    #: state (issue 42 item 3). A call, so the node sends the commands before the outlook's
    #: rollouts (tens of ms) are run: the pass planner starts that much sooner.
    feedback: list = field(default_factory=list)
    finished: tuple | None = None  # (goal token or None, result dict, a job's end: also on ~/job_result)
    solve: SolveRequest | None = None


class MemoryHealth:
    """Counters, values and named faults in memory: the default sink (tests read it); the
    node hands in an adapter to its /diagnostics."""

    def __init__(self):
        self.counts: dict[str, int] = {}
        self.values: dict[str, str] = {}
        self.faults: dict[str, tuple[str, str]] = {}  # name -> (level "warn" | "error", message)

    def count(self, name: str, increment: int = 1) -> None:
        self.counts[name] = self.counts.get(name, 0) + increment

    def set(self, name: str, value) -> None:
        self.values[name] = value

    def fault(self, name: str, message: str, level: str = "warn", hold_s: float | None = None) -> None:
        self.faults[name] = (level, message)

    def clear(self, name: str) -> None:
        self.faults.pop(name, None)


def contour_height_mm(x_mm, z_mm, parent_mm=()) -> tuple[float, float]:
    """(length mm, mean height above the parent mm) of a profile, trapezoid rule; ValueError
    for a profile that is not one."""
    x, z = [float(v) for v in x_mm], [float(v) for v in z_mm]
    parent = [float(v) for v in parent_mm]
    if len(x) != len(z) or len(x) < 2 or parent and len(parent) != len(x):
        raise ValueError("bead contour needs equally long x_mm and z_mm (and parent_mm, if given) with at least "
                         "2 points")
    if not all(math.isfinite(v) for v in x + z + parent):
        raise ValueError("bead contour has non-finite points")
    if any(b <= a for a, b in zip(x, x[1:])):
        raise ValueError("bead contour x_mm must increase strictly")
    if parent:  # the height above the parent surface, not above the datum
        z = [a - b for a, b in zip(z, parent)]
    length = x[-1] - x[0]
    return length, sum((z0 + z1) / 2 * (x1 - x0) for x0, x1, z0, z1 in zip(x, x[1:], z, z[1:])) / length


def scan_height_mm(x_mm, z_mm, parent_mm=()) -> tuple[float, float]:
    """(length mm, mean height above the parent mm) of a scanned profile (numpy: a scan has
    up to 10^5 points); ValueError for one that is not a profile."""
    x, z = np.asarray(x_mm, float), np.asarray(z_mm, float)
    parent = np.asarray(parent_mm, float) if len(parent_mm) else np.zeros_like(z)
    if x.ndim != 1 or x.size < 2 or z.shape != x.shape or parent.shape != x.shape:
        raise ValueError("a profile needs equally long x_mm, z_mm (and parent_mm) with at least 2 points")
    if not (np.isfinite(x).all() and np.isfinite(z).all() and np.isfinite(parent).all()) or np.any(np.diff(x) <= 0):
        raise ValueError("a profile needs finite points and x_mm increasing strictly")
    length = float(x[-1] - x[0])
    return length, float(np.trapezoid(z - parent, x) / length)


def goal_from_request(request: GoalRequest) -> JobGoal:
    """Validate a goal into a JobGoal; ValueError with the reason otherwise."""
    if request.x_mm or request.z_mm:
        length, height = contour_height_mm(request.x_mm, request.z_mm, request.parent_mm)
    else:
        length, height = request.bead_length_mm, request.bead_height_mm
    width = request.bead_width_mm or request.contour_width_mm
    return JobGoal(request.job_id or new_job_id(), float(height), float(width), float(length),
                   float(request.deadline_s))


class Sequencer:
    """One job at a time, from goal to end; see the module docstring. ``predictor_heard()``
    says whether a K1 predictor publishes (the decision then waits for its prediction)."""

    def __init__(self, settings: SequencerSettings, planner_config: dict, health=None,
                 log: Callable[[str, str], None] | None = None,
                 predictor_heard: Callable[[], bool] = lambda: False):
        # the part as measured in the decisions (issue 42): its own section, the rest is the SDP's
        part = planner_config.get("measured_part")
        if part is None:
            part = (yaml.safe_load(config_file("measured_part.yaml").read_text()) or {}).get("measured_part")
        self.rule = PartRule(**(part or {}))
        planner_config = {k: v for k, v in planner_config.items() if k != "measured_part"}
        self.settings, self.base_config = settings, planner_config
        _, self.charges, self.grid, self.cut_model = parse_planner_config(planner_config)
        # the cut of a pass planned on the predictor's K1, which the policy is solved for
        self.policy_model, self.mean_factor = policy_cut_model(self.cut_model, settings.k1_estimate_cv)
        self._profile: tuple | None = None  # (job id, passes, Profile) of the plant's latest scan
        self._machine_force_n = math.nan  # the configured F_max of the job being started (N)
        self._goal_profile: Profile | None = None  # the running goal's bead, if the goal gave its profile
        self.health = health if health is not None else MemoryHealth()
        self.log = log or (lambda level, text: None)
        self.predictor_heard = predictor_heard
        self.job: GrindingJob | None = None
        self.token = None  # the running job's goal (the node's handle); None for a resumed job
        self.model_update: PassModelUpdate | None = None
        self.solving: tuple | None = None  # (purpose "start" | "resolve", goal token, goal) while solved
        self._solve_request: SolveRequest | None = None  # the request of the solve running
        self.last_solve_ms = math.nan
        self.command: dict | None = None  # the latest pass command issued
        self._sent_at = None  # wall s the latest command went out
        self._unacknowledged = None  # (command, wall s sent) until the pass planner has it
        self._advance_after_solve = False
        self._awaited = None  # (stamp ns of the pass result whose K1 prediction is awaited, since wall s)
        self._last_prediction_stamp = None
        self._result_stamp_ns = 0  # of the latest pass result applied (plant time)
        self._not_before_ns = 0  # a result for the pass in flight is stamped no earlier
        self._scans: deque[Scan] = deque(maxlen=_KEPT_SCANS)
        self._held = None  # (PassReport, source, wall s) awaiting the scan after it / the planner's refusal
        self._refusals: dict[tuple[str, int], str] = {}  # the pass planner's refusals on its status

    # -- solving -----------------------------------------------------------------------------
    def solve(self, request: SolveRequest) -> tuple:
        """The goal's policy: pure, for a worker thread; (process, policy, ms)."""
        goal = request.goal
        process = dataclasses.replace(request.process, bead_width_mm=goal.bead_width_mm,
                                      bead_length_mm=goal.bead_length_mm)
        start = time.perf_counter()

        def stop_if_abandoned(_stages):
            if request.abandoned.is_set():
                raise SolveAbandoned(f"the policy of {goal.job_id} is no longer wanted")

        policy = solve(self.as_planned(process), request.charges,
                       self.grid.covering(goal.deadline_s, goal.material_mm), self.policy_model,
                       progress=stop_if_abandoned)
        return process, policy, 1000 * (time.perf_counter() - start)

    def as_planned(self, process: GrindingProcess) -> GrindingProcess:
        """The process the policy is solved with: K1 over the mean factor of the policy's cut model
        (the mean cut of a pass planned on the estimated K1, ``planned_on_estimate``)."""
        return dataclasses.replace(process, specific_energy_j_mm3=process.specific_energy_j_mm3 / self.mean_factor)

    def _solved(self, solution: tuple) -> tuple:
        process, policy, self.last_solve_ms = solution
        self.health.set("last_solve_ms", f"{self.last_solve_ms:.1f}")
        self.health.count("solves")
        return process, policy

    def _request_solve(self, out: Outputs, purpose: str, goal: JobGoal, process, token=None) -> None:
        self.solving = (purpose, token, goal)
        out.solve = self._solve_request = SolveRequest(goal, process, self.charges)

    def on_solved(self, solution: tuple | BaseException, now_s: float) -> Outputs:
        """The policy asked for (``Outputs.solve``), or the exception its solve raised."""
        out = Outputs()
        (purpose, token, goal), self.solving = self.solving, None
        if isinstance(solution, SolveAbandoned):  # its goal was cancelled: nothing waits for it
            self.health.count("abandoned_solves")
            return out
        if isinstance(solution, BaseException):
            if not isinstance(solution, (ValueError, ArithmeticError, MemoryError)):
                raise solution
            self._advance_after_solve = False  # what waited for the policy ends here
            if purpose == "start" and token is not None:
                self.token = None
                self.health.count("rejected_goals")
                out.finished = (token, self._rejected_result(f"no policy could be solved: {solution}"), False)
            elif self.job is not None and not self.job.finished:
                self.job.end(ABORTED, f"the policy could not be re-solved: {solution}")
                self._finish(out)
            return out
        process, policy = self._solved(solution)
        if purpose == "start" and token is not None:
            self._start(goal, process, policy)
        elif purpose == "resolve":
            self._resolved(out, process, policy)
        if self._advance_after_solve:  # a cancelled start: nothing waits
            self._advance_after_solve = False
            if self.job is not None and not self.job.finished:
                self._advance(out, now_s)
        return out

    def _configured(self, overrides: dict):
        """(process, charges) of the configuration with a goal's overrides on top."""
        base = self.base_config
        config = {**base, **{k: {**base.get(k, {}), **v} for k, v in overrides.items()}}
        process, charges, _, _ = parse_planner_config(config)
        return process, charges

    # -- goals -------------------------------------------------------------------------------
    def check_goal(self, request: GoalRequest) -> tuple[JobGoal, Any, Any]:
        """(goal, process, charges) of an acceptable goal; ValueError with the reason, counted
        and said in a fault (for 10 s), otherwise."""
        try:
            if self.job is not None and not self.job.finished:
                raise ValueError(f"job {self.job.goal.job_id} is still running")
            if self.solving is not None:
                raise ValueError("the planner is still solving a policy")
            try:
                overrides = {name: yaml.safe_load(text) for name, text in
                             (("charges", request.charges_yaml), ("process", request.process_yaml))}
                goal = dataclasses.replace(goal_from_request(request),
                                           config_overrides={k: v for k, v in overrides.items() if v})
                self._check_bounds(goal)
                process, charges = self._configured(goal.config_overrides)
            except (TypeError, yaml.YAMLError, AttributeError) as exc:
                raise ValueError(str(exc)) from None
            self._check_against_scan(goal)
        except ValueError as exc:
            self.health.count("rejected_goals")
            self.health.fault("goal", f"goal rejected: {exc}", "warn", hold_s=10.0)
            self.log("warn", f"goal rejected: {exc}")
            raise
        return goal, process, charges

    def _check_bounds(self, goal: JobGoal) -> None:
        """Bounded work: a goal whose policy would take unbounded time and memory is refused."""
        for value, name, unit in ((goal.deadline_s, "max_deadline_s", "s"),
                                  (goal.material_mm, "max_material_mm", "mm")):
            limit = getattr(self.settings, name)
            if value > limit:
                raise ValueError(f"{name.removeprefix('max_')} {value:g} {unit} is beyond this planner's {name} "
                                 f"({limit:g} {unit})")

    def _check_against_scan(self, goal: JobGoal) -> None:
        """The goal's bead against the bead on the machine (the plant's latest scan): a job
        planned for another bead runs passes that take other times and leave other material."""
        scan = self._scans[-1] if self._scans else None
        if scan is None:
            return  # no scanner heard (a planner alone): nothing to check against
        s = self.settings
        length_tolerance = max(s.goal_length_tolerance_mm, 0.02 * scan.length_mm)
        if abs(goal.bead_length_mm - scan.length_mm) > length_tolerance:
            raise ValueError(f"bead_length_mm {goal.bead_length_mm:g} mm is not the scanned bead's "
                             f"{scan.length_mm:g} mm (tolerance {length_tolerance:g} mm)")
        height_tolerance = max(s.goal_height_tolerance_mm, 0.25 * scan.height_mm)
        if abs(goal.material_mm - scan.height_mm) > height_tolerance:
            raise ValueError(f"bead height {goal.material_mm:.3f} mm is far from the scanned bead's mean height "
                             f"{scan.height_mm:.3f} mm (tolerance {height_tolerance:.3f} mm)")

    def accept(self, request: GoalRequest, token, now_s: float) -> Outputs:
        """Start the accepted goal: its policy is solved first (``Outputs.solve``)."""
        out = Outputs()
        try:
            goal, process, self.charges = self.check_goal(request)
        except ValueError as exc:  # the state changed since the goal's response
            out.finished = (token, self._rejected_result(str(exc)), False)
            return out
        self.token = token
        self._advance_after_solve = True
        self._machine_force_n = process.force_max_n
        # the goal's own profile (the demo sends the plant's scan), else the plant's scan before
        # any pass: a goal with its profile is decided the same whether or not the scan came first
        self._goal_profile = Profile(request.x_mm, request.z_mm, request.parent_mm) if request.x_mm else None
        self._request_solve(out, "start", goal, self._with_prior_force(goal, process), token)
        return out

    def _with_prior_force(self, goal: JobGoal, process):
        """The process with F_max lowered to the force the pass planner's guard lets its plans
        reach on the bead (``measured_part.prior_force_limit_n``; no profile: unchanged)."""
        profile = self._goal_profile
        if profile is None and self._profile is not None and self._profile[1] == 0:
            profile = self._profile[2]
        if profile is None:
            return process
        sized = dataclasses.replace(process, bead_width_mm=goal.bead_width_mm, bead_length_mm=goal.bead_length_mm)
        feeds = build_controls(sized, self.grid.covering(goal.deadline_s, goal.material_mm), self.cut_model).feeds_mm_s
        prior = prior_force_limit_n(profile, sized, feeds, self.rule)
        self.log("info", f"the plans can reach about {prior:.1f} N on the scanned bead "
                         f"(F_max {process.force_max_n:g} N)")
        return dataclasses.replace(process, force_max_n=prior)

    def _rejected_result(self, reason: str) -> dict:
        return {"reason": REJECTED, "message": reason, "passes": 0, "material_remaining_mm": 0.0,
                "time_remaining_s": 0.0, "lateness_s": 0.0, "total_charge": 0.0}

    def _start(self, goal: JobGoal, process, policy) -> None:
        self.job = GrindingJob(goal, policy, self.charges, self.settings.job_dir / f"{goal.job_id}.jsonl")
        machine = process.force_max_n if math.isnan(self._machine_force_n) else self._machine_force_n
        self.model_update = PassModelUpdate(dataclasses.replace(process, force_max_n=machine),
                                            self.settings.resolve_threshold)
        self.model_update.observe_force_limit(process.force_max_n)  # the prior the policy was solved with
        self.model_update.mark_solved()
        if process.force_max_n != machine:
            self._model_changed(Outputs())
        self._not_before_ns = self._result_stamp_ns = 0
        self._refusals.clear()
        self.log("info", f"job {goal.job_id}: X0 = {goal.material_mm:.3f} mm, deadline {goal.deadline_s:g} s, "
                         f"policy solved in {self.last_solve_ms:.0f} ms")

    def resume(self, now_s: float) -> Outputs:
        """Take up the newest unfinished job in ``job_dir`` (at start-up: solves here)."""
        out = Outputs()
        job_dir = self.settings.job_dir
        logs = unfinished_logs(job_dir) if job_dir.is_dir() else []
        if not logs:
            return out
        goal = read_goal(logs[-1])
        process, self.charges = self._configured(goal.config_overrides)
        self._goal_profile = None
        self.model_update = PassModelUpdate(process, self.settings.resolve_threshold)
        if model := read_model(logs[-1]):  # plan with the estimates the job had before the restart
            self.model_update.restore(model["specific_energy_j_mm3"], model["solved_with_j_mm3"],
                                      model.get("force_max_n"), model.get("solved_force_max_n"))
        _, policy = self._solved(self.solve(SolveRequest(goal, self.model_update.solved_process, self.charges)))
        self.job = GrindingJob.resume(logs[-1], policy, self.charges)
        self.log("info", f"resumed job {goal.job_id} at pass {self.job.state.passes} "
                         f"(t = {self.job.state.time_remaining_s:.1f} s, X = {self.job.state.material_mm:.3f} mm)")
        self.health.count("resumed_jobs")
        self._advance(out, now_s)
        return out

    def cancel(self, token) -> Outputs | None:
        """Cancel the goal ``token``: the outputs, or None to refuse (not the running goal)."""
        out = Outputs()
        if token is None or self.token is not token:
            return None
        if self.solving is not None and self.solving[1] is token:  # before its job began
            self.solving = (self.solving[0], None, self.solving[2])  # its policy is dropped
            self._solve_request.abandoned.set()  # and the solve stops at its next stage block
            self._advance_after_solve, self.token = False, None
            out.finished = (token, {**self._rejected_result("cancelled while its policy was solved"),
                                    "reason": CANCELLED}, False)
            return out
        if self.job is None or self.job.finished:
            return None
        self.job.end(CANCELLED, "cancelled by the client")
        self._finish(out)
        return out

    # -- passes ------------------------------------------------------------------------------
    def _advance(self, out: Outputs, now_s: float) -> None:
        if self.solving is not None:  # decide on the policy being solved
            self._advance_after_solve = True
            return
        decision = self.job.decide(amend=self._amend)
        if decision is None:
            self._finish(out)
            return
        process = self.model_update.process  # one K1 for the cut depth here and the force downstream
        cut = decision.get("cut_depth_mm")  # a finishing pass's (measured_part); else eq. 4.6's
        command = {"stamp_ns": self._result_stamp_ns,  # the plant time of the state decided on
                   "job_id": self.job.goal.job_id, "pass_index": decision["pass_index"],
                   "normal_force_n": decision["force_n"], "feed_speed_mm_s": decision["feed_mm_s"],
                   "cut_depth_mm": float(process.cut_depth_mm(decision["force_n"], decision["feed_mm_s"])
                                         if cut is None else cut),
                   "specific_energy_j_mm3": float(process.specific_energy_j_mm3),
                   "pass_duration_s": decision["duration_s"], "material_remaining_mm": decision["material_mm"],
                   "time_remaining_s": decision["time_remaining_s"], "expected_penalty": decision["expected_penalty"]}
        self.command, self._sent_at = command, now_s
        self._not_before_ns = self._result_stamp_ns
        self._unacknowledged = (command, now_s)
        self._held = None
        self.health.clear("overdue")
        out.commands.append((command, False))
        out.feedback.append(functools.partial(self._feedback, command, decision))

    def _profile_now(self) -> Profile | None:
        """The plant's scan of the job's part as it now is (after the passes applied), if here."""
        if self.job.state.passes == 0 and self._goal_profile is not None:
            return self._goal_profile
        if self._profile is None:
            return None
        job_id, passes, profile = self._profile
        return profile if job_id in ("", self.job.goal.job_id) and passes == self.job.state.passes else None

    def _amend(self, time_remaining_s: float, material_mm: float, decision: dict) -> dict:
        """The policy's decision with the scan's local state in it (``measured_part.amend_decision``)."""
        policy = self.job.policy
        planned = GrindingProcess.from_dict(policy.metadata["process"])
        feeds, step_s = policy.metadata["feeds_mm_s"], float(policy.time_s[1] - policy.time_s[0])
        amended = amend_decision(decision, profile=self._profile_now(), process=self.model_update.process,
                                 rule=self.rule, time_remaining_s=time_remaining_s,
                                 stage_time_s=decision["stage_time_s"], feeds_mm_s=feeds,
                                 durations_s=pass_durations_s(planned, feeds, step_s))
        if amended is not decision:
            self.health.count("finishing_passes")
            self.log("info", f"pass {self.job.state.passes}: {amended['finish']}")
        return amended

    def _feedback(self, command: dict, decision: dict) -> dict:
        """GrindBead.Feedback values of a new command: where the job stands and can still get to."""
        state = self.job.state
        rollouts = self.rule.outlook_rollouts  # the first in full; later a quarter (the executor's time)
        seen = outlook(self.job.policy, self.as_planned(self.model_update.solved_process), self.charges,
                       self.policy_model,
                       time_remaining_s=state.time_remaining_s, material_mm=state.material_mm,
                       rollouts=rollouts if command["pass_index"] == 0 else max(1, rollouts // 4))
        if not seen.reachable:
            self.health.fault("deadline", seen.note, "warn", hold_s=30.0)
        note = "; ".join(filter(None, (decision.get("finish", ""), seen.note)))
        return {"pass_index": command["pass_index"], "material_remaining_mm": state.material_mm,
                "time_remaining_s": state.time_remaining_s, "expected_penalty": command["expected_penalty"],
                "deadline_reachable": seen.reachable, "expected_final_material_mm": seen.expected_final_mm,
                "note": note, "command": command}

    def _finish(self, out: Outputs, stop: bool = True) -> None:
        """End: the result, and a stop of the pass in flight, if one is (issue 37: a cancelled
        pass was ground to the end), unless ``stop`` is False (nothing of it runs)."""
        self._awaited = None  # a cancel while a prediction was awaited
        state = self.job.state
        if stop and state.pending is not None and self.command is not None \
                and self.command["pass_index"] == state.pending["pass_index"]:
            out.commands.append(({**self.command, "stop": True}, True))  # the force controller retracts
            self.health.count("passes_stopped")
        end = state.end
        result = {"reason": end["reason"], "message": end["message"], "passes": state.passes,
                  "material_remaining_mm": state.material_mm, "time_remaining_s": state.time_remaining_s,
                  "lateness_s": max(0.0, -state.time_remaining_s), "total_charge": end["charge"]}
        self.health.count(f"jobs_{end['reason']}")
        if state.not_as_planned:
            self.health.set("passes_not_as_planned", str(len(state.not_as_planned)))
        self.log("info", f"job {self.job.goal.job_id} ended: {end['reason']}, {state.passes} passes, "
                         f"charge {end['charge']:.4f}{self.job.not_as_planned_text()}")
        self._sent_at = self._unacknowledged = self._held = None
        self.health.clear("overdue")
        out.finished, self.token = (self.token, result, True), None

    def on_result(self, report: PassReport, source: str | None, now_s: float) -> Outputs:
        """A pass result from ``source`` ('plant', 'pass_planner'; None: the transport cannot
        tell), checked against the pass in flight and the plant's scans before it counts."""
        out = Outputs()
        job = self.job
        pending = job.state.pending if job is not None else None
        if pending is None or report.job_id != job.goal.job_id or report.pass_index != pending["pass_index"]:
            self.health.count("ignored_results")  # another pass's, a redelivery, another job's
            return out
        k = report.pass_index
        if report.stamp_ns < self._not_before_ns:
            return self._refuse(out, f"pass {k} result stamped {report.stamp_ns * 1e-9:.3f} s, before its command "
                                     f"({self._not_before_ns * 1e-9:.3f} s)")
        if report.status == REJECTED_PASS:  # the pass planner cannot plan it: nothing was ground
            if source is not None and source != "pass_planner":
                return self._refuse(out, f"pass {k} REJECTED by {source}, not by the pass planner")
            if source is None and (report.job_id, k) not in self._refusals:
                self._held = (report, source, now_s)  # until the pass planner's status says it refused it
                return out
            # the first pass refused (e.g. the bead is out of the machine's reach): the goal is
            # what cannot be done; later: the job cannot go on
            job.end(REJECTED if k == 0 else ABORTED, f"pass {k} rejected: {report.reason}")
            self._finish(out, stop=False)
            return out
        if report.status not in STATUS_NAMES:
            return self._refuse(out, f"pass {k} result with unknown status {report.status}")
        cut, duration = report.measured_cut_depth_mm, report.duration_s
        if not (math.isfinite(cut) and math.isfinite(duration)) or duration < 0 or abs(cut) > 100:
            self.log("warn", f"pass result with invalid values {(cut, duration)} rejected")
            return self._refuse(out, f"pass {k} result with invalid values (cut {cut} mm, {duration} s)")
        verdict = self._inconsistency(report)
        if verdict is not None:
            return self._refuse(out, f"pass {k} result refused: {verdict}")
        before, after = self._scan_of(report.job_id, k), self._scan_of(report.job_id, k + 1)
        if before is not None and after is None:
            self._held = (report, source, now_s)  # the plant scans before it reports: the scan is on its way
            return out
        if before is not None and abs((before.height_mm - after.height_mm) - cut) > self.settings.scan_tolerance_mm:
            return self._refuse(out, f"pass {k} result refused: cut {cut:.4f} mm, the plant's scans show "
                                     f"{before.height_mm - after.height_mm:.4f} mm removed")
        self._apply(out, report, now_s)
        return out

    def _inconsistency(self, report: PassReport) -> str | None:
        """Why a result's numbers cannot be a pass on this bead; None if they can."""
        cut, x = report.measured_cut_depth_mm, self.job.state.material_mm
        tolerance = self.settings.scan_tolerance_mm
        if cut < -tolerance:
            return f"negative removal {cut:.4f} mm"
        if cut > x + self.settings.max_overgrind_mm:
            return f"removal {cut:.4f} mm beyond the {x:.4f} mm of material plus {self.settings.max_overgrind_mm:g} mm"
        volume = report.removed_volume_mm3
        if math.isfinite(volume) and (volume or cut):
            area = self.job.goal.bead_width_mm * self.job.goal.bead_length_mm
            if abs(volume - cut * area) > 0.05 * abs(cut * area) + tolerance * area:
                return f"removed volume {volume:.1f} mm^3 is not the cut {cut:.4f} mm x w x L ({cut * area:.1f} mm^3)"
        elif not math.isfinite(volume) and not math.isnan(volume):
            return f"removed volume {volume}"
        return None

    def _refuse(self, out: Outputs, reason: str) -> Outputs:
        self.health.count("rejected_results")
        self.health.fault("result", reason, "warn", hold_s=10.0)
        self.log("warn", reason)
        return out

    def _apply(self, out: Outputs, report: PassReport, now_s: float) -> None:
        self._held = None
        status = STATUS_NAMES[report.status]
        self.job.apply_result(report.pass_index, report.measured_cut_depth_mm, report.duration_s,
                              status=status, reason=report.reason if status != "completed" else "")
        if status != "completed":  # the scan is the truth: re-decided from what it measured
            self.health.count(f"passes_{status}")
            self.health.fault("last_pass", f"pass {report.pass_index} {status}: {report.reason}", "warn",
                              hold_s=30.0)
        self._unacknowledged = None
        self._result_stamp_ns = report.stamp_ns
        if report.burn_detected:  # until a pass without
            self.health.fault("burn", f"burn reported on pass {report.pass_index}")
        else:
            self.health.clear("burn")
        if (self.settings.prediction_wait_s > 0 and report.stamp_ns != self._last_prediction_stamp
                and self.model_update.plausible(report.specific_energy_j_mm3) and self.predictor_heard()):
            self._awaited = (report.stamp_ns, now_s)
            return
        self._advance(out, now_s)

    def _scan_of(self, job_id: str, passes: int) -> Scan | None:
        """The plant's latest scan of this job's part after ``passes`` passes."""
        return next((s for s in reversed(self._scans) if s.passes == passes and s.job_id in ("", job_id)), None)

    def on_scan(self, job_id: str, passes: int, x_mm, z_mm, *, parent_mm, width_mm: float, stamp_ns: int,
                now_s: float) -> Outputs:
        """A plant scan (grinding/contour): the bead goals are checked against, and the removal
        pass results are checked against. A held result is taken up once its scan is here."""
        out = Outputs()
        try:
            length, height = scan_height_mm(x_mm, z_mm, parent_mm)
        except ValueError as exc:
            self.health.count("rejected_scans")
            self.log("debug", f"scan refused: {exc}")
            return out
        scan = Scan(job_id, int(passes), length, height, float(width_mm), int(stamp_ns))
        self._scans.append(scan)
        self._profile = (job_id, int(passes), Profile(x_mm, z_mm, parent_mm))
        self.health.set("scanned_bead", f"{length:g} mm long, {height:.3f} mm mean height after {passes} passes")
        pending = self.job.state.pending if self.job is not None and not self.job.finished else None
        if (pending is not None and scan.job_id in ("", self.job.goal.job_id) and scan.passes == pending["pass_index"]
                and scan.stamp_ns < self._not_before_ns):
            # the part before the pass in flight, scanned earlier than the command: the plant
            # restarted (its clock from zero): results are stamped on its new clock
            self._not_before_ns = scan.stamp_ns
            self.health.count("plant_clock_restarts")
        if self._held is not None and self._held[0].status != REJECTED_PASS:
            report, source, _ = self._held
            self._held = None
            return self.on_result(report, source, now_s)
        return out

    def on_pass_planner_status(self, job_id: str, pass_index: str, error: bool, message: str,
                               now_s: float) -> Outputs:
        """The pass planner's status (received, planned, or refused when ``error``)."""
        out = Outputs()
        if self._unacknowledged and (job_id, pass_index) == (self._unacknowledged[0]["job_id"],
                                                              str(self._unacknowledged[0]["pass_index"])):
            self._unacknowledged = None  # received, planned or refused: the pass planner has it
        if error and pass_index.isdigit():
            self._refusals[(job_id, int(pass_index))] = message
            if len(self._refusals) > _KEPT_SCANS:
                del self._refusals[next(iter(self._refusals))]
            held = self._held
            if held is not None and held[0].status == REJECTED_PASS and (held[0].job_id, held[0].pass_index) == (
                    job_id, int(pass_index)):
                self._held = None
                return self.on_result(held[0], held[1], now_s)
        return out

    # -- the process model ------------------------------------------------------------------
    def on_prediction(self, value: float, stamp_ns: int, now_s: float) -> Outputs:
        """A K1 estimate (J/mm^3) from the pass-rate predictor, stamped like the result it follows."""
        out = Outputs()
        if self.model_update is None or self.job is None or self.job.finished:
            return out
        if not self.model_update.plausible(value):
            self.health.count("rejected_predictions")
        else:
            self.model_update.observe(value)
            self._model_changed(out)
        self._last_prediction_stamp = stamp_ns
        if self._awaited and self._awaited[0] == stamp_ns:
            self._awaited = None
            self._advance(out, now_s)
        return out

    def on_trajectory(self, job_id: str, pass_index: int, forces_n, planned_cut_mm: float) -> Outputs:
        """The pass planner's plan of the pass in flight: the force its plans can reach."""
        out, command = Outputs(), self.command
        if (self.job is None or self.job.finished or command is None or job_id != command["job_id"]
                or pass_index != command["pass_index"]):
            return out
        forces = np.asarray(forces_n, float)
        peak = float(np.max(forces)) if forces.size else math.nan  # NaN if any is: refused below
        # the pass planner caps a cut deeper than the material left (issue 37 item 1): that cap
        # says nothing of the force its plans can reach
        commanded_mm = command["cut_depth_mm"]
        if command["material_remaining_mm"] > 0:
            commanded_mm = min(commanded_mm, command["material_remaining_mm"])
        try:
            self.model_update.observe_plan(command["normal_force_n"], commanded_mm, planned_cut_mm, peak)
        except ValueError as exc:  # a plan with no force, or a command that cuts nothing
            self.health.count("unused_trajectories")
            self.log("debug", f"plan of pass {pass_index} says nothing about the force limit: {exc}")
            return out
        self._model_changed(out)
        return out

    def _model_changed(self, out: Outputs) -> None:
        """Log the process model; re-solve when it moved (after the solve running, if one is)."""
        update = self.model_update
        self.job.update_model(update.process.specific_energy_j_mm3, update.solved_with, update.process.force_max_n,
                              update.solved_force_max_n)
        if update.needs_solve and self.solving is None:
            self._request_solve(out, "resolve", self.job.goal, update.process)

    def _resolved(self, out: Outputs, process, policy) -> None:
        if self.job is None or self.job.finished:
            return
        self.job.policy = policy
        self.model_update.mark_solved(process)
        self.log("info", f"K1 now {process.specific_energy_j_mm3:.3f} J/mm^3, force limit "
                         f"{process.force_max_n:.1f} N: policy re-solved in {self.last_solve_ms:.0f} ms")
        self._model_changed(out)

    # -- watchdog ----------------------------------------------------------------------------
    def tick(self, now_s: float) -> Outputs:
        """Once a second: the prediction wait, resends, a pass overdue; whether a K1 predictor is
        heard, on the health report (``k1_predictor``: a job session starts once it is)."""
        out, s = Outputs(), self.settings
        self.health.set("k1_predictor", "heard" if self.predictor_heard() else "none")
        waited_s = now_s - self._awaited[1] if self._awaited else 0.0
        if waited_s > s.prediction_stall_s or (waited_s > s.prediction_wait_s and not self.predictor_heard()):
            self._awaited = None
            self.health.count("prediction_timeouts")
            self.log("warn", "no K1 prediction for the pass just measured: deciding without it")
            self._advance(out, now_s)
        if self._sent_at is None or self.job is None or self.job.finished:
            return out
        if self._unacknowledged and s.command_resend_s > 0 and now_s - self._unacknowledged[1] > s.command_resend_s:
            command = self._unacknowledged[0]
            out.commands.append((command, True))  # the pass planner ignores a command it already has
            self._unacknowledged = (command, now_s)
            self.health.count("commands_resent")
            self.log("warn", f"pass {command['pass_index']} not acknowledged by the pass planner after "
                             f"{s.command_resend_s:g} s: command sent again")
        if self._held is not None and now_s - self._held[2] > s.prediction_wait_s:
            self.health.fault("held_result", f"pass {self._held[0].pass_index} result held {now_s - self._held[2]:.0f}"
                                             " s: no plant scan after it (or pass planner refusal) confirms it")
        else:
            self.health.clear("held_result")
        self._watch_overdue(out, now_s)
        return out

    def _watch_overdue(self, out: Outputs, now_s: float) -> None:
        if self.job.state.pending is None or self.command is None:
            return  # decided on: a prediction or a solve is awaited, not a pass
        s, k = self.settings, self.command["pass_index"]
        age = now_s - self._sent_at
        due = s.overdue_factor * self.command["pass_duration_s"] + s.overdue_margin_s
        if age > s.pass_timeout_s:
            self.job.end(ABORTED, f"pass {k} outstanding {age:.0f} s, {age - due:.0f} s past its due {due:.0f} s "
                                  f"(planned {self.command['pass_duration_s']:.1f} s): no pass result before the "
                                  f"timeout ({s.pass_timeout_s:g} s)")
            self._finish(out)
            self.health.fault("overdue", f"job ended: pass {k} had no result after {age:.0f} s", "error", hold_s=60.0)
        elif age > due:
            level = "error" if age > 3 * due else "warn"
            self.health.fault("overdue", f"pass {k} outstanding {age:.0f} s, {age - due:.0f} s past its due "
                                         f"{due:.0f} s (planned {self.command['pass_duration_s']:.1f} s)", level)
