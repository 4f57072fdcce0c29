"""A grinding job driven by a policy, with an append-only log that survives restarts.

The top tier of seed 002 (section 3.3, Fig. 5-7): after every pass the planner looks the
policy up at the measured state (time and material remaining) and decides the next pass,
or ends the job. Every goal, decision, pass result, process-model update and end is
appended to a JSON-lines log *before* it is acted on, so a restarted planner replays the
log and resumes at the last recorded state: a decided pass whose result has not arrived
is awaited, never re-issued.

Units: mm, N, s; charges in currency units.
"""

from __future__ import annotations

import json
import math
import uuid
from dataclasses import asdict, dataclass, field
from pathlib import Path

from hex_control.grinding.sdp import Charges, Policy

DONE, QUIT, CANCELLED, ABORTED, REJECTED = "done", "quit", "cancelled", "aborted", "rejected"


@dataclass(frozen=True)
class JobGoal:
    job_id: str
    material_mm: float  # mean bead height to remove, X0
    bead_width_mm: float
    bead_length_mm: float
    deadline_s: float
    #: the goal's own planner settings over the node's configuration, e.g. {"process":
    #: {"reset_time_s": 4.2}}: logged with the goal so that a resumed job plans as it began
    config_overrides: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in ("material_mm", "bead_width_mm", "bead_length_mm", "deadline_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not self.job_id or "/" in self.job_id:
            raise ValueError(f"job_id must be a non-empty name without '/', got {self.job_id!r}")


@dataclass
class JobState:
    time_remaining_s: float
    material_mm: float
    passes: int = 0
    in_path_charge: float = 0.0
    pending: dict | None = None  # the decided pass awaiting its result
    end: dict | None = None
    history: list = field(default_factory=list)
    #: passes that did not run as planned: (pass index, "aborted" | "faulted", the reason)
    not_as_planned: list = field(default_factory=list)


class GrindingJob:
    """One job: decide passes from ``policy``, apply measured results, end by the policy."""

    def __init__(self, goal: JobGoal, policy: Policy, charges: Charges, log_path: Path, replay: bool = False):
        self.goal, self.policy, self.charges, self.log_path = goal, policy, charges, Path(log_path)
        self.state = JobState(goal.deadline_s, goal.material_mm)
        if not replay:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            self._append({"type": "goal", **asdict(goal)})

    # -- log ---------------------------------------------------------------------------
    def _append(self, record: dict) -> None:
        with open(self.log_path, "a") as log:
            log.write(json.dumps(record) + "\n")
            log.flush()

    @classmethod
    def resume(cls, log_path: Path, policy: Policy, charges: Charges) -> GrindingJob:
        """Rebuild a job from its log (a torn last line from a crash is ignored)."""
        records = read_log(log_path)
        job = cls(read_goal(log_path), policy, charges, log_path, replay=True)
        for record in records[1:]:
            job._apply(record)
        return job

    def _apply(self, record: dict) -> None:
        kind = record["type"]
        if kind == "decision":
            self.state.pending = record
        elif kind == "idle":
            self.state.time_remaining_s = record["time_remaining_s"]
        elif kind == "result":
            self.state.time_remaining_s = record["time_remaining_s"]
            self.state.material_mm = record["material_mm"]
            self.state.passes += 1
            self.state.in_path_charge += record["in_path_charge"]
            self.state.pending = None
            self.state.history.append(record)
            status = record.get("status", "completed" if record.get("completed", True) else "aborted")
            if status != "completed":
                self.state.not_as_planned.append((record["pass_index"], status, record.get("reason", "")))
        elif kind == "end":
            self.state.end = record

    def _record(self, record: dict) -> None:
        self._append(record)  # first on disk, then in memory: a crash in between replays it
        self._apply(record)

    # -- decisions -----------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        return self.state.end is not None

    def final_charge(self) -> float:
        late = max(0.0, -self.state.time_remaining_s)
        lateness = float(self.charges.lateness(late)) if late > 0 else 0.0
        return float(self.charges.deadline(self.state.material_mm)) + lateness + self.state.in_path_charge

    def decide(self, amend=None) -> dict | None:
        """The next pass to run (also returned again while it is pending), or None when the
        job has ended by the policy's own logic. ``amend(t, x, decision)`` (optional) returns
        the policy's decision at (t s, X mm) with what the scan shows locally in it
        (``measured_part.amend_decision``): a pass it adds carries its mean ``cut_depth_mm``
        and why (``finish``)."""
        if self.finished:
            return None
        if self.state.pending is not None:
            return self.state.pending
        step = self.policy.time_s[1] - self.policy.time_s[0]
        while True:
            t, x = self.state.time_remaining_s, self.state.material_mm
            decision = self.policy.lookup(t, x)
            if amend is not None:
                decision = amend(t, x, decision)
            if decision["action"] == "grind":
                record = {"type": "decision", "pass_index": self.state.passes, "time_remaining_s": t,
                          "material_mm": x, "force_n": decision["force_n"], "feed_mm_s": decision["feed_mm_s"],
                          "duration_s": decision["duration_s"], "expected_penalty": decision["expected_penalty"],
                          "cut_depth_mm": decision.get("cut_depth_mm"), "finish": decision.get("finish", "")}
                self._record(record)
                return record
            fastest_feed = max(self.policy.metadata["feeds_mm_s"])
            shortest_s = self.goal.bead_length_mm / fastest_feed + self.policy.metadata["process"]["reset_time_s"]
            if (decision["action"] == "wait" and x > self.charges.deadline.tolerance_mm
                    and t - step >= shortest_s):
                self._record({"type": "idle", "time_remaining_s": t - step})  # a pass starts later
                continue
            within = 0.0 <= x <= self.charges.deadline.tolerance_mm
            self.end(DONE if within else QUIT, "policy ends the job")
            return None

    def not_as_planned_text(self) -> str:
        """'' when every pass ran as planned; else '; 2 of 5 passes not as planned: pass 1
        faulted (cut short), ...' -- a job's end must say so (issue 37 item 2)."""
        bad = self.state.not_as_planned
        if not bad:
            return ""
        each = ", ".join(f"pass {k} {status}" + (f" ({reason})" if reason else "") for k, status, reason in bad)
        return f"; {len(bad)} of {self.state.passes} passes not as planned: {each}"

    def apply_result(self, pass_index: int, cut_mm: float, duration_s: float, completed: bool = True,
                     *, status: str | None = None, reason: str = "") -> None:
        """Measured outcome of the pending pass (also of an aborted or faulted one: the
        removal measured by the scanner is what happened). ``status``: "completed",
        "aborted" or "faulted" (default from ``completed``); ``reason``: why not completed."""
        status = status or ("completed" if completed else "aborted")
        if status not in ("completed", "aborted", "faulted"):
            raise ValueError(f"unknown pass status {status!r}")
        pending = self.state.pending
        if pending is None or pass_index != pending["pass_index"]:
            raise ValueError(f"no pending pass {pass_index}")
        if not (math.isfinite(cut_mm) and math.isfinite(duration_s) and duration_s >= 0):
            raise ValueError("measured cut and duration must be finite, duration >= 0")
        finish = self.charges.in_path.surface_finish_per_mm_s * pending["feed_mm_s"]
        x, t = self.state.material_mm - cut_mm, self.state.time_remaining_s - duration_s
        last = self.policy.lookup(t, x)["action"] != "grind"
        self._record({"type": "result", "pass_index": pass_index, "cut_mm": cut_mm, "duration_s": duration_s,
                      "completed": status == "completed", "status": status, "reason": reason,
                      "material_mm": x, "time_remaining_s": t,
                      "in_path_charge": self.charges.in_path.per_pass + (finish if last else 0.0)})

    def update_model(self, specific_energy_j_mm3: float, solved_with_j_mm3: float, force_max_n: float,
                     solved_force_max_n: float) -> None:
        """Log the planner's process model: the latest K1 estimate (J/mm^3; commands' cut
        depths use it) and the force the plans can reach (N), and those the current policy
        was solved with."""
        self._record({"type": "model", "specific_energy_j_mm3": specific_energy_j_mm3,
                      "solved_with_j_mm3": solved_with_j_mm3, "force_max_n": force_max_n,
                      "solved_force_max_n": solved_force_max_n})

    def end(self, reason: str, message: str = "") -> None:
        """End the job; the message says which passes did not run as planned, if any."""
        if not self.finished:
            message += self.not_as_planned_text()
            self._record({"type": "end", "reason": reason, "message": message, "charge": self.final_charge(),
                          "material_mm": self.state.material_mm, "time_remaining_s": self.state.time_remaining_s,
                          "passes": self.state.passes,
                          "not_as_planned": [list(entry) for entry in self.state.not_as_planned]})


def read_log(log_path: Path) -> list[dict]:
    """A job log's records, in order (goal first)."""
    records = []
    for line in Path(log_path).read_text().splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            break  # torn by a crash mid-write: what follows was never acted on
    if not records or records[0].get("type") != "goal":
        raise ValueError(f"{log_path} is not a job log")
    return records


def read_model(log_path: Path) -> dict | None:
    """The last process-model update on a job log (see ``GrindingJob.update_model``), if any."""
    models = [r for r in read_log(log_path) if r["type"] == "model"]
    return models[-1] if models else None


def read_goal(log_path: Path) -> JobGoal:
    """The goal recorded on a job log's first line."""
    first = json.loads(Path(log_path).read_text().split("\n", 1)[0])
    if first.get("type") != "goal":
        raise ValueError(f"{log_path} is not a job log")
    return JobGoal(**{k: v for k, v in first.items() if k != "type"})


def new_job_id() -> str:
    return uuid.uuid4().hex[:12]


def unfinished_logs(directory: Path) -> list[Path]:
    """Job logs in ``directory`` without an end record, oldest first."""
    logs = []
    for path in sorted(Path(directory).glob("*.jsonl"), key=lambda p: p.stat().st_mtime):
        text = path.read_text()
        if '"type": "end"' not in text:
            logs.append(path)
    return logs
