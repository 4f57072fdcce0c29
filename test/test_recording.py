"""Issue 23 item 3: recordings in rosbag2's MCAP layout. Every message type of the graph
goes through a recording as its CDR bytes and comes back out through the mcap reader and
mcap-ros2-support's decoder -- the schema text alone, without rclpy -- field for field.
Issue 40 item 3: bag info as ros2's (size, start, end, duration); play at the recorded
pace (against the recorded timeline), with --loop, --clock and --remap."""

import math
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message

from hex_control.recording.bag import BagWriter, bag_info, describe, message_definition, read_messages
from hex_control.recording.playback import paced, parse_remaps
from hex_control.ros.infra.messages import message_class, to_primitive
from ros_harness import wait_until

MSGS = Path(sys.prefix) / "share" / "hex_control_msgs" / "msg"
GRAPH_TYPES = sorted({f"hex_control_msgs/msg/{p.stem}" for p in MSGS.glob("*.msg")} | {
    "geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PointStamped",
    "sensor_msgs/msg/JointState", "trajectory_msgs/msg/JointTrajectory", "std_msgs/msg/Float64",
    "rosgraph_msgs/msg/Clock", "diagnostic_msgs/msg/DiagnosticArray", "diagnostic_msgs/msg/DiagnosticStatus",
    "hex_control_msgs/action/GrindBead_Feedback", "hex_control_msgs/action/GrindBead_Result"})


def _filled(cls, depth: int = 0):
    """A message with every field set to a value that is not its default (sequences of two)."""
    msg = cls()
    for name, kind in msg.get_fields_and_field_types().items():
        fixed = re.search(r"\[(\d+)\]$", kind)
        many = kind.startswith("sequence<") or fixed is not None
        base = re.sub(r"^sequence<|(, ?\d+)?>$|\[\d*\]$", "", kind)
        base = re.sub(r"<=\d+$", "", base)
        if "/" in base:
            element = lambda: _filled(message_class(base), depth + 1)  # noqa: E731
        elif base in ("string", "wstring"):
            element = lambda: "s"  # noqa: E731
        elif base == "boolean":
            element = lambda: True  # noqa: E731
        elif base == "octet":
            element = lambda: bytes([7])  # noqa: E731
        elif base in ("float", "double"):
            element = lambda: 2.5 + depth  # noqa: E731
        else:
            element = lambda: 3 + depth  # noqa: E731
        value = [element() for _ in range(int(fixed.group(1)) if fixed else 2)] if many else element()
        setattr(msg, name, value)
    return msg


