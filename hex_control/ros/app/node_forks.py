"""A fork server for the graph's nodes: one process imports rclpy, numpy and the node
modules once and forks each node from there, so a graph start pays its imports once, not
once per node (a lock-step graph was ready on 3.8 CPU s, 2.2 forked).

It imports more than the modules' own imports: what a node module lists in ``PRELOAD``
(the modules its node imports while starting, e.g. scipy.linalg for the plant's servo) and
the type support modules of every interface type imported (else loaded in every node; the
middleware's own support of a type still loads in the node that uses it). With numpy.random
imported ahead, numpy's global RandomState is the same in every fork: the nodes draw from
seeded generators of their own. One server serves the graphs of a process that share the
modules and the environment but for what only a running node reads
(:meth:`NodeForks.shared`): a test worker's graphs, `hexctl demo --jobs N`.
(The nodes of a lock-step graph were then ready on 1.3-1.4 CPU s, not 2.0-2.4, and a
process's next graph paid no server's 0.45-0.6 s.)

The server runs no thread of its own and only imports: nothing of rclpy is initialised
before a fork, so every node makes its own context and DDS participant, as a node started
from its command line does. (Loading rclpy starts lttng-ust's two listener threads; the
wheels have no ``liblttng-ust-fork.so`` to preload, so a fork while one of them holds its
lock could leave tracing broken in that node: the project does not trace.) A fork runs its
module's ``main()`` as the node's console script would, with its own environment, session,
argv and log file.

The protocol, one JSON object a line: the server reads ``{"module", "argv", "env", "log"}``
on stdin and writes ``{"pid"}``, later ``{"exit": pid, "code"}`` (the code as
``Popen.returncode`` gives it) on a private copy of its stdout; fd 1 is then its stderr, so
that nothing printed in the server can corrupt the protocol.

:class:`NodeForks` is the client: ``start`` returns a :class:`ForkedNode`, which answers
as much of ``subprocess.Popen`` as the graph uses (pid, poll, wait, send_signal, kill).
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import threading
import time

#: the modules every node imports first (the rest come with the node modules themselves)
SHARED_IMPORTS = ("numpy", "rclpy", "rclpy.executors", "yaml")
UNKNOWN_EXIT = -255  # the exit code of a node whose server died before it (not a signal's)


def _run_fork(request: dict, server_fds: tuple[int, ...]) -> None:
    """In the child: become the node (never returns)."""
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # one sent meanwhile comes now, in here
        os.setsid()
        signal.set_wakeup_fd(-1)
        for fd in server_fds:
            os.close(fd)
        log = os.open(request["log"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(log, 1)
        os.dup2(log, 2)
        os.close(log)
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.close(null)
        sys.stdout = open(1, "w", buffering=1, closefd=False)
        sys.stderr = open(2, "w", buffering=1, closefd=False)
        os.environ.clear()
        os.environ.update(request["env"])
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        sys.argv = [request["module"], *request["argv"]]
        result = sys.modules[request["module"]].main()  # as its console script runs it
        code = result if isinstance(result, int) else 0
    except SystemExit as stop:
        code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
    except KeyboardInterrupt:  # before the node's own handler: die of it, as python would
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    except BaseException:  # noqa: BLE001 -- the node's traceback goes to its log, as python -m would print it
        import traceback

        traceback.print_exc()
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _import_type_supports() -> None:
    """Import the type support module of every message, service and action type imported
    (what a node's first publisher or client of the type would import). Only a head start: a
    type whose support fails to load is left to the node that uses it to report."""
    for name, module in list(sys.modules.items()):
        if name.rpartition(".")[2] in ("msg", "srv", "action"):
            for value in list(vars(module).values()):
                if isinstance(value, type) and hasattr(value, "__import_type_support__"):
                    try:
                        value.__import_type_support__()
                    except Exception:  # noqa: BLE001 -- a head start only (the docstring)
                        continue


def serve(modules: list[str]) -> None:
    """The server's loop (``python -m hex_control.ros.app.node_forks MODULE...``)."""
    import importlib

    protocol = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # whatever prints (an import, too) goes to stderr, not into the protocol
    for name in (*SHARED_IMPORTS, *modules):
        for preload in getattr(importlib.import_module(name), "PRELOAD", ()):
            importlib.import_module(preload)
    _import_type_supports()
    wake_read, wake_write = os.pipe()
    os.set_blocking(wake_write, False)
    signal.set_wakeup_fd(wake_write)
    signal.signal(signal.SIGCHLD, lambda *_: None)  # wakes the select through the pipe
    children: set[int] = set()
    requests = sys.stdin.fileno()
    pending = b""
    while True:
        ready, _, _ = select.select([requests, wake_read], [], [])
        if wake_read in ready:
            os.read(wake_read, 4096)
        if requests in ready:
            chunk = os.read(requests, 65536)
            if not chunk:
                return  # the client is gone; the nodes live on, as Popen children would
            pending += chunk
            while b"\n" in pending:
                line, pending = pending.split(b"\n", 1)
                request = json.loads(line)
                # a SIGINT the client sends the moment it has the pid must reach the node,
                # not the server's code in the child: held until the child can take it
                signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
                pid = os.fork()
                if pid == 0:
                    _run_fork(request, (wake_read, wake_write, protocol.fileno()))
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
                children.add(pid)
                protocol.write(json.dumps({"pid": pid}) + "\n")
        for pid in list(children):
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                children.discard(pid)
                code = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
                protocol.write(json.dumps({"exit": pid, "code": code}) + "\n")


class ForkedNode:
    """A node the server forked: the parts of ``subprocess.Popen`` the graph uses."""

    def __init__(self, forks: NodeForks, pid: int):
        self.forks, self.pid = forks, pid
        self._code: int | None = None

    @property
    def returncode(self) -> int | None:
        return self.poll()

    def poll(self) -> int | None:
        if self._code is None:
            self._code = self.forks.exit_codes.get(self.pid)
            if self._code is None and self.forks.server_gone:  # nobody reports its exit: is it there?
                try:
                    os.kill(self.pid, 0)
                except ProcessLookupError:
                    self._code = UNKNOWN_EXIT
        return self._code

    def wait(self, timeout: float | None = None) -> int:
        end = None if timeout is None else time.monotonic() + timeout
        with self.forks.changed:
            while self.poll() is None:
                left = None if end is None else end - time.monotonic()
                if left is not None and left <= 0:
                    raise subprocess.TimeoutExpired(f"node {self.pid}", timeout)
                # the reader notifies every exit; a gone server does not, hence the slices
                self.forks.changed.wait(min(left, 0.1) if left is not None else 0.1)
        return self.poll()

    def send_signal(self, number: int) -> None:
        if self.returncode is None:
            try:
                os.kill(self.pid, number)
            except ProcessLookupError:
                pass

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


#: environment variables the server's imports do not read, by prefix: ROS, its middleware
#: and its logging read theirs when a node initializes, after the fork; pytest's name the
#: test (a key with them started a server for every test)
READ_AFTER_FORK = ("ROS_", "RMW_", "FASTDDS_", "FASTRTPS_", "RCUTILS_", "PYTEST_")


class NodeForks:
    """The client of one fork server, started with ``env`` (the nodes' common environment)
    and the node ``modules`` to import."""

    _shared: dict[tuple, NodeForks] = {}
    _sharing = threading.Lock()

    @classmethod
    def shared(cls, modules: list[str], env: dict) -> NodeForks:
        """This process's running server for these modules and this environment (but for
        READ_AFTER_FORK: what the server's imports read, library paths or OpenBLAS's
        threads, must be the graph's), or a new one, which closes the servers no graph
        uses. The caller releases it (:meth:`release`) when its graph has stopped; the last one
        runs until the process ends."""
        key = (tuple(sorted(modules)),
               tuple(sorted((k, v) for k, v in env.items() if not k.startswith(READ_AFTER_FORK))))
        with cls._sharing:
            forks = cls._shared.get(key)
            if forks is None or not forks.running:
                for other_key, other in list(cls._shared.items()):
                    if other.users == 0 or not other.running:
                        del cls._shared[other_key]
                        other.close()
                forks = cls._shared[key] = cls(modules, env)
            forks.users += 1
            return forks

    def release(self) -> None:
        with NodeForks._sharing:
            self.users -= 1

    @property
    def running(self) -> bool:
        return not self.server_gone and self.server.poll() is None

    def __init__(self, modules: list[str], env: dict):
        self.server = subprocess.Popen([sys.executable, "-P", "-m", __name__, *modules], env=env,
                                       stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1,
                                       start_new_session=True)
        self.exit_codes: dict[int, int] = {}
        self.server_gone = False  # its stdout ended: exits are no longer reported
        self.users = 0  # graphs forking from it (shared)
        self.changed = threading.Condition()
        self._started: list[int] = []
        self._starting = threading.Lock()  # one start at a time: the n-th pid answers the n-th request
        threading.Thread(target=self._read, name="node-forks", daemon=True).start()

    def _read(self) -> None:
        try:
            for line in self.server.stdout:
                try:
                    message = json.loads(line)
                except ValueError:
                    continue
                with self.changed:
                    if "exit" in message:
                        self.exit_codes[message["exit"]] = message["code"]
                    else:  # a pid used again is a new node: the old one's exit is not its own
                        self.exit_codes.pop(message["pid"], None)
                        self._started.append(message["pid"])
                    self.changed.notify_all()
        finally:
            with self.changed:
                self.server_gone = True
                self.changed.notify_all()

    def start(self, module: str, argv: list[str], env: dict, log_path, timeout_s: float = 60.0) -> ForkedNode:
        open(log_path, "w").close()  # a log that cannot be made fails here, as Popen's would
        with self._starting:
            with self.changed:
                known = len(self._started)
            self.server.stdin.write(json.dumps({"module": module, "argv": list(argv), "env": env,
                                                "log": str(log_path)}) + "\n")
            self.server.stdin.flush()
            with self.changed:
                self.changed.wait_for(lambda: len(self._started) > known or self.server_gone, timeout_s)
                if len(self._started) == known:
                    self.close()  # a pid that came later would have no owner
                    raise RuntimeError(f"the fork server did not start {module} within {timeout_s:g} s "
                                       f"(server exit code {self.server.poll()})")
                return ForkedNode(self, self._started[known])

    def close(self) -> None:
        """Stop the server (the nodes it forked are the graph's to stop)."""
        if self.server.poll() is None:
            self.server.stdin.close()
            try:
                self.server.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                self.server.kill()
                self.server.wait()


if __name__ == "__main__":
    serve(sys.argv[1:])
