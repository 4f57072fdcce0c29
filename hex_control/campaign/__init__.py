"""Campaigns: many seeded jobs as independent cells, in parallel (issue 39 item 4).

ROS-free. A campaign is a list of :class:`Job` (a seed, the job's report directory and the
plain settings its job function needs), a job function ``fn(job) -> summary`` (a dict,
JSON-able) and an executor that runs ``fn`` on every job somewhere -- in this process
(:class:`~hex_control.campaign.executors.SerialExecutor`), in local worker processes
(:class:`~hex_control.campaign.executors.ProcessExecutor`) or on Ray
(:class:`~hex_control.campaign.executors.RayExecutor`) -- and hands back one
:class:`Outcome` per job as it ends, in whatever order. :func:`run_campaign` gathers them,
shows progress and returns them in seed order; :func:`gather` turns them into the
statistics over the jobs that ran, in seed order, so that the table depends on the seeds
only, not on the worker count, the backend or which job ended first (each job's outcome
depends only on its seed: the graph runs in lock-step).

A job that fails (its function raises, or its worker dies) is an Outcome with ``error``
set: counted and reported, its seed listed in ``campaign.json``; the others' statistics
are written as usual. The grinding job's function is
:func:`hex_control.ros.app.campaign_cell.grind_cell` (it imports rclpy; this package must not).
"""

from __future__ import annotations

import json
import math
import os
import socket
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

#: the campaign's own file beside statistics.json: seeds, failures, backend, wall time
CAMPAIGN_FILE = "campaign.json"
#: the statistics over the jobs that ran, as ``hexctl demo --jobs N`` writes them
STATISTICS_FILE = "statistics.json"


@dataclass(frozen=True)
class Job:
    """One cell's work: ``seed`` (the process-variation seed), ``directory`` (its report
    directory) and ``settings`` (plain, picklable values the job function reads)."""

    seed: int
    directory: str
    settings: dict = field(default_factory=dict)


@dataclass
class Outcome:
    """What a job left: its ``summary`` (None if it failed), ``error`` (one line: why it
    failed, '' if it ran), its wall time (s) and where it ran (host, process id, ROS domain
    if the job function says so in ``summary['_where']``)."""

    seed: int
    summary: dict | None = None
    error: str = ""
    wall_s: float = 0.0
    where: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.summary is not None and not self.error


def seeded_jobs(first_seed: int, count: int, output: str | Path, settings: dict | None = None) -> list[Job]:
    """``count`` jobs of seeds ``first_seed``, ``first_seed + 1`` ..., each in
    ``output/job_<seed:03d>`` (the directories ``hexctl demo --jobs N`` uses).
    ValueError for a count below 1 or a negative seed."""
    if int(count) != count or count < 1:
        raise ValueError(f"a campaign needs at least one job, not {count!r}")
    if int(first_seed) != first_seed or first_seed < 0:
        raise ValueError(f"seeds are integers >= 0, not {first_seed!r}")
    return [Job(seed, str(Path(output) / f"job_{seed:03d}"), dict(settings or {}))
            for seed in range(int(first_seed), int(first_seed) + int(count))]


def one_line(exc: BaseException) -> str:
    """An exception as one line: its type and first line (a GraphFailure's ``one_line``)."""
    text = getattr(exc, "one_line", None) or str(exc).strip().splitlines()[0:1]
    text = text if isinstance(text, str) else (text[0] if text else "")
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def run_one(fn, job: Job) -> Outcome:
    """``fn(job)`` as an Outcome: an exception (Exception, not an interrupt) is the job's
    failure, one line; the summary must be a dict. Runs in the worker."""
    start = time.monotonic()
    where = {"host": socket.gethostname(), "pid": os.getpid()}
    try:
        summary = fn(job)
    except Exception as exc:  # the job failed; the campaign goes on
        return Outcome(job.seed, None, one_line(exc), time.monotonic() - start, where)
    if not isinstance(summary, dict):
        return Outcome(job.seed, None, f"the job function returned {type(summary).__name__}, not a dict",
                       time.monotonic() - start, where)
    where.update(summary.pop("_where", {}) or {})
    return Outcome(job.seed, summary, "", time.monotonic() - start, where)


