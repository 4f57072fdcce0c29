"""``hexctl campaign`` (issue 39 item 4): seeded jobs as independent cells on a pluggable
executor, gathered into the statistics of ``hexctl demo --jobs N``.

The core's tests run a fake job function (a pure function of the seed, milliseconds); one
test runs two short real jobs on two local workers against the serial demo of the same
seeds; one runs the fake jobs on a local Ray."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hex_control.campaign import Job, Outcome, campaign_record, gather, run_campaign, seeded_jobs, write_campaign
from hex_control.campaign.domains import bound_udp_ports, domains_in_use, lease_domain
from hex_control.campaign.executors import ProcessExecutor, RayExecutor, SerialExecutor

#: seeds the fake job fails on (a graph failure, as GraphFailure would)
FAILING = {3, 7}


class FakeGraphFailure(RuntimeError):
    one_line = "node plant exited with code 1; its log: plant.log"


def fake_job(job: Job) -> dict:
    """A job whose outcome is a function of its seed alone: a summary of the fields the
    statistics read, drawn from the seed's generator (floats to the last bit)."""
    if job.seed in FAILING:
        raise FakeGraphFailure("node plant exited with code 1")
    rng = np.random.default_rng(job.seed)
    charge = float(rng.exponential(0.01)) if rng.random() < 0.4 else 0.0
    return {"seed": job.seed, "charge": charge, "material_mm": float(rng.normal(0.01, 0.01)),
            "expected": float(rng.uniform(0.005, 0.01)), "passes": int(rng.integers(2, 7)),
            "_where": {"ros_domain_id": 0}}


def fake_statistics(summaries: list[dict]) -> dict:
    """Order-sensitive to the last bit, as job_statistics is (sums of floats)."""
    charges = np.array([s["charge"] for s in summaries])
    return {"jobs": len(summaries), "seeds": [s["seed"] for s in summaries], "charge_mean": float(charges.mean()),
            "charge_sum": float(sum(s["charge"] for s in summaries)),
            "material_mean_mm": float(np.mean([s["material_mm"] for s in summaries])),
            "passes_mean": float(np.mean([s["passes"] for s in summaries]))}


def crashing_job(job: Job) -> dict:
    """Seed 1's worker dies without a word (as a segfault would)."""
    if job.seed == 1:
        os._exit(9)
    return fake_job(job)


class ShuffledExecutor:
    """The outcomes in a given order (a parallel backend's: whichever ends first)."""

    name, workers = "shuffled", 1

    def __init__(self, order):
        self.order = order

    def map_unordered(self, fn, jobs):
        by_seed = {job.seed: job for job in jobs}
        for seed in self.order:
            yield SerialExecutor().map_unordered(fn, [by_seed[seed]]).__next__()


JOBS = seeded_jobs(0, 10, "/nonexistent")


