"""The suite's clean-up of Fast DDS shared memory (ros_harness.remove_stale_fastdds_shm, run
at the end of every test run): files whose owner died go, files a live owner holds stay."""

import fcntl
import os

import pytest

from ros_harness import SHM_DIR, remove_stale_fastdds_shm


def test_a_dead_owners_segment_goes_and_a_held_one_stays():
    if not SHM_DIR.is_dir():
        pytest.skip("no /dev/shm")
    stale, held = (SHM_DIR / f"fastdds_{os.getpid():08x}{k:08x}" for k in (1, 2))
    files = [stale, stale.with_name(stale.name + "_el"), held, held.with_name(held.name + "_el")]
    for path in files:
        path.write_bytes(b"")
    try:
        with open(files[3], "ab") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # as a live participant holds its segment's lock file
            removed = remove_stale_fastdds_shm()
        assert removed is not None and removed >= 2
        assert not files[0].exists() and not files[1].exists()
        assert files[2].exists() and files[3].exists()
    finally:
        for path in files:
            path.unlink(missing_ok=True)
