"""Attacks on the robot_state node and ``hexctl view`` (issue 40's additions) from a second
process on the cell's domain, as docs/graph.md's threat model has them: both run as real
processes; this process plays the plant (the owner of telemetry and contours, as the
impostor the threat model leaves standing, to reach the checks behind the door) and a rogue
node of its own name.

One graph for the module (the suite stays fast): robot_state and the view must obey only the
plant, refuse malformed, huge and off-timeline batches and an enormous contour (counted, a
WARN) and stay up; never ask the plant for per-period strut states; and the view must keep
serving a reading client while other clients connect and never read."""

import contextlib
import json
import math
import re
import sys

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PolygonStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from test_robot_state_node import FoxgloveClient
from tf2_msgs.msg import TFMessage
from websockets.sync.client import connect

from hex_control.config import DEFAULT_MACHINE_FILE, config_file
from hex_control.kinematics import load_machine
from hex_control.kinematics.robot_telemetry import MAX_BATCH_SAMPLES
from hex_control.ros.infra.interfaces import LATCHED, TELEMETRY
from hex_control_msgs.msg import Contour, PlantTelemetry
from ros_harness import NodeProcess, wait_until

KEEP = QoSProfile(depth=10_000)
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def _status(diagnostics: list, node: str):
    for array in reversed(diagnostics):
        for status in array.status:
            if status.name == node:
                return status
    return None


def _counter(diagnostics: list, node: str, key: str) -> int:
    status = _status(diagnostics, node)
    return int({v.key: v.value for v in status.values}.get(key, 0)) if status is not None else 0


def _stamps(tf: list) -> set[float]:
    return {round(m.transforms[0].header.stamp.sec + m.transforms[0].header.stamp.nanosec * 1e-9, 6) for m in list(tf)}


class Telemetry:
    """Batches of the shipped machine at its home pose (lowered by ``dz_mm``), 1 ms apart."""

    def __init__(self):
        self.machine, _ = load_machine(config_file(DEFAULT_MACHINE_FILE))
        self.names = list(self.machine.joint_names)

    def batch(self, start_s: float, samples: int = 3, dz_mm: float = 0.0, **changes) -> PlantTelemetry:
        pose = np.array(self.machine.home_pose, float)
        pose[2] -= dz_mm
        positions, reachable = self.machine.joint_positions_mm(pose[None])
        assert reachable.all()
        fields = {"strut_names": self.names, "time_s": [start_s + 0.001 * k for k in range(samples)],
                  "deflection_mm": [0.0] * samples, "measured_force_n": [10.0] * samples,
                  "true_force_n": [10.0] * samples, "strut_lengths_m": np.tile(positions[0] * 1e-3, samples).tolist()}
        return PlantTelemetry(**(fields | changes))


def _silent_subscriber(clients: contextlib.ExitStack, port: int):
    """A client that subscribes to every channel, then never reads again (its small queue
    full, the socket's buffers fill: the server must not wait for it). No pings to answer, and
    it never reads the server's close either."""
    socket = clients.enter_context(connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, open_timeout=30,
                                           max_queue=2, ping_interval=None, close_timeout=0.2))
    subscribed = 0
    while subscribed < 5:
        frame = socket.recv(timeout=30)
        if isinstance(frame, str) and json.loads(frame)["op"] == "advertise":
            for channel in json.loads(frame)["channels"]:
                subscribed += 1
                socket.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": subscribed,
                                                                              "channelId": channel["id"]}]}))
    return socket


