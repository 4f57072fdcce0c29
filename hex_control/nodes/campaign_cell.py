"""The grinding job as a campaign's cell (``hexctl campaign``; :mod:`hex_control.campaign`).

:func:`grind_cell` runs in a worker process: it leases a ROS domain of the host for the
cell (:func:`hex_control.campaign.domains.lease_domain`), runs one seeded job on a fresh
graph with :func:`~hex_control.nodes.grind_job.run_job`, and writes the job's report
directory as ``hexctl demo --jobs N`` does (``run.json``, ``job.json`` with ``wall_s`` and
``simulated_pass_time_s``, the PNGs, logs and recording). :func:`campaign_settings`
prepares, once in the driver, what every cell shares: the run options and the calibrated
reset time t_R (a pure computation, the same in every cell).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from hex_control.campaign import Job
from hex_control.campaign.domains import lease_domain
from hex_control.config import config_file
from hex_control.grinding.job import unfinished_logs


def campaign_settings(options: dict, machine_file: str, record: bool = True, timeout_s: float = 1800.0) -> dict:
    """What every cell of a campaign shares: the run ``options`` (RUN_DEFAULTS' keys;
    lock-step only: a campaign's outcomes must depend on the seeds alone), the machine
    file, whether to record, the calibrated t_R with the input shaper (printed, as the
    demo prints it) and a job's timeout (s)."""
    from hex_control.nodes.grind_job import _calibrated_reset_time

    if options.get("realtime"):
        raise ValueError("a campaign runs its jobs in lock-step (their outcomes then depend on their seeds "
                         "alone); --realtime is for watching one job: hexctl demo --realtime")
    reset_time_s = _calibrated_reset_time(options["bead_length"], options["deadline"], machine_file)
    return {"options": dict(options), "machine_file": machine_file, "record": bool(record),
            "reset_time_s": float(reset_time_s), "timeout_s": float(timeout_s)}


def grind_cell(job: Job) -> dict:
    """One seeded job in its own ROS domain; the job's summary (``job.json``'s content, and
    ``_where``: host and domain, for campaign.json). A graph that fails raises GraphFailure
    (``resume_dir`` set where an unfinished job is left: ``hexctl demo --resume`` takes it up)."""
    from hex_control.grinding.job_report import write_report
    from hex_control.nodes.grind_job import GraphFailure, run_job, start_policy, store_run_options

    settings, directory = job.settings, Path(job.directory)
    options = {**settings["options"], "seed": job.seed}
    overrides = {"bead_length_mm": float(options["bead_length"]), "bead_height_mm": float(options["bead_height"]),
                 "dulling_per_pass": float(options["dulling"])}
    store_run_options(directory, options)
    with lease_domain(os.environ) as domain:
        start = time.monotonic()
        try:
            record = run_job(directory, options["deadline"], job.seed, "lockstep", options["real_time_factor"],
                             settings["reset_time_s"], overrides, timeout_s=settings["timeout_s"], quiet=True,
                             machine_file=str(config_file(settings["machine_file"])),
                             namespace=options["namespace"], record=settings["record"])
        except GraphFailure as exc:
            jobs_dir = directory / "jobs"
            exc.resume_dir = directory if jobs_dir.is_dir() and unfinished_logs(jobs_dir) else None
            raise
        wall = time.monotonic() - start
    policy, _ = start_policy(record)
    summary = write_report(record, directory, policy)
    summary["wall_s"] = wall
    summary["simulated_pass_time_s"] = sum(r["duration_s"] for r in record.results.values())
    (directory / "job.json").write_text(json.dumps(summary, indent=2, default=float))
    return {**json.loads(json.dumps(summary, default=float)), "_where": {"ros_domain_id": domain}}


def job_line(seed: int, summary: dict) -> str:
    """The line ``hexctl demo --jobs N`` prints for a job that ran."""
    from hex_control.nodes.grind_job import _part_text

    o = summary["outcome"]
    return (f"job {seed}: {o['reason']} after {o['passes']} passes, X = {o['material_remaining_mm']:+.4f} mm, "
            f"t = {o['time_remaining_s']:+.1f} s, charge {o['total_charge']:.4f} "
            f"(expected J at the start {summary['expected_penalty_at_start']:.4f}); {_part_text(summary)}; "
            f"{summary['simulated_pass_time_s']:.0f} s of passes in {summary['wall_s']:.0f} s wall")


def tolerance_mm() -> float:
    """The sequence planner's tolerance band (mm) that the statistics count parts inside."""
    from hex_control.grinding.config import load_planner_config

    return load_planner_config(config_file("sequence_planner.yaml"))[1].deadline.tolerance_mm