def _namespace_to_primitive(value):
    if hasattr(value, "__slots__") and not isinstance(value, (bytes, str)):  # mcap_ros2's decoded classes
        return {k: _namespace_to_primitive(getattr(value, k)) for k in value.__slots__}
    if isinstance(value, (list, tuple)):
        return [_namespace_to_primitive(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    return value


@pytest.mark.parametrize("type_name", GRAPH_TYPES)
def test_every_message_type_of_the_graph_round_trips_through_a_recording(type_name, tmp_path):
    original = _filled(message_class(type_name))
    with BagWriter(tmp_path / "bag") as writer:
        writer.add_topic("/cell/topic", type_name, [{"durability": "transient_local"}])
        writer.write("/cell/topic", serialize_message(original), 1_000_000_123)
    with open(tmp_path / "bag" / "bag_0.mcap", "rb") as stream:
        [(schema, channel, message, decoded)] = list(
            make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    assert (schema.encoding, channel.message_encoding, schema.name) == ("ros2msg", "cdr", type_name)
    assert schema.data.decode() == message_definition(type_name)
    assert message.log_time == 1_000_000_123 and channel.topic == "/cell/topic"
    expected = to_primitive(original)
    assert _namespace_to_primitive(decoded) == pytest.approx(expected) if not isinstance(expected, dict) \
        else _compare(_namespace_to_primitive(decoded), expected)


def _compare(decoded, expected):
    assert decoded.keys() == expected.keys()
    for key, value in expected.items():
        if isinstance(value, dict):
            _compare(decoded[key], value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            assert len(decoded[key]) == len(value)
            for a, b in zip(decoded[key], value):
                _compare(a, b)
        else:
            assert decoded[key] == pytest.approx(value), key
    return True


def test_the_metadata_is_rosbag2s_and_a_recording_is_read_back_in_time_order(tmp_path):
    with BagWriter(tmp_path / "run") as writer:
        writer.add_topic("/a", "std_msgs/msg/Float64", [{"reliability": "reliable"}])
        writer.add_topic("/b", "rosgraph_msgs/msg/Clock")
        for t, topic in ((30, "/a"), (10, "/b"), (20, "/a")):
            writer.write(topic, serialize_message(message_class(
                "std_msgs/msg/Float64" if topic == "/a" else "rosgraph_msgs/msg/Clock")()), t)
    info = bag_info(tmp_path / "run")
    assert info["version"] == 9 and info["storage_identifier"] == "mcap" and info["message_count"] == 3
    assert info["starting_time"] == {"nanoseconds_since_epoch": 10} and info["duration"] == {"nanoseconds": 20}
    counts = {e["topic_metadata"]["name"]: e["message_count"] for e in info["topics_with_message_count"]}
    assert counts == {"/a": 2, "/b": 1} and info["relative_file_paths"] == ["run_0.mcap"]
    assert [(topic, t) for topic, _, _, t in read_messages(tmp_path / "run")] == [("/b", 10), ("/a", 20), ("/a", 30)]
    with pytest.raises(ValueError):
        BagWriter(tmp_path / "run")  # not over an earlier recording


def test_hexctl_record_keeps_a_latched_message_and_bag_info_lists_it(ros, ros_env, tmp_path):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    publishing = ros.node("latched_publisher")
    publisher = publishing.create_publisher(Float64, "/recorded/latched", latched)
    publisher.publish(Float64(data=42.5))
    hexctl = str(Path(sys.executable).parent / "hexctl")
    out = tmp_path / "rec"
    recorder = subprocess.Popen([hexctl, "record", "/recorded/latched", "-o", str(out)], env=ros_env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(recorder.stdout), daemon=True)
    reader.start()
    # the latched message reaches the late-joining recorder when it matches; Ctrl-C then ends it
    wait_until(lambda: any("first message on /recorded/latched" in line for line in lines), 60.0,
               what="the recorder's first message")
    recorder.send_signal(signal.SIGINT)
    recorder.wait(timeout=60)
    reader.join(timeout=10)
    output = "".join(lines)
    assert recorder.returncode == 0, output
    [(topic, type_name, data, _)] = list(read_messages(out))
    from rclpy.serialization import deserialize_message

    assert (topic, type_name, deserialize_message(data, Float64).data) == ("/recorded/latched",
                                                                          "std_msgs/msg/Float64", 42.5)
    info = subprocess.run([hexctl, "bag", "info", str(out)], env=ros_env, capture_output=True, text=True, timeout=60)
    assert info.returncode == 0 and "Topic information: Topic: /recorded/latched | Type: std_msgs/msg/Float64 | " \
        "Count: 1 | Serialization Format: cdr" in info.stdout, info.stdout
    offered = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert offered["topics_with_message_count"][0]["topic_metadata"]["offered_qos_profiles"][0]["durability"] \
        == "transient_local"
    # hexctl play publishes it again, latched as it was offered: a late subscriber gets it
    publishing.destroy_publisher(publisher)
    # rclpy finalizes a destroyed publisher only once the executor has let go of its event
    # handlers; until then its latched 42.5 would reach the new subscriber beside the played one
    wait_until(lambda: publishing.count_publishers("/recorded/latched") == 0, 30.0,
               what="the original publisher to be gone")
    again = ros.collect(Float64, "/recorded/latched", latched)
    played = subprocess.run([hexctl, "play", str(out), "--wait", "60"], env=ros_env, capture_output=True, text=True,
                            timeout=120)
    assert played.returncode == 0 and "played 1 messages on 1 topics" in played.stdout
    wait_until(lambda: again, 30.0, what="the played message")
    assert [m.data for m in again] == [42.5]


def test_bag_info_says_size_start_end_and_duration(tmp_path):
    with BagWriter(tmp_path / "run") as writer:
        writer.add_topic("/a", "std_msgs/msg/Float64")
        writer.add_topic("/b", "rosgraph_msgs/msg/Clock")
        for t_ns, topic in ((1_765_000_000_250_000_000, "/a"), (1_765_000_045_750_000_000, "/b")):
            writer.write(topic, serialize_message(message_class(
                "std_msgs/msg/Float64" if topic == "/a" else "rosgraph_msgs/msg/Clock")()), t_ns)
    text = describe(tmp_path / "run")
    size = sum(f.stat().st_size for f in (tmp_path / "run").iterdir())
    lines = dict(line.split(":", 1) for line in text.splitlines()[:8])
    assert lines["Files"].strip() == "run_0.mcap" and lines["Storage id"].strip() == "mcap"
    assert lines["Bag size"].strip() == (f"{size / 1024:.1f} KiB" if size >= 1024 else f"{size} B")
    assert lines["Duration"].strip() == "45.500000000s" and lines["Messages"].strip() == "2"
    assert lines["Start"].strip().endswith("(1765000000.250000000)")
    assert lines["End"].strip().endswith("(1765000045.750000000)")
    start_clock = time.strftime("%H:%M:%S", time.localtime(1_765_000_000))
    assert f" {start_clock}.250000000 (" in lines["Start"]
    assert text.splitlines()[8:] == [
        "Topic information: Topic: /a | Type: std_msgs/msg/Float64 | Count: 1 | Serialization Format: cdr",
        "                   Topic: /b | Type: rosgraph_msgs/msg/Clock | Count: 1 | Serialization Format: cdr"]


class _FakeClock:
    """A monotonic clock that moves only when slept on, or by ``cost`` a message handed out."""

    def __init__(self):
        self.now = 100.0

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0
        self.now += seconds


def test_paced_keeps_the_recorded_timeline_and_lateness_does_not_add_up():
    clock = _FakeClock()
    recorded = [("/a", i, 1_000_000_000 * i // 2) for i in range(91)]  # 45 s at 2 Hz
    sent = []
    for message in paced(recorded, 1.0, now=lambda: clock.now, sleep=clock.sleep):
        sent.append(clock.now - 100.0)
        clock.now += 0.05 if message[1] != 10 else 3.0  # publishing costs 50 ms; one took 3 s
    assert sent[:10] == pytest.approx([0.5 * i for i in range(10)])
    # late after the slow one, at once; from then on, on the recorded timeline again
    assert sent[10] == pytest.approx(5.0) and sent[11] == pytest.approx(8.0) and sent[12] == pytest.approx(8.05)
    assert sent[17] == pytest.approx(8.5) and sent[-1] == pytest.approx(45.0)  # not 45 + 91 x 0.05 + 3
    # at twice the pace: half the time; a tick (a /clock) every period, with the recorded time
    clock = _FakeClock()
    ticks = []
    sent = [clock.now for _ in paced(recorded[:11], 2.0, now=lambda: clock.now, sleep=clock.sleep,
                                     tick=lambda t_ns: ticks.append((clock.now - 100.0, t_ns)), tick_period_s=0.1)]
    assert sent[-1] - sent[0] == pytest.approx(2.5)
    assert len(ticks) == 26 and all(t_ns == pytest.approx(wall * 2e9, abs=1) for wall, t_ns in ticks)
    with pytest.raises(ValueError):
        list(paced(recorded, 0.0))


def test_parse_remaps():
    assert parse_remaps(["/a:=/b", "c:=d/e"]) == {"/a": "/b", "/c": "/d/e"}
    assert parse_remaps(None) == {}
    for bad in ("/a=/b", ":=/b", "/a:="):
        with pytest.raises(ValueError):
            parse_remaps([bad])


def test_play_keeps_the_recorded_pace_remaps_loops_and_publishes_the_clock(ros, ros_env, tmp_path):
    """61 messages over 3 s: received over 3 s (a 45.5 s recording took 49.7 s), under the
    remapped name, with the recorded time on /clock; --loop plays again until Ctrl-C."""
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Float64

    first_ns = 1_765_000_000_000_000_000
    with BagWriter(tmp_path / "paced") as writer:
        writer.add_topic("/recorded/paced", "std_msgs/msg/Float64", [{"reliability": "reliable"}])
        for i in range(61):
            writer.write("/recorded/paced", serialize_message(Float64(data=float(i))), first_ns + i * 50_000_000)
    arrivals = []
    node = ros.node("play_listener")
    node.create_subscription(Float64, "/recorded/paced_again", lambda m: arrivals.append((time.monotonic(), m.data)),
                             100)
    clocks = ros.collect(Clock, "/clock")
    hexctl = str(Path(sys.executable).parent / "hexctl")
    played = subprocess.run([hexctl, "play", str(tmp_path / "paced"), "--wait", "60", "--clock", "20",
                             "--remap", "/recorded/paced:=/recorded/paced_again"], env=ros_env,
                            capture_output=True, text=True, timeout=120)
    assert played.returncode == 0, played
    took = float(re.search(r"in ([\d.]+) s \(recorded span 3\.000 s, rate 1\)", played.stdout).group(1))
    assert took == pytest.approx(3.0, abs=0.1), played.stdout
    wait_until(lambda: len(arrivals) == 61, 30.0, what="the played messages")
    assert [d for _, d in arrivals] == [float(i) for i in range(61)]
    assert arrivals[-1][0] - arrivals[0][0] == pytest.approx(3.0, abs=0.3)  # as received, under load
    stamps = [c.clock.sec * 1_000_000_000 + c.clock.nanosec for c in clocks]
    assert len(stamps) >= 20 and all(first_ns <= s <= first_ns + 3_100_000_000 for s in stamps)
    assert stamps == sorted(stamps)
    # --loop: from the start again until Ctrl-C
    arrivals.clear()
    looping = subprocess.Popen([hexctl, "play", str(tmp_path / "paced"), "--loop", "--rate", "4",
                                "--remap", "/recorded/paced:=/recorded/paced_again"], env=ros_env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wait_until(lambda: len(arrivals) > 61 + 5, 60.0, what="a second pass")
    looping.send_signal(signal.SIGINT)
    output, _ = looping.communicate(timeout=60)
    assert looping.returncode == 0, output
    data = [d for _, d in arrivals]
    restart = data.index(60.0) + 1
    assert data[restart:restart + 5] == [0.0, 1.0, 2.0, 3.0, 4.0]
    refused = subprocess.run([hexctl, "play", str(tmp_path / "paced"), "--remap", "/not/recorded:=/x"], env=ros_env,
                             capture_output=True, text=True, timeout=60)
    assert refused.returncode == 2 and "has no topic /not/recorded" in refused.stderr


def test_a_jobs_recorder_leaves_out_the_streams_telemetry_batches(tmp_path):
    """Issue 39 item 3: the plant computes plant/strut_states only while someone subscribes,
    so the job's recorder (everything under the cell) leaves it and the other per-period
    streams plant/telemetry batches out, and records the batches and the rest."""
    from types import SimpleNamespace

    from rclpy.qos import QoSProfile

    from hex_control.recording.bag import BagWriter
    from hex_control.ros.tools.recorder import BATCHED_IN_TELEMETRY, Recorder

    topics = {"/cell/plant/strut_states": "sensor_msgs/msg/JointState",
              "/cell/plant/true_wrench": "geometry_msgs/msg/WrenchStamped",
              "/cell/plant/wrench": "geometry_msgs/msg/WrenchStamped",
              "/cell/plant/telemetry": "hex_control_msgs/msg/PlantTelemetry",
              "/cell/plant/force_axis_command": "hex_control_msgs/msg/ForceAxisCommand",
              "/cell/grinding/contour": "hex_control_msgs/msg/Contour",
              "/other/plant/wrench": "geometry_msgs/msg/WrenchStamped"}
    subscribed = []
    node = SimpleNamespace(
        get_topic_names_and_types=lambda: [(name, [kind]) for name, kind in topics.items()],
        get_publishers_info_by_topic=lambda name: [SimpleNamespace(qos_profile=QoSProfile(depth=10))],
        create_subscription=lambda cls, name, callback, qos, raw: subscribed.append(name) or name,
        create_timer=lambda period, callback: None)
    Recorder(node, BagWriter(tmp_path / "bag"), all_topics=True, under="/cell", exclude=BATCHED_IN_TELEMETRY)
    assert sorted(subscribed) == ["/cell/grinding/contour", "/cell/plant/telemetry"]


def test_the_unbatcher_gives_every_period_s_wrench_and_command_once():
    """Issue 39: a job's recording writes plant/wrench and plant/force_axis_command from the
    telemetry batches: each sample's measured force at its plant time, each command stamped
    with the state it answered (the sample before), a holding plant's repeated state once."""
    from geometry_msgs.msg import WrenchStamped
    from rclpy.serialization import deserialize_message, serialize_message

    from hex_control.ros.tools.recorder import Unbatcher
    from hex_control_msgs.msg import ForceAxisCommand, PlantTelemetry

    batches = [PlantTelemetry(time_s=[0.0, 0.005], measured_force_n=[1.0, 2.0], table_command_mm=[-1.0, -1.5]),
               PlantTelemetry(time_s=[0.005], measured_force_n=[2.0], table_command_mm=[-1.5]),  # held: again
               PlantTelemetry(time_s=[0.01, 0.015], measured_force_n=[3.0, 4.0], table_command_mm=[-2.0, -2.5])]
    unbatch = Unbatcher()
    out = [(topic, kind, data) for batch in batches for topic, kind, data in unbatch(serialize_message(batch))]
    wrenches = [deserialize_message(d, WrenchStamped) for t, _, d in out if t == "plant/wrench"]
    commands = [deserialize_message(d, ForceAxisCommand) for t, _, d in out if t == "plant/force_axis_command"]
    assert {(t, k) for t, k, _ in out} == {("plant/wrench", "geometry_msgs/msg/WrenchStamped"),
                                           ("plant/force_axis_command", "hex_control_msgs/msg/ForceAxisCommand")}
    assert [(w.header.stamp.nanosec, w.wrench.force.z, w.header.frame_id) for w in wrenches] == [
        (0, 1.0, "tool"), (5_000_000, 2.0, "tool"), (10_000_000, 3.0, "tool"), (15_000_000, 4.0, "tool")]
    assert [(c.header.stamp.nanosec, c.position_mm) for c in commands] == [
        (0, -1.5), (5_000_000, -2.0), (10_000_000, -2.5)]
    # a restarted plant (its clock back at 0): a new timeline, whose first sample has no command
    out = list(unbatch(serialize_message(PlantTelemetry(time_s=[0.0, 0.005], measured_force_n=[5.0, 6.0],
                                                        table_command_mm=[-1.0, -1.1]))))
    assert [t for t, _, _ in out] == ["plant/wrench", "plant/wrench", "plant/force_axis_command"]
    # another process's batches: arrays that disagree, a stamp that is no plant time, a flood
    for hostile in (PlantTelemetry(time_s=[1.0, 1.005], measured_force_n=[1.0]),
                    PlantTelemetry(time_s=[1.0], measured_force_n=[1.0], table_command_mm=[1.0, 2.0]),
                    PlantTelemetry(time_s=[math.nan], measured_force_n=[1.0]),
                    PlantTelemetry(time_s=[-1.0], measured_force_n=[1.0]),
                    PlantTelemetry(time_s=[0.0] * 100_001, measured_force_n=[0.0] * 100_001)):
        assert list(unbatch(serialize_message(hostile))) == []
    assert unbatch.refused == 5 and unbatch.last_time_s == 0.005


def test_a_plant_state_carries_the_force_command_held_over_its_period():
    from hex_control.plant.simulator import PlantSimulator

    plant = PlantSimulator()
    assert plant.advance(0.005, -2.0).table_command_mm == -2.0
    assert plant.advance(0.005, -1.25).table_command_mm == -1.25
