"""The whole graph in lock-step on a fixed job: simulated seconds per wall second, and CPU
seconds per simulated second of every node, for each executor (``HEX_EXECUTOR``), against
the 0.24 simulated s per wall s that the per-sample flow reached (README, stop 19).

Counted from the goal to the job's result: planning between passes is in the wall time
(the plant's clock stands still meanwhile), graph start-up is not.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from unittest import mock

from hex_control.bench import benchmark

#: simulated s per wall s of the per-sample flow (a sample per message through three
#: processes, /clock at 200 Hz to every node), README of stop 19
PER_SAMPLE_FLOW = 0.24
TICKS_S = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """User + system CPU of a process (s), from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_S


def run_graph_job(output: Path, executor: str, bead_length_mm: float, deadline_s: float, seed: int,
                  *, reset_time_s: float) -> dict:
    """One job on a fresh graph whose nodes spin on ``executor``; figures of the run."""
    from hex_control.ros.app.grind_job import JobSession

    with mock.patch.dict(os.environ, HEX_EXECUTOR=executor):  # the graph's processes take it at start
        session = JobSession(output, seed, plant_overrides={"bead_length_mm": bead_length_mm})
    with session:
        session.start_job(deadline_s, reset_time_s)
        processes = dict(session.graph.processes)
        cpu_start = {name: cpu_s(p.pid) for name, p in processes.items()}
        sim_start, wall_start = session.record.force[-1][0], time.monotonic()
        outcome = session.wait_for_outcome(600.0)
        wall = time.monotonic() - wall_start
        sim = session.record.force[-1][0] - sim_start
        cpu = {name: cpu_s(p.pid) - cpu_start[name] for name, p in processes.items()}
    return {"outcome": outcome, "wall_s": wall, "sim_s": sim, "cpu_s": cpu,
            "results": {k: (r["measured_cut_depth_mm"], r["duration_s"]) for k, r in session.record.results.items()}}


@benchmark("graph")
def graph_case(quick: bool) -> list[str]:
    from hex_control.ros.app.grind_job import calibrate_reset_time

    bead_length_mm, deadline_s, seed = (60.0, 15.0, 7) if quick else (60.0, 30.0, 7)
    reset = calibrate_reset_time(bead_length_mm)["zvd"].reset_time_s
    lines = [f"job: seed {seed}, {bead_length_mm:g} mm bead, deadline {deadline_s:g} s, lock-step"]
    runs = {}
    with tempfile.TemporaryDirectory() as folder:
        for executor in ("events", "single"):
            run = runs[executor] = run_graph_job(Path(folder) / executor, executor, bead_length_mm, deadline_s,
                                                 seed, reset_time_s=reset)
            rate = run["sim_s"] / run["wall_s"]
            lines.append(f"{executor:>6} executor: {run['sim_s']:.1f} simulated s in {run['wall_s']:.1f} wall s = "
                         f"{rate:.2f} simulated s per wall s ({rate / PER_SAMPLE_FLOW:.1f}x the per-sample flow's "
                         f"{PER_SAMPLE_FLOW}); {run['outcome']['reason']} after {run['outcome']['passes']} passes")
            per_node = ", ".join(f"{name} {cpu / run['sim_s']:.3f}" for name, cpu in
                                 sorted(run["cpu_s"].items(), key=lambda item: -item[1]))
            lines.append(f"        CPU s per simulated s: {per_node}; total "
                         f"{sum(run['cpu_s'].values()) / run['sim_s']:.3f}")
    same = runs["events"]["results"] == runs["single"]["results"]
    lines.append(f"ratio single / events wall time: {runs['single']['wall_s'] / runs['events']['wall_s']:.2f}x; "
                 f"the same passes with both executors: {same}")
    return lines
