"""Record topics into a rosbag2-layout MCAP directory (:mod:`hex_control.recording.bag`),
and play one back: ``hexctl record`` / ``hexctl play``, and the recorder every
``hexctl demo`` job runs.

The recorder subscribes raw (the CDR bytes, never deserialized) to the topics it is given,
or with ``all_topics`` to every topic it discovers as it appears, except hidden ones
(a name part starting with '_', as ``ros2 bag record -a``) and those it is told to leave
out (``exclude``). It subscribes as the publishers offer: transient-local if one of them is
(a latched topic's last message is recorded too), reliable if all are.

A recorder's subscription is not free for the publisher: every reader of a per-period
stream is one more send in the lock-step loop's critical path (the wrench and the force
command cost the graph 14 % of its pace: ``hexctl bench graph``), and the plant computes
``plant/strut_states`` only while someone subscribes. So a job's recorder leaves out the
per-period streams whose every value ``plant/telemetry`` already carries in batches
(:data:`BATCHED_IN_TELEMETRY`); the batches are recorded as they are, and with ``unbatch``
the recorder writes the measured wrench and the force command of each batch's samples
under their own topics as well (:class:`Unbatcher`: the plant's values and sim-time
stamps, at the batch's receive time), so the recording reads as before in Foxglove or
PlotJuggler, at no cost to the loop.
"""

from __future__ import annotations

import time
from pathlib import Path

from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from hex_control.recording.bag import BagWriter, bag_info, read_messages
from hex_control.recording.playback import paced, parse_remaps
from hex_control.ros.infra.diagnostics import CLOCK_QOS
from hex_control.ros.infra.messages import message_class

DISCOVERY_PERIOD_S = 0.5
#: per-period streams whose content plant/telemetry batches (measured force, force command,
#: strut lengths, true force, deflection, tool centre): a job's recording keeps the batches
#: and leaves these out
BATCHED_IN_TELEMETRY = ("plant/wrench", "plant/force_axis_command", "plant/strut_states", "plant/true_wrench",
                        "plant/deflection", "plant/tool_centre")
#: how the plant offers the per-period streams (reliable, volatile, depth 100): what the unbatched ones say
PER_PERIOD_QOS = {"history": "keep_last", "depth": 100, "reliability": "reliable", "durability": "volatile"}
MAX_UNBATCHED = 100_000  # samples of one telemetry batch unbatched at most (the plant sends 20)
MAX_STAMP_S = 2.0**31  # a ROS stamp's seconds
DEPTH = 1000  # a burst of this many messages between two executor turns is kept
ACK_WAIT_S = 2.0  # play: at the end, wait this long in all for reliable subscribers' acknowledgements


def _hidden(topic: str) -> bool:
    return any(part.startswith("_") for part in topic.split("/"))


def _offered(info) -> dict:
    q = info.qos_profile
    return {"history": q.history.name.lower(), "depth": q.depth, "reliability": q.reliability.name.lower(),
            "durability": q.durability.name.lower()}


class Unbatcher:
    """The per-period messages ``plant/telemetry`` batches carry, one batch after another:
    (topic relative to the cell, type name, CDR bytes) of ``plant/wrench`` (the measured
    normal force, frame ``tool``, stamped with the sample's plant time) and
    ``plant/force_axis_command`` (the table's target in mm, stamped with the state it
    answered: the sample before, whose period it was held over). The last sample again (a
    holding plant's state) is skipped; an earlier one starts a new timeline (a restarted
    plant: its first sample has no command). A batch whose arrays disagree, that holds over
    :data:`MAX_UNBATCHED` samples or a stamp that is not a finite plant time (anyone may
    publish on the topic) gives nothing and is counted in ``refused``."""

    def __init__(self):
        from geometry_msgs.msg import WrenchStamped

        from hex_control_msgs.msg import ForceAxisCommand

        self.last_time_s = None
        self.refused = 0
        self._wrench, self._command = WrenchStamped(), ForceAxisCommand()
        self._wrench.header.frame_id = "tool"

    def __call__(self, data: bytes):
        from rclpy.serialization import deserialize_message, serialize_message

        from hex_control.ros.infra.interfaces import time_msg
        from hex_control_msgs.msg import PlantTelemetry

        batch = deserialize_message(data, PlantTelemetry)
        times, forces, commands = batch.time_s, batch.measured_force_n, batch.table_command_mm
        if not (len(times) == len(forces) <= MAX_UNBATCHED and len(commands) in (0, len(times))
                and all(0.0 <= t <= MAX_STAMP_S for t in times)):
            self.refused += 1
            return
        wrench, command = self._wrench, self._command
        for k, time_s in enumerate(times):
            last, self.last_time_s = self.last_time_s, time_s
            if last is not None and time_s == last:
                continue
            wrench.header.stamp = time_msg(time_s)
            wrench.wrench.force.z = forces[k]
            yield "plant/wrench", "geometry_msgs/msg/WrenchStamped", serialize_message(wrench)
            if last is not None and time_s > last and commands:
                command.header.stamp = time_msg(last)
                command.position_mm = commands[k]
                yield "plant/force_axis_command", "hex_control_msgs/msg/ForceAxisCommand", serialize_message(command)


