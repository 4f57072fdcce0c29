"""The robot_state node and hexctl view over real processes (issue 40 items 1-2): a moving
machine's /tf puts the disk where the plant's tool-centre telemetry says it grinds, the
robot description is the machine's URDF, and a WebSocket client of the Foxglove server
receives and decodes the 3-D scene and the force.

One cell for the module (plant in real time with a bead, robot_state, hexctl view): the
test moves the struts itself along 12 mm of the bead, so no planner is needed."""

import base64
import json
import math
import re
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from rclpy.qos import QoSProfile
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
MOVE_MM, MOVE_S = 12.0, 2.0  # the tool's move along the bead, and its wall time


def _transforms(message: TFMessage) -> list[FrameTransform]:
    return [FrameTransform(t.header.frame_id, t.child_frame_id,
                           (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z),
                           (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                            t.transform.rotation.w)) for t in message.transforms]


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


@pytest.fixture(scope="module")
def cell(ros_env, tmp_path_factory):
    """The cell moving: (harness, collected messages, view's port, machine, bead frame)."""
    logs = tmp_path_factory.mktemp("robot_state")
    machine, document = load_machine(config_file(DEFAULT_MACHINE_FILE))
    frame = load_pass_planner_config("pass_planner.yaml", document).frame
    ros = RosHarness(int(ros_env["ROS_DOMAIN_ID"]))
    processes = [NodeProcess(command, ros_env, logs / f"{name}.log") for name, command in (
        ("plant", ["hex-plant", "--ros-args", "-p", "mode:=realtime", "-p", "grinding:=true",
                   "-p", "strut_command_owner:=''", "-p", "bead_length_mm:=60.0"]),
        ("robot_state", ["hex-robot-state"]),
        ("view", [sys.executable, "-m", "hex_control.cli", "view", "--port", "0"]))]
    try:
        got = {"tf": ros.collect(TFMessage, "/tf", KEEP), "static": ros.collect(TFMessage, "/tf_static", TF_STATIC),
               "telemetry": ros.collect(PlantTelemetry, "/plant/telemetry", TELEMETRY),
               "description": ros.collect(String, "/robot_description", LATCHED),
               "joints": ros.collect(JointState, "/joint_states", KEEP),
               "diagnostics": ros.collect(DiagnosticArray, "/diagnostics", KEEP),
               "outline": ros.collect(PolygonStamped, "/grinding/bead_outline", LATCHED)}
        node = ros.node("strut_source")
        commands = node.create_publisher(JointState, "/plant/strut_command", 10)
        wait_until(lambda: commands.get_subscription_count() >= 1, 60.0, what="the plant")
        wait_until(lambda: got["description"] and got["static"], 60.0, what="the robot description and /tf_static")
        # the disk centre 30 mm above the bead's datum, along 12 mm of it from 5 mm in
        x = np.linspace(5.0, 5.0 + MOVE_MM, 50)
        poses = np.zeros((len(x), 6))
        poses[:, :3] = frame.positions_mm(x, np.full(len(x), 30.0))
        lengths, reachable = machine.joint_positions_mm(poses)
        assert reachable.all()
        start = time.monotonic()
        for row in lengths:
            commands.publish(JointState(name=machine.joint_names, position=(row / 1000.0).tolist()))
            time.sleep(MOVE_S / len(lengths))  # paces the commands (the plant runs on the wall clock)
        wait_until(lambda: len(got["tf"]) >= 10, 60.0, what="ten /tf messages")
        port = int(wait_until(lambda: re.search(r"ws://127\.0\.0\.1:(\d+)", processes[2].output()), 60.0,
                              what="hexctl view's address").group(1))
        assert time.monotonic() - start < 120
        yield ros, got, port, machine, frame
        for process in processes:
            assert process.alive(), process.output()[-3000:]
    finally:
        for process in processes:
            process.stop()
        ros.close()


def test_tf_puts_the_disk_where_the_plants_tool_centre_telemetry_says(cell):
    """Acceptance (issue 40): base -> disk from /tf and /tf_static, against the plant's
    tool centre (x along the bead, height above it, deflection included) at the same sim
    time: within 1e-6 mm, on a machine in motion."""
    ros, got, _, machine, frame = cell
    static = [t for message in got["static"] for t in _transforms(message)]
    assert {(t.parent, t.child) for t in static} >= {("base", "machine"), ("machine", "bead"),
                                                     ("platform", "spindle"), ("disk", "tool")}
    samples = {}
    for message in list(got["telemetry"]):
        for k, time_s in enumerate(message.time_s):
            samples[round(time_s * 1e9)] = (message.centre_x_mm[k], message.centre_height_mm[k])
    compared, xs, worst_mm = 0, [], 0.0
    for message in list(got["tf"]):
        stamp = _stamp_ns(message.transforms[0].header.stamp)
        assert all(_stamp_ns(t.header.stamp) == stamp for t in message.transforms)  # one instant per message
        if stamp not in samples:
            continue
        tree = static + _transforms(message)
        disk_in_bead = np.linalg.inv(frame_pose(tree, "bead")) @ frame_pose(tree, "disk")[:, 3]
        x_mm, height_mm = samples[stamp]
        worst_mm = max(worst_mm, abs(disk_in_bead[0] * 1000 - x_mm), abs(disk_in_bead[2] * 1000 - height_mm))
        xs.append(x_mm)
        compared += 1
    assert compared >= 10, f"{compared} of {len(got['tf'])} /tf messages had a telemetry sample"
    assert worst_mm <= 1e-6, f"the disk is {worst_mm:.3g} mm from the plant's tool centre"
    print(f"base -> disk against the tool centre: {compared} instants, worst {worst_mm:.2g} mm")
    assert max(xs) - min(xs) > MOVE_MM / 2, "the machine did not move"
    # /joint_states names the plant's joints (strut lengths, m) and the universal joints
    joints = got["joints"][-1]
    assert set(machine.joint_names) <= set(joints.name) and len(joints.name) == len(joints.position) == 18
    lengths = dict(zip(joints.name, joints.position))
    assert all(2.0 < lengths[name] < 3.4 for name in machine.joint_names)
    # its /diagnostics count the states it published, and no sample it could not place
    wait_until(lambda: int(diagnostics_value(list(got["diagnostics"]), "/robot_state", "states") or 0) >= compared,
               30.0, what="robot_state's count of states")
    assert diagnostics_value(list(got["diagnostics"]), "/robot_state", "no_frames") is None


