"""Zombie Fast DDS shared-memory files: found by their unheld locks, removed, live ones kept."""

from __future__ import annotations

import fcntl
import os
import time

import pytest

from hex_control.nodes.dds_shm import SHM_DIRECTORY, clean_zombie_files, zombie_files


def _touch(directory, *names):
    for name in names:
        (directory / name).write_bytes(b"")


def test_only_files_whose_locks_nobody_holds_are_removed(tmp_path):
    _touch(tmp_path,
           "fastdds_0123456789abcdef", "fastdds_0123456789abcdef_el",  # live segment
           "fastdds_fedcba9876543210", "fastdds_fedcba9876543210_el",  # dead segment
           "fastdds_port7411", "fastdds_port7411_el", "sem.fastdds_port7411_mutex",  # dead port
           "fastdds_port7413", "fastdds_port7413_el", "fastdds_port7413_sl",  # a live sender holds _sl
           "sem.other_mutex", "unrelated_el")
    held = [open(tmp_path / name, "ab") for name in ("fastdds_0123456789abcdef_el", "fastdds_port7413_sl")]
    for handle in held:
        fcntl.flock(handle, fcntl.LOCK_SH)
    try:
        dead = {"fastdds_fedcba9876543210", "fastdds_fedcba9876543210_el",
                "fastdds_port7411", "fastdds_port7411_el", "sem.fastdds_port7411_mutex"}
        assert zombie_files(tmp_path) == []  # all just made: may be a participant being created
        assert {p.name for p in zombie_files(tmp_path, min_age_s=0.0)} == dead
        assert {p.name for p in clean_zombie_files(tmp_path, min_age_s=0.0)} == dead
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
            ["fastdds_0123456789abcdef", "fastdds_0123456789abcdef_el", "fastdds_port7413",
             "fastdds_port7413_el", "fastdds_port7413_sl", "sem.other_mutex", "unrelated_el"])
    finally:
        for handle in held:
            handle.close()
    # released locks: the rest are zombies now; a missing directory has none
    hour_ago = time.time() - 3600.0
    for path in tmp_path.iterdir():
        os.utime(path, (hour_ago, hour_ago))
    assert len(clean_zombie_files(tmp_path)) == 5
    assert zombie_files(tmp_path / "absent") == []


def _exclusive_locks_open_in(pid: int) -> set[str]:
    """Names of the ``_el`` lock files in /dev/shm that process ``pid`` has open."""
    names = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith(f"{SHM_DIRECTORY}/") and target.endswith("_el"):
            names.add(os.path.basename(target))
    return names


def test_a_killed_node_leaves_zombies_and_a_live_one_does_not(spawn):
    """The premise, on the real middleware: a node's files are held while it lives and
    become zombies when it is SIGKILLed."""
    if not SHM_DIRECTORY.is_dir():
        pytest.skip(f"no {SHM_DIRECTORY}: Fast DDS keeps its shared memory elsewhere here")
    node = spawn(["hex-input-shaper"])
    deadline = time.monotonic() + 30.0
    while not (mine := _exclusive_locks_open_in(node.process.pid)):
        assert time.monotonic() < deadline, "the node made no shared-memory files"
        time.sleep(0.2)
    time.sleep(1.0)  # all its ports open
    mine = _exclusive_locks_open_in(node.process.pid)
    assert not mine & {p.name for p in zombie_files(min_age_s=0.0)}
    node.process.kill()
    node.process.wait()
    bases = {name.removesuffix("_el") for name in mine}
    its_files = {f"{b}{suffix}" for b in bases for suffix in ("", "_el", "_sl")} | {f"sem.{b}_mutex" for b in bases}
    zombies = [p for p in zombie_files(min_age_s=0.0) if p.name in its_files]
    assert mine <= {p.name for p in zombies}, "a lock still held after SIGKILL"
    for path in zombies:  # only the killed node's: other graphs may be starting on this machine
        path.unlink()