class Recorder:
    """Records into ``writer`` on ``node``'s executor: ``topics`` (full names), or all of them,
    or all under the namespace ``under``, but those of ``exclude`` (names relative to ``under``);
    ``unbatch``: also the per-period streams of ``plant/telemetry`` (:class:`Unbatcher`)."""

    def __init__(self, node, writer: BagWriter, topics=None, all_topics: bool = False, *, on_first=None,
                 under: str = "", exclude=(), unbatch: bool = False):
        if not all_topics and not topics:
            raise ValueError("record which topics? give some, or all")
        self.node, self.writer = node, writer
        self.wanted = None if all_topics else {node.resolve_topic_name(t) for t in topics}
        self.under = under.rstrip("/") + "/"
        self.excluded = {self.under + t.lstrip("/") for t in exclude}
        self.subscriptions = {}
        self.counts: dict[str, int] = {}
        self.on_first = on_first  # called with a topic's name on its first message
        self.telemetry = self.under + "plant/telemetry" if unbatch else None
        self.unbatch = Unbatcher() if unbatch else None
        self._timer = node.create_timer(DISCOVERY_PERIOD_S, self.discover)
        self.discover()

    def discover(self) -> None:
        for name, types in self.node.get_topic_names_and_types():
            if (name in self.subscriptions or name in self.excluded
                    or self.wanted is not None and name not in self.wanted):
                continue
            if self.wanted is None and (_hidden(name) or not name.startswith(self.under)):
                continue
            publishers = self.node.get_publishers_info_by_topic(name)
            if not publishers:
                continue  # a subscriber's topic: nothing to record yet, and no QoS to match
            try:
                cls = message_class(types[0])
            except ValueError:
                continue  # a type this install does not have: cannot be recorded
            latched = any(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
            reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DEPTH,
                             reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
            self.writer.add_topic(name, types[0], [_offered(p) for p in publishers])
            self.counts[name] = 0
            self.subscriptions[name] = self.node.create_subscription(
                cls, name, lambda data, topic=name: self._write(topic, data), qos, raw=True)

    def _write(self, topic: str, data: bytes) -> None:
        now_ns = time.time_ns()
        self._count(topic)
        self.writer.write(topic, data, now_ns)
        if topic == self.telemetry:
            for relative, type_name, sample in self.unbatch(data):
                name = self.under + relative
                if name not in self.counts:
                    self.writer.add_topic(name, type_name, [PER_PERIOD_QOS])
                    self.counts[name] = 0
                self._count(name)
                self.writer.write(name, sample, now_ns)

    def _count(self, topic: str) -> None:
        self.counts[topic] += 1
        if self.counts[topic] == 1 and self.on_first:
            self.on_first(topic)

    def close(self) -> None:
        self._timer.cancel()
        self.node.destroy_timer(self._timer)
        for subscription in self.subscriptions.values():
            self.node.destroy_subscription(subscription)
        self.subscriptions.clear()
        self.writer.close()


def record(output: str, topics, all_topics: bool, duration_s: float | None) -> int:
    """``hexctl record``: until Ctrl-C (or ``duration_s``); prints what it recorded."""
    import rclpy

    from hex_control.ros.infra.runtime import init, make_executor, spin_until_stopped

    stop = init([])
    node = rclpy.create_node("hexctl_record", start_parameter_services=False)
    recorder = Recorder(node, BagWriter(Path(output)), topics, all_topics,
                        on_first=lambda topic: print(f"first message on {topic}", flush=True))
    if duration_s is not None:
        node.create_timer(duration_s, stop.set)
    executor = make_executor()
    executor.add_node(node)
    print(f"recording {'all topics' if all_topics else ', '.join(sorted(recorder.wanted))} into {output} "
          "(Ctrl-C ends it)", flush=True)
    try:
        spin_until_stopped(executor, stop)
    finally:
        recorder.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"recorded {sum(recorder.counts.values())} messages on {len(recorder.counts)} topics into {output}")
    return 0


