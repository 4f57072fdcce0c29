"""Start-ups of the whole graph in lock-step, counted (issue 21 item 10): how many fresh
graphs are not ready within their waits (the plant's first scan, the control streams
matched, the sequence planner's action server answering, then ``LOOP_START_S`` for the
force loop's first answered state), and the time to ready, the slowest against the
median. A start that hangs leaves its nodes' tracebacks (SIGUSR1) in its logs, which are
kept; the others are removed.
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

from hex_control.bench import benchmark


def start_graphs(starts: int, folder: Path, progress=None) -> tuple[list[float], dict[int, str]]:
    """Start and stop ``starts`` fresh graphs; (seconds to ready of each ready one,
    {start: what it hung waiting for})."""
    from hex_control.ros.app.grind_job import JobSession

    ready_s, hung = [], {}
    for index in range(starts):
        output = folder / f"start-{index:03d}"
        with JobSession(output, seed=index) as session:
            began = time.monotonic()
            try:
                session.wait_until_ready()
                ready_s.append(time.monotonic() - began)
            except TimeoutError as exc:
                hung[index] = str(exc).split(" waiting for ", 1)[-1]
                session.graph.dump_tracebacks()
        if index not in hung:
            shutil.rmtree(output)
        if progress:
            progress(index + 1, starts, len(hung))
    return ready_s, hung


def _progress(done: int, total: int, hung: int) -> None:
    print(f"\r   started {done}/{total}, {hung} hung", end="\n" if done == total else "", flush=True)


@benchmark("graph-starts")
def graph_starts_case(quick: bool) -> list[str]:
    starts = 5 if quick else 50
    folder = Path(tempfile.mkdtemp(prefix="hex_graph_starts_"))
    ready_s, hung = start_graphs(starts, folder, _progress)
    lines = [f"{starts} fresh lock-step graphs: {len(ready_s)} ready, {len(hung)} hung"]
    for what, count in Counter(hung.values()).most_common():
        lines.append(f"  {count} waiting for {what}")
    if ready_s:
        median = statistics.median(ready_s)
        lines.append(f"time to ready: median {median:.2f} s, slowest {max(ready_s):.2f} s "
                     f"({max(ready_s) / median:.1f}x the median)")
    if hung:
        lines.append(f"logs of the hung starts (with their nodes' tracebacks): {folder}")
    else:
        shutil.rmtree(folder)
    return lines
