"""Launch-free ROS 2 test harness: private contexts, a spinning executor, wait helpers,
and nodes as real subprocesses (console scripts).

Each test gets its own ``rclpy.Context`` on the run's own ``ROS_DOMAIN_ID`` (so parallel
runs on one machine do not see each other), discovery limited to localhost, and a
``SingleThreadedExecutor`` spinning in a thread. Teardown order: executor.shutdown ->
destroy nodes -> context.shutdown -> join the thread.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import io
import os
import signal
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile

from hex_control.ros.app.graph import graph_nodes, stop_hung
from hex_control.ros.app.node_forks import NodeForks

#: Fast DDS accepts domain ids 0..232; stay clear of the default 0 used interactively, and of
#: 200..232, where the loop benchmark (hex_control/bench/loop.py) starts its own
_DOMAIN_FIRST, _DOMAIN_COUNT = 100, 100


def run_domain_id() -> int:
    """A domain id for this test run: fixed by the environment, else from the process id;
    under pytest-xdist one per worker, next to each other (from the controller's id)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if worker.startswith("gw"):
        workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
        first = int(os.environ.get("HEX_TEST_DOMAIN_ID", _DOMAIN_FIRST + os.getppid() % (_DOMAIN_COUNT - workers)))
        return first + int(worker[2:])
    return int(os.environ.get("HEX_TEST_DOMAIN_ID", _DOMAIN_FIRST + os.getpid() % _DOMAIN_COUNT))


def wait_until(condition, timeout_s: float, interval_s: float = 0.02, what: str = "condition"):
    """Poll ``condition()`` until it returns a truthy value; raise TimeoutError after timeout_s."""
    end = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > end:
            raise TimeoutError(f"timed out after {timeout_s:g} s waiting for {what}")
        time.sleep(interval_s)


def wait_for_count(count, target: int, stall_s: float, what: str = "items") -> None:
    """:func:`wait_until` ``count()`` reaches ``target``, for as long as it keeps rising:
    TimeoutError only once it has stood still for ``stall_s``. For work whose pace is the
    machine's (a node computing a chain of results): a loaded machine is slower, a stuck node
    stands still."""
    last = count()
    while last < target:
        last = wait_until(lambda: (n := count()) > last and n, stall_s,
                          what=f"{what} beyond {last} of {target}")


def diagnostics_value(diagnostics: list, node_name: str, key: str):
    """A node's latest value of a /diagnostics key (a counter or a value) among the collected
    DiagnosticArrays, or None."""
    for array in reversed(diagnostics):
        for status in array.status:
            if status.name == node_name:
                return {v.key: v.value for v in status.values}.get(key)
    return None


class RosHarness:
    """One private rclpy context with an executor spinning in a background thread."""

    def __init__(self, domain_id: int, executor_class=SingleThreadedExecutor):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        # SingleThreadedExecutor by default: rclpy's MultiThreadedExecutor delivered 226 of 1001
        # messages of a 200 Hz stream in 5 s here (the single-threaded one all 1001)
        self.executor = executor_class(context=self.context)
        self._nodes = []
        self._closing = False
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - shutdown of the context ends the spin; else say why
            if not self._closing:
                traceback.print_exc()
                raise

    @property
    def spinning(self) -> bool:
        """Whether the executor thread still runs callbacks (nothing else completes a future)."""
        return self._thread.is_alive()

    def add(self, node):
        """Spin an already constructed node (build it with ``context=harness.context``)."""
        self._nodes.append(node)
        self.executor.add_node(node)
        return node

    def node(self, name: str):
        return self.add(rclpy.create_node(name, context=self.context))

    def collect(self, msg_type, topic: str, qos=10, publishers: int = 0, timeout_s: float = 15.0) -> list:
        """Subscribe and return the list that received messages are appended to; with
        ``publishers`` > 0, first wait until that many publishers have matched."""
        received: list = []
        subscription = self.node(f"collect_{len(self._nodes)}").create_subscription(
            msg_type, topic, received.append, qos)
        wait_until(lambda: subscription.get_publisher_count() >= publishers, timeout_s,
                   what=f"{publishers} publisher(s) to match on {topic}")
        return received

    def wait_for_message(self, msg_type, topic: str, timeout_s: float = 10.0, predicate=None,
                         qos=QoSProfile(depth=10)):
        """The first message on ``topic`` satisfying ``predicate`` (default: any)."""
        received = self.collect(msg_type, topic, qos)
        predicate = predicate or (lambda _m: True)
        return wait_until(lambda: next((m for m in list(received) if predicate(m)), None),
                          timeout_s, what=f"a message on {topic}")

    def wait_for_service(self, client, timeout_s: float = 10.0) -> None:
        if not client.wait_for_service(timeout_sec=timeout_s):
            raise TimeoutError(f"service {client.srv_name} not available within {timeout_s:g} s")

    def call(self, client, request, timeout_s: float = 10.0, resend_s: float = 3.0):
        """The response to ``request``; asked again every ``resend_s`` unanswered (Fast DDS
        drops a response to a client it has not matched yet -- the services here are
        idempotent), TimeoutError after ``timeout_s``."""
        self.wait_for_service(client, timeout_s)
        end = time.monotonic() + timeout_s
        while True:
            future = client.call_async(request)
            try:
                wait_until(future.done, min(resend_s, max(end - time.monotonic(), 0.0)))
                return future.result()
            except TimeoutError:
                client.remove_pending_request(future)
                if time.monotonic() >= end:
                    raise TimeoutError(f"no response from {client.srv_name} within {timeout_s:g} s") from None

    def wait_for_match(self, node, topic: str, publishers: int = 0, subscribers: int = 0,
                       timeout_s: float = 15.0) -> None:
        """Wait until the graph shows at least this many publishers / subscribers on topic."""
        wait_until(lambda: node.count_publishers(topic) >= publishers
                   and node.count_subscribers(topic) >= subscribers,
                   timeout_s, what=f"{publishers} publisher(s), {subscribers} subscriber(s) on {topic}")

    def close(self) -> None:
        self._closing = True
        self.executor.shutdown(timeout_sec=5.0)
        for node in self._nodes:
            for waitable in list(node.waitables):  # action clients and servers: destroy_node leaves them, and
                waitable.destroy()  # they keep the DDS participant until the garbage collector finalizes them
            node.destroy_node()
        self.context.try_shutdown()
        self._thread.join(timeout=5.0)


def forked_node_module(command: list[str], env: dict) -> tuple[str, list[str]] | None:
    """(module, its arguments) of a graph node's command line, to be forked as the graph
    forks it: ``hex-plant ARGS`` or ``PYTHON [-P|-u|-B]... -m hex_control.ros.nodes.plant
    ARGS``; None for any other command (other interpreter options, another program), or
    with HEX_NODE_FORKS=0 (as for a graph)."""
    if env.get("HEX_NODE_FORKS", "1") == "0" or not command:
        return None
    name = Path(command[0]).name
    if name.startswith("hex-"):
        module, arguments = f"hex_control.ros.nodes.{name[4:].replace('-', '_')}", command[1:]
    elif name.startswith("python"):
        k = 1
        while k < len(command) and command[k] in ("-P", "-u", "-B"):
            k += 1
        if k + 1 >= len(command) or command[k] != "-m":
            return None
        module, arguments = command[k + 1], command[k + 2:]
    else:
        return None
    return (module, list(arguments)) if module in graph_node_modules() else None


@functools.cache
def graph_node_modules() -> tuple[str, ...]:
    """The node modules a graph's fork server imports (``NodeGraph.start``)."""
    return tuple(sorted({spec.module_path for spec in graph_nodes(Path("jobs"))}))


class NodeProcess:
    """A node started as a process of its own, e.g. ``NodeProcess(['hex-load-predictor', ...])``.

    A node of the graph (:func:`forked_node_module`) is forked from the fork server its
    worker's graphs use (``node_forks.py``), as the graph's own nodes are: its ``main()``
    with the command line's arguments, environment, log, signals and exit code, without the
    0.6-0.8 CPU s of imports that each of some 70 starts a suite paid. Unlike a fresh
    process it runs in a session of its own, in the server's working directory (the log's
    path is made absolute), with ``sys.argv[0]`` the module's name."""

    def __init__(self, command: list[str], env: dict, log_path: Path):
        self.log_path = Path(log_path).resolve()
        self._log = None
        self._forks = None
        forked = forked_node_module(command, env)
        if forked is not None:
            self._forks = NodeForks.shared(list(graph_node_modules()), env)
            try:
                self.process = self._forks.start(*forked, env, self.log_path)
            except BaseException:
                self._forks.release()
                raise
            return
        executable = Path(sys.executable).parent / command[0]
        if executable.exists():
            command = [str(executable), *command[1:]]
        self._log = open(self.log_path, "w")  # noqa: SIM115 - closed in stop()
        self.process = subprocess.Popen(command, env=env, stdout=self._log, stderr=subprocess.STDOUT)

    def output(self) -> str:
        if self._log is not None and not self._log.closed:
            self._log.flush()
        return self.log_path.read_text()

    def alive(self) -> bool:
        return self.process.poll() is None

    def stop(self, timeout_s: float = 10.0, dump: bool = False) -> int:
        """SIGINT (``dump``: at once SIGUSR1 then SIGABRT, for every thread's traceback in
        the log; so does a node that has not stopped ``timeout_s`` after SIGINT)."""
        if self.alive():
            if not dump:
                self.process.send_signal(signal.SIGINT)
            stop_hung(self.process, 0.0 if dump else timeout_s)
        if self._log is not None:
            self._log.close()
        if self._forks is not None:
            self._forks.release()
            self._forks = None
        return self.process.returncode


#: where Fast DDS keeps its shared-memory segments and ports on Linux
SHM_DIR = Path("/dev/shm")


def remove_stale_fastdds_shm(folder: Path = SHM_DIR, min_age_s: float = 60.0) -> int | None:
    """Remove the Fast DDS shared-memory files in ``folder`` that no live process holds (its
    segments and ports each come with a lock file its owner holds while it lives): Fast DDS's
    own `fastdds shm clean`, whose cleaner is loaded alone (its CLI imports psutil for its
    other verbs), on lock files older than ``min_age_s`` only: a file is made a moment before
    its lock is taken, by this run's nodes or by any other Fast DDS program on the machine.
    The files removed, or None where the venv has no such tool (or it has changed). The
    suite kills nodes on purpose, and each left its files: 3.4 GB in a day of runs on one host."""
    tool = Path(sys.prefix) / "tools/fastdds/shm/clean.py"
    if not tool.is_file() or not folder.is_dir():
        return None
    spec = importlib.util.spec_from_file_location("fastdds_shm_clean", tool)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    cleaner = getattr(module, "Clean", None)
    if not all(hasattr(cleaner, name) for name in ("run", "_Clean__shm_dir", "_Clean__list_dir")):
        return None  # its one place for the files could no longer be given: not /dev/shm by surprise

    class FolderClean(cleaner):
        def _Clean__shm_dir(self):  # the cleaner's place for the files and its listing (name-mangled)
            return folder

        def _Clean__list_dir(self):
            now = time.time()
            return [path.name for path in folder.iterdir()
                    if now - path.stat(follow_symlinks=False).st_mtime >= min_age_s]

    before = sum(1 for _ in folder.iterdir())
    with contextlib.redirect_stdout(io.StringIO()):
        FolderClean().run(False)
    return before - sum(1 for _ in folder.iterdir())