def test_the_core_imports_neither_ros_nor_ray():
    """The campaign's core is ROS-free, and only a campaign on Ray pays for importing Ray."""
    probe = ("import sys, hex_control.campaign, hex_control.campaign.executors, hex_control.campaign.domains, "
             "hex_control.cli\nprint(sorted(m for m in ('rclpy', 'ray', 'hex_control_msgs') if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"


def test_seeded_jobs_are_the_demos_directories_and_refuse_nonsense(tmp_path):
    jobs = seeded_jobs(100, 3, tmp_path, {"deadline": 60.0})
    assert [j.seed for j in jobs] == [100, 101, 102]
    assert [Path(j.directory).name for j in jobs] == ["job_100", "job_101", "job_102"]
    assert all(j.settings == {"deadline": 60.0} for j in jobs)
    for count, seed in ((0, 0), (-3, 0), (2.5, 0), (2, -1)):
        with pytest.raises(ValueError):
            seeded_jobs(seed, count, tmp_path)
    with pytest.raises(ValueError, match="two jobs of one seed"):
        run_campaign([JOBS[0], JOBS[0]], fake_job, SerialExecutor(), progress=False)


def test_the_table_does_not_depend_on_the_order_jobs_end_in():
    serial = run_campaign(JOBS, fake_job, SerialExecutor(), progress=False)
    reversed_ = run_campaign(JOBS, fake_job, ShuffledExecutor(range(9, -1, -1)), progress=False)
    scrambled = run_campaign(JOBS, fake_job, ShuffledExecutor([4, 9, 0, 7, 2, 8, 1, 3, 6, 5]), progress=False)
    assert [o.seed for o in reversed_] == list(range(10))  # gathered in seed order
    table = gather(serial, fake_statistics)
    assert gather(reversed_, fake_statistics) == table
    assert gather(scrambled, fake_statistics) == table
    # the statistics see the summaries in seed order, as hexctl demo --jobs N runs them
    assert table["seeds"] == [0, 1, 2, 4, 5, 6, 8, 9] and table["jobs"] == 8


def test_a_failed_job_is_counted_and_reported_not_fatal(tmp_path):
    lines = []
    outcomes = run_campaign(JOBS, fake_job, SerialExecutor(), progress=False, on_outcome=lambda o: lines.append(o))
    failed = [o for o in outcomes if not o.ok]
    assert [o.seed for o in failed] == sorted(FAILING)
    assert all(o.summary is None and o.error == "FakeGraphFailure: node plant exited with code 1; its log: "
               "plant.log" for o in failed)
    assert len(lines) == 10  # every outcome reported as it came, the failures too
    assert all("_where" not in o.summary and o.where["ros_domain_id"] == 0 for o in outcomes if o.ok)
    record = campaign_record(outcomes, "serial", 1, wall_s=2.0)
    assert (record["jobs"], record["ran"], record["failed"]) == (10, 8, 2)
    assert record["failures"] == [{"seed": 3, "error": failed[0].error}, {"seed": 7, "error": failed[1].error}]
    stats = gather(outcomes, fake_statistics)
    write_campaign(tmp_path, outcomes, stats, record)
    assert json.loads((tmp_path / "statistics.json").read_text()) == stats
    assert (tmp_path / "statistics.json").read_text() == json.dumps(stats, indent=2)  # as hexctl demo writes it
    assert json.loads((tmp_path / "campaign.json").read_text())["failures"][1]["seed"] == 7
    # no job ran: no statistics, the campaign's record all the same
    none = [Outcome(3, None, "X: y")]
    assert gather(none, fake_statistics) is None
    write_campaign(tmp_path / "none", none, None, campaign_record(none, "serial", 1, 1.0))
    assert not (tmp_path / "none" / "statistics.json").exists()


def test_a_job_function_returning_no_dict_is_a_failure():
    outcome = run_campaign(JOBS[:1], lambda job: None, SerialExecutor(), progress=False)[0]
    assert not outcome.ok and outcome.error == "the job function returned NoneType, not a dict"


def test_the_worker_count_does_not_change_the_results():
    jobs = JOBS[2:8]  # seeds 3 and 7 fail
    serial = run_campaign(jobs, fake_job, SerialExecutor(), progress=False)
    one = run_campaign(jobs, fake_job, ProcessExecutor(1), progress=False)
    three = run_campaign(jobs, fake_job, ProcessExecutor(3), progress=False)
    for outcomes in (one, three):
        assert [(o.seed, o.summary, o.error) for o in outcomes] == [(o.seed, o.summary, o.error) for o in serial]
        assert gather(outcomes, fake_statistics) == gather(serial, fake_statistics)
    assert len({o.where["pid"] for o in three}) == 6  # a fresh process for every job
    assert all(o.where["pid"] != os.getpid() for o in three)


def test_a_worker_that_dies_is_that_jobs_failure():
    outcomes = run_campaign(JOBS[:4], crashing_job, ProcessExecutor(2), progress=False)
    assert [o.ok for o in outcomes] == [True, False, True, False]  # seed 3 fails as a fake graph failure
    assert outcomes[1].error == "WorkerDied: the job's process ended (exit code 9) without an outcome"
    assert outcomes[3].error.startswith("FakeGraphFailure")


def lingering_job(job: Job) -> dict:
    """Seed 0 ends once seed 1 has started; seed 1 runs until stopped, and says it was
    stopped through its ``finally`` (as a cell's JobSession stops its graph)."""
    flags = Path(job.settings["flags"])
    if job.seed == 0:
        deadline = time.monotonic() + 60.0
        while not (flags / "1.started").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        return {"seed": 0}
    (flags / "1.started").write_text("")
    try:
        time.sleep(120.0)  # the job's body: a long run, stopped before its end or not at all
        (flags / "1.ended").write_text("")
    finally:
        (flags / "1.stopped").write_text("")
    return {"seed": 1}


def test_a_stopped_campaign_lets_its_running_cells_unwind(tmp_path):
    jobs = seeded_jobs(0, 2, tmp_path, {"flags": str(tmp_path)})
    outcomes = ProcessExecutor(2).map_unordered(lingering_job, jobs)
    first = next(outcomes)
    assert first.seed == 0 and first.ok
    outcomes.close()  # as Ctrl-C or SIGTERM in hexctl campaign: the running cell gets one SIGTERM
    assert (tmp_path / "1.stopped").exists()  # its finally ran: a cell's graph would be stopped
    assert not (tmp_path / "1.ended").exists()  # stopped, not waited for to the end of its run


def test_the_progress_bar_counts_done_and_failed_with_an_eta(capfd):
    run_campaign(JOBS[:5], fake_job, SerialExecutor(), progress=True, on_outcome=lambda o: f"line {o.seed}")
    out, err = capfd.readouterr()
    assert [line for line in out.splitlines() if line.startswith("line")] == [f"line {k}" for k in range(5)]
    assert "campaign: 5/5 jobs (done 4, failed 1)" in err and "ETA" in err


def test_cells_on_one_host_never_share_a_domain(tmp_path):
    environments = [{"ROS_DOMAIN_ID": "42", "ROS_STATIC_PEERS": "10.0.0.1"} for _ in range(3)]
    held = []
    with lease_domain(environments[0], tmp_path, start=5) as a, lease_domain(environments[1], tmp_path, start=5) as b, \
            lease_domain(environments[2], tmp_path, start=5) as c:
        held = [a, b, c]
        assert len(set(held)) == 3
        assert [int(e["ROS_DOMAIN_ID"]) for e in environments] == held
        assert all(e["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST" and "ROS_STATIC_PEERS" not in e
                   for e in environments)
        # another process cannot take them while held
        probe = ("import sys; from pathlib import Path; from hex_control.campaign.domains import lease_domain\n"
                 f"with lease_domain({{}}, Path(sys.argv[1]), domains={held!r}, start=0) as d: print(d)")
        run = subprocess.run([sys.executable, "-c", probe, str(tmp_path)], capture_output=True, text=True, timeout=60)
        assert run.returncode != 0 and "every ROS domain" in run.stderr
    assert environments[0] == {"ROS_DOMAIN_ID": "42", "ROS_STATIC_PEERS": "10.0.0.1"}  # restored
    with lease_domain({}, tmp_path, domains=held[:1], start=0) as again:  # released on leaving
        assert again == held[0]


def test_a_domain_whose_dds_ports_are_bound_is_skipped(tmp_path):
    assert domains_in_use({7400 + 250 * 5 + 11, 7399, 7400 + 250 * 9}) == {5, 9}
    busy = domains_in_use(bound_udp_ports())
    free = [d for d in range(1, 102) if d not in busy]
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:  # a participant's port of domain free[0]
        try:
            sock.bind(("127.0.0.1", 7400 + 250 * free[0] + 11))
        except OSError:
            pytest.skip("the port was taken meanwhile")
        with lease_domain({}, tmp_path, domains=free[:2], start=0) as domain:
            assert domain == free[1]


def test_a_campaign_on_a_local_ray_gives_the_same_table():
    ray = pytest.importorskip("ray", reason="ray is in requirements.lock; this venv lacks it")
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the fake job, for Ray's workers
    jobs = JOBS[2:7]  # seed 3 fails
    serial = run_campaign(jobs, fake_job, SerialExecutor(), progress=False)
    executor = RayExecutor(num_cpus=2, init_options={"configure_logging": False})
    on_ray = run_campaign(jobs, fake_job, executor, progress=False)
    assert not ray.is_initialized()  # the executor shut down the Ray it started
    assert [(o.seed, o.summary, o.error) for o in on_ray] == [(o.seed, o.summary, o.error) for o in serial]
    assert gather(on_ray, fake_statistics) == gather(serial, fake_statistics)
    assert len({o.where["pid"] for o in on_ray}) == 5  # max_calls=1: a fresh worker for each job
    assert [o.ok for o in on_ray] == [True, False, True, True, True]


#: the end-to-end tests' short job (test_end_to_end.BEAD): one pass in a 12 s deadline; the
#: reports' PNGs (test_end_to_end draws them) not drawn: 1.7 CPU s a job
SHORT = ["--bead-length", "60", "--bead-height", "0.8", "--deadline", "12", "--seed", "6", "--no-record",
         "--no-plots"]


def _hexctl(*arguments) -> list[str]:
    return [str(Path(sys.executable).parent / "hexctl"), *arguments]


def _per_seed(directory: Path) -> dict:
    """Each job's job.json but for what differs from run to run: its wall time, the job id's clock."""
    jobs = {}
    for path in sorted(directory.glob("job_*/job.json")):
        summary = json.loads(path.read_text())
        del summary["wall_s"], summary["goal"]["job_id"]
        jobs[path.parent.name] = summary
    return jobs


def _differences(a, b, path: str = "") -> list[str]:
    """Where two JSON values differ, as paths (a failure says which figure moved)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for key in sorted(set(a) | set(b), key=str)
                for d in _differences(a.get(key), b.get(key), f"{path}.{key}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for k, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{path}[{k}]")]
    return [] if a == b or (a != a and b != b) else [f"{path}: {a!r} != {b!r}"]


def test_two_real_jobs_on_two_workers_end_as_in_the_serial_demo(ros_env, tmp_path):
    """``hexctl campaign --workers 2`` against ``hexctl demo --jobs 2`` of the same seeds, run
    side by side (three cells on two cores: lock-step outcomes do not depend on the load)."""
    from conftest import DOMAIN_ID

    from hex_control.campaign.domains import DOMAINS

    serial_dir, campaign_dir = tmp_path / "serial", tmp_path / "campaign"
    # the demo runs in the test run's domain, which takes no lease: hold it, so that no cell takes it
    # before the demo's participants bind its ports
    held = lease_domain({}, domains=[DOMAIN_ID]) if DOMAIN_ID in DOMAINS else None
    if held is not None:
        held.__enter__()
    try:
        with open(tmp_path / "serial.log", "w") as log:
            serial = subprocess.Popen(_hexctl("demo", "--jobs", "2", "--output", str(serial_dir), *SHORT),
                                      env=ros_env, stdout=log, stderr=subprocess.STDOUT)
            campaign = subprocess.run(_hexctl("campaign", "--jobs", "2", "--workers", "2", "--output",
                                              str(campaign_dir), *SHORT), env=ros_env, capture_output=True,
                                      text=True, timeout=900)
            assert serial.wait(timeout=900) == 0, (tmp_path / "serial.log").read_text()[-3000:]
    finally:
        if held is not None:
            held.__exit__(None, None, None)
    assert campaign.returncode == 0, campaign.stdout[-3000:] + campaign.stderr[-3000:]
    assert "campaign: 2/2 jobs (done 2, failed 0)" in campaign.stderr  # the progress bar
    assert "job 6: quit after 1 passes" in campaign.stdout and "job 7:" in campaign.stdout
    serial_jobs, campaign_jobs = _per_seed(serial_dir), _per_seed(campaign_dir)
    assert sorted(campaign_jobs) == ["job_006", "job_007"]
    # every pass, cut, part figure and charge, to the last bit
    assert not _differences(serial_jobs, campaign_jobs), _differences(serial_jobs, campaign_jobs)
    assert campaign_jobs["job_006"]["outcome"]["passes"] >= 1
    assert (campaign_dir / "statistics.json").read_text() == (serial_dir / "statistics.json").read_text()
    record = json.loads((campaign_dir / "campaign.json").read_text())
    assert (record["ran"], record["failed"], record["workers"], record["backend"]) == (2, 0, 2, "processes")
    domains = [cell["ros_domain_id"] for cell in record["cells"]]
    assert len(set(domains)) == 2 and DOMAIN_ID not in domains
    assert (campaign_dir / "job_006" / "run.json").exists() and (campaign_dir / "job_006" / "profiles").is_dir()
    assert not list(campaign_dir.glob("*/*.png")) and not list(serial_dir.glob("*/*.png"))  # --no-plots