class Progress:
    """Jobs done / failed and the ETA, as a bar on stderr (tqdm), redrawn every
    ``refresh_s`` (a job takes minutes: the elapsed time moves between them); ``note``
    prints a line on stdout above it. ``enabled=False``: silent (tests)."""

    def __init__(self, total: int, enabled: bool = True, stream=None, refresh_s: float = 1.0):
        self.total, self.done, self.failed = total, 0, 0
        self.bar, self._stop = None, threading.Event()
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=self._counts(), unit="job", file=stream or sys.stderr,
                            dynamic_ncols=True, bar_format="{desc} |{bar}| {elapsed} < ETA {remaining}")
            threading.Thread(target=self._redraw, args=(refresh_s,), daemon=True, name="progress").start()

    def _redraw(self, refresh_s: float) -> None:
        while not self._stop.wait(refresh_s):
            self.bar.refresh()

    def update(self, outcome: Outcome) -> None:
        self.done += outcome.ok
        self.failed += not outcome.ok
        if self.bar is not None:
            self.bar.set_description_str(self._counts(), refresh=False)
            self.bar.update(1)

    def _counts(self) -> str:
        return f"campaign: {self.done + self.failed}/{self.total} jobs (done {self.done}, failed {self.failed})"

    def note(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(text, file=sys.stdout)

    def close(self) -> None:
        self._stop.set()
        if self.bar is not None:
            self.bar.close()


def run_campaign(jobs: list[Job], fn, executor, *, progress: bool = True, on_outcome=None) -> list[Outcome]:
    """Run ``fn`` on every job on ``executor`` (its ``map_unordered(fn, jobs)`` yields an
    Outcome per job as each ends); ``on_outcome(outcome)`` for each as it comes (a line to
    print: return it). Returns the outcomes in seed order. Two jobs of one seed are refused
    (ValueError): each seed is one cell's."""
    seeds = [job.seed for job in jobs]
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"two jobs of one seed in {seeds}")
    bar = Progress(len(jobs), enabled=progress)
    outcomes = {}
    try:
        for outcome in executor.map_unordered(fn, jobs):
            if outcome.seed not in seeds or outcome.seed in outcomes:
                raise RuntimeError(f"the executor returned seed {outcome.seed} unasked or twice")
            outcomes[outcome.seed] = outcome
            bar.update(outcome)
            text = on_outcome(outcome) if on_outcome else None
            if text:
                if progress:
                    bar.note(text)
                else:
                    print(text, flush=True)
    finally:
        bar.close()
    missing = set(seeds) - set(outcomes)
    if missing:
        raise RuntimeError(f"the executor ended without an outcome for seeds {sorted(missing)}")
    return [outcomes[seed] for seed in sorted(outcomes)]


def gather(outcomes: list[Outcome], statistics) -> dict | None:
    """``statistics(summaries)`` over the jobs that ran, in seed order (the order
    ``hexctl demo --jobs N`` runs them in, so that the same seeds give the same table to the
    last bit, whichever ended first); None if none ran."""
    summaries = [o.summary for o in sorted(outcomes, key=lambda o: o.seed) if o.ok]
    return statistics(summaries) if summaries else None


def campaign_record(outcomes: list[Outcome], backend: str, workers: int | None, wall_s: float) -> dict:
    """``campaign.json``: the seeds, the failed jobs with why, where each ran, the wall time."""
    failed = [o for o in outcomes if not o.ok]
    busy_s = sum(o.wall_s for o in outcomes)
    return {"jobs": len(outcomes), "ran": len(outcomes) - len(failed), "failed": len(failed),
            "seeds": [o.seed for o in outcomes], "failures": [{"seed": o.seed, "error": o.error} for o in failed],
            "backend": backend, "workers": workers, "wall_s": wall_s,
            "job_wall_s_sum": busy_s, "speedup_over_job_walls": busy_s / wall_s if wall_s > 0 else math.nan,
            "cells": [{"seed": o.seed, "wall_s": o.wall_s, **o.where} for o in outcomes]}


def write_campaign(output: str | Path, outcomes: list[Outcome], stats: dict | None, record: dict) -> None:
    """``output/statistics.json`` (as ``hexctl demo --jobs N`` writes it; not written if no
    job ran) and ``output/campaign.json``."""
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    if stats is not None:
        (out / STATISTICS_FILE).write_text(json.dumps(stats, indent=2))
    (out / CAMPAIGN_FILE).write_text(json.dumps(record, indent=2) + "\n")


__all__ = ["CAMPAIGN_FILE", "STATISTICS_FILE", "Job", "Outcome", "Progress", "campaign_record", "gather",
           "one_line", "run_campaign", "run_one", "seeded_jobs", "write_campaign"]
