"""``hexctl daemon start|stop|status``: a long-lived participant that has already discovered
the graph, as ros2cli's daemon. ``topic list``, ``node list``, ``service list`` ask it for its
graph and ``topic echo`` has it subscribe and forward the serialized messages (a latched
topic, its publishers all transient local, it goes on holding after the echo, and the next
echo gets the stored messages at once: a new subscription waits for the publisher to learn
of it, 0.3 s idle and up to 2.5 s at a load of 20 here): a verb's own
new participant waits for discovery, and Fast DDS finds about one remote participant in four
only at that one's next announcement, up to 3 s later (measured here, at any load, whatever
the initial announcements), so a list cut short missed topics and an echo took up to 3 s.

The first verb that finds no daemon starts one and works without it this time; the daemon
ends after IDLE_S without a request. One daemon per user and discovery setting (domain id,
discovery range, static peers, RMW), on a Unix socket. Requests and answers are JSON lines;
an echo is answered by a header line, then each message as a 4-byte big-endian length and
its CDR bytes, until the client closes the connection.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import queue
import socket
import socketserver
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from pathlib import Path

#: a daemon without requests ends after this long (s; HEXCTL_DAEMON_IDLE_S)
IDLE_S = float(os.environ.get("HEXCTL_DAEMON_IDLE_S", "600"))
#: a node seen without endpoints counts as still being discovered for at most this long (s)
INCOMPLETE_NODE_S = 3.0
#: how often the daemon looks at its graph (s)
LOOK_S = 0.2
#: a latched topic's messages the daemon keeps (a late subscriber's history)
LATCHED_DEPTH = 100
#: the graph a daemon serves counts as settled once it has run this long and stood still for
#: GRAPH_QUIET_S (common.MIN_DISCOVERY_S: every participant announces itself every 3 s)
SETTLED_AGE_S = 4.5
GRAPH_QUIET_S = 0.6
NODE_NAME = "_hexctl_daemon"  # hidden: a leading underscore (node list leaves it out)
_ENVIRONMENT = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "RMW_IMPLEMENTATION",
                "ROS_LOCALHOST_ONLY")


def socket_path(environ=os.environ) -> Path:
    """The daemon's socket for this user and discovery setting."""
    setting = "|".join(environ.get(k, "") for k in _ENVIRONMENT)
    digest = hashlib.sha256(setting.encode()).hexdigest()[:12]
    return Path(tempfile.gettempdir()) / f"hexctl-daemon-{os.getuid()}-{digest}.sock"


# -- the client side (the verbs) ---------------------------------------------------------------

def disabled() -> bool:
    return os.environ.get("HEXCTL_NO_DAEMON", "") not in ("", "0")


def connect(timeout_s: float = 2.0) -> socket.socket | None:
    """A connection to the running daemon, or None (none runs, or it does not answer)."""
    if disabled():
        return None
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.settimeout(timeout_s)
    try:
        client.connect(str(socket_path()))
    except OSError:
        client.close()
        return None
    return client


