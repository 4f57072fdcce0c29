"""The whole graph in lock-step on a fixed job: simulated seconds per wall second, CPU
seconds per simulated second of every node and of the observer (this process: the job's
observer and its recorder), and the share of wall time the plant's clock stood still while
the planners planned, against the 0.24 simulated s per wall s that the per-sample flow
reached (README, stop 19).

Variants, run alternately in this process (the machine's load changes between runs): the
demo's set-up (``EventsExecutor`` everywhere, the recorder on, leaving out the per-period
streams that ``plant/telemetry`` batches), the recorder of every topic (as before issue 39),
no recorder, and every node on the ``SingleThreadedExecutor`` (``HEX_EXECUTOR``).

Counted from the goal to the job's result: planning between passes is in the wall time
(the plant's clock stands still meanwhile), graph start-up is not.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from contextlib import contextmanager, nullcontext
from pathlib import Path
from unittest import mock

from hex_control.bench import benchmark
from hex_control.plant.lockstep import PLAN_AHEAD_S

#: simulated s per wall s of the per-sample flow (a sample per message through three
#: processes, /clock at 200 Hz to every node), README of stop 19
PER_SAMPLE_FLOW = 0.24
TICKS_S = os.sysconf("SC_CLK_TCK")
#: name: (HEX_EXECUTOR, record, topics the recorder leaves out; None: the demo's)
VARIANTS = {"demo": ("events", True, None), "record-all": ("events", True, ()),
            "no-record": ("events", False, None), "single": ("single", True, None)}


def cpu_s(pid: int) -> float:
    """User + system CPU of a process (s), from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_S


def own_cpu_s() -> float:
    """User + system CPU of this process, every thread (s)."""
    times = os.times()
    return times.user + times.system


def standing_wall_s(arrivals: list[tuple[float, float]], start: tuple[float, float],
                    hold_points_s: list[float]) -> float:
    """Wall time (s) the plant's clock stood still for planning, from the telemetry batches'
    (wall s of arrival, sim s of their last sample) after the goal went out at ``start`` =
    (wall s, the plant's sim s then). In lock-step the plant stands at the goal until the
    first pass is in hand, and after each scan once it has run ``plan_ahead_s`` on, at
    ``hold_points_s`` (sim s), until the next is. Each of those gaps counts its wall time
    beyond what its sim time took at the job's pace (the median over the other batches);
    the other gaps' jitter is not standing."""
    gaps = [(w1 - w0, s1 - s0, s0) for (w0, s0), (w1, s1) in zip([start, *arrivals], arrivals) if s1 > s0]

    def holds(sim_start_s: float, sim_s: float) -> bool:
        return any(sim_start_s - 1e-6 <= point < sim_start_s + sim_s - 1e-6 for point in hold_points_s)

    standing, running = [], []
    for k, (wall, sim, s0) in enumerate(gaps):
        (standing if k == 0 or holds(s0, sim) else running).append((wall, sim))
    if not running:
        return 0.0
    pace = statistics.median(wall / sim for wall, sim in running)
    return sum(max(0.0, wall - sim * pace) for wall, sim in standing)


@contextmanager
def _logs_said_on_failure(session):
    """A job that fails or does not start prints its nodes' last log lines: the logs go with
    the benchmark's temporary folder."""
    from hex_control.ros.app.grind_job import GraphFailure

    try:
        yield
    except (GraphFailure, TimeoutError):
        for name in ("plant", "force_controller", "kinematics", "pass_planner"):
            print(f"--- {name}:\n{session.graph.log_tail(name, 40)}")
        raise


