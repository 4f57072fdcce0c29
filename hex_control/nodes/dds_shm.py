"""Remove the Fast DDS shared-memory files of processes that died without cleaning up.

Fast DDS (ROS 2's default middleware) gives every participant a shared-memory segment
and every listening port a file in ``/dev/shm``, each with a lock file (``<name>_el``
exclusive, ``<name>_sl`` shared) that its live owner holds with ``flock``. A SIGKILLed
node leaves them behind unlocked, and a later process that opens the same port number can
end up listening on a port nobody delivers to: its graph discovers itself but no sample
arrives (eProsima/Fast-DDS issues 5053 and 5469; the remedy they give is eProsima's
``fastdds shm clean``, which this re-implements for the wheels that do not ship it).

Only files whose lock nobody holds are removed, so a graph that is running stays intact;
and only those older than a few seconds, because a participant starting right now creates
its files a moment before it locks them.
"""

from __future__ import annotations

import fcntl
import os
import re
import time
from pathlib import Path

SHM_DIRECTORY = Path("/dev/shm")
MIN_AGE_S = 5.0  # younger unlocked files may belong to a participant that is being created
_LOCK = re.compile(r"^(fastdds_(?:[0-9a-f]{16}|port\d+))_(el|sl)$")


def _held(lock_file: Path) -> bool:
    """Whether a live process holds ``lock_file`` (a non-blocking exclusive flock fails)."""
    try:
        with open(lock_file, "ab") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False  # gone meanwhile, or not ours to open: nothing to protect
    return False


def _age_s(path: Path) -> float:
    try:
        return time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return 0.0


def zombie_files(directory: Path = SHM_DIRECTORY, min_age_s: float = MIN_AGE_S) -> list[Path]:
    """The Fast DDS files in ``directory`` whose owners are gone: every segment or port
    none of whose lock files is held or younger than ``min_age_s``, with its lock files
    and (ports) its mutex."""
    directory = Path(directory)
    locks: dict[str, list[Path]] = {}
    try:
        names = os.listdir(directory)
    except FileNotFoundError:
        return []
    for name in names:
        if match := _LOCK.match(name):
            locks.setdefault(match.group(1), []).append(directory / name)
    zombies = []
    for base, lock_files in sorted(locks.items()):
        if any(_age_s(lock) < min_age_s or _held(lock) for lock in lock_files):
            continue
        candidates = [directory / base, *lock_files, directory / f"sem.{base}_mutex"]
        zombies += [path for path in candidates if path.exists()]
    return zombies


def clean_zombie_files(directory: Path = SHM_DIRECTORY, min_age_s: float = MIN_AGE_S) -> list[Path]:
    """Delete :func:`zombie_files`; returns what was deleted."""
    removed = []
    for path in zombie_files(directory, min_age_s):
        try:
            path.unlink()
            removed.append(path)
        except FileNotFoundError:
            pass
    return removed
