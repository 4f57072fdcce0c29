"""``hexctl daemon start|stop|status``: a long-lived participant that has already discovered
the graph, as ros2cli's daemon. ``topic list``, ``node list``, ``service list``, ``action
list`` ask it for its graph and ``topic echo`` has it subscribe and forward each message as
the YAML the verb prints. A verb's own new participant waits for discovery, and Fast DDS
finds about one remote participant in four only at that one's next announcement, up to 3 s
later (measured here, at any load, whatever the initial announcements), so a list cut short
missed topics and an echo took up to 3 s.

Latched topics (every publisher transient local) the daemon subscribes to as soon as its
graph shows them, before anyone asks, and holds their messages (:class:`_Latched`; not a
stream's, STREAM_HZ): an echo gets them at once.
Subscribing only at the first echo, that echo waited for the publisher to learn of the new
subscription: 0.3 s idle, up to 3.1 s beside two CPU burners.

The client side (the verbs, :func:`list_verb`, :func:`echo_verb`) imports nothing but the
standard library: a verb answered by the daemon starts without rclpy or yaml (their
import with the verb's module, 0.2 s of CPU, took up to 2 s beside two CPU burners).

The first verb that finds no daemon starts one and works without it this time; the daemon
ends after IDLE_S without a request. One daemon per user, discovery setting (domain id,
discovery range, static peers, RMW) and PROTOCOL, on a Unix socket. Requests and answers are
JSON lines; an echo is answered by a header line, then each message's YAML text (UTF-8) as a
4-byte big-endian length and the text, until the client closes the connection.
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
#: topics the daemon does not subscribe to before an echo asks: every node's log (transient
#: local, but a stream; held, the daemon would take every line of every node)
NOT_HELD = ("/rosout",)
#: the requests' and answers' format: part of the socket's name, so that a verb never asks a
#: daemon of another hexctl version (that one ends when idle)
PROTOCOL = 2
#: a latched topic held unasked with more live messages than this a second (Hz; over
#: STREAM_WINDOW_S) is a stream (the plant's telemetry, its true wrench: transient local,
#: 10 to 1000 Hz): the daemon lets go of it (its CPU is the cell's) and echoes it as any topic
STREAM_HZ = 5.0
STREAM_WINDOW_S = 2.0
NODE_NAME = "_hexctl_daemon"  # hidden: a leading underscore (node list leaves it out)
_ENVIRONMENT = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "RMW_IMPLEMENTATION",
                "ROS_LOCALHOST_ONLY")


def socket_path(environ=os.environ) -> Path:
    """The daemon's socket for this user and discovery setting."""
    setting = "|".join([*(environ.get(k, "") for k in _ENVIRONMENT), str(PROTOCOL)])
    digest = hashlib.sha256(setting.encode()).hexdigest()[:12]
    return Path(tempfile.gettempdir()) / f"hexctl-daemon-{os.getuid()}-{digest}.sock"


# -- the client side (the verbs) ---------------------------------------------------------------

class VerbError(Exception):
    """A verb that cannot go on: its message is printed as one line, with ``code`` (exit codes:
    :mod:`.common`)."""

    def __init__(self, message: str, code: int = 2):
        super().__init__(message)
        self.code = code


def hidden(name: str) -> bool:
    """A hidden topic or service (a name part starting with '_', e.g. an action's
    ``_action/...`` internals), as ros2cli hides them unless --include-hidden."""
    return any(part.startswith("_") for part in name.split("/"))


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


def held_topics() -> dict[str, int] | None:
    """The latched topics the daemon holds, each with the number of its messages stored; None
    without a daemon."""
    answer = request({"op": "held"})
    return None if answer is None else answer["topics"]


def settled_graph(max_wait_s: float) -> dict | None:
    """The daemon's graph once settled (at most ``max_wait_s``), or None without a daemon."""
    end = time.monotonic() + max_wait_s
    while True:
        graph = request({"op": "graph"})
        if graph is None or (graph["age_s"] >= SETTLED_AGE_S and graph["quiet_s"] >= GRAPH_QUIET_S) \
                or time.monotonic() >= end:
            return graph
        time.sleep(min(0.1, max(end - time.monotonic(), 0.0)))


#: an action's feedback topic, by which a graph names the action (as rcl does)
ACTION_FEEDBACK = "/_action/feedback"


