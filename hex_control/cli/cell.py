"""hexctl demo, demo-load-predictor, campaign, job-stats: the grinding cell's jobs over ROS 2
(hex_control/ros/app/, hex_control/campaign/). rclpy and Ray load only inside a verb."""

from __future__ import annotations

import sys
import time

MACHINES = {"hexapod": "machines/nist_ingersoll.yaml", "pru3": "machines/pru3_feed.yaml"}  # hexctl demo --machine


def add_parsers(commands) -> None:
    # the run's options default to None here (hex_control.grinding.run_files.RUN_DEFAULTS fills
    # them): --resume must tell an option given from one left out
    demo = commands.add_parser("demo", help="the main job: the whole hierarchy grinds a weld bead on the plant",
                               epilog="exit codes: 0 the job(s) ended as the policy intended, without burn; 1 not; "
                                      "2 a bad option or input; 3 the graph failed (a node died, its loop stood)")
    demo.add_argument("--output", default="output/demo", help="report directory")
    demo.add_argument("--deadline", type=float, default=None, help="the job's deadline (s; default 100)")
    demo.add_argument("--seed", type=int, default=None, help="process-variation seed of the (first) job (default 0)")
    demo.add_argument("--jobs", type=int, default=None, help="seeded jobs to run one after the other (statistics)")
    demo.add_argument("--realtime", action="store_true", default=None,
                      help="plant in real time (watch it live) instead of lock-step")
    demo.add_argument("--real-time-factor", type=float, default=None, help="with --realtime: sim speed vs wall (1)")
    demo.add_argument("--bead-length", type=float, default=None, help="bead length (mm; default 300)")
    demo.add_argument("--bead-height", type=float, default=None, help="bead height (mm; default 1)")
    demo.add_argument("--dulling", type=float, default=None, help="K1 growth per pass (a disk that dulls; default 0)")
    demo.add_argument("--machine", choices=sorted(MACHINES), default=None,
                      help="the NIST-like hexapod (default), or the 3-PRU head on a feed stage")
    demo.add_argument("--restart-planner-after", type=int, default=None, metavar="K",
                      help="fault drill: kill the sequence planner after pass K and restart it")
    demo.add_argument("--machine-host", default="", help="command prefix that puts the machine-side nodes on "
                      "another host, e.g. 'ip netns exec hexA' (scripts/two_hosts.sh)")
    demo.add_argument("--machine-peers", default="", help="ROS_STATIC_PEERS for the machine-side nodes")
    demo.add_argument("--no-record", action="store_true", help="do not record the messages (recording/: "
                      "rosbag2's MCAP layout, for Foxglove, PlotJuggler, hexctl play)")
    demo.add_argument("--no-plots", action="store_true", help="write the report without its PNGs")
    demo.add_argument("--resume", metavar="DIR", default=None,
                      help="take up the unfinished job of a run cut off in DIR (its --output): the planner resumes it "
                           "from DIR/jobs, the plant the part as last scanned, with the options the run started with "
                           "(DIR/run.json: its seed ...; one given that differs is an error); without it every run "
                           "starts afresh")
    demo.add_argument("--namespace", default=None, help="run the cell under this namespace, e.g. /cell2 (one "
                      "namespace holds one cell; cells side by side in a domain do not meet)")
    demo.add_argument("--view", nargs="?", type=int, const=8765, default=None, metavar="PORT",
                      help="serve the cell live to Foxglove meanwhile (hexctl view) on ws://127.0.0.1:PORT "
                           "(default 8765); best with --realtime")

    predictor = commands.add_parser("demo-load-predictor", help="the Kalman load predictor alone over ROS 2")
    predictor.add_argument("--output", default="output/load_predictor", help="report directory")
    predictor.add_argument("--samples", type=int, default=2000, help="load samples to publish")
    predictor.add_argument("--rate", type=float, default=200.0, help="sample rate (Hz)")
    predictor.add_argument("--seed", type=int, default=7)

    campaign = commands.add_parser(
        "campaign", help="seeded jobs as independent cells in parallel (local processes or Ray), and their statistics",
        epilog="the same seeds give the same statistics.json as hexctl demo --jobs N, whatever the workers or backend. "
               "exit codes: 0 every job ran and ended as its policy intended, without burn; 1 not; 2 a bad option; "
               "3 a job's graph failed (counted in campaign.json; the others' statistics are written)")
    campaign.add_argument("--jobs", type=int, default=20, help="seeded jobs, seeds --seed .. --seed + N - 1 (20)")
    campaign.add_argument("--seed", type=int, default=None, help="the first job's seed (default 0)")
    campaign.add_argument("--output", default="output/campaign", help="report directory (job_<seed>/ inside)")
    campaign.add_argument("--workers", type=int, default=None,
                          help="local worker processes, each running one cell at a time (default: the CPU count)")
    campaign.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                          help="run on Ray, one task per job: a cluster's address (ray://head:10001, auto), or none "
                               "for a local Ray (with --workers CPUs)")
    campaign.add_argument("--deadline", type=float, default=None, help="each job's deadline (s; default 100)")
    campaign.add_argument("--bead-length", type=float, default=None, help="bead length (mm; default 300)")
    campaign.add_argument("--bead-height", type=float, default=None, help="bead height (mm; default 1)")
    campaign.add_argument("--dulling", type=float, default=None, help="K1 growth per pass (default 0)")
    campaign.add_argument("--machine", choices=sorted(MACHINES), default=None, help="hexapod (default) or pru3")
    campaign.add_argument("--no-record", action="store_true", help="do not record each job's messages")
    campaign.add_argument("--no-plots", action="store_true",
                          help="write each job's report without its PNGs (about 1.7 CPU s a job)")
    campaign.add_argument("--job-timeout", type=float, default=1800.0, help="wall seconds a job may take (1800)")
    campaign.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")

    stats = commands.add_parser("job-stats", help="statistics over report directories of hexctl demo")
    stats.add_argument("directories", nargs="+", help="report directories (a job's, or one with job_* inside)")
    stats.add_argument("--output", default="", help="also write the statistics here (JSON)")

    demo.set_defaults(func=_demo)
    predictor.set_defaults(func=_demo_load_predictor)
    campaign.set_defaults(func=_campaign)
    stats.set_defaults(func=_job_stats)


