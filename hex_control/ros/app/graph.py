"""The whole node graph as processes, without ros2 launch (DESIGN.md section 4).

``graph_nodes`` lists every node of the grinding hierarchy with its command line (the
shipped configuration, sim time from the plant); ``NodeGraph`` starts them as separate
processes, each logging to its own file, and can stop, kill or restart one (the fault
tests do). ``placement`` puts nodes on another host: a command prefix and environment per
node, e.g. ``ip netns exec hexA`` with that host's ``ROS_STATIC_PEERS`` (scripts/two_hosts.sh).
The same command lines work with the console scripts (``hex-plant`` ...) or
``ros2 run hex_control plant`` in a full ROS 2 install.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from hex_control.config import config_file, node_parameters
from hex_control.grinding.run_files import validated_namespace
from hex_control.ros.app.node_forks import ForkedNode, NodeForks

SIM_TIME = ["-p", "use_sim_time:=true"]  # only where a node reads the clock: the rest run on stamps and wall timers
#: the nodes that belong next to the hardware; the rest (planners, predictors) can run on a cell computer
MACHINE_SIDE = ("plant", "kinematics", "input_shaper", "force_controller")
#: (topic, publishing node, subscribing node) of the volatile streams a pass runs on: a
#: sample sent before its edge has matched is lost, so a job starts once all are there. A
#: pass's tool path and trajectories are latched (handed over whole), so they need no wait.
STREAM_EDGES = (("plant/wrench", "plant", "force_controller"),
                ("plant/force_axis_command", "force_controller", "plant"))
#: DDS participant ids a node restarted after a crash takes, one after another. Every
#: process's participant is id 0 on the first free ports (7410 + 250 domain + 2n): a node
#: started again after it was killed takes its dead predecessor's, which the other
#: participants still hold until its lease ends. A sequence planner stopped in a pass, killed
#: and restarted so heard nothing from the graph in 4 of 5 tries, in none of 4 with an id of
#: its own (docs/known_problems.md). Below 32: under LOCALHOST discovery a
#: participant announces itself to ids 0..31 only; from the top, clear of the lowest ports
#: the graph's own participants take.
RESTART_PARTICIPANT_IDS = range(31, 19, -1)


def missing_stream_edges(node) -> list[str]:
    """The STREAM_EDGES that ``node`` (any node in the graph) does not yet see."""
    missing = []
    for topic, publisher, subscriber in STREAM_EDGES:
        publishers = {info.node_name for info in node.get_publishers_info_by_topic(topic)}
        subscribers = {info.node_name for info in node.get_subscriptions_info_by_topic(topic)}
        if publisher not in publishers or subscriber not in subscribers:
            missing.append(f"{publisher} -> {topic} -> {subscriber}")
    return missing


@dataclass(frozen=True)
class NodeSpec:
    name: str
    module: str  # hex_control.ros.nodes.<module>
    arguments: tuple[str, ...]  # after --ros-args

    @property
    def module_path(self) -> str:
        return f"hex_control.ros.nodes.{self.module}"

    def command(self) -> list[str]:
        # -P: not the working directory's hex_control (a checkout there would shadow the
        # installed one: a demo run from another clone started that clone's nodes)
        return [sys.executable, "-P", "-m", self.module_path, "--ros-args", *self.arguments]


def graph_nodes(job_dir: Path, seed: int = 0, *, mode: str = "lockstep", plant_overrides: dict | None = None,
                machine_file: str | None = None, real_time_factor: float = 1.0, namespace: str = "") -> list[NodeSpec]:
    """The grinding hierarchy with the shipped configuration: plant (``mode``, process
    variation seeded by ``seed``), kinematics, input shaper, force controller (answering
    every measurement), pass planner, sequence planner (job log in ``job_dir``), the
    pass-rate load predictor, the robot state publisher (robot description, joint states, TF)
    and, when the force controller feeds its prediction forward (``feed_forward_mm_per_n`` > 0),
    the control-rate load predictor.

    Every name in the graph is relative, so a ``namespace`` (e.g. ``/cell2``) holds one
    whole cell, its sim clock included (``/cell2/clock``: /clock remapped to the
    namespace's), beside others in the same domain."""
    namespace = validated_namespace(namespace)
    machine = ["-p", f"machine_file:={machine_file}"] if machine_file else []
    plant = ["--params-file", str(config_file("plant.yaml")), "-p", f"mode:={mode}", "-p", f"seed:={seed}",
             "-p", f"real_time_factor:={float(real_time_factor)}", *machine]
    for name, value in (plant_overrides or {}).items():
        plant += ["-p", f"{name}:={value}"]
    controller = config_file("force_controller.yaml")
    nodes = [
        NodeSpec("plant", "plant", tuple(plant)),
        NodeSpec("kinematics", "kinematics", tuple(machine)),
        NodeSpec("input_shaper", "input_shaper", ()),
        NodeSpec("force_controller", "force_controller", ("--params-file", str(controller), "-p",
                                                           "trigger:=measurement")),
        NodeSpec("pass_planner", "pass_planner", (*SIM_TIME, *machine)),
        NodeSpec("sequence_planner", "sequence_planner", ("-p", f"job_dir:={job_dir}")),
        # the URDF, /joint_states and /tf from the plant's telemetry (only observes)
        NodeSpec("robot_state", "robot_state", tuple(machine)),
    ]
    # the first __ns remapping on a command line wins: the predictors, under the cell's
    # <namespace>/load_predictor, get theirs alone; the sim clock is the cell's, named
    # absolutely since the predictors sit a level below it
    clock = ("-r", f"/clock:={namespace}/clock")
    cell = clock + (("-r", f"__ns:={namespace}") if namespace else ())
    nodes = [NodeSpec(n.name, n.module, cell + n.arguments) for n in nodes]
    nodes.append(NodeSpec("load_predictor_pass", "load_predictor", clock + predictor_arguments("pass", namespace)))
    if node_parameters("force_controller.yaml", "force_controller").get("feed_forward_mm_per_n", 0.0):
        # a control-rate prediction nobody uses costs 200 Hz
        nodes.append(NodeSpec("load_predictor_force", "load_predictor",
                              clock + predictor_arguments("force", namespace)))
    return nodes


def predictor_arguments(name: str, namespace: str = "") -> tuple[str, ...]:
    """A load predictor's arguments: node ``name`` under ``<namespace>/load_predictor`` (its
    prediction on ``<namespace>/load_predictor/<name>/prediction``), the shipped parameter
    file's section ``/**/load_predictor/<name>``, which names its input relative to the cell
    (``input_namespace: parent``)."""
    return ("-r", f"__ns:={namespace}/load_predictor", "-r", f"__node:={name}", "--params-file",
            str(config_file("load_predictor.yaml")))


def stop_hung(process: subprocess.Popen, timeout_s: float) -> int:
    """Wait ``timeout_s`` for a process told to stop; then SIGUSR1 (a node dumps every
    thread's traceback, :func:`hex_control.ros.infra.runtime.init`), SIGABRT (with
    PYTHONFAULTHANDLER set, any Python process dumps what it can) and SIGKILL. Exit code."""
    try:
        return process.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGUSR1)
    try:
        return process.wait(timeout=1.0)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGABRT)
    try:
        return process.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        process.kill()
        return process.wait()


