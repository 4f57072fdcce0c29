"""The robot_state node and hexctl view during a job (issue 40 items 1-2): /tf puts the disk
where the plant's tool-centre telemetry says it grinds, the robot description is the
machine's URDF, the bead's outline follows the scans, and a WebSocket client of the Foxglove
server receives and decodes the 3-D scene, the force and the pass table.

One job for the module: the whole graph (robot_state in it) grinds a 60 mm bead in lock-step
(two or three passes), hexctl view serving the cell and a Foxglove client subscribed all along."""

import base64
import contextlib
import json
import re
import sys
import threading
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from websockets.sync.client import connect

from hex_control.config import DEFAULT_MACHINE_FILE, config_file
from hex_control.grinding.config import load_pass_planner_config
from hex_control.kinematics import load_machine
from hex_control.kinematics.robot_model import FrameTransform, frame_pose
from hex_control.ros.app.foxglove_view import CHANNEL_TOPICS
from hex_control.ros.infra.interfaces import LATCHED, TELEMETRY
from hex_control.ros.nodes.robot_state import TF_STATIC
from hex_control_msgs.msg import PlantTelemetry
from ros_harness import NodeProcess, RosHarness, diagnostics_value, wait_until

KEEP = QoSProfile(depth=10_000)
JOB = {"bead_length_mm": 60.0, "bead_height_mm": 0.8, "specific_energy_cv": 0.0}  # a short job, no variation
RESET_TIME_S = 4.7  # the shipped machine's ZVD-shaped reset time (test_end_to_end)