def run_graph_job(output: Path, executor: str, bead_length_mm: float, deadline_s: float, seed: int,
                  *, reset_time_s: float, record: bool = True, excluded=None) -> dict:
    """One job on a fresh graph whose nodes spin on ``executor``; figures of the run."""
    from hex_control.ros.app import grind_job

    leaving_out = (nullcontext() if excluded is None
                   else mock.patch.object(grind_job, "RECORD_EXCLUDED", tuple(excluded)))
    with mock.patch.dict(os.environ, HEX_EXECUTOR=executor), leaving_out:
        session = grind_job.JobSession(output, seed, plant_overrides={"bead_length_mm": bead_length_mm},
                                       record=record)
    with session, _logs_said_on_failure(session):
        session.start_job(deadline_s, reset_time_s)
        processes = dict(session.graph.processes)
        arrivals = session.observer.telemetry_arrivals = []
        cpu_start = {name: cpu_s(p.pid) for name, p in processes.items()}
        own_start = own_cpu_s()
        sim_start, wall_start = session.record.force[-1][0], time.monotonic()
        outcome = session.wait_for_outcome(600.0)
        wall = time.monotonic() - wall_start
        # to the last pass's scan: a lock-step plant runs on a little after it (plan_ahead_s)
        results = session.record.results.values()
        sim = (max(r["stamp_s"] for r in results) if results else session.record.force[-1][0]) - sim_start
        cpu = {name: cpu_s(p.pid) - cpu_start[name] for name, p in processes.items()}
        cpu["observer"] = own_cpu_s() - own_start
        if sim <= 0:  # the loop never ran: no figure per simulated s (a fresh clone once stood 300 s so)
            raise grind_job.GraphFailure(f"the job simulated nothing in {wall:.0f} s of wall time",
                                         f"outcome {outcome}")
    standing = standing_wall_s(arrivals, (wall_start, sim_start), [r["stamp_s"] + PLAN_AHEAD_S for r in results])
    return {"outcome": outcome, "wall_s": wall, "sim_s": sim, "cpu_s": cpu, "standing_s": standing,
            "results": {k: (r["measured_cut_depth_mm"], r["duration_s"]) for k, r in session.record.results.items()}}


@benchmark("graph")
def graph_case(quick: bool) -> list[str]:
    from hex_control.plant.reset_time import calibrate_reset_time

    bead_length_mm, deadline_s, seed = (60.0, 10.0, 7) if quick else (60.0, 30.0, 7)
    rounds, variants = (1, ("demo", "single")) if quick else (2, tuple(VARIANTS))
    reset = calibrate_reset_time(bead_length_mm)["zvd"].reset_time_s
    lines = [f"job: seed {seed}, {bead_length_mm:g} mm bead, deadline {deadline_s:g} s, lock-step; "
             f"{rounds} round(s) of the variants, alternating; load average {os.getloadavg()[0]:.1f} at the start"]
    runs: dict[str, list[dict]] = {name: [] for name in variants}
    with tempfile.TemporaryDirectory() as folder:
        for k in range(rounds):
            for name in variants:
                executor, record, excluded = VARIANTS[name]
                runs[name].append(run_graph_job(Path(folder) / f"{name}-{k}", executor, bead_length_mm, deadline_s,
                                                seed, reset_time_s=reset, record=record, excluded=excluded))
    for name, variant_runs in runs.items():
        rates = [run["sim_s"] / run["wall_s"] for run in variant_runs]
        run = max(variant_runs, key=lambda r: r["sim_s"] / r["wall_s"])
        rate = max(rates)
        lines.append(f"{name:>10}: {run['sim_s']:.1f} simulated s in {run['wall_s']:.1f} wall s = {rate:.2f} simulated "
                     f"s per wall s (runs: {', '.join(f'{r:.2f}' for r in rates)}; {rate / PER_SAMPLE_FLOW:.1f}x the "
                     f"per-sample flow's {PER_SAMPLE_FLOW}); clock standing for planning "
                     f"{100 * run['standing_s'] / run['wall_s']:.1f} % of the wall time; "
                     f"{run['outcome']['reason']} after {run['outcome']['passes']} passes")
        per_node = ", ".join(f"{node} {cpu / run['sim_s']:.3f}" for node, cpu in  # the plant first
                             sorted(run["cpu_s"].items(), key=lambda item: (item[0] != "plant", -item[1])))
        lines.append(f"            CPU s per simulated s: {per_node}; total "
                     f"{sum(run['cpu_s'].values()) / run['sim_s']:.3f}")
    best = {name: min(r["wall_s"] for r in variant_runs) for name, variant_runs in runs.items()}
    same = all(r["results"] == runs["demo"][0]["results"] for variant_runs in runs.values() for r in variant_runs)
    ratios = ", ".join(f"{name} {best[name] / best['demo']:.2f}x" for name in variants if name != "demo")
    lines.append(f"wall time against the demo's set-up (best runs): {ratios}; the same passes in every run: {same}")
    return lines
