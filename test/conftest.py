"""Fixtures: unit tests need none; ROS tests use ``ros`` (in-process) and ``spawn`` (subprocess)."""

from __future__ import annotations

import os
import signal
import sys
import warnings
from pathlib import Path

# as in `make test` and the nodes (hex_control/ros/__init__.py): one OpenBLAS thread, since
# its spinning workers slow numpy 20x on a loaded machine; effective if numpy is not loaded yet
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# a `hexctl daemon` a test's verb starts (ros_cli/daemon.py) ends a minute after its last
# request, not ten: the run's domains are free soon after the run
os.environ.setdefault("HEXCTL_DAEMON_IDLE_S", "60")
# a run started in the background of a script (`make test &`) ignores SIGINT, and so did every
# process a test started: the tests of Ctrl-C on hexctl verbs waited for ever (3 of 3 under a
# background `/usr/bin/time pytest`). Handled here, it is the default again in every child.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from ros_harness import NodeProcess, RosHarness, remove_stale_fastdds_shm, run_domain_id  # noqa: E402

DOMAIN_ID = run_domain_id()


def load_script(name: str):
    """The module of ``scripts/<name>.py`` (the scripts are not a package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, Path(__file__).resolve().parent.parent / f"scripts/{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def ros_env():
    """Environment for subprocess nodes: this run's domain, discovery on localhost only."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(DOMAIN_ID)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    env["PYTHONFAULTHANDLER"] = "1"  # a crashing node leaves its threads' tracebacks in its log
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    yield env
    from hex_control.ros.tools.ros_cli import daemon

    if daemon.connect() is not None:  # this run's daemon, if a test started one: not left behind
        daemon.request({"op": "stop"})


@pytest.fixture
def ros(ros_env):
    harness = RosHarness(DOMAIN_ID)
    yield harness
    harness.close()


@pytest.fixture
def spawn(ros_env, tmp_path, request):
    """``spawn(['hex-load-predictor', '--ros-args', ...])`` -> NodeProcess, stopped at teardown."""
    processes: list[NodeProcess] = []

    def start(command: list[str]) -> NodeProcess:
        process = NodeProcess(command, ros_env, tmp_path / f"{Path(command[0]).name}-{len(processes)}.log")
        processes.append(process)
        return process

    yield start
    failed = getattr(request.node, "call_failed", False)
    for process in processes:
        # a failed test's nodes that still run leave every thread's traceback in their logs:
        # a node that hangs says where
        if process.stop(dump=failed) and failed:
            print(f"--- {process.log_path.name} (exit {process.process.returncode}):\n{process.output()[-4000:]}")


#: the modules whose tests run whole graphs or builds (tens of seconds each, half the suite's
#: wall time), costliest first (the colcon build last: `make setup` has built its interface
#: package, which on a fresh checkout had made it the longest single test)
SLOW_FIRST = ("test_end_to_end.py", "test_ros_cli.py", "test_attacks.py", "test_bench.py", "test_campaign.py",
              "test_determinism.py", "test_demo.py", "test_hostile_inputs.py", "test_colcon_build.py")
#: of those, the modules whose fixtures serve the whole module: dealt to one worker whole
WHOLE_MODULES = ("test_ros_cli.py",)
#: how many workers take the slow tests (the rest start with the quick ones and steal)
SLOW_LANES = 2
#: their slow tests that start processes without the ``ros_env`` fixture
SLOW_WITHOUT_ROS_ENV = ("test_loop_benchmark_runs_the_force_loop_over_ros",
                        "test_a_campaign_on_a_local_ray_gives_the_same_table")


def _is_slow(item) -> bool:
    """A test of SLOW_FIRST that starts processes (their unit tests are quick)."""
    return item.path.name in SLOW_FIRST and ("ros_env" in getattr(item, "fixturenames", ())
                                              or item.name in SLOW_WITHOUT_ROS_ENV)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """In xdist's controller, for each worker: the ``--dist`` it parsed (xdist sets the
    worker's own to "no")."""
    node.workerinput["dist"] = node.config.getoption("dist")


def pytest_collection_modifyitems(config, items):
    """The slow tests first. Under ``--dist worksteal`` (``make test``) dealt out to
    SLOW_LANES workers, each lane's share at the head of the block the scheduler first sends
    it (it splits the collection into equal contiguous blocks, and an idle worker steals from
    the tail of another's queue); the shares are even in number of tests, not in cost. Why
    two lanes: docs/testing.md."""
    slow = sorted(filter(_is_slow, items), key=lambda item: SLOW_FIRST.index(item.path.name))
    short = [item for item in items if not _is_slow(item)]
    workers = getattr(config, "workerinput", {}).get("workercount", 1)
    dist = getattr(config, "workerinput", {}).get("dist", config.getoption("dist", "no"))
    if workers == 1 or dist != "worksteal":
        items[:] = slow + short
        return
    units: list[list] = []  # each dealt to one worker: a test, or a whole module
    for item in slow:
        if units and item.path.name in WHOLE_MODULES and units[-1][0].path == item.path:
            units[-1].append(item)
        else:
            units.append([item])
    shares: list[list] = [[] for _ in range(workers)]
    for unit in units:  # to the lane with the fewest slow tests so far
        min(shares[:SLOW_LANES], key=len).extend(unit)
    ordered, left = [], len(items)
    for k, share in enumerate(shares):  # the scheduler's block sizes, as worksteal computes them
        block = left // (workers - k)
        filler = max(block - len(share), 0)
        ordered += share + short[:filler]
        del short[:filler]
        left -= block
    items[:] = ordered + short


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.when == "call" and report.failed:
        item.call_failed = True
    return report


def pytest_sessionfinish(session):
    """Once, after every worker has ended (xdist's controller, or a run without workers): the
    Fast DDS shared-memory files that the run's killed processes left behind, removed (some
    250 files a run; what a live process holds stays)."""
    if not hasattr(session.config, "workerinput"):
        try:
            remove_stale_fastdds_shm()
        except Exception as exc:  # noqa: BLE001 -- the middleware's tool: a tidy-up, not a test
            warnings.warn(f"Fast DDS shared memory not cleaned: {exc!r}", stacklevel=1)
