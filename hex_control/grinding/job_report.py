"""The report of a grinding job run on the whole hierarchy: what each tier asked for and what
the plant measured, as JSON and CSV (the PNGs: :mod:`hex_control.grinding.job_plots`), and
statistics over many seeded jobs.

Units: mm, N, s; charges in currency units.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.part_quality import TOLERANCE_MM


@dataclass
class JobRecord:
    """What an observer of the graph saw."""

    goal: dict = field(default_factory=dict)
    contours: dict = field(default_factory=dict)  # pass index -> (Contour, width mm)
    commands: dict = field(default_factory=dict)  # pass index -> the PassCommand's values
    results: dict = field(default_factory=dict)  # pass index -> the PassResult's values
    trajectories: dict = field(default_factory=dict)  # pass index -> (grind start s, times s, forces N)
    planned_cut_mm: dict = field(default_factory=dict)  # pass index -> the pass planner's depth (force/stall guard)
    force: list = field(default_factory=list)  # (t s, measured N)
    telemetry_gaps: list = field(default_factory=list)  # (from s, to s): plant time the observer never saw
    struts: list = field(default_factory=list)  # (t s, lengths m ...)
    strut_names: list = field(default_factory=list)  # the plant's joint names, in the order of ``struts``
    # (stamp s of the pass result it follows, K1 J/mm^3, probability that the disk dulls)
    k1_predictions: list = field(default_factory=list)
    outcome: dict | None = None
    events: list = field(default_factory=list)  # ("command" | "trajectory" | "result", pass index) as they came
    first_pass: int = 0  # the first pass observed: that of a resumed job's first result here

    def guard_cut_mm(self, index: int) -> float | None:
        """The depth the pass planner planned pass ``index`` with (mm) where its force or
        stall guard cut the sequence planner's; None where it planned the commanded depth."""
        planned, command = self.planned_cut_mm.get(index), self.commands.get(index)
        if planned is None or command is None or abs(planned - command["cut_depth_mm"]) < 1e-9:
            return None
        return planned

    @property
    def intended(self) -> bool:
        """The job ended by the policy's own logic (done or Quit Now), every pass reported."""
        return self.outcome is not None and self.outcome["reason"] in ("done", "quit") \
            and sorted(self.results) == self._expected_passes(len(self.results))

    def _expected_passes(self, count: int) -> list[int]:
        return list(range(self.first_pass, self.first_pass + count))

    @property
    def not_as_planned(self) -> list[dict]:
        """The passes the plant reported ABORTED or FAULTED (ran, but not as planned), with
        the reason: the state was re-decided from their scans (issue 37 item 2)."""
        return [{"pass": i, "status": r["status"], "reason": r.get("reason", "")}
                for i, r in sorted(self.results.items()) if r.get("status") in ("aborted", "faulted")]

    @property
    def part_quality(self) -> dict | None:
        """The part-quality figures of the last scan (PassResult.part_quality), None if none."""
        scanned = [r["part_quality"] for _, r in sorted(self.results.items())
                   if "part_quality" in r and math.isfinite(r["part_quality"]["gouge_mm"])]
        return scanned[-1] if scanned else None

    def summary(self) -> dict:
        passes = [{"pass": i, **self.commands.get(i, {}), "pass_planner_cut_depth_mm": self.planned_cut_mm.get(i),
                   **{f"measured_{k}" if k in self.commands.get(i, {}) else k: v for k, v in self.results[i].items()}}
                  for i in sorted(self.results)]
        start_penalty = self.commands[0]["expected_penalty"] if 0 in self.commands else \
            self.goal.get("expected_penalty_at_start", math.nan)  # a resumed job's, from its log
        results_in_order = [i for kind, i in self.events if kind == "result"]
        quality, not_as_planned = self.part_quality, self.not_as_planned
        # the first feedback's word on the deadline (issue 42), when the observer recorded it
        outlook = {k: v for k, v in self.commands.get(0, {}).items()
                   if k in ("deadline_reachable", "expected_final_material_mm", "planner_note")}
        return {"goal": self.goal, "outcome": self.outcome, "expected_penalty_at_start": start_penalty,
                **({"outlook_at_start": outlook} if outlook else {}),
                "part_quality": quality,
                "part_within_tolerance": quality is not None and quality["max_deviation_mm"] <= TOLERANCE_MM,
                "ended_as_intended": self.intended,
                # a job whose passes were not all run as planned is never a clean end, whatever its reason
                "passes_not_as_planned": not_as_planned, "ended_clean": self.intended and not not_as_planned,
                "passes": passes,
                # each pass once, in order (a restarted planner must not repeat or skip one)
                "passes_in_order": results_in_order == self._expected_passes(len(results_in_order)),
                "planner_restarts": sum(kind == "planner_restart" for kind, _ in self.events),
                "dulling_detected_after_pass": next((k for k, _, _, drift in specific_energy_by_pass(self)
                                                     if drift > 0.5), None),
                "burn": any(r["burn"] for r in self.results.values()),
                "stall": any(r["stall"] for r in self.results.values())}


