"""Issue 23 item 2, issue 40 item 3: hexctl's ros2cli verbs against live nodes -- topic
pub/echo/list/info with QoS (latched topics echoed every time, lists complete every time),
node list/info (hidden action internals), param list/get/set/describe/dump/load,
service list/call, action list/send_goal with a Ctrl-C cancel, interface show -- with
the exit codes scripts rely on (0 done, 1 the graph said no, 2 bad input, an unknown
name or nobody there, 130 interrupted)."""

import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64

from hex_control.bench.topic_tools import timed_hexctl
from hex_control.ros.tools.ros_cli import daemon as cli_daemon
from hex_control_msgs.msg import Contour
from ros_harness import wait_until

HEXCTL = str(Path(sys.executable).parent / "hexctl")
#: a line of Fast DDS's own log (its transports write errors to stderr, e.g. a shared-memory
#: port it could not lock among /dev/shm's leftovers: the verb went on over UDP and was right)
MIDDLEWARE_LOG = re.compile(r"\[(?:\x1b\[[\d;]*m)?RTPS_[A-Z_]+")


def said(completed) -> str:
    """What a verb wrote to stderr itself: its lines, the middleware's log left out."""
    return "\n".join(line for line in completed.stderr.strip().splitlines() if not MIDDLEWARE_LOG.search(line))


def hexctl(ros_env, *arguments, timeout=120):
    return subprocess.run([HEXCTL, *arguments], env=ros_env, capture_output=True, text=True, timeout=timeout)


class Running:
    """A hexctl verb in the background, its output read line by line."""

    def __init__(self, ros_env, *arguments):
        self.process = subprocess.Popen([HEXCTL, *arguments], env=ros_env, stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True)
        self.lines, self.errors = [], []
        for stream, into in ((self.process.stdout, self.lines), (self.process.stderr, self.errors)):
            threading.Thread(target=lambda s=stream, i=into: i.extend(s), daemon=True).start()

    def wait_for(self, text: str, timeout_s: float = 60.0):
        wait_until(lambda: any(text in line for line in self.lines), timeout_s, what=repr(text))

    def interrupt(self) -> int:
        self.process.send_signal(signal.SIGINT)
        return self.process.wait(timeout=60)


@pytest.fixture(scope="module", autouse=True)
def no_daemon_left(ros_env):
    """The verbs start a daemon (hex_control/ros/tools/ros_cli/daemon.py): none outlives this module."""
    yield
    hexctl(ros_env, "daemon", "stop")


@pytest.fixture
def shaper(spawn):
    process = spawn(["hex-input-shaper", "--ros-args", "-r", "__ns:=/cli"])
    wait_until(lambda: "ready:" in process.output(), 60.0, what="the input shaper")
    return process