def start() -> None:
    """Start a daemon in the background (its own session: a Ctrl-C on the verb leaves it)."""
    if disabled():
        return
    subprocess.Popen([sys.executable, "-m", "hex_control.ros.tools.ros_cli.daemon"], stdin=subprocess.DEVNULL,
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def request(message: dict, timeout_s: float = 5.0) -> dict | None:
    """The daemon's answer to one request; None if no daemon answered (one is started then)."""
    client = connect(timeout_s)
    if client is None:
        start()
        return None
    try:
        with client:
            client.sendall(json.dumps(message).encode() + b"\n")
            line = client.makefile("rb").readline()
        return json.loads(line) if line else None
    except (OSError, ValueError):
        return None


def settled_graph(max_wait_s: float) -> dict | None:
    """The daemon's graph once settled (at most ``max_wait_s``), or None without a daemon."""
    end = time.monotonic() + max_wait_s
    while True:
        graph = request({"op": "graph"})
        if graph is None or (graph["age_s"] >= SETTLED_AGE_S and graph["quiet_s"] >= GRAPH_QUIET_S) \
                or time.monotonic() >= end:
            return graph
        time.sleep(min(0.1, max(end - time.monotonic(), 0.0)))


def echo_stream(topic: str, timeout_s: float, qos: dict):
    """(type name, the connection, its reading file) of the daemon's echo of ``topic``, once
    it has found the publishers and subscribed; None without a daemon. The daemon's error (no
    publisher in time) is raised as ValueError."""
    client = connect(timeout_s + 2.0)
    if client is None:
        start()
        return None
    client.settimeout(None)
    client.sendall(json.dumps({"op": "echo", "topic": topic, "timeout_s": timeout_s, **qos}).encode() + b"\n")
    stream = client.makefile("rb")
    header = stream.readline()
    if not header:
        client.close()
        return None
    answer = json.loads(header)
    if "error" in answer:
        client.close()
        raise ValueError(answer["error"])
    return answer["type"], client, stream


def read_frame(stream) -> bytes | None:
    """The next message's CDR bytes of an echo stream; None when the daemon ended it."""
    size = stream.read(4)
    if len(size) < 4:
        return None
    return stream.read(struct.unpack(">I", size)[0])


def daemon_verb(verb: str) -> int:
    """``hexctl daemon start|stop|status``."""
    if verb == "start":
        if connect() is None:
            start()
            end = time.monotonic() + 30.0
            while connect() is None:
                if time.monotonic() >= end:
                    raise ValueError(f"the hexctl daemon did not come up on {socket_path()} within 30 s")
                time.sleep(0.1)
        print("The daemon is running")
        return 0
    answer = None if connect() is None else request({"op": "stop" if verb == "stop" else "status"})
    if answer is None:
        print("The daemon is not running")
        return 0 if verb == "stop" else 1
    print("The daemon has been stopped" if verb == "stop" else
          f"The daemon is running (pid {answer['pid']}, for {answer['age_s']:.0f} s, {socket_path()})")
    return 0


class _Latched:
    """A latched topic the daemon holds: its type, the messages stored (CDR), and the queues
    of the echoes listening. Touched only on the spinning thread."""

    def __init__(self, type_name: str):
        self.type_name = type_name
        self.messages: deque = deque(maxlen=LATCHED_DEPTH)
        self.listeners: list[queue.Queue] = []
        self.subscription = None

    def on_message(self, data: bytes) -> None:
        self.messages.append(data)
        for listener in self.listeners:
            listener.put(data)


# -- the daemon ---------------------------------------------------------------------------------

class _Daemon:
    def __init__(self):
        import rclpy

        from hex_control.ros.tools.ros_cli.common import graph_snapshot

        rclpy.init(args=None)
        self.rclpy, self.snapshot = rclpy, graph_snapshot
        self.node = rclpy.create_node(NODE_NAME, start_parameter_services=False)
        self.started = self.changed = time.monotonic()
        self.last_request = self.started
        self.graph, _complete = graph_snapshot(self.node)
        self.incomplete_since = None
        self.jobs: queue.Queue = queue.Queue()  # (function, its result's queue): run on the spinning thread
        self.echoes = 0
        self.stopping = False
        self.latched: dict[str, _Latched] = {}
        self.wake = self.node.create_guard_condition(lambda: None)

    def hold(self, topic: str, publishers) -> _Latched | None:
        """The held subscription of ``topic`` if its publishers are all transient local
        (created now, kept for the next echo), else None. On the spinning thread."""
        from rclpy.qos import DurabilityPolicy

        from hex_control.ros.infra.messages import message_class
        from hex_control.ros.tools.ros_cli.topic import publishers_qos

        if topic in self.latched:
            return self.latched[topic]
        qos = publishers_qos(publishers, depth=LATCHED_DEPTH)
        if qos.durability != DurabilityPolicy.TRANSIENT_LOCAL or len({p.topic_type for p in publishers}) != 1:
            return None
        held = _Latched(publishers[0].topic_type)
        held.subscription = self.node.create_subscription(message_class(held.type_name), topic, held.on_message,
                                                          qos, raw=True)
        self.latched[topic] = held
        return held

    def forget_gone_publishers(self) -> None:
        """A held topic whose publishers are gone: their messages go with them."""
        for topic, held in self.latched.items():
            if held.messages and not self.node.get_publishers_info_by_topic(topic):
                held.messages.clear()

    def on_spin_thread(self, function):
        answer: queue.Queue = queue.Queue()
        self.jobs.put((function, answer))
        self.wake.trigger()  # the spin's wait ends now, not at its timeout
        ok, value = answer.get()
        if not ok:
            raise value
        return value

    def run(self) -> None:
        last_look = 0.0
        while not self.stopping and self.rclpy.ok():
            self.rclpy.spin_once(self.node, timeout_sec=0.02 if self.echoes else 0.05)
            while not self.jobs.empty():
                function, answer = self.jobs.get()
                try:
                    answer.put((True, function()))
                except Exception as exc:  # noqa: BLE001 - handed to the request's thread
                    answer.put((False, exc))
            now = time.monotonic()
            if now - last_look >= LOOK_S:
                last_look = now
                graph, complete = self.snapshot(self.node)
                # the daemon's own subscriptions are no news
                graph = (tuple(n for n in graph[0] if n[1] != NODE_NAME), *graph[1:])
                if complete:
                    self.incomplete_since = None
                elif self.incomplete_since is None:
                    self.incomplete_since = now
                # a node seen without its endpoints yet: still being discovered (for a while)
                waiting = self.incomplete_since is not None and now - self.incomplete_since < INCOMPLETE_NODE_S
                if graph != self.graph or waiting:
                    self.graph, self.changed = graph, now
                    self.forget_gone_publishers()
                if not self.echoes and now - self.last_request > IDLE_S:
                    self.stopping = True

    def graph_answer(self) -> dict:
        nodes, topics, services = self.graph
        now = time.monotonic()
        return {"age_s": now - self.started, "quiet_s": now - self.changed,
                "nodes": [[n[0], n[1]] for n in nodes], "topics": [[n, list(t)] for n, t in topics],
                "services": [[n, list(t)] for n, t in services]}

    def echo_latched(self, connection, topic: str) -> None:
        """A held latched topic: the stored messages at once, then each new one."""
        held, frames = self.latched[topic], queue.Queue()

        def listen():
            held.listeners.append(frames)
            for data in held.messages:
                frames.put(data)
        self.on_spin_thread(listen)
        try:
            self.forward(connection, held.type_name, frames)
        finally:
            self.on_spin_thread(lambda: held.listeners.remove(frames))

    def forward(self, connection, type_name: str, frames: queue.Queue) -> None:
        """Send the header, then each message of ``frames`` until the client closes."""
        self.echoes += 1
        try:
            connection.sendall(json.dumps({"type": type_name}).encode() + b"\n")
            connection.setblocking(False)
            while not self.stopping:
                try:
                    data = frames.get(timeout=0.2)
                except queue.Empty:
                    try:
                        if connection.recv(1, socket.MSG_PEEK) == b"":
                            return  # the client closed
                    except BlockingIOError:
                        pass
                    continue
                connection.setblocking(True)
                connection.sendall(struct.pack(">I", len(data)) + data)
                connection.setblocking(False)
        except OSError:
            return  # the client went
        finally:
            self.echoes -= 1

    def echo(self, connection, message: dict) -> None:
        """Subscribe once the topic's publishers are known, forward until the client goes."""
        from hex_control.ros.tools.ros_cli.common import VerbError, qos_from_options
        from hex_control.ros.tools.ros_cli.topic import publishers_qos

        topic, timeout_s = message["topic"], float(message["timeout_s"])
        end = time.monotonic() + timeout_s
        while not (publishers := self.on_spin_thread(lambda: self.node.get_publishers_info_by_topic(topic))):
            if time.monotonic() >= end:
                raise VerbError(f"no publisher of {topic} within {timeout_s:g} s "
                                "(is it running, with the same ROS_DOMAIN_ID? hexctl topic list)")
            time.sleep(0.02)
        if not any(message.get(k) for k in ("durability", "reliability", "depth")) \
                and self.on_spin_thread(lambda: self.hold(topic, publishers)) is not None:
            self.echo_latched(connection, topic)
            return
        qos = qos_from_options(message.get("durability"), message.get("reliability"), message.get("depth"),
                               publishers_qos(publishers))
        type_name = publishers[0].topic_type
        from hex_control.ros.infra.messages import message_class

        cls = message_class(type_name)
        frames: queue.Queue = queue.Queue()
        subscription = self.on_spin_thread(lambda: self.node.create_subscription(
            cls, topic, frames.put, qos, raw=True))
        try:
            self.forward(connection, type_name, frames)
        finally:
            self.on_spin_thread(lambda: self.node.destroy_subscription(subscription))


def serve() -> int:
    """Run the daemon until IDLE_S without requests or ``hexctl daemon stop``."""
    path = socket_path()

    class Handler(socketserver.StreamRequestHandler):
        def handle(self):
            from hex_control.ros.tools.ros_cli.common import VerbError

            daemon.last_request = time.monotonic()
            line = self.rfile.readline()
            try:
                message = json.loads(line)
                if message.get("op") == "graph":
                    answer = daemon.graph_answer()
                elif message.get("op") == "status":
                    answer = {"pid": os.getpid(), "age_s": time.monotonic() - daemon.started}
                elif message.get("op") == "stop":
                    daemon.stopping, answer = True, {"stopped": os.getpid()}
                elif message.get("op") == "echo":
                    daemon.echo(self.connection, message)
                    return
                else:
                    answer = {"error": f"unknown request {line[:80]!r}"}
            except (VerbError, ValueError, KeyError, TypeError) as exc:
                answer = {"error": str(exc)}
            self.wfile.write(json.dumps(answer).encode() + b"\n")

    class Server(socketserver.ThreadingMixIn, socketserver.UnixStreamServer):
        daemon_threads = True

    # one daemon a socket: the lock is held while it lives (a stale socket is replaced)
    lock = open(f"{path}.lock", "w")  # noqa: SIM115 - held until the process ends
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return 0  # one runs already
    daemon = _Daemon()
    path.unlink(missing_ok=True)
    server = Server(str(path), Handler)
    os.chmod(path, 0o600)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        daemon.run()
    finally:
        server.shutdown()
        path.unlink(missing_ok=True)
        daemon.node.destroy_node()
        daemon.rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(serve())