def start_policy(record: JobRecord):
    """The policy the sequence planner solved for this goal at the start (same config, and
    its cut model of a pass planned on the estimated K1; not its force limit from the scan),
    and the charges: the report's policy map and expected J."""
    import dataclasses

    from hex_control.config import config_file
    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.sdp import solve
    from hex_control.grinding.sequencer import SequencerSettings, policy_cut_model

    process, charges, grid, cut_model = load_planner_config(config_file("sequence_planner.yaml"))
    changes = {"bead_width_mm": record.goal["bead_width_mm"], "bead_length_mm": record.goal["bead_length_mm"]}
    if record.goal.get("reset_time_s") is not None:
        changes["reset_time_s"] = record.goal["reset_time_s"]
    model, factor = policy_cut_model(cut_model, SequencerSettings(Path()).k1_estimate_cv)
    process = dataclasses.replace(process, **changes, specific_energy_j_mm3=process.specific_energy_j_mm3 / factor)
    grid = grid.covering(record.goal["deadline_s"], record.goal["material_mm"])
    return solve(process, charges, grid, model), charges


def write_report(record: JobRecord, out: Path, policy=None, plots: bool = True) -> dict:
    """JSON, the scanned profiles (CSV) and, with ``plots``, the PNGs of one job in ``out``;
    ``policy`` (the start policy) for the map."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = record.summary()
    (out / "job.json").write_text(json.dumps(summary, indent=2, default=float))
    if record.contours:  # the scans, for `hexctl pass --contour`
        (out / "profiles").mkdir(exist_ok=True)
    for index, (contour, _) in record.contours.items():
        contour.to_csv(out / "profiles" / f"after_pass_{index}.csv")
    if plots:  # about 1.7 CPU s a job: a campaign of many may do without
        from hex_control.grinding.job_plots import plot_job  # matplotlib: 0.46 s to import, only to plot

        plot_job(record, out, policy)
    return summary


def specific_energy_by_pass(record: JobRecord) -> list[tuple[int, float, float, float]]:
    """(pass k, K1 the plant measured on pass k, K1 the pass-rate predictor then predicted
    for pass k + 1, the probability it gave that the disk dulls) -- NaN where no prediction
    came; K1 in J/mm^3. A prediction belongs to the pass result whose stamp it carries."""
    rows = []
    for k, result in sorted(record.results.items()):
        predicted = [(value, drift) for stamp, value, drift in record.k1_predictions
                     if "stamp_s" in result and abs(stamp - result["stamp_s"]) < 1e-6]
        rows.append((k, result["specific_energy_j_mm3"], *(predicted[-1] if predicted else (math.nan, math.nan))))
    return rows


def load_job_summaries(directories: list[Path]) -> list[dict]:
    """The ``job.json`` of each report directory given, or of each ``job_*`` inside one
    (``hexctl demo --jobs N``), in name order: batches run apart are pooled this way."""
    summaries = []
    for directory in map(Path, directories):
        files = [directory / "job.json"] if (directory / "job.json").exists() else \
            sorted(directory.glob("job_*/job.json"))
        if not files:
            raise ValueError(f"no job.json in {directory} or in its job_* directories")
        summaries += [json.loads(f.read_text()) for f in files]
    return summaries


def job_statistics(summaries: list[dict], tolerance_mm: float) -> dict:
    """Over many jobs: the final material, charges against the start policy's expected
    penalty (mean and its standard error), overgrinding beyond the tolerance, burn."""
    charges = np.array([s["outcome"]["total_charge"] for s in summaries])
    expected = np.array([s["expected_penalty_at_start"] for s in summaries])
    final = np.array([s["outcome"]["material_remaining_mm"] for s in summaries])
    n = len(summaries)
    se = float(charges.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
    return {"jobs": n, "ended_as_intended": int(sum(s["ended_as_intended"] for s in summaries)),
            "reasons": {r: sum(s["outcome"]["reason"] == r for s in summaries) for r in ("done", "quit", "aborted")},
            "passes_mean": float(np.mean([s["outcome"]["passes"] for s in summaries])),
            "final_material_mm": {"mean": float(final.mean()), "min": float(final.min()), "max": float(final.max())},
            "overground": int(np.sum(final < 0)),  # below the final contour: the band is 0 <= X <= tolerance
            "inside_tolerance_band": int(np.sum((final >= 0) & (final <= tolerance_mm))),
            "burns": int(sum(s["burn"] for s in summaries)), "stalls": int(sum(s["stall"] for s in summaries)),
            "charge_mean": float(charges.mean()), "charge_standard_error": se,
            "expected_penalty_mean": float(expected.mean()),
            "charge_minus_expected_in_standard_errors": float((charges.mean() - expected.mean()) / se)
            if se and se > 0 else math.nan,
            "jobs_charged": int(np.sum(charges > 0)),
            **_part_statistics([s.get("part_quality") for s in summaries], summaries),
            **_plan_error([p for s in summaries for p in s.get("passes", [])]),
            "jobs_with_passes_out_of_order": int(sum(not s.get("passes_in_order", True) for s in summaries)),
            "jobs_with_passes_not_as_planned": int(sum(bool(s.get("passes_not_as_planned")) for s in summaries)),
            "passes_faulted": int(sum(p["status"] == "faulted" for s in summaries
                                      for p in s.get("passes_not_as_planned", []))),
            "planner_restarts": int(sum(s.get("planner_restarts", 0) for s in summaries))}


def _part_statistics(qualities: list, summaries: list) -> dict:
    """Mean and worst of the finished parts' local figures (mm), over the jobs that have them,
    and how many parts lie inside the buyer's band."""
    scanned = [q for q in qualities if q]
    if not scanned:
        return {}
    figure = lambda name, worst: {"mean": float(np.mean([q[name] for q in scanned])),  # noqa: E731
                                  "worst": float(worst([q[name] for q in scanned]))}
    return {"parts_scanned": len(scanned), "gouge_mm": figure("gouge_mm", max),
            "ends_gouge_mm": figure("ends_gouge_mm", max),
            "highest_mm": figure("highest_mm", max), "rms_mm": figure("rms_mm", max),
            "max_deviation_mm": figure("max_deviation_mm", max),
            "parts_gouged_beyond_tolerance": int(sum(q["gouge_mm"] > TOLERANCE_MM for q in scanned)),
            "parts_within_tolerance": int(sum(q["max_deviation_mm"] <= TOLERANCE_MM for q in scanned)),
            "parts_outside_with_a_pass_left": int(sum(_pass_left(s) for s in summaries
                                                      if s.get("part_quality") and
                                                      s["part_quality"]["max_deviation_mm"] > TOLERANCE_MM))}