class NodeGraph:
    """Start, stop, kill and restart the graph's processes; logs in ``log_dir``."""

    def __init__(self, nodes: list[NodeSpec], log_dir: Path, env: dict | None = None,
                 placement: dict[str, tuple[list[str], dict]] | None = None):
        self.specs = {spec.name: spec for spec in nodes}
        self.placement = placement or {}
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = dict(os.environ if env is None else env)
        self.env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.env["PYTHONUNBUFFERED"] = "1"
        self.env["PYTHONFAULTHANDLER"] = "1"  # SIGABRT leaves every thread's traceback in the log
        self.processes: dict[str, subprocess.Popen | ForkedNode] = {}
        self.starts: dict[str, int] = {}
        self.restarts = 0  # of nodes after a crash: the next one's participant id
        self._crashed: set[str] = set()  # killed: their participants left without a word
        # nodes forked from one process that imported them (node_forks.py): a graph start pays
        # no imports but the first in a process; HEX_NODE_FORKS=0 starts each from its command line
        self.forks_enabled = self.env.get("HEX_NODE_FORKS", "1") != "0"
        self.forks: NodeForks | None = None

    def start(self, name: str | None = None) -> None:
        for spec in ([self.specs[name]] if name else self.specs.values()):
            count = self.starts.get(spec.name, 0)
            log_path = self.log_dir / f"{spec.name}{'-' + str(count) if count else ''}.log"
            prefix, extra = self.placement.get(spec.name, ([], {}))
            previous = self.processes.get(spec.name)
            if spec.name in self._crashed or (previous is not None and previous.poll() is not None):
                self._crashed.discard(spec.name)
                extra = {**extra, **self._restart_profile(log_path, {**self.env, **extra})}
            if self.forks_enabled and not prefix:  # forked from the server that holds the imports
                if self.forks is None or not self.forks.running:
                    if self.forks is not None:
                        self.forks.release()
                    self.forks = NodeForks.shared(sorted({s.module_path for s in self.specs.values()}), self.env)
                self.processes[spec.name] = self.forks.start(spec.module_path, ["--ros-args", *spec.arguments],
                                                             {**self.env, **extra}, log_path)
            else:
                with open(log_path, "w") as log:
                    self.processes[spec.name] = subprocess.Popen(
                        [*prefix, *spec.command()], env={**self.env, **extra}, stdout=log, stderr=subprocess.STDOUT,
                        start_new_session=True)
            self.starts[spec.name] = count + 1

    def _restart_profile(self, log_path: Path, env: dict) -> dict[str, str]:
        """The environment giving a node restarted after a crash a DDS participant id of its
        own (see RESTART_PARTICIPANT_IDS); none where the node has a Fast DDS profile of the
        user's."""
        if env.get("FASTDDS_DEFAULT_PROFILES_FILE"):
            return {}
        participant_id = RESTART_PARTICIPANT_IDS[self.restarts % len(RESTART_PARTICIPANT_IDS)]
        self.restarts += 1
        profile = log_path.with_suffix(".fastdds.xml").resolve()
        profile.write_text(
            '<?xml version="1.0" encoding="UTF-8"?>\n<dds xmlns="http://www.eprosima.com"><profiles>\n'
            '  <participant profile_name="restarted_node" is_default_profile="true">\n'
            f'    <rtps><participantID>{participant_id}</participantID></rtps>\n'
            '  </participant>\n</profiles></dds>\n')
        return {"FASTDDS_DEFAULT_PROFILES_FILE": str(profile)}

    def kill(self, name: str) -> None:
        """SIGKILL: the node gets no chance to clean up (a crash)."""
        process = self.processes.pop(name)
        process.kill()
        process.wait()
        self._crashed.add(name)

    def stop(self, name: str | None = None, timeout_s: float = 10.0) -> dict[str, int]:
        """SIGINT, then to those still running ``timeout_s`` later SIGABRT (a hung node writes
        its threads' tracebacks into its log) and SIGKILL; the exit codes."""
        names = [name] if name else list(self.processes)
        for n in names:
            if self.processes[n].poll() is None:
                self.processes[n].send_signal(signal.SIGINT)
        codes, deadline = {}, time.monotonic() + timeout_s
        for n in names:
            codes[n] = stop_hung(self.processes.pop(n), max(deadline - time.monotonic(), 0.0))
        if not self.processes and self.forks is not None:  # the server stays for the process's next graph
            self.forks.release()
            self.forks = None
        return codes

    def dump_tracebacks(self, timeout_s: float = 5.0) -> list[str]:
        """SIGUSR1 to every running node (each writes its threads' tracebacks into its log,
        :func:`hex_control.ros.infra.runtime.init`); waits until every log has grown by them, at
        most ``timeout_s``. The names of the nodes whose logs did not grow. A node still
        importing, before its handler is installed, dies of the signal: for a graph about to be
        stopped."""
        sizes = {name: self.log_path(name).stat().st_size for name, process in self.processes.items()
                 if process.poll() is None}
        for name in sizes:
            self.processes[name].send_signal(signal.SIGUSR1)
        end = time.monotonic() + timeout_s
        while (silent := [name for name, size in sizes.items() if self.log_path(name).stat().st_size == size]) \
                and time.monotonic() < end:
            time.sleep(0.05)
        return silent

    def dead(self) -> dict[str, int]:
        """Processes that have exited on their own, with their exit codes."""
        return {name: p.returncode for name, p in self.processes.items() if p.poll() is not None}

    def log_path(self, name: str) -> Path:
        """The log of the node's latest start."""
        count = self.starts.get(name, 1) - 1
        return self.log_dir / f"{name}{'-' + str(count) if count else ''}.log"

    def log_tail(self, name: str, lines: int = 20) -> str:
        path = self.log_path(name)
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:]) if path.exists() else ""
