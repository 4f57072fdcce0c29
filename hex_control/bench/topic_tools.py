"""``hexctl topic echo`` of latched topics and ``hexctl topic list`` as a user runs them, 20
tries each (issue 40: every echo within 2 s, every list complete), idle and beside two CPU
burners (``python3 -c "while True: pass"``): through the hexctl daemon (the verbs' default
once it runs) and, as the baseline in the same process, from each verb's own participant
(HEXCTL_NO_DAEMON=1, a quarter of the tries: its list waits at least 4.5 s).

The graph: three publisher processes (three DDS participants, as three nodes of the cell),
each with one of the cell's latched topics and eight volatile ones. Each try runs, as
separate processes: an echo ``--once`` of each latched topic, and ``topic list``. Each
process times its start-up (Python, hexctl, rclpy and the verb's modules imported) and the
verb itself (from its call to its return: discovery, the message, shut-down) apart: at a
load of 20 on 2 cores, start-up alone varied from 1.4 to 7 s between processes, and a
wall time less a start-up measured beside it said nothing. An echo succeeds when it printed
the message and the verb took at most ECHO_BOUND_S; a list when it named every topic.
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
PUBLISHER = [sys.executable, "-m", "hex_control.ros.tools.latched_publisher"]
HEXCTL = str(Path(sys.executable).parent / "hexctl")
#: hexctl, timed: its start-up and the verb apart, on stderr's last line
TIMED = [sys.executable, "-m", "hex_control.ros.tools.timed_hexctl"]


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


def timed_hexctl(env, *arguments) -> tuple[float, float, subprocess.CompletedProcess]:
    """(start-up s, the verb's own s, the result) of ``hexctl arguments`` (test_ros_cli uses it)."""
    result = subprocess.run([*TIMED, *arguments], env=env, capture_output=True, text=True,
                            timeout=120)
    start_up, verb = (float(v) for v in result.stderr.strip().splitlines()[-1].split()[1:3])
    return start_up, verb, result


def _figures(values) -> str:
    return f"p50 {statistics.median(values):.2f} s, max {max(values):.2f} s"


def _phase(env, tries: int, expected: set[str]) -> tuple[list[str], float, float]:
    """(the lines, p50 of the echoes s, p50 of the lists s)."""
    start_ups, echoes, lists = [], [], []
    echo_ok = list_ok = 0
    for _ in range(tries):
        for topic, _module, _name in LATCHED:
            start_up, verb, echoed = timed_hexctl(env, "topic", "echo", topic, "--once", "--timeout", "30")
            start_ups.append(start_up)
            echoes.append(verb)
            echo_ok += echoed.returncode == 0 and "bench" in echoed.stdout and verb <= ECHO_BOUND_S
        start_up, verb, listed = timed_hexctl(env, "topic", "list")
        start_ups.append(start_up)
        lists.append(verb)
        list_ok += listed.returncode == 0 and expected <= set(listed.stdout.split())
    return [f"start-up (imports)          : {_figures(start_ups)}",
            f"echo --once, latched        : {echo_ok}/{len(echoes)} within {ECHO_BOUND_S:g} s; {_figures(echoes)}",
            f"topic list                  : {list_ok}/{len(lists)} complete ({len(expected)} topics); "
            f"{_figures(lists)}"], statistics.median(echoes), statistics.median(lists)


@benchmark("topic_tools")
def topic_tools(quick: bool) -> list[str]:
    tries = 3 if quick else 20
    env = _environment()
    direct = env | {"HEXCTL_NO_DAEMON": "1"}
    publishers = [[*PUBLISHER, topic, module, name, str(i), str(VOLATILE_PER_PUBLISHER)]
                  for i, (topic, module, name) in enumerate(LATCHED)]
    expected = {topic for topic, *_ in LATCHED} | {f"/bench/p{i}/topic_{j:02d}" for i in range(len(LATCHED))
                                                   for j in range(VOLATILE_PER_PUBLISHER)}
    lines = [f"{len(LATCHED)} publisher processes, load average {os.getloadavg()[0]:.1f} at the start"]
    with _processes(publishers, env, ready=True):
        subprocess.run([HEXCTL, "daemon", "start"], env=env, capture_output=True, timeout=120, check=True)
        try:
            end = time.monotonic() + 60.0  # the daemon has discovered the publishers
            while not expected <= set(timed_hexctl(env, "topic", "list")[2].stdout.split()) and time.monotonic() < end:
                time.sleep(0.5)
            for burners in (0, 2):
                with _processes([[sys.executable, "-c", "while True: pass"]] * burners, env, ready=False):
                    medians = []
                    for what, environment, count in (("hexctl daemon", env, tries),
                                                     ("own participant", direct, max(tries // 4, 1))):
                        lines.append(f"-- {what}, {count} tries, beside {burners} CPU burners "
                                     f"(load average {os.getloadavg()[0]:.1f})")
                        phase, echo_s, list_s = _phase(environment, count, expected)
                        lines += phase
                        medians.append((echo_s, list_s))
                    (echo_d, list_d), (echo_o, list_o) = medians
                    lines.append(f"ratio p50 own participant / daemon: echo {echo_o / echo_d:.1f}x, "
                                 f"list {list_o / list_d:.1f}x")
        finally:
            subprocess.run([HEXCTL, "daemon", "stop"], env=env, capture_output=True, timeout=120)
    return lines