def list_verb(kind: str, wait_s: float, *, show_types: bool = False, include_hidden: bool = False) -> int | None:
    """``hexctl topic|node|service|action list`` from the daemon's graph once settled (at most
    ``wait_s``): 0, or None without a daemon (one is started; the verb discovers on its own)."""
    graph = settled_graph(wait_s)
    if graph is None:
        return None
    if kind == "node":
        names = {f"{ns.rstrip('/')}/{name}" for ns, name in graph["nodes"]}
        lines = sorted(n for n in names if not n.rsplit("/", 1)[-1].startswith(("hexctl_", "_")))
    elif kind == "action":
        lines = [topic.removesuffix(ACTION_FEEDBACK) + (
                 f" [{', '.join(t.removesuffix('_FeedbackMessage') for t in types)}]" if show_types else "")
                 for topic, types in sorted(graph["topics"]) if topic.endswith(ACTION_FEEDBACK)]
    else:
        lines = [f"{name} [{', '.join(types)}]" if show_types else name
                 for name, types in sorted(graph["topics" if kind == "topic" else "services"])
                 if include_hidden or not hidden(name)]
    for line in lines:
        print(line)
    return 0


def echo_verb(topic: str, limit: int, field: str, timeout_s: float, *, durability=None, reliability=None,
              depth=None) -> int | None:
    """``hexctl topic echo`` through the daemon: its participant has discovered the publishers
    already, and holds a latched topic's messages. Prints ``limit`` messages (0: until
    interrupted) as YAML; ``timeout_s`` bounds the wait for the first. 0, or None without a
    daemon (one is started)."""
    topic = topic if topic.startswith("/") else "/" + topic
    if depth is not None and depth < 1:
        raise VerbError(f"--qos-depth must be >= 1, got {depth}")
    end = time.monotonic() + timeout_s
    client = connect(timeout_s + 2.0)
    if client is None:
        start()
        return None
    with client:
        client.sendall(json.dumps({"op": "echo", "topic": topic, "timeout_s": timeout_s, "field": field,
                                   "durability": durability, "reliability": reliability,
                                   "depth": depth}).encode() + b"\n")
        stream = client.makefile("rb")
        client.settimeout(timeout_s + 5.0)  # the daemon answers by then: the type, or no publisher
        try:
            header = stream.readline()
        except TimeoutError:
            raise VerbError(f"the hexctl daemon did not answer the echo of {topic} (hexctl daemon stop; "
                            "HEXCTL_NO_DAEMON=1 to do without)", 1) from None
        if not header:
            raise VerbError(f"the hexctl daemon ended the echo of {topic}", 1)
        answer = json.loads(header)
        if "error" in answer:
            raise VerbError(answer["error"])
        received = 0
        while limit <= 0 or received < limit:
            client.settimeout(None if received else max(end - time.monotonic(), 0.001))
            try:
                size = stream.read(4)
                text = stream.read(struct.unpack(">I", size)[0]) if len(size) == 4 else b""
            except TimeoutError:
                raise VerbError(f"no message on {topic} within {timeout_s:g} s") from None
            if not text:
                raise VerbError(f"the hexctl daemon ended the echo of {topic}", 1)
            print(text.decode())
            print("---", flush=True)
            received += 1
    return 0


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
    """A latched topic the daemon holds: its type, the messages stored (CDR) and the queues of
    the echoes listening (an echo's thread joins and leaves under the lock: no turn of the
    spinning thread to wait for).

    A late subscriber gets each publisher's history, up to that one's depth, which the graph
    does not tell (UNKNOWN): each publisher keeps here as many messages as it had written
    before the subscription was made (its history then, by their source time stamps; at
    least 1, at most LATCHED_DEPTH), so that an echo --once of a depth-1 topic republished
    since prints the newest message, not the first one held. A publisher that came later
    keeps 1."""

    def __init__(self, type_name: str):
        self.type_name = type_name
        self.created_ns = time.time_ns()  # before the subscription: a message written earlier is history
        self.stores: dict[str, deque] = {}  # publisher gid -> deque of (arrival number, CDR)
        self.arrivals = 0
        self.live = 0  # messages written after the subscription was made, since the last look
        self.listeners: list[queue.Queue] = []
        self.subscription = None
        self.dropped = False
        self.lock = threading.Lock()

    def on_message(self, data: bytes, info) -> None:
        info = info or {}
        publisher = repr(info.get("publisher_gid"))
        with self.lock:
            store = self.stores.setdefault(publisher, deque(maxlen=LATCHED_DEPTH))
            if (info.get("source_timestamp") or 0) >= self.created_ns:  # live, its history has come
                self.live += 1
                if store.maxlen == LATCHED_DEPTH and len(store) < LATCHED_DEPTH:
                    store = self.stores[publisher] = deque(store, maxlen=max(len(store), 1))
            self.arrivals += 1
            store.append((self.arrivals, data))
            for listener in self.listeners:
                listener.put(data)

    def listen(self, frames: queue.Queue) -> bool:
        """``frames`` gets the messages stored, then each new one; False if no longer held."""
        with self.lock:
            if self.dropped:
                return False
            self.listeners.append(frames)
            for _number, data in sorted(m for store in self.stores.values() for m in store):
                frames.put(data)
            return True

    def leave(self, frames: queue.Queue) -> None:
        with self.lock:
            self.listeners.remove(frames)

    def clear(self) -> None:
        with self.lock:
            self.stores.clear()

    def drop_if_stream(self, window_s: float) -> bool:
        """Whether the topic is a stream (more than STREAM_HZ live messages a second over
        ``window_s``) that no echo listens to: then marked dropped (an echo's thread no longer
        joins). Resets the count."""
        with self.lock:
            stream = self.live > STREAM_HZ * window_s and not self.listeners
            self.live = 0
            self.dropped = stream
            return stream


