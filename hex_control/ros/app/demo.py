"""``hexctl demo`` and a campaign's cell: calibrate t_R, run seeded jobs on fresh graphs
(:func:`hex_control.ros.app.grind_job.run_job`), write each job's report and, for several,
the statistics. Each run's options are stored in its directory (``run_files.RUN_FILE``)
when it starts: ``--resume`` takes them up (its seed), and refuses one given that differs."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from hex_control.config import config_file
from hex_control.grinding.job import unfinished_logs
from hex_control.grinding.job_report import job_line, job_statistics, start_policy, write_report
from hex_control.grinding.run_files import resumable_job_dir, store_run_options
from hex_control.plant.reset_time import calibrate_reset_time, reset_time_lines
from hex_control.ros.app.graph import MACHINE_SIDE
from hex_control.ros.app.grind_job import GraphFailure, run_job


def calibrated_reset_time(bead_length_mm: float, deadline_s: float, machine_file: str) -> float:
    """t_R with the input shaper (s), printed beside the unshaped one."""
    reset = calibrate_reset_time(bead_length_mm, machine_file=machine_file)
    print("\n".join(reset_time_lines(reset, bead_length_mm, deadline_s)))
    return reset["zvd"].reset_time_s


def use_private_domain(environment) -> bool:
    """Set ``ROS_DOMAIN_ID`` in ``environment`` to a domain for this run unless it is set:
    1..101 (the ids whose ports never clash with the ephemeral range), from the process id,
    so two demos started side by side differ. True if it chose one."""
    if environment.get("ROS_DOMAIN_ID", "").strip():
        return False
    environment["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 101)
    return True


def run_seeded_job(directory: Path, options: dict, *, reset_time_s: float | None, machine_file: str,
                   quiet: bool = False, placement: dict | None = None, restart_planner_after: int | None = None,
                   record: bool = True, resume: bool = False, timeout_s: float = 1800.0,
                   plots: bool = True) -> tuple[dict, object]:
    """One job of ``hexctl demo`` or of a campaign's cell, on a fresh graph: the run's
    ``options`` (:func:`run_options`, its seed included) stored in ``directory`` (unless
    resumed), the job run, its report written (``job.json`` with ``wall_s`` and
    ``simulated_pass_time_s``; the PNGs unless not ``plots``). The summary and the start
    policy's charges. A graph that fails raises GraphFailure (``resume_dir`` set where an
    unfinished job is left)."""
    directory, seed = Path(directory), options["seed"]
    if not resume:
        store_run_options(directory, options)
    overrides = {"bead_length_mm": float(options["bead_length"]), "bead_height_mm": float(options["bead_height"]),
                 "dulling_per_pass": float(options["dulling"])}
    start = time.monotonic()
    try:
        job = run_job(directory, options["deadline"], seed, "realtime" if options["realtime"] else "lockstep",
                      options["real_time_factor"], reset_time_s=reset_time_s, plant_overrides=overrides,
                      timeout_s=timeout_s, quiet=quiet,
                      placement=placement, machine_file=str(config_file(machine_file)),
                      restart_planner_after=restart_planner_after, namespace=options["namespace"], record=record,
                      resume=resume)
    except GraphFailure as exc:
        jobs_dir = directory / "jobs"
        exc.resume_dir = directory if jobs_dir.is_dir() and unfinished_logs(jobs_dir) else None
        raise
    wall = time.monotonic() - start
    policy, charges = start_policy(job)
    summary = write_report(job, directory, policy, plots=plots)
    summary["wall_s"] = wall
    summary["simulated_pass_time_s"] = sum(r["duration_s"] for r in job.results.values())
    (directory / "job.json").write_text(json.dumps(summary, indent=2, default=float))
    return summary, charges


def run_demo(output: str, options: dict, *, machine_file: str = "machines/nist_ingersoll.yaml", jobs: int = 1,
             machine_host: list[str] | None = None,
             machine_peers: str = "", restart_planner_after: int | None = None, record: bool = True,
             resume: bool = False, plots: bool = True) -> int:
    """``hexctl demo``: calibrate t_R, run ``jobs`` seeded jobs, report each and, for several,
    the statistics. ``options``: :func:`run_options` (seed, deadline, bead, machine,
    namespace ...), stored into each job's directory as it starts; ``machine_file``: the
    machine option's file (config/machines/). 0 only if every job ended
    as its policy intended, without burn. The graph runs in a ROS domain of its own unless
    ROS_DOMAIN_ID is set, and under the ``namespace`` option if given; each job's messages
    are recorded into its ``recording/`` (unless not ``record``), its report drawn as PNGs
    (unless not ``plots``). ``resume``: take up the unfinished job of an earlier
    run cut off in ``output`` (its deadline and t_R come from its log, the rest of its options
    from its RUN_FILE, through ``options``) instead. A node that dies or a loop that stands
    raises GraphFailure (``resume_dir`` set where an unfinished job is left)."""
    seed = options["seed"]
    if use_private_domain(os.environ):
        print(f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}: a domain of the demo's own (export ROS_DOMAIN_ID "
              "to run it in yours)")
    out = Path(output)
    if resume:
        jobs, reset_time_s = 1, None
        print(f"resuming the unfinished job of {resumable_job_dir(out)} (seed {seed})")
    else:
        reset_time_s = calibrated_reset_time(options["bead_length"], options["deadline"], machine_file)
    placement = None
    if machine_host:  # the machine-side nodes on another host (network namespace) with its DDS peers
        placement = {name: (machine_host, {"ROS_STATIC_PEERS": machine_peers} if machine_peers else {})
                     for name in MACHINE_SIDE}
        print(f"machine-side nodes {', '.join(MACHINE_SIDE)} run under: {' '.join(machine_host)}")
    summaries, charges = [], None
    for k in range(jobs):
        directory = out / f"job_{seed + k:03d}" if jobs > 1 else out
        summary, charges = run_seeded_job(directory, {**options, "seed": seed + k}, reset_time_s=reset_time_s,
                                          machine_file=machine_file, quiet=jobs > 1, placement=placement,
                                          restart_planner_after=restart_planner_after, record=record, resume=resume,
                                          plots=plots)
        summaries.append(summary)
        print(job_line(seed + k, summary), flush=True)
    if jobs > 1:
        stats = job_statistics(summaries, charges.deadline.tolerance_mm)
        (out / "statistics.json").write_text(json.dumps(stats, indent=2))
        print(json.dumps(stats, indent=2))
    print(f"report: {out}")
    ok = all(s["ended_as_intended"] and not s["burn"] for s in summaries)
    return 0 if ok else 1
