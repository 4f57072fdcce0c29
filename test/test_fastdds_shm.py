"""The suite's clean-up of Fast DDS shared memory (ros_harness.remove_stale_fastdds_shm, run
when a test run has ended): files whose owner died go, files a live owner holds stay. Here on
a folder of its own: /dev/shm is not cleaned while the other workers' nodes run."""

import fcntl

from ros_harness import remove_stale_fastdds_shm


def test_a_dead_owners_segment_and_port_go_and_held_ones_stay(tmp_path):
    names = ("fastdds_00000000000000a1", "fastdds_00000000000000a1_el",  # a dead owner's segment
             "fastdds_00000000000000b2", "fastdds_00000000000000b2_el",  # a live one's
             "fastdds_port7411", "fastdds_port7411_el", "sem.fastdds_port7411_mutex",  # a dead port
             "fastdds_port7413", "fastdds_port7413_sl", "sem.fastdds_port7413_mutex")  # a live one
    for name in names:
        (tmp_path / name).write_bytes(b"")
    with open(tmp_path / names[3], "ab") as segment, open(tmp_path / names[8], "ab") as port:
        fcntl.flock(segment, fcntl.LOCK_EX)  # as a live participant holds its lock files
        fcntl.flock(port, fcntl.LOCK_SH)
        assert remove_stale_fastdds_shm(tmp_path) == 0  # all made just now: perhaps not locked yet
        assert remove_stale_fastdds_shm(tmp_path, min_age_s=0.0) == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names[2:4] + names[7:])
    assert remove_stale_fastdds_shm(tmp_path / "absent") is None
