"""A loaded machine for a test, at the least CPU it takes (issue 39: the determinism test's
two burners took some 20 CPU s of a suite whose other workers already kept both cores busy).

:class:`LoadedMachine` holds one CPU-burning process per core and lets run only as many as
the machine lacks: every ``tick_s`` it reads how many tasks the rest of the machine has
runnable (``procs_running`` of /proc/stat, averaged over the tick, less the burners that
run) and runs burners until the runnable tasks number one more than the cores, so that
some task always waits for a CPU. On an idle machine, beside a one-core job, both burners
run, as two plain burners did; beside a busy test suite, few or none.

What the test gets is measured, not assumed: ``runnable_mean``, the runnable tasks of the
whole machine, burners included, averaged over the hold.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading

#: a burner: killed with its parent (PR_SET_PDEATHSIG; a stopped burner cannot see its own
#: end), gone at once if the parent went before that, and ending itself after 600 s
BURN = """import ctypes, os, signal, sys, time
ctypes.CDLL(None).prctl(1, signal.SIGKILL)
if os.getppid() != int(sys.argv[1]):
    sys.exit()
end = time.monotonic() + 600
while time.monotonic() < end:
    pass
"""


def runnable_tasks() -> int:
    """Tasks runnable on the machine now, running or waiting for a CPU (/proc/stat)."""
    with open("/proc/stat") as stat:
        for line in stat:
            if line.startswith("procs_running "):
                return int(line.split()[1])
    raise OSError("/proc/stat has no procs_running")


def burners_wanted(others: float, cores: int) -> int:
    """Burners to run beside ``others`` runnable tasks (mean) so that the runnable tasks
    number at least one more than the ``cores``; never more than one per core."""
    return min(cores, max(0, math.ceil(cores + 1 - others)))


class LoadedMachine:
    """``with LoadedMachine() as load: ...``: the machine loaded while held; ``load.runnable_mean``
    after it. ``samples_per_tick`` reads of /proc/stat are spread over each ``tick_s``."""

    def __init__(self, cores: int | None = None, tick_s: float = 0.1, samples_per_tick: int = 10):
        self.cores = cores or len(os.sched_getaffinity(0))  # the cores this process may use
        self.tick_s, self.samples_per_tick = tick_s, samples_per_tick
        self.burners: list[subprocess.Popen] = []
        self.running = 0  # the first ``running`` burners run, the others are stopped
        self._samples: list[int] = []  # runnable tasks of the whole machine, one per read
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._keep, name="loaded-machine", daemon=True)

    @property
    def reads(self) -> int:
        """Reads of the runnable tasks so far."""
        return len(self._samples)

    @property
    def runnable_mean(self) -> float:
        return sum(self._samples) / len(self._samples) if self._samples else math.nan

    def __enter__(self) -> LoadedMachine:
        runnable_tasks()  # a machine that does not say cannot be kept loaded: OSError now
        try:
            for _ in range(self.cores):
                self.burners.append(subprocess.Popen([sys.executable, "-c", BURN, str(os.getpid())]))
        except BaseException:
            self._kill_burners()
            raise
        self.running = self.cores
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        self._kill_burners()

    def _kill_burners(self) -> None:
        for burner in self.burners:
            burner.kill()  # a stopped one too
            burner.wait()

    def _keep(self) -> None:
        while not self._stop.is_set():
            reads = []
            for _ in range(self.samples_per_tick):
                if self._stop.wait(self.tick_s / self.samples_per_tick):
                    return
                reads.append(runnable_tasks() - 1)  # this thread, reading
            self._samples += reads
            self._run(burners_wanted(sum(reads) / len(reads) - self.running, self.cores))

    def _run(self, count: int) -> None:
        for k, burner in enumerate(self.burners):
            if (k < count) != (k < self.running):
                burner.send_signal(signal.SIGCONT if k < count else signal.SIGSTOP)
        self.running = count