def _demo(args) -> int:
    """``hexctl demo``: the run's options (resumed: the stored ones, a conflict refused), the
    run; a graph that fails (a node died, the loop stood) is one line on stderr and exit 3."""
    from hex_control.grinding.run_files import RUN_DEFAULTS, resumable_job_dir, run_options
    from hex_control.ros.app.demo import run_demo
    from hex_control.ros.app.grind_job import GraphFailure

    given = {name: getattr(args, name) for name in RUN_DEFAULTS if getattr(args, name) is not None}
    if args.resume is not None:
        if args.jobs not in (None, 1):
            raise ValueError(f"--resume takes up one job, not --jobs {args.jobs}")
        resumable_job_dir(args.resume)  # ValueError first if there is nothing to resume
    options = run_options(given, args.resume)
    viewer = _start_view(args.view, options["namespace"]) if args.view is not None else None
    try:
        return run_demo(args.resume or args.output, options, machine_file=MACHINES[options["machine"]],
                        jobs=args.jobs or 1, machine_host=args.machine_host.split() or None,
                        machine_peers=args.machine_peers, restart_planner_after=args.restart_planner_after,
                        record=not args.no_record, resume=args.resume is not None, plots=not args.no_plots)
    except (GraphFailure, TimeoutError) as exc:  # a graph that did not start or answer: TimeoutError
        from hex_control import cli

        if cli._terminated_by is not None:  # the nodes stopped because hexctl was told to stop
            return 128 + cli._terminated_by
        print(f"hexctl demo: {getattr(exc, 'one_line', exc)}", file=sys.stderr)
        return 3
    finally:
        if viewer is not None:
            _stop_view(viewer)