def _pass_left(summary: dict) -> bool:
    """Whether the job ended with time for its fastest pass (L / feed_max + t_R, s) left (issue 42:
    no such job may end outside the band)."""
    goal, t = summary.get("goal") or {}, summary["outcome"].get("time_remaining_s", 0.0)
    if not goal.get("bead_length_mm") or goal.get("reset_time_s") is None:
        return False
    return t >= goal["bead_length_mm"] / GrindingProcess().feed_max_mm_s + goal["reset_time_s"]


def _plan_error(passes: list) -> dict:
    """Measured against planned cut depth over the completed passes: the mean absolute
    error (mm) and relative to the plan (the thesis sees about 10 % from the process)."""
    pairs = [(p.get("pass_planner_cut_depth_mm") or p["cut_depth_mm"], p["measured_cut_depth_mm"]) for p in passes
             if p.get("status") == "completed" and "cut_depth_mm" in p]
    if not pairs:
        return {}
    planned, measured = np.array(pairs).T
    return {"cut_depth_error_mm": {"mean_absolute": float(np.mean(np.abs(measured - planned))),
                                   "mean_absolute_relative": float(np.mean(np.abs(measured - planned) / planned)),
                                   "mean_relative": float(np.mean((measured - planned) / planned)),
                                   "passes": len(pairs)}}


