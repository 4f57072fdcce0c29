"""One seed, one part (issue 19, DESIGN.md 4.1): the whole graph in lock-step, run twice
with the same seed, once at the root on an idle machine and once in a cell's namespace
on a loaded one (more tasks runnable than cores: CPU-burning processes fill what the rest
of the machine leaves, cpu_load.py), gives bit-identical pass commands, measured cuts and
final contours. (The namespace is issue 37 item 7: every node and parameter file lands in
the cell, so its job is the root's; it had its own test and two jobs more, issue 39.)

Why it can: the tool path reaches the plant whole, as a strut trajectory, before the pass
starts; the plant advances only when the force command answering its last state and the
trajectory covering the next step are in hand; and between passes its clock stands still
while the planners plan, so the time a pass waits for is the pass planner's fixed
start_delay_s, not however long the planning took on a busy machine."""


import numpy as np
from cpu_load import LoadedMachine
from test_end_to_end import BEAD, RESET_TIME_S, assert_contact_when_planned

from hex_control.ros.app.grind_job import JobSession


def _job(directory, seed: int, namespace: str = "") -> dict:
    with JobSession(directory, seed=seed, plant_overrides=BEAD, record=False, namespace=namespace) as session:
        session.start_job(20.0, RESET_TIME_S, job_id="determinism")
        outcome = session.wait_for_outcome(400.0)
    record = session.record
    assert_contact_when_planned(record)  # the controller held each pass's force trajectory in time
    assert record.k1_predictions  # the cell's observer heard the cell's own pass predictor
    return {"outcome": outcome, "commands": record.commands,
            "cuts": {k: (r["measured_cut_depth_mm"], r["duration_s"], r["stamp_s"]) for k, r in record.results.items()},
            "contours": {k: (c.x_mm, c.z_mm) for k, (c, _) in record.contours.items()}}


def test_the_same_seed_gives_the_same_part_on_an_idle_and_a_loaded_machine(ros_env, tmp_path):
    idle = _job(tmp_path / "idle", seed=7)
    with LoadedMachine() as load:
        loaded = _job(tmp_path / "loaded", seed=7, namespace="/cell3")
    assert load.runnable_mean > load.cores, load.runnable_mean  # some task waited for a CPU
    assert idle["outcome"]["passes"] >= 2
    # the predictor moved K1 after pass 0 (a namespaced predictor once ran with default
    # parameters on the root's results: K1 planned 10.0 every pass)
    plans = [idle["commands"][k]["specific_energy_j_mm3"] for k in range(idle["outcome"]["passes"])]
    assert plans[0] == 10.0 and plans[1] != 10.0, plans
    assert loaded["outcome"] == idle["outcome"]
    assert loaded["commands"] == idle["commands"]  # every decision, to the last bit
    assert loaded["cuts"] == idle["cuts"]  # measured cut, duration and the plant time it ended
    assert sorted(loaded["contours"]) == sorted(idle["contours"])
    for k, (x, z) in idle["contours"].items():
        assert np.array_equal(loaded["contours"][k][0], x) and np.array_equal(loaded["contours"][k][1], z)
