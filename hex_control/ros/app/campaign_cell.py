"""The grinding job as a campaign's cell (``hexctl campaign``; :mod:`hex_control.campaign`).

:func:`grind_cell` runs in a worker process: it leases a ROS domain of the host for the
cell (:func:`hex_control.campaign.domains.lease_domain`), runs one seeded job on a fresh
graph with :func:`~hex_control.ros.app.demo.run_seeded_job`, and writes the job's report
directory as ``hexctl demo --jobs N`` does (``run.json``, ``job.json`` with ``wall_s`` and
``simulated_pass_time_s``, the PNGs unless ``--no-plots``, logs and recording).
:func:`campaign_settings` prepares, once in the driver, what every cell shares: the run
options and the calibrated reset time t_R (a pure computation, the same in every cell).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from hex_control.campaign import Job
from hex_control.campaign.domains import lease_domain
from hex_control.config import config_file


def campaign_settings(options: dict, machine_file: str, record: bool = True, timeout_s: float = 1800.0,
                      plots: bool = True) -> dict:
    """What every cell of a campaign shares: the run ``options`` (RUN_DEFAULTS' keys;
    lock-step only: a campaign's outcomes must depend on the seeds alone), the machine
    file, whether to record and whether to draw each report's PNGs, the calibrated t_R
    with the input shaper (printed, as the demo prints it) and a job's timeout (s)."""
    from hex_control.ros.app.demo import calibrated_reset_time

    if options.get("realtime"):
        raise ValueError("a campaign runs its jobs in lock-step (their outcomes then depend on their seeds "
                         "alone); --realtime is for watching one job: hexctl demo --realtime")
    reset_time_s = calibrated_reset_time(options["bead_length"], options["deadline"], machine_file)
    return {"options": dict(options), "machine_file": machine_file, "record": bool(record), "plots": bool(plots),
            "reset_time_s": float(reset_time_s), "timeout_s": float(timeout_s)}


def grind_cell(job: Job) -> dict:
    """One seeded job in its own ROS domain, as ``hexctl demo --jobs N`` runs each; the job's
    summary (``job.json``'s content, and ``_where``: host and domain, for campaign.json). A
    graph that fails raises GraphFailure (``resume_dir`` set where an unfinished job is
    left: ``hexctl demo --resume`` takes it up)."""
    from hex_control.ros.app.demo import run_seeded_job

    settings = job.settings
    with lease_domain(os.environ) as domain:
        summary, _ = run_seeded_job(Path(job.directory), {**settings["options"], "seed": job.seed},
                                    reset_time_s=settings["reset_time_s"], machine_file=settings["machine_file"],
                                    quiet=True, record=settings["record"], timeout_s=settings["timeout_s"],
                                    plots=settings["plots"])
    return {**json.loads(json.dumps(summary, default=float)), "_where": {"ros_domain_id": domain}}


def tolerance_mm() -> float:
    """The sequence planner's tolerance band (mm) that the statistics count parts inside."""
    from hex_control.grinding.config import load_planner_config

    return load_planner_config(config_file("sequence_planner.yaml"))[1].deadline.tolerance_mm