def _start_view(port: int, namespace: str):
    """``hexctl view`` as a process of its own in the demo's domain (chosen here, before the
    demo would choose it), so that the view's work never slows the demo's loop."""
    import os
    import subprocess

    from hex_control.ros.app.demo import use_private_domain

    if not 0 <= port <= 65535:
        raise ValueError(f"--view: the port must be 0..65535, got {port}")
    if use_private_domain(os.environ):
        print(f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}: a domain of the demo's own (export ROS_DOMAIN_ID "
              "to run it in yours)")
    return subprocess.Popen([sys.executable, "-P", "-m", "hex_control.cli", "view", "--port", str(port),
                             "--namespace", namespace], start_new_session=True)


def _stop_view(viewer) -> None:
    import signal
    import subprocess

    viewer.send_signal(signal.SIGINT)
    try:
        viewer.wait(timeout=10.0)
    except subprocess.TimeoutExpired:
        viewer.kill()
        viewer.wait()


def _demo_load_predictor(args) -> int:
    from hex_control.ros.app.demo_load_predictor import run_demo

    return run_demo(args.output, args.samples, args.rate, args.seed)


def _job_stats(args) -> int:
    import json
    from pathlib import Path

    from hex_control.config import config_file
    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.job_report import job_statistics, load_job_summaries

    summaries = load_job_summaries(args.directories)
    charges = load_planner_config(config_file("sequence_planner.yaml"))[1]
    text = json.dumps(job_statistics(summaries, charges.deadline.tolerance_mm), indent=2)
    print(text)
    if args.output:
        Path(args.output).write_text(text + "\n")
    return 0


def _campaign(args) -> int:
    """``hexctl campaign``: N seeded cells on local worker processes or Ray, the statistics
    of ``hexctl demo --jobs N`` over those that ran (hex_control/campaign/)."""
    import json

    from hex_control.campaign import campaign_record, gather, run_campaign, seeded_jobs, write_campaign
    from hex_control.campaign.executors import ProcessExecutor, RayExecutor
    from hex_control.grinding.job_report import job_line, job_statistics
    from hex_control.grinding.run_files import RUN_DEFAULTS, run_options
    from hex_control.ros.app.campaign_cell import campaign_settings, grind_cell, tolerance_mm

    given = {name: getattr(args, name, None) for name in RUN_DEFAULTS if getattr(args, name, None) is not None}
    options = run_options(given)
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be at least 1, not {args.workers}")
    executor = (RayExecutor(args.ray or None, num_cpus=args.workers) if args.ray is not None
                else ProcessExecutor(args.workers))
    settings = campaign_settings(options, MACHINES[options["machine"]], record=not args.no_record,
                                 timeout_s=args.job_timeout, plots=not args.no_plots)
    jobs = seeded_jobs(options["seed"], args.jobs, args.output, settings)
    where = f"Ray at {args.ray}" if args.ray else "a local Ray" if args.ray is not None else \
        f"{executor.workers} local worker processes"
    print(f"campaign: {len(jobs)} jobs, seeds {jobs[0].seed}..{jobs[-1].seed}, on {where}; each cell in a ROS domain "
          "of its own", flush=True)
    start = time.monotonic()
    outcomes = run_campaign(jobs, grind_cell, executor, progress=not args.no_progress,
                            on_outcome=lambda o: job_line(o.seed, o.summary) if o.ok else f"job {o.seed}: FAILED: "
                                                                                         f"{o.error}")
    wall = time.monotonic() - start
    stats = gather(outcomes, lambda summaries: job_statistics(summaries, tolerance_mm()))
    record = campaign_record(outcomes, executor.name, executor.workers, wall)
    write_campaign(args.output, outcomes, stats, record)
    if stats is not None:
        print(json.dumps(stats, indent=2))
    ran = [o for o in outcomes if o.ok]
    print(f"campaign: {len(ran)} of {len(outcomes)} jobs ran, {record['failed']} failed"
          f"{' (seeds ' + ', '.join(str(f['seed']) for f in record['failures']) + ')' if record['failed'] else ''}; "
          f"{wall:.0f} s wall for {record['job_wall_s_sum']:.0f} s of job wall time; report: {args.output}")
    if record["failed"]:
        return 3
    return 0 if all(o.summary["ended_as_intended"] and not o.summary["burn"] for o in ran) else 1