# -- the report as text: the pass table's rows, a job's line ---------------------------------
def pass_row(index: int, command: dict, result: dict, guard_cut_mm: float | None = None) -> str:
    """One row of the pass table (:data:`PASS_TABLE_HEADER`); ``guard_cut_mm``: the depth the
    pass planner's force or stall guard planned instead of the command's, shown with a *."""
    quality = result["part_quality"]
    cut = f"{command['cut_depth_mm']:>8.4f}" if guard_cut_mm is None else f"{guard_cut_mm:>7.4f}*"
    return (f"{index:>4} {command['material_mm']:>8.3f} {command['time_remaining_s']:>7.1f} "
            f"{command['force_n']:>6.1f} {command['feed_mm_s']:>6.1f} {command['specific_energy_j_mm3']:>7.1f} "
            f"{cut} "
            f"{result['measured_cut_depth_mm']:>8.4f} {result['mean_normal_force_n']:>7.1f} "
            f"{result['duration_s']:>6.2f} {result['specific_energy_j_mm3']:>7.1f} "
            f"{quality['gouge_mm']:>6.3f} {quality['highest_mm']:>6.3f} {result['status']}")


PASS_TABLE_HEADER = (f"{'pass':>4} {'X (mm)':>8} {'t (s)':>7} {'F (N)':>6} {'V mm/s':>6} {'K1 plan':>7} {'plan mm':>8} "
          f"{'meas mm':>8} "
          f"{'F meas':>7} {'dur s':>6} {'K1 meas':>7} {'gouge':>6} {'high':>6} status")


def part_text(summary: dict) -> str:
    """The part's figures from a job's summary, in one clause."""
    q = summary["part_quality"]
    if q is None:
        return "part not scanned"
    return (f"part: gouge {q['gouge_mm']:.3f} mm at x = {q['gouge_x_mm']:.0f} mm, highest {q['highest_mm']:+.3f} mm, "
            f"RMS {q['rms_mm']:.3f} mm ({'within' if summary['part_within_tolerance'] else 'outside'} "
            f"+-{TOLERANCE_MM:g} mm)")


def job_line(seed: int, summary: dict) -> str:
    """The line printed for a job that ran (``hexctl demo``, ``hexctl campaign``)."""
    o = summary["outcome"]
    return (f"job {seed}: {o['reason']} after {o['passes']} passes, X = {o['material_remaining_mm']:+.4f} mm, "
            f"t = {o['time_remaining_s']:+.1f} s, charge {o['total_charge']:.4f} "
            f"(expected J at the start {summary['expected_penalty_at_start']:.4f}); {part_text(summary)}; "
            f"{summary['simulated_pass_time_s']:.0f} s of passes in {summary['wall_s']:.0f} s wall")
