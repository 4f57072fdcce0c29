"""Where a campaign's jobs run: each executor's ``map_unordered(fn, jobs)`` runs
``run_one(fn, job)`` for every job and yields the Outcomes as jobs end (ROS-free).

- :class:`SerialExecutor`: one after the other in this process (tests, a single job).
- :class:`ProcessExecutor`: local worker processes, at most ``workers`` at a time, a fresh
  process for each job (a cell's rclpy state and node processes end with it; a worker that
  dies is that job's failure, not the campaign's).
- :class:`RayExecutor`: one Ray task per job (``ray.init(address=...)`` on a cluster, a local
  Ray without an address); Ray is imported only here, when a campaign asks for it.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from collections import deque
from multiprocessing.connection import wait

from hex_control.campaign import Job, Outcome, run_one

#: seconds a stopped campaign gives its running cells to stop their graphs before SIGKILL
STOP_GRACE_S = 30.0


def default_workers() -> int:
    """The CPUs this process may run on (its affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


class SerialExecutor:
    """Every job in this process, one after the other, in the order given."""

    name, workers = "serial", 1

    def map_unordered(self, fn, jobs: list[Job]):
        for job in jobs:
            yield run_one(fn, job)


def _exit_on_sigterm(signum, frame):
    # once: a second SIGTERM must not cut short the unwinding that stops the cell's graph
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise SystemExit(128 + signum)


def _cell(fn, job: Job, connection) -> None:
    """A worker process's body: run the job, send its Outcome. The campaign stops its cells
    with one SIGTERM, which raises SystemExit, so that the job's ``with`` blocks unwind (a
    cell stops its graph, whose nodes run in sessions of their own); Ctrl-C in a terminal
    reaches the campaign, not its cells, for the same reason (a second signal mid-unwind)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        connection.send(run_one(fn, job))
    finally:
        connection.close()


class ProcessExecutor:
    """At most ``workers`` jobs at a time, each in a fresh process (``spawn``: nothing of
    this process's state, threads or imports is inherited). A process that exits without
    an Outcome (killed, crashed) gives a failed one naming its exit code."""

    name = "processes"

    def __init__(self, workers: int | None = None, start_method: str = "spawn"):
        self.workers = default_workers() if workers is None else int(workers)
        if self.workers < 1:
            raise ValueError(f"--workers must be at least 1, not {workers}")
        self.context = multiprocessing.get_context(start_method)

    def map_unordered(self, fn, jobs: list[Job]):
        pending, running = deque(jobs), {}  # the process's sentinel -> (process, job, our end, start)
        try:
            while pending or running:
                while pending and len(running) < self.workers:
                    job = pending.popleft()
                    ours, theirs = self.context.Pipe(duplex=False)
                    process = self.context.Process(target=_cell, args=(fn, job, theirs), name=f"cell-{job.seed}",
                                                   daemon=False)
                    process.start()
                    theirs.close()
                    running[process.sentinel] = (process, job, ours, time.monotonic())
                # an Outcome arrives on the pipe before its process exits: read what is ready first
                ready = wait([entry[2] for entry in running.values()] + list(running), timeout=1.0)
                for sentinel, (process, job, ours, start) in list(running.items()):
                    if ours not in ready and sentinel not in ready:
                        continue
                    outcome = None
                    try:
                        if ours.poll():
                            outcome = ours.recv()
                    except (EOFError, OSError):
                        pass
                    if outcome is None and process.is_alive():
                        continue  # the pipe closed ahead of the exit: next round
                    process.join()
                    ours.close()
                    del running[sentinel]
                    if outcome is None:
                        code = process.exitcode
                        how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
                        outcome = Outcome(job.seed, None, f"WorkerDied: the job's process ended ({how}) without "
                                          "an outcome", time.monotonic() - start, {"pid": process.pid})
                    yield outcome
        finally:  # stopped (Ctrl-C, SIGTERM, an error here): the cells stop their graphs, then go
            self._stop([entry[0] for entry in running.values()])

    @staticmethod
    def _stop(processes) -> None:
        for process in processes:
            if process.is_alive():
                process.terminate()
        end = time.monotonic() + STOP_GRACE_S
        for process in processes:
            process.join(max(0.0, end - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join()


class RayExecutor:
    """One Ray task per job. ``address``: a cluster's (``ray.init(address=...)``, e.g.
    ``ray://head:10001`` or ``auto``); None starts a local Ray with ``num_cpus`` (None: all).
    A Ray already initialised in this process is used as it is (and left running). Each
    task takes ``cpus_per_job`` of a node's CPUs and a fresh worker process
    (``max_calls=1``: a cell's rclpy state ends with it). A task whose worker died, or
    that Ray could not run, is that job's failure."""

    name = "ray"

    def __init__(self, address: str | None = None, num_cpus: int | None = None, cpus_per_job: float = 1.0,
                 init_options: dict | None = None):
        self.address, self.num_cpus, self.cpus_per_job = address, num_cpus, cpus_per_job
        self.init_options = dict(init_options or {})
        self.workers = num_cpus

    def _init(self, ray) -> bool:
        if ray.is_initialized():
            return False
        options = {"include_dashboard": False, "log_to_driver": False, **self.init_options}
        if self.address:
            ray.init(address=self.address, **options)
        else:
            ray.init(num_cpus=self.num_cpus, **options)
        return True

    def map_unordered(self, fn, jobs: list[Job]):
        import ray  # only a campaign on Ray pays for it

        owned = self._init(ray)
        task = ray.remote(num_cpus=self.cpus_per_job, max_calls=1)(run_one)
        references = {task.remote(fn, job): (job, time.monotonic()) for job in jobs}
        try:
            while references:
                done, _ = ray.wait(list(references), num_returns=1, timeout=1.0)
                for reference in done:
                    job, start = references.pop(reference)
                    try:
                        outcome = ray.get(reference)
                    except ray.exceptions.RayError as exc:  # the worker died, the task could not run
                        outcome = Outcome(job.seed, None, f"{type(exc).__name__}: {str(exc).strip().splitlines()[0]}"
                                          if str(exc).strip() else type(exc).__name__, time.monotonic() - start)
                    yield outcome
        finally:
            if references:  # stopped early: the tasks not yet ended stop their graphs, then Ray goes
                for reference in references:
                    ray.cancel(reference)
                ray.wait(list(references), num_returns=len(references), timeout=STOP_GRACE_S)
            if owned:
                ray.shutdown()