def test_param_verbs_read_and_set_a_running_nodes_parameters(shaper, ros_env, tmp_path):
    listed = hexctl(ros_env, "param", "list", "/cli/input_shaper")
    assert listed.returncode == 0 and "  shaper" in listed.stdout.splitlines()
    assert hexctl(ros_env, "param", "get", "/cli/input_shaper", "shaper").stdout.strip() == "String value is: zvd"
    described = hexctl(ros_env, "param", "describe", "/cli/input_shaper", "damping").stdout
    assert "Type: double" in described and "Range: 0.0 .. 0.99" in described
    refused = hexctl(ros_env, "param", "set", "/cli/input_shaper", "damping", "5.0")
    assert refused.returncode == 1 and "out of range" in refused.stderr
    assert hexctl(ros_env, "param", "set", "/cli/input_shaper", "damping", "0.05").returncode == 0
    assert hexctl(ros_env, "param", "get", "/cli/input_shaper", "damping").stdout.strip() == "Double value is: 0.05"
    dumped = hexctl(ros_env, "param", "dump", "/cli/input_shaper").stdout
    assert dumped.startswith("/cli/input_shaper:\n  ros__parameters:\n") and "    damping: 0.05" in dumped
    missing = hexctl(ros_env, "param", "get", "/cli/nobody", "x", "--timeout", "1")
    assert missing.returncode == 2 and "no parameter services of /cli/nobody" in missing.stderr
    # an unknown name: one line, exit 2 (it printed "not enough values to unpack")
    for verb in (["get", "/cli/input_shaper", "no_such"], ["set", "/cli/input_shaper", "no_such", "1"],
                 ["describe", "/cli/input_shaper", "damping", "no_such"]):
        unknown = hexctl(ros_env, "param", *verb)
        assert unknown.returncode == 2, unknown
        assert said(unknown) == "hexctl: /cli/input_shaper has no parameter no_such " \
                                         "(hexctl param list /cli/input_shaper)", unknown.stderr
    # describe: several names, the declared choices
    described = hexctl(ros_env, "param", "describe", "/cli/input_shaper", "shaper", "damping").stdout
    shaper_part, damping_part = described.split("Parameter name: damping")
    assert shaper_part.startswith("Parameter name: shaper\n  Type: string")
    assert "  Constraints: one of: 2hump_ei, 3hump_ei, ei, mzv, zv, zvd, zvdd, optimized" in shaper_part, described
    assert "Range: 0.0 .. 0.99" in damping_part
    # load: a dumped file, edited, goes back in; a value out of range is refused (exit 1)
    parameters = tmp_path / "shaper.yaml"
    parameters.write_text(dumped.replace("    damping: 0.05", "    damping: 0.07"))
    loaded = hexctl(ros_env, "param", "load", "/cli/input_shaper", str(parameters))
    assert loaded.returncode == 0 and "Set parameter damping successful" in loaded.stdout, loaded
    assert hexctl(ros_env, "param", "get", "/cli/input_shaper", "damping").stdout.strip() == "Double value is: 0.07"
    parameters.write_text("/**:\n  ros__parameters:\n    damping: 5.0\n")
    refused = hexctl(ros_env, "param", "load", "/cli/input_shaper", str(parameters))
    assert refused.returncode == 1, refused
    assert "Set parameter damping failed: Parameter damping out of range" in refused.stderr


def test_node_and_service_verbs(shaper, ros_env):
    # each verb discovers the graph afresh: on a loaded machine ask again until it has
    wait_until(lambda: "/cli/input_shaper" in hexctl(ros_env, "node", "list").stdout.split(), 60.0,
               what="the node in node list")
    info = wait_until(lambda: (lambda out: out if "/cli/motion/tool_path: " in out else "")(
        hexctl(ros_env, "node", "info", "/cli/input_shaper").stdout), 60.0, what="node info")
    assert "    /cli/motion/tool_path: hex_control_msgs/msg/ToolPath" in info.split("  Subscribers:")[1]
    wait_until(lambda: "/cli/input_shaper/get_parameters [rcl_interfaces/srv/GetParameters]"
               in hexctl(ros_env, "service", "list", "-t").stdout, 60.0, what="the service in service list")
    called = hexctl(ros_env, "service", "call", "/cli/input_shaper/get_parameters", "rcl_interfaces/srv/GetParameters",
                    "{names: [shaper]}")
    assert called.returncode == 0 and "string_value: zvd" in called.stdout
    bad = hexctl(ros_env, "service", "call", "/cli/input_shaper/get_parameters", "rcl_interfaces/srv/GetParameters",
                 "{names: [shaper")
    assert bad.returncode == 2 and "not YAML" in bad.stderr


def test_topic_pub_and_echo_reach_latched_endpoints_and_echo_ends_cleanly_on_ctrl_c(ros_env, spawn):
    publisher = Running(ros_env, "topic", "pub", "/cli/latched", "std_msgs/msg/Float64", "{data: 2.5}", "-1",
                        "--qos-durability", "transient_local", "--wait", "0")
    publisher.process.wait(timeout=60)
    latched = Running(ros_env, "topic", "pub", "/cli/latched", "std_msgs/msg/Float64", "{data: 2.5}", "-t", "0",
                      "-r", "0.05", "--qos-durability", "transient_local", "--wait", "0")
    latched.wait_for("publishing #1")
    # matched to the latched publisher; discovery included in the echo's bound, which beside two
    # CPU burners and the suite once passed its default 10 s
    echoed = hexctl(ros_env, "topic", "echo", "/cli/latched", "--once", "--timeout", "60")
    assert echoed.returncode == 0 and echoed.stdout.splitlines()[0] == "data: 2.5"
    assert latched.interrupt() in (0, 130)
    # a byte field prints as its number; Ctrl-C on echo: exit 130, no traceback
    status = Running(ros_env, "topic", "echo", "/cli/silent", "--timeout", "60")
    pub = Running(ros_env, "topic", "pub", "/cli/silent", "diagnostic_msgs/msg/DiagnosticStatus", "{level: 2}",
                  "-t", "0", "-r", "2")
    status.wait_for("level: 2")
    assert status.interrupt() == 130 and not any("Traceback" in line for line in status.errors)
    pub.interrupt()