def _transforms(message: TFMessage) -> list[FrameTransform]:
    return [FrameTransform(t.header.frame_id, t.child_frame_id,
                           (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z),
                           (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                            t.transform.rotation.w)) for t in message.transforms]


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class FoxgloveClient(threading.Thread):
    """A client of the Foxglove WebSocket protocol: subscribes to every channel the server
    advertises and keeps each message frame (log time, payload) by topic until stopped."""

    def __init__(self, port: int):
        super().__init__(daemon=True)
        self.port, self.stopped, self.error = port, threading.Event(), None
        self.channels, self.received, self.advertised = {}, {}, set()

    def run(self) -> None:
        try:
            with connect(f"ws://127.0.0.1:{self.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                         open_timeout=30) as socket:
                by_subscription = {}
                while not self.stopped.is_set():
                    try:
                        frame = socket.recv(timeout=0.2)
                    except TimeoutError:
                        continue
                    if isinstance(frame, str):
                        message = json.loads(frame)
                        for channel in message.get("channels", []) if message["op"] == "advertise" else []:
                            self.advertised.add(channel["topic"])
                            self.channels[channel["topic"]] = channel
                            by_subscription[len(by_subscription) + 1] = channel["topic"]
                            socket.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": len(by_subscription), "channelId": channel["id"]}]}))
                        continue
                    assert frame[0] == 1, f"binary op {frame[0]}"  # MessageData
                    topic = by_subscription[int.from_bytes(frame[1:5], "little")]
                    self.received.setdefault(topic, []).append((int.from_bytes(frame[5:13], "little"),
                                                                bytes(frame[13:])))
        except Exception as error:  # noqa: BLE001 - the test says what went wrong
            self.error = error


@pytest.fixture(scope="module")
def cell(ros_env, tmp_path_factory):
    """A job ground: (collected messages, the Foxglove client, machine, bead frame, outcome)."""
    from hex_control.ros.app.grind_job import JobSession

    output = tmp_path_factory.mktemp("robot_state")
    machine, document = load_machine(config_file(DEFAULT_MACHINE_FILE))
    frame = load_pass_planner_config("pass_planner.yaml", document).frame
    with contextlib.ExitStack() as stack:
        ros = RosHarness(int(ros_env["ROS_DOMAIN_ID"]))
        stack.callback(ros.close)
        got = {"tf": ros.collect(TFMessage, "/tf", KEEP), "static": ros.collect(TFMessage, "/tf_static", TF_STATIC),
               "telemetry": ros.collect(PlantTelemetry, "/plant/telemetry", TELEMETRY),
               "description": ros.collect(String, "/robot_description", LATCHED),
               "joints": ros.collect(JointState, "/joint_states", KEEP),
               "diagnostics": ros.collect(DiagnosticArray, "/diagnostics", KEEP),
               "outline": ros.collect(PolygonStamped, "/grinding/bead_outline", QoSProfile(
                   depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))}
        view = NodeProcess([sys.executable, "-m", "hex_control.cli", "view", "--port", "0"], ros_env,
                           output / "view.log")
        stack.callback(view.stop)
        session = stack.enter_context(JobSession(output, seed=5, plant_overrides=JOB, record=False))
        port = int(wait_until(lambda: re.search(r"ws://127\.0\.0\.1:(\d+)", view.output()), 60.0,
                              what="hexctl view's address").group(1))
        client = FoxgloveClient(port)
        client.start()
        stack.callback(client.stopped.set)
        wait_until(lambda: "/scene/machine" in client.received or client.error, 60.0, what="the view's first scene")
        session.start_job(18.0, RESET_TIME_S)
        outcome = session.wait_for_outcome(400.0)
        passes = outcome["passes"]
        wait_until(lambda: len(got["outline"]) > passes and _table_rows(client) >= passes, 60.0,
                   what="every scan's outline and the whole pass table")
        assert view.alive(), view.output()[-3000:]
        yield got, client, machine, frame, outcome


def _table_rows(client) -> int:
    tables = client.received.get("/pass_table", [])
    return len([row for row in json.loads(tables[-1][1])["rows"] if "status" in row]) if tables else 0


def test_tf_puts_the_disk_where_the_plants_tool_centre_telemetry_says(cell):
    """Acceptance (issue 40): during a job, base -> disk from /tf and /tf_static against the
    plant's tool centre (x along the bead, height above it, the structure's deflection
    included) at the same sim time: within 1e-6 mm, in contact and moving."""
    got, _, machine, _, outcome = cell
    assert outcome["passes"] >= 2
    static = [t for message in got["static"] for t in _transforms(message)]
    assert {(t.parent, t.child) for t in static} >= {("base", "machine"), ("machine", "bead"),
                                                     ("platform", "spindle"), ("disk", "tool")}
    samples = {}
    for message in list(got["telemetry"]):
        for k, time_s in enumerate(message.time_s):
            samples[round(time_s * 1e9)] = (message.centre_x_mm[k], message.centre_height_mm[k],
                                            message.measured_force_n[k])
    compared, xs, worst_mm, in_contact = 0, [], 0.0, 0
    for message in list(got["tf"]):
        stamp = _stamp_ns(message.transforms[0].header.stamp)
        assert all(_stamp_ns(t.header.stamp) == stamp for t in message.transforms)  # one instant per message
        if stamp not in samples:
            continue
        tree = static + _transforms(message)
        disk_in_bead = np.linalg.inv(frame_pose(tree, "bead")) @ frame_pose(tree, "disk")[:, 3]
        x_mm, height_mm, force_n = samples[stamp]
        worst_mm = max(worst_mm, abs(disk_in_bead[0] * 1000 - x_mm), abs(disk_in_bead[2] * 1000 - height_mm))
        xs.append(x_mm)
        compared += 1
        in_contact += force_n > 10.0
    assert compared >= 50, f"{compared} of {len(got['tf'])} /tf messages had a telemetry sample"
    assert worst_mm <= 1e-6, f"the disk is {worst_mm:.3g} mm from the plant's tool centre"
    print(f"base -> disk against the tool centre: {compared} instants ({in_contact} grinding), "
          f"worst {worst_mm:.2g} mm")
    assert in_contact >= 10 and max(xs) - min(xs) > 50.0, "the job neither ground nor travelled the bead"
    # /joint_states names the plant's joints (strut lengths, m) and the universal joints
    joints = got["joints"][-1]
    assert set(machine.joint_names) <= set(joints.name) and len(joints.name) == len(joints.position) == 18
    lengths = dict(zip(joints.name, joints.position))
    assert all(2.0 < lengths[name] < 3.4 for name in machine.joint_names)
    # its /diagnostics count the states it published, and no sample it could not place
    wait_until(lambda: int(diagnostics_value(list(got["diagnostics"]), "/robot_state", "states") or 0) >= compared,
               30.0, what="robot_state's count of states")
    assert diagnostics_value(list(got["diagnostics"]), "/robot_state", "no_frames") is None


def test_the_robot_description_is_the_machines_urdf_and_the_outline_follows_the_scans(cell):
    got, _, machine, _, outcome = cell
    root = ET.fromstring(got["description"][-1].data)
    links = {link.get("name") for link in root.iter("link")}
    joints = {joint.get("name"): joint for joint in root.iter("joint")}
    assert root.get("name") == machine.name
    assert {"base", "machine", "bead", "platform", "spindle", "disk", "tool"} <= links
    for name in machine.joint_names:  # the struts: prismatic, their stroke as limits (m)
        assert joints[name].get("type") == "prismatic"
        limit = joints[name].find("limit")
        assert float(limit.get("lower")) == pytest.approx(machine.strut_length_min_mm / 1000)
        assert float(limit.get("upper")) == pytest.approx(machine.strut_length_max_mm / 1000)
    assert all(j.find("parent").get("link") in links and j.find("child").get("link") in links
               for j in joints.values())
    # the workpiece: each scan of the 60 mm bead as an outline in its frame (m), lower each pass
    heights = []
    for outline in got["outline"]:
        points = [(p.x, p.z) for p in outline.polygon.points]
        assert outline.header.frame_id == "bead" and len(points) % 2 == 0 and len(points) > 20
        assert points[0][0] == 0.0 and points[len(points) // 2 - 1][0] == pytest.approx(0.060)
        heights.append(max(z for _, z in points))
    assert len(heights) >= outcome["passes"] + 1
    assert heights[0] > 0.0007 and heights[-1] < heights[0], heights
    assert all(after <= before for before, after in zip(heights, heights[1:])), heights


def _message_class(channel: dict):
    """The protobuf class of a channel, from the schema it advertised (a FileDescriptorSet)."""
    descriptors = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in descriptors.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def test_a_websocket_client_of_hexctl_view_decodes_the_scene_the_force_and_the_pass_table(cell):
    """Foxglove's WebSocket protocol: the server advertises its channels with their schemas;
    the client subscribes and gets binary message frames (op 1, subscription id, log time,
    payload), here decoded with protobuf from the advertised schema (scene, TF) and as JSON
    (force, pass table), as they came during the job."""
    _, client, _, _, outcome = cell
    assert client.error is None, client.error
    channels, received = client.channels, dict(client.received)
    assert client.advertised == set(CHANNEL_TOPICS)
    assert set(received) >= {"/scene/machine", "/scene/bead", "/scene/force", "/tf", "/plant/wrench", "/pass_table"}
    assert channels["/scene/machine"]["encoding"] == "protobuf"
    assert channels["/scene/machine"]["schemaName"] == "foxglove.SceneUpdate"

    scene = _message_class(channels["/scene/machine"]).FromString(received["/scene/machine"][-1][1])
    by_frame = {entity.frame_id: entity for entity in scene.entities}
    assert {"platform", "disk", "strut_0_tube", "strut_5_rod"} <= set(by_frame)
    assert all(entity.frame_locked for entity in scene.entities)
    disk = by_frame["disk"].cylinders[0]
    assert disk.size.x == pytest.approx(disk.size.y) and disk.size.x > 0.05  # the disk's diameter (m)

    decode = _message_class(channels["/scene/bead"])
    first, last = (decode.FromString(received["/scene/bead"][k][1]).entities[0] for k in (0, -1))
    assert first.frame_id == "bead" and len(last.lines) == 3  # contour, parent, the bead as first scanned
    assert len(last.lines[0].points) > 10 and last.lines[0].points[-1].x == pytest.approx(0.060, abs=1e-3)
    assert max(p.z for p in last.lines[0].points) < max(p.z for p in first.lines[0].points)  # ground down

    transforms = _message_class(channels["/tf"]).FromString(received["/tf"][-1][1])
    assert {t.child_frame_id for t in transforms.transforms} >= {"platform", "disk"}

    wrenches = list(received["/plant/wrench"])  # one snapshot: the client receives on (the plant runs past the end)
    forces = [json.loads(payload) for _, payload in wrenches]
    assert all(f["header"]["frame_id"] == "tool" for f in forces)
    assert max(f["wrench"]["force"]["z"] or 0.0 for f in forces) > 20.0  # the passes' normal force (N)
    log_times = [log_time for log_time, _ in wrenches]
    stamps = [f["header"]["stamp"]["sec"] * 10**9 + f["header"]["stamp"]["nanosec"] for f in forces]
    assert log_times == stamps  # the timeline is the cell's sim time
    arrows = [_message_class(channels["/scene/force"]).FromString(payload).entities[0].arrows
              for _, payload in received["/scene/force"]]
    assert any(arrows) and all(a[0].shaft_length + a[0].head_length < 0.1 for a in arrows if a)

    rows = json.loads(received["/pass_table"][-1][1])["rows"]
    assert [row["pass"] for row in rows] == list(range(outcome["passes"]))
    for row in rows:
        assert row["status"] == "completed" and row["X_mm"] > 0 and row["F_N"] > 0 and row["cut_measured_mm"] > 0
        assert row["K1_J_mm3"] is not None and row["J"] is not None
    assert rows[1]["X_mm"] == pytest.approx(rows[0]["X_mm"] - rows[0]["cut_measured_mm"], abs=1e-9)
