"""Node ``plant``: the simulated hardware (:class:`hex_control.plant.simulator.PlantSimulator`)
and the source of ``/clock`` -- every other node runs on sim time (use_sim_time:=true).

Modes (``mode``):
- ``lockstep``: after publishing the state at time t the plant waits for the force-axis
  command that answers it, then advances one control period. Deterministic for a seed when
  the controller answers every measurement (force_controller trigger:=measurement); as fast
  as the graph allows. Until the first command arrives the state is re-sent every
  ``lockstep_timeout_s``; after that a timeout advances with the held command and is counted.
- ``realtime``: advances every control period of wall time divided by ``real_time_factor``
  with the latest command; a period whose measurement went unanswered is a missed cycle.
With ``end_time_s`` > 0 the plant stops advancing there (a run of fixed length). Timing
counts from the first answered measurement; ``report_file`` also gets it as JSON every second.
Command latency (measurement out to command in, wall time) and missed cycles are reported
in ``/diagnostics``.

Topics:
    /clock                      rosgraph_msgs/Clock          out  sim time
    /plant/wrench               geometry_msgs/WrenchStamped  out  sensor force, force.z (N)
    /plant/true_wrench          geometry_msgs/WrenchStamped  out  the true normal force (N),
                                                                  transient-local, last 1000
    /plant/strut_states         sensor_msgs/JointState       out  lengths (m), speeds (m/s)
    /plant/deflection           std_msgs/Float64             out  structural-mode deflection (mm)
    /plant/force_axis_command   std_msgs/Float64             in   table position command (mm)
    /plant/strut_command        sensor_msgs/JointState       in   strut lengths (m)
"""

from __future__ import annotations

import json
import math
import os
import time

from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.runtime import run_node
from hex_control.plant.force_table import ForceTableParameters
from hex_control.plant.loop_timing import LoopTiming
from hex_control.plant.machine import MachineParameters
from hex_control.plant.simulator import PlantSimulator

TABLE_PARAMETERS = ("stiction_n", "runout_mm", "disk_frequency_hz", "disk_slowdown_hz_per_n", "sensor_noise_n",
                    "sensor_cutoff_hz", "contact_mm", "rotational_stiffness_n_mm_rad", "disk_radius_mm",
                    "position_loop")
MACHINE_PARAMETERS = ("servo_frequency_hz", "servo_damping", "mode_frequency_hz", "mode_damping")