def test_action_send_goal_is_accepted_and_ctrl_c_cancels_it(ros_env, spawn, tmp_path):
    spawn(["hex-sequence-planner", "--ros-args", "-r", "__ns:=/cli", "-p", f"job_dir:={tmp_path}"])
    # Each call is a new participant with its own discovery: ask until one has seen the action.
    wait_until(lambda: "/cli/sequence_planner/grind_bead [hex_control_msgs/action/GrindBead]"
               in hexctl(ros_env, "action", "list", "-t", "--wait", "1").stdout, 120.0, what="the action")
    goal = Running(ros_env, "action", "send_goal", "/cli/sequence_planner/grind_bead",
                   "hex_control_msgs/action/GrindBead",
                   "{job_id: cli-job, bead_height_mm: 0.8, bead_width_mm: 10.0, bead_length_mm: 60.0, "
                   "deadline_s: 30.0}",
                   "--feedback")
    goal.wait_for("Goal accepted with ID:")
    code = goal.interrupt()
    output = "".join(goal.lines)
    assert "Canceling goal..." in output and "Goal finished with status: CANCELED" in output, output + \
        "".join(goal.errors)
    assert code == 130  # the documented exit of an interrupted verb (it was 1)
    # node info shows the action, not its _action/ topics and services (unless asked)
    info = hexctl(ros_env, "node", "info", "/cli/sequence_planner").stdout
    assert "  Action Servers:\n    /cli/sequence_planner/grind_bead: hex_control_msgs/action/GrindBead" in info
    assert "_action" not in info, info
    hidden = hexctl(ros_env, "node", "info", "/cli/sequence_planner", "--include-hidden").stdout
    assert "/cli/sequence_planner/grind_bead/_action/send_goal: hex_control_msgs/action/GrindBead_SendGoal" \
        in hidden
    assert "_action" not in hexctl(ros_env, "service", "list").stdout
    unknown = hexctl(ros_env, "node", "info", "/cli/nobody", "--wait", "2")
    assert unknown.returncode == 2 and said(unknown) == "hexctl: unknown node /cli/nobody (hexctl node list)"


LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: issue 40: an echo of a latched topic returns within this (s). Asserted here of the verb's
#: own time (from its call to its return): the whole process (Python's start, the imports)
#: varies with the machine's load, 0.3 s idle to several s at a load of 15 on 2 cores. 20
#: tries of the whole process, idle and beside two CPU burners: hexctl bench topic_tools
ECHO_BOUND_S = 2.0
TRIES = 3
NO_DAEMON = {"HEXCTL_NO_DAEMON": "1"}


@pytest.fixture
def daemon(ros_env):
    """A running hexctl daemon of this run's domain, stopped at the end."""
    started = hexctl(ros_env, "daemon", "start")
    assert started.returncode == 0 and started.stdout.strip() == "The daemon is running", started
    yield
    hexctl(ros_env, "daemon", "stop")