def test_the_robot_description_is_the_machines_urdf(cell):
    _, got, _, machine, _ = cell
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
    # and the workpiece: the scanned 60 mm bead as an outline in its frame (m)
    outline = wait_until(lambda: got["outline"], 30.0, what="the bead outline")[-1]
    points = [(p.x, p.z) for p in outline.polygon.points]
    assert outline.header.frame_id == "bead" and len(points) % 2 == 0 and len(points) > 20
    assert points[0][0] == 0.0 and points[len(points) // 2 - 1][0] == pytest.approx(0.060)
    assert max(z for _, z in points) > 0.0005 and points[-1] == (0.0, 0.0)


def _message_class(channel: dict):
    """The protobuf class of a channel, from the schema it advertised (a FileDescriptorSet)."""
    descriptors = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in descriptors.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def test_a_websocket_client_of_hexctl_view_decodes_the_scene_and_the_force(cell):
    """Foxglove's WebSocket protocol: the server advertises its channels with their schemas;
    the client subscribes and gets binary message frames (op 1, subscription id, log time,
    payload), here decoded with protobuf from the advertised schema (scene, TF) and as JSON
    (force)."""
    _, _, port, machine, _ = cell
    wanted = ("/scene/machine", "/scene/bead", "/tf", "/plant/wrench")
    advertised = set()
    with connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                 open_timeout=30) as socket:
        channels, received = {}, {}
        end = time.monotonic() + 60.0
        while time.monotonic() < end and len(received) < len(wanted):
            frame = socket.recv(timeout=max(end - time.monotonic(), 0.1))
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    for channel in message["channels"]:
                        advertised.add(channel["topic"])
                        if channel["topic"] in wanted and channel["topic"] not in channels:
                            channels[channel["topic"]] = channel
                            socket.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": len(channels), "channelId": channel["id"]}]}))
                continue
            assert frame[0] == 1, f"binary op {frame[0]}"  # MessageData
            subscription = int.from_bytes(frame[1:5], "little")
            topic = list(channels)[subscription - 1]
            received.setdefault(topic, []).append((int.from_bytes(frame[5:13], "little"), bytes(frame[13:])))
    assert set(received) == set(wanted), f"received {sorted(received)}, channels {sorted(channels)}"
    assert advertised == set(CHANNEL_TOPICS)
    assert channels["/scene/machine"]["encoding"] == "protobuf"
    assert channels["/scene/machine"]["schemaName"] == "foxglove.SceneUpdate"

    scene = _message_class(channels["/scene/machine"]).FromString(received["/scene/machine"][-1][1])
    by_frame = {entity.frame_id: entity for entity in scene.entities}
    assert {"platform", "disk", "strut_0_tube", "strut_5_rod"} <= set(by_frame)
    assert all(entity.frame_locked for entity in scene.entities)
    disk = by_frame["disk"].cylinders[0]
    assert disk.size.x == pytest.approx(disk.size.y) and disk.size.x > 0.05  # the disk's diameter (m)

    bead = _message_class(channels["/scene/bead"]).FromString(received["/scene/bead"][-1][1])
    [entity] = bead.entities
    assert entity.frame_id == "bead" and len(entity.lines) >= 2
    contour = entity.lines[0].points
    assert len(contour) > 10 and contour[-1].x == pytest.approx(0.060, abs=1e-3)  # the 60 mm bead, in m
    assert max(p.z for p in contour) > 0.0005  # its height (m) above the parent

    transforms = _message_class(channels["/tf"]).FromString(received["/tf"][-1][1])
    assert {t.child_frame_id for t in transforms.transforms} >= {"platform", "disk"}

    forces = [json.loads(payload) for _, payload in received["/plant/wrench"]]
    assert all(math.isfinite(f["wrench"]["force"]["z"]) and f["header"]["frame_id"] == "tool" for f in forces)
    log_times = [log_time for log_time, _ in received["/plant/wrench"]]
    stamps = [f["header"]["stamp"]["sec"] * 10**9 + f["header"]["stamp"]["nanosec"] for f in forces]
    assert log_times == stamps and stamps == sorted(stamps)  # the timeline is the cell's sim time
