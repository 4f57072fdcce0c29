"""Issue 23 item 2: hexctl's ros2cli verbs against live nodes -- topic pub/echo with QoS
(latched topics), node list/info, param list/get/set/describe/dump, service list/call,
action list/send_goal with a Ctrl-C cancel -- with the exit codes scripts rely on
(0 done, 1 the graph said no, 2 bad input or nobody there, 130 interrupted)."""

import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from ros_harness import wait_until

HEXCTL = str(Path(sys.executable).parent / "hexctl")


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


@pytest.fixture
def shaper(spawn):
    process = spawn(["hex-input-shaper", "--ros-args", "-r", "__ns:=/cli"])
    wait_until(lambda: "ready:" in process.output(), 60.0, what="the input shaper")
    return process


def test_param_verbs_read_and_set_a_running_nodes_parameters(shaper, ros_env):
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
    echoed = hexctl(ros_env, "topic", "echo", "/cli/latched", "--once")  # matched to the latched publisher
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
    assert code == 1