def test_echo_of_a_latched_topic_returns_at_once_every_time(ros, ros_env, daemon):
    """The QoS is chosen after the publishers are discovered: transient local when they all
    are (chosen before, a latched topic was subscribed volatile and echo hung 3 of 4 times);
    the daemon has discovered them already (a new participant finds one in four late)."""
    node = ros.node("contour_publisher")
    node.create_publisher(Contour, "/cli/grinding/contour", LATCHED).publish(
        Contour(job_id="latched", pass_index=3, x_mm=[0.0, 1.5], z_mm=[0.25, 0.5]))
    # the daemon subscribes to a latched topic when its graph shows it, before any echo asks,
    # and holds its message (subscribing at the first echo, that echo waited for the publisher
    # to match: up to 3.1 s beside two CPU burners); an echo then answers from memory
    wait_until(lambda: (cli_daemon.held_topics() or {}).get("/cli/grinding/contour") == 1, 60.0,
               what="the daemon holding the latched message unasked")
    verbs = []
    for attempt in range(TRIES):
        _whole, _start_up, verb_s, echoed = timed_hexctl(ros_env, "topic", "echo", "/cli/grinding/contour", "--once",
                                                         "--field", "z_mm", "--timeout", "30")
        assert echoed.returncode == 0 and echoed.stdout == "- 0.25\n- 0.5\n---\n", (attempt, echoed)
        verbs.append(verb_s)
    assert max(verbs) < ECHO_BOUND_S, [round(v, 2) for v in verbs]
    # the verb answered by the daemon starts lean: it imports no rclpy (0.2 s of CPU, up to 1 s
    # and more beside two burners)
    lean = subprocess.run([sys.executable, "-c", "import sys; from hex_control.cli import main; "
                           "code = main(['topic', 'echo', '/cli/grinding/contour', '--once', '--field', 'pass_index']);"
                           " print(code, 'rclpy' in sys.modules)"], env=ros_env, capture_output=True, text=True,
                          timeout=120)
    assert lean.stdout == "3\n---\n0 False\n", lean
    # without a daemon: the verb's own node, the same message. Subscribed volatile, it would
    # wait for its --timeout and exit 2. How long it takes is rclpy's import and DDS discovery,
    # which follow the load (5.4 s at load 12, one announcement period over a bound that held
    # beside two burners): `hexctl bench topic_tools` reports it, this test does not judge it
    echoed = hexctl(ros_env | NO_DAEMON, "topic", "echo", "/cli/grinding/contour", "--once", "--field", "z_mm",
                    "--timeout", "60")
    assert echoed.returncode == 0 and echoed.stdout == "- 0.25\n- 0.5\n---\n", echoed
    # --timeout bounds everything: no publisher, or a publisher that never sends, is exit 2
    # after the bound (the silent one is given 8 s, long enough to be discovered when a Fast
    # DDS announcement, every 3 s, is missed); an echo that ignored it (it once hung 11 min) fails on the
    # subprocess's own timeout. How soon after the bound it exits is the benchmark's
    # (hexctl bench topic_tools), not this test's: it is Python starting, which follows the load
    for topic, bound_s, why in (
            ("/cli/nobody_publishes", 1.5, "no publisher of /cli/nobody_publishes within 1.5 s (is it running, "
                                           "with the same ROS_DOMAIN_ID? hexctl topic list)"),
            ("/cli/silent_latched", 8.0, "no message on /cli/silent_latched within 8 s")):
        if topic == "/cli/silent_latched":
            node.create_publisher(Contour, topic, LATCHED)
            ros.wait_for_match(node, topic, publishers=1)
        for env in (ros_env, ros_env | NO_DAEMON):
            start = time.monotonic()
            silent = hexctl(env, "topic", "echo", topic, "--timeout", f"{bound_s:g}", timeout=60)
            assert silent.returncode == 2 and said(silent) == f"hexctl: {why}", silent
            assert time.monotonic() - start >= bound_s  # a floor, not a speed: it gave up no sooner than told