class PlantNode(Node):
    def __init__(self, **kwargs):
        super().__init__("plant", **kwargs)
        read_only = ParameterDescriptor(read_only=True)
        table_defaults, machine_defaults = ForceTableParameters(), MachineParameters()
        for name, default in (("mode", "lockstep"), ("control_period_s", 0.005), ("internal_step_s", 0.001),
                              ("real_time_factor", 1.0), ("lockstep_timeout_s", 1.0), ("seed", 0),
                              ("end_time_s", 0.0), ("report_file", ""),
                              ("table_start_mm", -1.0), ("strut_names", ["strut_1", "strut_2", "strut_3",
                                                                         "strut_4", "strut_5", "strut_6"]),
                              *((n, getattr(table_defaults, n)) for n in TABLE_PARAMETERS),
                              *((n, getattr(machine_defaults, n)) for n in MACHINE_PARAMETERS)):
            self.declare_parameter(name, default, read_only)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.mode = p("mode")
        if self.mode not in ("lockstep", "realtime"):
            raise ValueError(f"mode must be lockstep or realtime, got {self.mode!r}")
        self.period_s = p("control_period_s")
        self.strut_names = list(p("strut_names"))
        table = ForceTableParameters(**{n: p(n) for n in TABLE_PARAMETERS})
        machine = MachineParameters(struts=len(self.strut_names), participation=1.0 / len(self.strut_names),
                                    **{n: p(n) for n in MACHINE_PARAMETERS})
        steps = round(self.period_s / p("internal_step_s"))
        if steps < 1 or abs(steps * p("internal_step_s") - self.period_s) > 1e-9:
            raise ValueError("control_period_s must be a whole number of internal_step_s")
        self.sim = PlantSimulator(table, machine, p("internal_step_s"), p("seed"), p("table_start_mm"))
        self.command_mm = p("table_start_mm")
        self.timing = LoopTiming()
        self.started = False  # a first command has answered a measurement
        self.loop_start = self.loop_end = None
        self.diagnostics = Diagnostics(self)
        self.clock_publisher = self.create_publisher(Clock, "/clock", 10)
        self.wrench_publisher = self.create_publisher(WrenchStamped, "/plant/wrench", 100)
        # transient-local: a late joiner (a logger, a test) still gets the last 1000 states
        self.truth_publisher = self.create_publisher(WrenchStamped, "/plant/true_wrench", QoSProfile(
            depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.strut_publisher = self.create_publisher(JointState, "/plant/strut_states", 100)
        self.deflection_publisher = self.create_publisher(Float64, "/plant/deflection", 100)
        self.create_subscription(Float64, "/plant/force_axis_command", self._on_force_command, 100)
        self.create_subscription(JointState, "/plant/strut_command", self._on_strut_command, 100)
        if self.mode == "realtime":
            self.create_timer(self.period_s / p("real_time_factor"), self._advance)
        else:
            self.create_timer(p("lockstep_timeout_s") / 4, self._lockstep_watchdog)
        self.create_timer(1.0, self._report)
        self._publish_state()

    # -- inputs ----------------------------------------------------------------------------
    def _on_force_command(self, msg: Float64) -> None:
        if not math.isfinite(msg.data):
            self.diagnostics.count("rejected_force_command")
            return
        self.command_mm = msg.data
        now = time.monotonic()
        answered = self.timing.answered(now)
        if answered and not self.started:
            self.started, self.loop_start = True, now
            self.timing = LoopTiming()  # count from here: startup is not the loop
        if self.mode == "lockstep":
            if answered:
                self._advance()
            else:
                self.diagnostics.count("unsolicited_commands")

    def _on_strut_command(self, msg: JointState) -> None:
        try:
            positions = dict(zip(msg.name, msg.position)) if msg.name else dict(zip(self.strut_names, msg.position))
            self.sim.command_struts([positions[name] for name in self.strut_names])
        except (KeyError, ValueError) as error:
            self.diagnostics.count("rejected_strut_command")
            self.get_logger().warning(f"strut command rejected: {error}", throttle_duration_sec=1.0)

    # -- stepping --------------------------------------------------------------------------
    def _advance(self) -> None:
        end = self.get_parameter("end_time_s").value
        if 0 < end <= self.sim.time_s + 1e-9:
            self.loop_end = self.loop_end or time.monotonic()
            return  # the run is over: hold still
        self.timing.cycle()
        self.sim.advance(self.period_s, self.command_mm)
        self._publish_state()

    def _lockstep_watchdog(self) -> None:
        pending = self.timing.pending_since_s
        if pending is None or time.monotonic() - pending < self.get_parameter("lockstep_timeout_s").value:
            return
        if not self.started:
            self._publish_state()  # nobody answered yet: say it again
            return
        self.diagnostics.count("lockstep_timeouts")
        self._advance()

    def _publish_state(self) -> None:
        state = self.sim.snapshot()
        stamp = Time(nanoseconds=round(state.time_s * 1e9)).to_msg()
        self.clock_publisher.publish(Clock(clock=stamp))
        for publisher, force in ((self.wrench_publisher, state.measured_force_n),
                                 (self.truth_publisher, state.force_n)):
            wrench = WrenchStamped()
            wrench.header.stamp, wrench.header.frame_id = stamp, "tool"
            wrench.wrench.force.z = force
            publisher.publish(wrench)
        if state.strut_lengths_m is not None:
            joints = JointState(name=self.strut_names, position=state.strut_lengths_m.tolist(),
                                velocity=state.strut_speeds_m_s.tolist())
            joints.header.stamp = stamp
            self.strut_publisher.publish(joints)
            self.deflection_publisher.publish(Float64(data=state.deflection_mm))
        self.timing.sent(time.monotonic())

    def _report(self) -> None:
        wall = (self.loop_end or time.monotonic()) - self.loop_start if self.loop_start is not None else math.nan
        p50, p99 = self.timing.latency_percentiles_ms()
        report = {"sim_time_s": self.sim.time_s, "cycles": self.timing.cycles,
                  "loop_rate_hz": self.timing.cycles / wall if wall > 0 else math.nan,
                  "missed_fraction": self.timing.missed_fraction, "latency_p50_ms": p50, "latency_p99_ms": p99}
        for name, value in report.items():
            self.diagnostics.set(name, f"{value:.4g}")
        path = self.get_parameter("report_file").value
        if path:
            with open(path + ".tmp", "w") as stream:
                json.dump(report, stream)
            os.replace(path + ".tmp", path)


def main(args=None) -> int:
    return run_node(PlantNode, args)


if __name__ == "__main__":
    main()
