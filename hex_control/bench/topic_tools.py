"""``hexctl topic echo`` of latched topics and ``hexctl topic list`` as a user runs them, 20
tries each (issue 40: every echo within 2 s, every list complete), idle and beside two CPU
burners (``python3 -c "while True: pass"``).

The graph: three publisher processes (three DDS participants, as three nodes of the cell),
each with one of the cell's latched topics and eight volatile ones. Each try runs, as
separate processes: the verb's start-up alone (``topic echo`` of a topic nobody publishes
with ``--timeout 0``: Python, rclpy, a node, shut-down; the in-process baseline the echoes
are compared with), an echo ``--once`` of each latched topic, and ``topic list``. An echo
succeeds when it printed the message within ECHO_BOUND_S beyond that try's start-up; a
list when it named every topic of the graph.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from hex_control.bench import benchmark

#: issue 40: an echo of a latched topic returns within this (s), beyond the verb's own start-up
ECHO_BOUND_S = 2.0
#: (topic, module, class) of the cell's latched topics; each message's text fields say "bench"
LATCHED = (("/grinding/contour", "hex_control_msgs.msg", "Contour"),
           ("/robot_description", "std_msgs.msg", "String"),
           ("/force_controller/status", "diagnostic_msgs.msg", "DiagnosticStatus"))
VOLATILE_PER_PUBLISHER = 8
PUBLISHER = """
import importlib, sys
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64
topic, module, name, index, extra = sys.argv[1:6]
cls = getattr(importlib.import_module(module), name)
rclpy.init()
node = rclpy.create_node(f"bench_publisher_{index}")
latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
message = cls()
for field in ("job_id", "data", "name"):
    if hasattr(message, field) and isinstance(getattr(message, field), str):
        setattr(message, field, "bench")
node.create_publisher(cls, topic, latched).publish(message)
for i in range(int(extra)):
    node.create_publisher(Float64, f"/bench/p{index}/topic_{i:02d}", 10)
print("ready:", flush=True)
rclpy.spin(node)
"""
HEXCTL = str(Path(sys.executable).parent / "hexctl")


def _environment() -> dict:
    """A domain of the bench's own: clear of the tests' 100..199 and the loop bench's 200..232."""
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(60 + os.getpid() % 40), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               OPENBLAS_NUM_THREADS="1")
    return env


@contextmanager
def _processes(commands, env, ready: bool):
    started = [subprocess.Popen(c, env=env, stdout=subprocess.PIPE if ready else subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, text=True) for c in commands]
    try:
        if ready:
            for process in started:
                process.stdout.readline()  # "ready:"
        yield started
    finally:
        for process in started:
            process.kill()
            process.wait()


def _run(env, *arguments) -> tuple[float, subprocess.CompletedProcess]:
    start = time.monotonic()
    result = subprocess.run([HEXCTL, *arguments], env=env, capture_output=True, text=True, timeout=120)
    return time.monotonic() - start, result


def _figures(values) -> str:
    return f"p50 {statistics.median(values):.2f} s, max {max(values):.2f} s"


def _phase(env, tries: int, expected: set[str]) -> list[str]:
    start_ups, echoes, beyond, lists = [], [], [], []
    echo_ok = list_ok = 0
    for _ in range(tries):
        start_up, nothing = _run(env, "topic", "echo", "/bench/nobody", "--timeout", "0")
        start_ups.append(start_up)
        for topic, _module, _name in LATCHED:
            wall, echoed = _run(env, "topic", "echo", topic, "--once", "--timeout", "30")
            echoes.append(wall)
            beyond.append(wall - start_up)
            echo_ok += echoed.returncode == 0 and "bench" in echoed.stdout and \
                wall - start_up <= ECHO_BOUND_S and nothing.returncode == 2
        wall, listed = _run(env, "topic", "list")
        lists.append(wall)
        list_ok += listed.returncode == 0 and expected <= set(listed.stdout.split())
    return [f"start-up alone (baseline)   : {_figures(start_ups)}",
            f"echo --once, latched        : {echo_ok}/{len(echoes)} within {ECHO_BOUND_S:g} s beyond start-up; "
            f"wall {_figures(echoes)}; beyond start-up {_figures(beyond)}; "
            f"ratio p50 echo / start-up {statistics.median(echoes) / statistics.median(start_ups):.2f}x",
            f"topic list                  : {list_ok}/{len(lists)} complete ({len(expected)} topics); "
            f"wall {_figures(lists)}"]


@benchmark("topic_tools")
def topic_tools(quick: bool) -> list[str]:
    tries = 3 if quick else 20
    env = _environment()
    publishers = [[sys.executable, "-c", PUBLISHER, topic, module, name, str(i), str(VOLATILE_PER_PUBLISHER)]
                  for i, (topic, module, name) in enumerate(LATCHED)]
    expected = {topic for topic, *_ in LATCHED} | {f"/bench/p{i}/topic_{j:02d}" for i in range(len(LATCHED))
                                                   for j in range(VOLATILE_PER_PUBLISHER)}
    lines = [f"{tries} tries, {len(LATCHED)} publisher processes, load average {os.getloadavg()[0]:.1f} at the start"]
    with _processes(publishers, env, ready=True):
        for burners in (0, 2):
            with _processes([[sys.executable, "-c", "while True: pass"]] * burners, env, ready=False):
                lines.append(f"-- beside {burners} CPU burners (load average {os.getloadavg()[0]:.1f})")
                lines += _phase(env, tries, expected)
    return lines