def test_robot_state_and_the_view_obey_the_plant_refuse_the_rest_and_stay_up(ros, ros_env, tmp_path):
    robot_state = NodeProcess([sys.executable, "-m", "hex_control.ros.nodes.robot_state"], ros_env,
                              tmp_path / "robot_state.log")
    view = NodeProcess([sys.executable, "-m", "hex_control.cli", "view", "--port", "0"], ros_env, tmp_path / "view.log")
    clients = contextlib.ExitStack()  # the WebSocket clients
    try:
        tf = ros.collect(TFMessage, "/tf", KEEP)
        diagnostics = ros.collect(DiagnosticArray, "/diagnostics", KEEP)
        outlines = ros.collect(PolygonStamped, "/grinding/bead_outline", QoSProfile(
            depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        plant, rogue = ros.node("plant"), ros.node("rogue")
        telemetry = Telemetry()
        plant_telemetry = plant.create_publisher(PlantTelemetry, "/plant/telemetry", TELEMETRY)
        rogue_telemetry = rogue.create_publisher(PlantTelemetry, "/plant/telemetry", TELEMETRY)
        wait_until(lambda: plant_telemetry.get_subscription_count() >= 2 and rogue_telemetry.get_subscription_count()
                   >= 2, 60.0, what="robot_state and the view on /plant/telemetry")

        def counted(node, key, at_least=1):
            wait_until(lambda: _counter(diagnostics, node, key) >= at_least or not robot_state.alive(), 30.0,
                       what=f"{node} to count {at_least} {key}")
            assert robot_state.alive() and view.alive(), robot_state.output()[-3000:] + view.output()[-3000:]

        # the plant's batch places the machine; a rogue's (the platform 20 mm lower) is refused, named in a WARN
        plant_telemetry.publish(telemetry.batch(1.0))
        wait_until(lambda: 1.002 in _stamps(tf), 30.0, what="/tf of the plant's batch")
        rogue_telemetry.publish(telemetry.batch(1.5, dz_mm=20.0))
        counted("/robot_state", "foreign_telemetry")
        counted("/foxglove_view", "foreign_telemetry")
        assert "/rogue" in _status(diagnostics, "/robot_state").message
        assert _status(diagnostics, "/robot_state").level == DiagnosticStatus.WARN

        # malformed batches from the plant itself: refused whole, before any work
        lengths = telemetry.batch(1.1).strut_lengths_m
        malformed = [telemetry.batch(1.1, time_s=[1.1, 1.101, math.nan]),  # a NaN or inf last stamp ended the node
                     telemetry.batch(1.1, time_s=[1.1, 1.101, math.inf]),
                     telemetry.batch(1.1, strut_lengths_m=lengths[:-1]),
                     telemetry.batch(1.1, deflection_mm=[]),
                     telemetry.batch(1.1, strut_names=telemetry.names[:5]),
                     telemetry.batch(1.1, time_s=[], deflection_mm=[], strut_lengths_m=[]),
                     telemetry.batch(1.1, samples=MAX_BATCH_SAMPLES + 1),
                     telemetry.batch(1e12),  # beyond what a ROS stamp holds
                     telemetry.batch(-5.0),
                     telemetry.batch(1.1, time_s=[1.102, 1.101, 1.1])]
        off_timeline = [telemetry.batch(0.5), telemetry.batch(1e6)]  # back, far ahead: one batch each
        for msg in malformed + off_timeline:
            plant_telemetry.publish(msg)
        plant_telemetry.publish(telemetry.batch(1.1))
        counted("/robot_state", "rejected_telemetry", len(malformed))
        counted("/robot_state", "stale_telemetry", len(off_timeline))
        wait_until(lambda: 1.102 in _stamps(tf), 30.0, what="/tf of the plant's next good batch")
        assert _stamps(tf) == {1.002, 1.102}  # nothing of the rogue's, the malformed or the off-timeline batches
        counted("/foxglove_view", "rejected_telemetry")  # the huge batch: the view's own limit

        # contours: a rogue's is refused at the door, the plant's of 10^6 points on its size; a good one is drawn
        plant_contour = plant.create_publisher(Contour, "/grinding/contour", LATCHED)
        rogue_contour = rogue.create_publisher(Contour, "/grinding/contour", LATCHED)
        wait_until(lambda: plant_contour.get_subscription_count() >= 2 and rogue_contour.get_subscription_count() >= 2,
                   60.0, what="robot_state and the view on /grinding/contour")
        huge = np.zeros(10**6)
        rogue_contour.publish(Contour(x_mm=[0.0, 60.0], z_mm=[5.0, 5.0]))
        counted("/robot_state", "foreign_contour")
        counted("/foxglove_view", "foreign_contour")
        plant_contour.publish(Contour(x_mm=huge, z_mm=huge, parent_mm=huge))
        counted("/robot_state", "rejected_contours")
        counted("/foxglove_view", "rejected_contour")
        x = np.linspace(0.0, 60.0, 50_000)  # long, within the limit: the view redraws it every second
        plant_contour.publish(Contour(x_mm=x, z_mm=np.full_like(x, 0.8)))
        outline = wait_until(lambda: outlines[-1] if outlines else None, 30.0, what="the plant's contour drawn")
        assert len(outlines) == 1 and len(outline.polygon.points) == 4000
        assert max(p.z for p in outline.polygon.points) == pytest.approx(0.8e-3)  # not the rogue's 5 mm

        # robot_state and the view never make the plant publish every period's strut states
        subscribers = {info.node_name for info in plant.get_subscriptions_info_by_topic("/plant/strut_states")}
        assert not subscribers & {"robot_state", "foxglove_view"}

        # the view: 20 clients that connect and idle, 3 that subscribe to everything and never read
        port = int(wait_until(lambda: re.search(r"ws://127\.0\.0\.1:(\d+)", view.output()), 30.0,
                              what="hexctl view's address").group(1))
        for _ in range(20):
            clients.enter_context(connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, open_timeout=30))
        for _ in range(3):
            _silent_subscriber(clients, port)
        reader = FoxgloveClient(port)
        reader.start()
        try:
            wait_until(lambda: "/scene/bead" in reader.received or reader.error, 30.0, what="the reader's bead scene")
            # 20 batches of 10,000 samples: the view sends 80,000 wrench messages, some 12 MB, to each
            # subscriber, far beyond what the silent clients' socket buffers hold
            starts = [1.2 + 10.0 * k for k in range(20)]
            for start in starts:
                plant_telemetry.publish(telemetry.batch(start, samples=10_000))
            last_s = round(starts[-1] + 9.999, 6)
            wait_until(lambda: last_s in _stamps(tf), 60.0, what="robot_state's /tf of the last batch")
            wait_until(lambda: any(t >= round(last_s * 1e9) for t, _ in reader.received.get("/tf", []))
                       or reader.error, 60.0, what="the reading client's /tf of the last batch")
            # the reader is served to the end: in such a burst the SDK drops what overflows a client's own queue
            # (the burst's last wrenches among it, once in a CI beside two other test workers), and a batch sent
            # after the burst reaches the reader (a later one each second, until one has)
            after = []

            def served_after_the_burst():
                if reader.error or after and any(t >= round(after[0] * 1e9)
                                                 for t, _ in reader.received.get("/plant/wrench", [])):
                    return True
                after.append(starts[-1] + 10.0 + len(after))
                plant_telemetry.publish(telemetry.batch(after[-1]))
                return False

            wait_until(served_after_the_burst, 60.0, 1.0, what="a wrench sent after the burst at the reading client")
            assert reader.error is None, reader.error
        finally:
            reader.stopped.set()
            reader.join(timeout=5.0)
        assert robot_state.alive() and view.alive()
    finally:
        clients.close()
        assert view.stop() in (0, 130), view.output()[-3000:]
        robot_state.stop()
