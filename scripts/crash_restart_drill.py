"""Does the lock-step loop start on a graph that follows a crashed one?

Each cycle starts the whole graph (lock-step plant), waits for the plant's clock to pass
``--sim-s`` simulated seconds, SIGKILLs ``--kill`` nodes (a crash: their Fast DDS
shared-memory files stay behind) and stops the rest. With ``--restart`` the killed nodes
are started again, as the fault drills do, and the graph runs another ``--sim-s`` before
an orderly stop. A cycle whose clock stands still for ``--stall-s`` wall seconds counts as
a hang, and a fresh observer then counts what still flows on the loop's two topics.

    python scripts/crash_restart_drill.py --cycles 12 [--restart] [--kill]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

from hex_control.ros.app.graph import NodeGraph, graph_nodes
from hex_control.ros.infra.interfaces import STREAM
from hex_control_msgs.msg import ForceAxisCommand


@contextmanager
def observer(name: str):
    """(node, executor) in a private context, torn down on exit."""
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()


def plant_clock_reaches(sim_s: float, stall_s: float) -> tuple[bool, float, float]:
    """Spin an observer on /plant/wrench: (reached, last sim time (s), wall time (s))."""
    with observer("drill_observer") as (node, executor):
        latest = {"sim_s": -1.0}
        node.create_subscription(WrenchStamped, "/plant/wrench",
                                 lambda m: latest.update(sim_s=m.header.stamp.sec + m.header.stamp.nanosec * 1e-9),
                                 STREAM)
        start = since = time.monotonic()
        seen = latest["sim_s"]
        while latest["sim_s"] < sim_s:
            executor.spin_once(timeout_sec=0.1)
            if latest["sim_s"] != seen:
                seen, since = latest["sim_s"], time.monotonic()
            elif time.monotonic() - since > stall_s:
                return False, latest["sim_s"], time.monotonic() - start
        return True, latest["sim_s"], time.monotonic() - start


def samples_in(topics: dict, seconds: float) -> dict[str, int]:
    """Messages a fresh observer receives on each topic (name -> type) in ``seconds``."""
    with observer("drill_probe") as (node, executor):
        counts = dict.fromkeys(topics, 0)
        for topic, msg_type in topics.items():
            node.create_subscription(msg_type, topic, lambda _m, t=topic: counts.__setitem__(t, counts[t] + 1),
                                     STREAM)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
        return counts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=10)
    parser.add_argument("--sim-s", type=float, default=3.0, help="simulated seconds a cycle must reach")
    parser.add_argument("--stall-s", type=float, default=45.0, help="wall seconds of a standing clock = hang")
    parser.add_argument("--kill", nargs="*", default=["sequence_planner", "force_controller"],
                        help="nodes to SIGKILL at the end of a cycle (none: every stop is orderly)")
    parser.add_argument("--restart", action="store_true", help="restart the killed nodes and run on")
    args = parser.parse_args()
    hangs = 0
    with tempfile.TemporaryDirectory() as tmp:
        for cycle in range(args.cycles):
            directory = Path(tmp) / f"cycle_{cycle}"
            graph = NodeGraph(graph_nodes(directory / "jobs", seed=cycle), directory / "logs")
            graph.start()
            try:
                reached, sim_s, wall_s = plant_clock_reaches(args.sim_s, args.stall_s)
                if not reached:  # which edge of the loop carries nothing?
                    streams = {"/plant/wrench": WrenchStamped, "/plant/force_axis_command": ForceAxisCommand}
                    print(f"  hung: {samples_in(streams, 5.0)} messages in 5 s", flush=True)
                for name in args.kill:
                    graph.kill(name)
                if args.restart and reached:
                    for name in args.kill:
                        graph.start(name)
                    reached, sim_s, wall = plant_clock_reaches(sim_s + args.sim_s, args.stall_s)
                    wall_s += wall
            finally:
                graph.stop()
            hangs += not reached
            shm_files = sum(1 for n in os.listdir("/dev/shm") if n.startswith("fastdds_"))
            print(f"cycle {cycle + 1}/{args.cycles}: {'ran' if reached else 'HUNG'} to {sim_s:.2f} s sim in "
                  f"{wall_s:.1f} s wall; fastdds files in /dev/shm now {shm_files}", flush=True)
    print(f"{hangs} of {args.cycles} graphs hung")
    return 1 if hangs else 0


if __name__ == "__main__":
    raise SystemExit(main())