def test_the_daemon_holds_the_newest_latched_message_and_lets_go_of_streams(ros, ros_env, daemon):
    """A depth-1 latched topic republished: an echo --once prints the newest message, as a
    new subscriber would get it (holding the first 100, it printed the first one held). A
    transient-local stream (the plant's telemetry) is not held: its CPU is the cell's."""
    node = ros.node("republisher")
    contour = node.create_publisher(Contour, "/cli/held/contour", LATCHED)
    contour.publish(Contour(job_id="first", pass_index=1))
    wait_until(lambda: (cli_daemon.held_topics() or {}).get("/cli/held/contour") == 1, 60.0,
               what="the first contour held")
    contour.publish(Contour(job_id="second", pass_index=2))
    wait_until(lambda: hexctl(ros_env, "topic", "echo", "/cli/held/contour", "--once", "--field",
                              "pass_index").stdout == "2\n---\n", 60.0, what="the newest contour echoed")
    assert cli_daemon.held_topics()["/cli/held/contour"] == 1  # the publisher's history: one message
    stream = node.create_publisher(Float64, "/cli/held/stream", QoSProfile(
        depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    stream.publish(Float64(data=1.0))
    wait_until(lambda: "/cli/held/stream" in (cli_daemon.held_topics() or {}), 60.0, what="the stream held first")

    def publish_and_ask():  # five messages a poll: well over STREAM_HZ however slow the polls
        for _ in range(5):
            stream.publish(Float64(data=2.0))
        return "/cli/held/stream" not in (cli_daemon.held_topics() or {"/cli/held/stream": 0})
    wait_until(publish_and_ask, 60.0, what="the daemon letting go of the stream")
    echoed = hexctl(ros_env, "topic", "echo", "/cli/held/stream", "--once", "--timeout", "30")
    assert echoed.returncode == 0 and echoed.stdout.startswith("data: "), echoed


def test_topic_list_is_complete_every_time_and_topic_info_names_the_endpoints(ros, ros_env, shaper, daemon):
    """list waits until discovery has settled; at a fixed 1 s it listed 2, 15 and 23 of 29 topics."""
    node = ros.node("many_topics")
    ours = {f"/cli/many/topic_{i:02d}" for i in range(25)}
    for name in sorted(ours):
        node.create_publisher(Float64, name, LATCHED if name.endswith("0") else 10)
    expected = ours | {"/cli/motion/tool_path", "/cli/motion/tool_path_raw", "/rosout", "/parameter_events"}
    wait_until(lambda: expected <= {n for n, _ in node.get_topic_names_and_types()}, 60.0, what="the topics")
    # the verb's own participant (no daemon): it waits until its discovery has settled
    listed = hexctl(ros_env | NO_DAEMON, "topic", "list")
    assert listed.returncode == 0 and expected <= set(listed.stdout.split()), \
        sorted(expected - set(listed.stdout.split()))
    for attempt in range(TRIES):  # the daemon's graph, settled (20 tries idle and loaded: hexctl bench topic_tools)
        listed = hexctl(ros_env, "topic", "list")
        assert listed.returncode == 0 and expected <= set(listed.stdout.split()), \
            (attempt, sorted(expected - set(listed.stdout.split())))
    assert "/cli/input_shaper" in hexctl(ros_env, "node", "list").stdout.split()
    info = hexctl(ros_env, "topic", "info", "/cli/many/topic_10", "-v")
    assert info.returncode == 0, info
    assert info.stdout.startswith("Type: std_msgs/msg/Float64\n\nPublisher count: 1\n\n"), info.stdout
    assert "Node name: many_topics\nNode namespace: /\nTopic type: std_msgs/msg/Float64\n" \
           "Endpoint type: PUBLISHER\n" in info.stdout
    assert "  Reliability: RELIABLE\n" in info.stdout and "  Durability: TRANSIENT_LOCAL\n" in info.stdout
    assert "Subscription count: 0" in info.stdout
    unknown = hexctl(ros_env, "topic", "info", "/cli/no_such_topic", "--wait", "2")
    assert unknown.returncode == 2 and said(unknown) == \
        "hexctl: unknown topic /cli/no_such_topic (hexctl topic list)"
    # the daemon: one a domain, stopped on request
    assert hexctl(ros_env, "daemon", "status").stdout.startswith("The daemon is running (pid ")
    assert hexctl(ros_env, "daemon", "stop").stdout.strip() == "The daemon has been stopped"
    wait_until(lambda: hexctl(ros_env, "daemon", "status").returncode == 1, 30.0, what="the daemon gone")


def test_interface_show_expands_nested_types_and_refuses_unknown_ones():
    shown = subprocess.run([HEXCTL, "interface", "show", "geometry_msgs/msg/WrenchStamped"], capture_output=True,
                           text=True, timeout=60)
    assert shown.returncode == 0
    assert "std_msgs/Header header\n\tbuiltin_interfaces/Time stamp\n\t\tint32 sec\n\t\tuint32 nanosec\n" \
           "\tstring frame_id\nWrench wrench\n\tVector3  force\n\t\tfloat64 x\n" in shown.stdout
    action = subprocess.run([HEXCTL, "interface", "show", "hex_control_msgs/GrindBead"], capture_output=True,
                            text=True, timeout=60)
    assert action.returncode == 0 and action.stdout.count("\n---\n") == 2 and "\tfloat64[] z_mm\n" in action.stdout
    for bad in ("hex_control_msgs/msg/NoSuch", "no_such_pkg/msg/X", "nonsense"):
        refused = subprocess.run([HEXCTL, "interface", "show", bad], capture_output=True, text=True, timeout=60)
        assert refused.returncode == 2 and len(said(refused).splitlines()) == 1, refused
