"""``hexctl topic echo`` of latched topics and ``hexctl topic list`` as a user runs them, 20
tries each (issue 40: every echo within 2 s, every list complete), idle and beside two CPU
burners (``python3 -c "while True: pass"``): through the hexctl daemon (the verbs' default
once it runs) and, as the baseline in the same process, from each verb's own participant
(HEXCTL_NO_DAEMON=1, a quarter of the tries: its list waits at least 4.5 s).

The graph: three publisher processes (three DDS participants, as three nodes of the cell),
each with one of the cell's latched topics and eight volatile ones. Each try runs, as
separate processes: an echo ``--once`` of each latched topic, and ``topic list``. An echo
succeeds when it printed the message and its whole process (Python's start, hexctl's
imports, the verb, the exit) took at most ECHO_BOUND_S; a list when it named every topic.
Each process also times its start-up (hexctl's modules imported) and the verb apart.

Two more cases, per try a new publisher process with a latched topic of its own: its first
echo once ``topic list`` names it (the daemon subscribes to a latched topic when its graph
shows it, before anyone asks: the contract), and, for information, an echo started at
once when the publisher is up (then the daemon must discover the new participant first,
which Fast DDS does up to 3 s late about one time in four: known_problems.md).

``TOPIC_TOOLS_BURNERS=0,2`` (the default) chooses the phases by their number of burners.
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

#: issue 40: an echo of a latched topic returns within this (s), the whole hexctl process
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
BURNER = [sys.executable, "-c", "while True: pass"]


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


def timed_hexctl(env, *arguments) -> tuple[float, float, float, subprocess.CompletedProcess]:
    """(the whole process s, its start-up s, the verb's own s, the result) of ``hexctl
    arguments`` (test_ros_cli uses it)."""
    start = time.monotonic()
    result = subprocess.run([*TIMED, *arguments], env=env, capture_output=True, text=True, timeout=120)
    wall = time.monotonic() - start
    start_up, verb = (float(v) for v in result.stderr.strip().splitlines()[-1].split()[1:3])
    return wall, start_up, verb, result


def _figures(values) -> str:
    return f"p50 {statistics.median(values):.2f} s, max {max(values):.2f} s"


def _echo_line(what: str, echoes) -> str:
    """``echoes``: (whole s, start-up s, verb s, printed the message)."""
    ok = sum(printed and wall <= ECHO_BOUND_S for wall, _s, _v, printed in echoes)
    return (f"{what:28s}: {ok}/{len(echoes)} within {ECHO_BOUND_S:g} s; whole {_figures([e[0] for e in echoes])}; "
            f"verb {_figures([e[2] for e in echoes])}")


def _phase(env, tries: int, expected: set[str]) -> tuple[list[str], float, float]:
    """(the lines, p50 of the echoes' whole processes s, p50 of the lists' s)."""
    start_ups, echoes, lists = [], [], []
    list_ok = 0
    for _ in range(tries):
        for topic, _module, _name in LATCHED:
            wall, start_up, verb, echoed = timed_hexctl(env, "topic", "echo", topic, "--once", "--timeout", "30")
            start_ups.append(start_up)
            echoes.append((wall, start_up, verb, echoed.returncode == 0 and "bench" in echoed.stdout))
        wall, start_up, verb, listed = timed_hexctl(env, "topic", "list")
        start_ups.append(start_up)
        lists.append(wall)
        list_ok += listed.returncode == 0 and expected <= set(listed.stdout.split())
    return [f"start-up (hexctl imported)  : {_figures(start_ups)}",
            _echo_line("echo --once, latched", echoes),
            f"topic list                  : {list_ok}/{len(lists)} complete ({len(expected)} topics); "
            f"whole {_figures(lists)}"], statistics.median(e[0] for e in echoes), statistics.median(lists)


def _new_topics(env, tries: int, tag: str) -> list[str]:
    """The first echo of a latched topic new to the daemon, ``tries`` times each way."""
    listed_first, at_once = [], []
    for i in range(tries):
        for way, into in (("listed", listed_first), ("at_once", at_once)):
            if way == "at_once" and i >= max(tries // 4, 1):
                continue
            topic = f"/bench/new_{tag}_{way}_{i}"
            with _processes([[*PUBLISHER, topic, "std_msgs.msg", "String", f"new_{tag}_{way}_{i}", "0"]], env,
                            ready=True):
                if way == "listed":
                    end = time.monotonic() + 60.0
                    while topic not in timed_hexctl(env, "topic", "list")[3].stdout.split() \
                            and time.monotonic() < end:
                        pass
                wall, start_up, verb, echoed = timed_hexctl(env, "topic", "echo", topic, "--once", "--timeout",
                                                            "30")
                into.append((wall, start_up, verb, echoed.returncode == 0 and "bench" in echoed.stdout))
    return [_echo_line("new topic, once listed", listed_first),
            _echo_line("new topic, publisher just up", at_once) + " (not the contract: discovery)"]


@benchmark("topic_tools")
def topic_tools(quick: bool) -> list[str]:
    tries = 3 if quick else 20
    phases = [int(b) for b in os.environ.get("TOPIC_TOOLS_BURNERS", "0,2").split(",")]
    env = _environment()
    direct = env | {"HEXCTL_NO_DAEMON": "1"}
    publishers = [[*PUBLISHER, topic, module, name, str(i), str(VOLATILE_PER_PUBLISHER)]
                  for i, (topic, module, name) in enumerate(LATCHED)]
    expected = {topic for topic, *_ in LATCHED} | {f"/bench/p{i}/topic_{j:02d}" for i in range(len(LATCHED))
                                                   for j in range(VOLATILE_PER_PUBLISHER)}
    lines = [f"{len(LATCHED)} publisher processes, load average {os.getloadavg()[0]:.1f} at the start; "
             f"'whole': the hexctl process from its start to its exit"]
    with _processes(publishers, env, ready=True):
        subprocess.run([HEXCTL, "daemon", "start"], env=env, capture_output=True, timeout=120, check=True)
        try:
            end = time.monotonic() + 60.0  # the daemon has discovered the publishers
            while not expected <= set(timed_hexctl(env, "topic", "list")[3].stdout.split()) and time.monotonic() < end:
                time.sleep(0.5)
            for burners in phases:
                with _processes([BURNER] * burners, env, ready=False):
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
                    lines.append(f"-- hexctl daemon, latched topics new to it, beside {burners} CPU burners "
                                 f"(load average {os.getloadavg()[0]:.1f})")
                    lines += _new_topics(env, tries, f"b{burners}")
        finally:
            subprocess.run([HEXCTL, "daemon", "stop"], env=env, capture_output=True, timeout=120)
    return lines