def play(directory: str, rate: float, topics=None, wait_s: float = 0.0, loop: bool = False,
         *, clock_hz: float | None = None, remaps=None) -> int:
    """``hexctl play``: publish a recording's messages (raw) at ``rate`` times their recorded
    pace (:func:`hex_control.recording.playback.paced`: against the recorded timeline),
    each topic with the durability and reliability it was offered with, under its name or
    the one ``remaps`` (``from:=to``) give it; ``loop``: again from the start until Ctrl-C;
    ``clock_hz``: publish the recorded time on /clock at that rate (for nodes on sim time).
    First wait up to ``wait_s`` for every topic to have a subscriber, at the end (up to
    ACK_WAIT_S in all) for the reliable ones to acknowledge what they got."""
    import rclpy
    from builtin_interfaces.msg import Time
    from rosgraph_msgs.msg import Clock

    from hex_control.ros.infra.runtime import init

    if not rate > 0:
        raise ValueError(f"need a rate > 0, got {rate}")
    if clock_hz is not None and not clock_hz > 0:
        raise ValueError(f"need a --clock rate > 0 Hz, got {clock_hz}")
    info = bag_info(directory)
    remapped = parse_remaps(remaps)
    recorded = {e["topic_metadata"]["name"] for e in info["topics_with_message_count"]}
    unknown = sorted(set(remapped) - recorded) + sorted(set(topics or ()) - recorded)
    if unknown:
        raise ValueError(f"{directory} has no topic {', '.join(unknown)} (hexctl bag info {directory})")
    stop = init([])
    node = rclpy.create_node("hexctl_play", start_parameter_services=False)
    publishers = {}
    for entry in info["topics_with_message_count"]:
        meta = entry["topic_metadata"]
        offered = meta.get("offered_qos_profiles") or [{}]
        latched = any(q.get("durability") == "transient_local" for q in offered)
        reliable = all(q.get("reliability", "reliable") == "reliable" for q in offered)
        qos = QoSProfile(depth=100,
                         reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
        if topics is None or meta["name"] in topics:
            publishers[meta["name"]] = node.create_publisher(message_class(meta["type"]),
                                                             remapped.get(meta["name"], meta["name"]), qos)
    clock = node.create_publisher(Clock, "/clock", CLOCK_QOS) if clock_hz else None

    def tick(time_ns: int) -> None:
        clock.publish(Clock(clock=Time(sec=time_ns // 1_000_000_000, nanosec=time_ns % 1_000_000_000)))

    end = time.monotonic() + wait_s
    while time.monotonic() < end and not all(p.get_subscription_count() for p in publishers.values()):
        stop.wait(0.05)
    played, first_wall, last_wall = 0, None, None
    try:
        while not stop.is_set():
            for topic, _, data, _ in paced(read_messages(directory, list(publishers)), rate, sleep=stop.wait,
                                           tick=tick if clock else None,
                                           tick_period_s=1.0 / clock_hz if clock_hz else 0.025,
                                           stopped=stop.is_set):
                publishers[topic].publish(data)
                played += 1
                last_wall = time.monotonic()
                first_wall = first_wall or last_wall
            if not loop or not played:
                break
        acked_by = time.monotonic() + ACK_WAIT_S
        for publisher in publishers.values():
            publisher.wait_for_all_acked(Duration(nanoseconds=int(max(acked_by - time.monotonic(), 0.0) * 1e9)))
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    span = info["duration"]["nanoseconds"] / 1e9
    took = (last_wall - first_wall) if played else 0.0
    print(f"played {played} messages on {len(publishers)} topics from {directory} in {took:.3f} s "
          f"(recorded span {span:.3f} s, rate {rate:g})")
    return 0