def _latched_type(publishers) -> str | None:
    """The type of a latched topic's publishers (endpoint infos): all transient local and of
    one type; else None."""
    from rclpy.qos import DurabilityPolicy

    if publishers and len({p.topic_type for p in publishers}) == 1 \
            and all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers):
        return publishers[0].topic_type
    return None


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
        self.streams: set[str] = set()  # latched topics let go of: streams (STREAM_HZ)
        self.wake = self.node.create_guard_condition(lambda: None)
        self.hold_latched()

    def hold(self, topic: str, publishers) -> _Latched | None:
        """The held subscription of ``topic`` if its publishers (endpoint infos) are all
        transient local and of one type (created now if need be), else None. On the spinning
        thread."""
        from hex_control.ros.infra.messages import message_class
        from hex_control.ros.tools.ros_cli.topic import publishers_qos

        type_name = _latched_type(publishers)
        if type_name is None:
            return None
        held = self.latched.get(topic)
        if held is not None:
            return held if held.type_name == type_name else None
        try:
            cls = message_class(type_name)
        except ValueError:
            return None  # a type not installed here: an echo says so
        held = _Latched(type_name)
        held.subscription = self.node.create_subscription(cls, topic, held.on_message,
                                                          publishers_qos(publishers, depth=LATCHED_DEPTH), raw=True)
        self.latched[topic] = held
        return held

    def hold_latched(self) -> None:
        """Subscribe to every latched topic of the graph not held yet (before anyone asks:
        the publishers learn of the subscription now, not while an echo waits)."""
        for topic, _types in self.graph[1]:
            if topic not in self.latched and topic not in NOT_HELD and topic not in self.streams:
                publishers = self.node.get_publishers_info_by_topic(topic)
                if publishers:
                    self.hold(topic, publishers)

    def forget_gone_publishers(self) -> None:
        """A held topic whose publishers are gone: their messages go with them."""
        for topic, held in self.latched.items():
            if held.stores and not self.node.get_publishers_info_by_topic(topic):
                held.clear()
        # a stream's topic gone from the graph: when it comes back, it may be a latched one
        self.streams &= {topic for topic, _types in self.graph[1]}

    def drop_streams(self) -> None:
        """Let go of the held topics that turned out streams (:meth:`_Latched.drop_if_stream`)."""
        for topic, held in list(self.latched.items()):
            if held.drop_if_stream(STREAM_WINDOW_S):
                self.node.destroy_subscription(held.subscription)
                del self.latched[topic]
                self.streams.add(topic)

    def on_spin_thread(self, function):
        answer: queue.Queue = queue.Queue()
        self.jobs.put((function, answer))
        self.wake.trigger()  # the spin's wait ends now, not at its timeout
        ok, value = answer.get()
        if not ok:
            raise value
        return value

    def run(self) -> None:
        last_look = last_streams = 0.0
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
                    self.hold_latched()
                if now - last_streams >= STREAM_WINDOW_S:
                    last_streams = now
                    self.drop_streams()
                if not self.echoes and now - self.last_request > IDLE_S:
                    self.stopping = True

    def graph_answer(self) -> dict:
        nodes, topics, services = self.graph
        now = time.monotonic()
        return {"age_s": now - self.started, "quiet_s": now - self.changed,
                "nodes": [[n[0], n[1]] for n in nodes], "topics": [[n, list(t)] for n, t in topics],
                "services": [[n, list(t)] for n, t in services]}

    def forward(self, connection, type_name: str, frames: queue.Queue, text) -> None:
        """Send the header, then each message of ``frames`` as ``text(CDR bytes)`` until the
        client closes."""
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
                data = text(data).encode()
                connection.setblocking(True)
                connection.sendall(struct.pack(">I", len(data)) + data)
                connection.setblocking(False)
        except OSError:
            return  # the client went
        finally:
            self.echoes -= 1

    def echo(self, connection, message: dict) -> None:
        """Forward ``message["topic"]`` as YAML (``message["field"]`` of each message) until the
        client goes: from the held subscription of a latched topic, else from one made once
        the publishers are known (with their QoS, or the one asked for). A held topic takes
        one turn of the spinning thread: under load each turn waits for the scheduler."""
        from rclpy.serialization import deserialize_message

        from hex_control.ros.infra.messages import get_field, message_class
        from hex_control.ros.tools.ros_cli.common import qos_from_options
        from hex_control.ros.tools.ros_cli.topic import message_yaml, publishers_qos

        topic, timeout_s, field = message["topic"], float(message["timeout_s"]), str(message.get("field") or "")
        own_qos = any(message.get(k) for k in ("durability", "reliability", "depth"))
        end = time.monotonic() + timeout_s
        frames: queue.Queue = queue.Queue()

        def message_type(publishers):
            try:
                cls = message_class(publishers[0].topic_type)
                get_field(cls(), field)  # a wrong field is refused now, not at the first message
            except ValueError as exc:
                raise VerbError(f"{topic}: {exc}") from None
            return cls

        def find():
            """(the publishers, the message class, the held topic now listened to, or None);
            None before the publishers are known."""
            publishers = self.node.get_publishers_info_by_topic(topic)
            if not publishers:
                return None
            cls = message_type(publishers)
            held = None if own_qos or topic in NOT_HELD or topic in self.streams else self.hold(topic, publishers)
            if held is not None:
                held.listen(frames)  # on this thread: not dropped meanwhile
            return publishers, cls, held

        # a latched topic held already (the usual case): from this thread (rclpy's graph
        # queries are thread safe), without a turn of the spinning thread
        held = None if own_qos else self.latched.get(topic)
        publishers = self.node.get_publishers_info_by_topic(topic) if held is not None else []
        if held is not None and _latched_type(publishers) == held.type_name:
            cls = message_type(publishers)
            if not held.listen(frames):
                held = None  # let go of just now: a stream
        else:
            held = None
        if held is None:
            while (found := self.on_spin_thread(find)) is None:
                if time.monotonic() >= end:
                    raise VerbError(f"no publisher of {topic} within {timeout_s:g} s "
                                    "(is it running, with the same ROS_DOMAIN_ID? hexctl topic list)")
                time.sleep(0.02)
            publishers, cls, held = found

        def text(data: bytes) -> str:
            return message_yaml(deserialize_message(data, cls), field)

        if held is not None:
            try:
                self.forward(connection, held.type_name, frames, text)
            finally:
                held.leave(frames)
            return
        qos = qos_from_options(message.get("durability"), message.get("reliability"), message.get("depth"),
                               publishers_qos(publishers))
        subscription = self.on_spin_thread(lambda: self.node.create_subscription(
            cls, topic, frames.put, qos, raw=True))
        try:
            self.forward(connection, publishers[0].topic_type, frames, text)
        finally:
            self.on_spin_thread(lambda: self.node.destroy_subscription(subscription))


def serve() -> int:
    """Run the daemon until IDLE_S without requests or ``hexctl daemon stop``."""
    path = socket_path()

    class Handler(socketserver.StreamRequestHandler):
        def handle(self):
            daemon.last_request = time.monotonic()
            line = self.rfile.readline()
            if not line:
                return  # a connection only tried (hexctl daemon status), or a client gone
            try:
                message = json.loads(line)
                if message.get("op") == "graph":
                    answer = daemon.graph_answer()
                elif message.get("op") == "held":  # the latched topics held, with their messages counted
                    answer = {"topics": {topic: sum(len(store) for store in list(held.stores.values()))
                                          for topic, held in list(daemon.latched.items())}}
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
            try:
                self.wfile.write(json.dumps(answer).encode() + b"\n")
            except OSError:
                pass  # the client went (an interrupted verb)

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
