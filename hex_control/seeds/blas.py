"""Pin the BLAS libraries numpy and scipy bundle to one thread, after they are loaded.

The seed simulations multiply 6x6 matrices some 10^5 times a second; OpenBLAS's threads only
spin and contend for the cores there (``hexctl chatter`` took 111 s on a shared two-core
machine with the default threads, 16 s with one). ``OPENBLAS_NUM_THREADS`` works only before
numpy is imported, and ``hexctl`` imports it before a verb runs, so this calls each loaded
OpenBLAS's own ``*_set_num_threads`` (what threadpoolctl does), found in the process's
memory map. Child processes get the environment variables as well."""

from __future__ import annotations

import ctypes
import os

_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads", "openblas_set_num_threads")


def _loaded_blas_paths() -> set[str]:
    try:
        with open("/proc/self/maps") as maps:
            return {line.split()[-1] for line in maps if "openblas" in line.split()[-1].lower() and ".so" in line}
    except OSError:  # not Linux: the environment variables are all we can set
        return set()


def limit_blas_threads(threads: int = 1) -> int:
    """Set every loaded OpenBLAS to ``threads`` and the environment for child processes;
    returns how many libraries were set (0 if numpy is not loaded yet: then the
    environment alone takes effect)."""
    if threads < 1:
        raise ValueError("threads must be >= 1")
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[name] = str(threads)
    done = 0
    for path in sorted(_loaded_blas_paths()):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for setter in _SETTERS:
            function = getattr(library, setter, None)
            if function is not None:
                function(ctypes.c_int(threads))
                done += 1
                break
    return done


def blas_threads() -> dict[str, int]:
    """{library file: its thread count} of every loaded OpenBLAS (for tests and reports)."""
    counts = {}
    for path in sorted(_loaded_blas_paths()):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for getter in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                       "openblas_get_num_threads"):
            function = getattr(library, getter, None)
            if function is not None:
                counts[os.path.basename(path)] = int(function())
                break
    return counts
