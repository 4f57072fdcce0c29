"""The plant node's messages (:mod:`hex_control.ros.nodes.plant`): its state streams out (clock,
wrench, telemetry batches, strut states, debug streams), pass results and scans out, and its
inputs converted to the core's plain values."""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PointStamped, WrenchStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from hex_control.grinding.part_quality import part_quality
from hex_control.plant.pass_monitor import PassReport, ScheduledPass
from hex_control.ros.infra.diagnostics import CLOCK_QOS
from hex_control.ros.infra.interfaces import STREAM, TELEMETRY, part_quality_message, stamp_s, time_msg
from hex_control_msgs.msg import ForceTrajectory, PassResult, PlantTelemetry

STATUS = {"completed": PassResult.COMPLETED, "aborted": PassResult.ABORTED,
          "faulted": PassResult.FAULTED}


class NodeEvents:
    """The core's counters and faults (plant.core.Events) to a node's /diagnostics, its
    lines to the node's log."""

    def __init__(self, logger, diagnostics):
        self.logger = logger
        self.count, self.fault, self.clear = diagnostics.count, diagnostics.fault, diagnostics.clear

    def log(self, level: str, text: str) -> None:
        if level == "info":  # one call site per severity: rclpy's logger holds each site to one
            self.logger.info(text)
        elif level == "warning":  # a flood of refusals says so once a second
            self.logger.warning(text, throttle_duration_sec=1.0)
        else:
            self.logger.error(text, throttle_duration_sec=1.0)


def stamp_ns(stamp) -> int | None:
    """A header stamp in ns, None if its nanoseconds are out of range (not a stamp)."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec if 0 <= stamp.nanosec < 1_000_000_000 else None


def announced_pass(msg: ForceTrajectory) -> ScheduledPass:
    """The pass a force trajectory announces; ValueError if malformed."""
    return ScheduledPass.from_trajectory(
        msg.job_id, msg.pass_index, grind_start_s=stamp_s(msg.header.stamp), path_start_s=msg.path_start_s,
        path_end_s=msg.path_end_s, time_s=msg.time_from_start_s, force_n=msg.normal_force_n, x_mm=msg.x_mm,
        planned_cut_depth_mm=msg.planned_cut_depth_mm)


def pass_result_message(report: PassReport, end_zone_mm: float, time_s: float) -> PassResult:
    m = report.measurement
    end_zone_mm = min(end_zone_mm, m.contour_after.length_mm / 2)
    result = PassResult(job_id=m.job_id, pass_index=m.pass_index, status=STATUS[report.status],
                        reason=report.reason, measured_cut_depth_mm=m.measured_cut_depth_mm,
                        removed_volume_mm3=m.removed_volume_mm3, duration_s=report.duration_s,
                        mean_normal_force_n=m.mean_normal_force_n, peak_normal_force_n=m.peak_normal_force_n,
                        feed_speed_mm_s=m.mean_feed_mm_s, specific_energy_j_mm3=m.specific_energy_j_mm3,
                        cut_depth_coefficient=(m.measured_cut_depth_mm * m.mean_feed_mm_s / m.mean_normal_force_n
                                               if m.mean_normal_force_n > 0 else 0.0),
                        burn_detected=m.burn_detected, stall_detected=m.stall_detected,
                        part_quality=part_quality_message(part_quality(m.contour_after, end_zone_mm), end_zone_mm))
    result.header.stamp = time_msg(time_s)
    return result


class PlantStreams:
    """The plant's state out: /clock every ``clock_period_s`` of sim time, the wrench every
    period, telemetry batched per ``telemetry_period_s`` (while subscribed), strut states
    (while subscribed) and, with ``debug_streams``, the true wrench, deflection and centre.

    Per period only what must go: one wrench message, filled anew (a message built from
    scratch cost more than publishing it); whether anyone subscribes is asked once a batch
    (telemetry) or once a /clock period (strut states), not every period."""

    def __init__(self, node, strut_names: list[str], period_s: float, clock_period_s: float,
                 *, telemetry_period_s: float, debug_streams: bool, grinding: bool):
        self.strut_names, self.period_s, self.debug_streams = strut_names, period_s, debug_streams
        self.clock_period_s, self.telemetry_period_s = clock_period_s, telemetry_period_s
        self.next_clock_s = 0.0
        # (time s, measured N, true N, table mm, deflection mm, x mm, H mm, table command mm, lengths m)
        self.telemetry = []
        self.clock = node.create_publisher(Clock, "clock", CLOCK_QOS)  # /clock, or the cell's under its namespace
        self.wrench = node.create_publisher(WrenchStamped, "plant/wrench", 100)
        # transient-local: a late joiner (a logger, a test) still gets the last 1000 states
        self.truth = node.create_publisher(WrenchStamped, "plant/true_wrench", QoSProfile(
            depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.struts = node.create_publisher(JointState, "plant/strut_states", 100)
        self.deflection = node.create_publisher(Float64, "plant/deflection", 100)
        self.centre = node.create_publisher(PointStamped, "plant/tool_centre", STREAM) if grinding else None
        # kept (transient-local, the last 100 batches): a late observer still learns where the plant holds
        self.telemetry_publisher = node.create_publisher(PlantTelemetry, "plant/telemetry", TELEMETRY)
        self._wrench = WrenchStamped()
        self._wrench.header.frame_id = "tool"
        self._telemetry_subscribed = False  # asked as each batch begins
        self._strut_subscribers = 0  # asked with each /clock message

    def measurement(self, time_s: float, measured_force_n: float) -> None:
        """/clock when due, then the wrench the controller answers."""
        stamp = time_msg(time_s)
        if time_s >= self.next_clock_s - 1e-9:
            self.clock.publish(Clock(clock=stamp))
            self.next_clock_s = (math.floor(time_s / self.clock_period_s + 1e-6) + 1) * self.clock_period_s
            self._strut_subscribers = self.struts.get_subscription_count()
        wrench = self._wrench
        wrench.header.stamp = stamp
        wrench.wrench.force.z = float(measured_force_n)
        self.wrench.publish(wrench)

    def state(self, state) -> None:
        """The period's telemetry, strut states and (``debug_streams``) the rest."""
        self.record(state)
        stamp = time_msg(state.time_s)
        if self.debug_streams:
            truth = WrenchStamped()
            truth.header.stamp, truth.header.frame_id = stamp, "tool"
            truth.wrench.force.z = state.force_n
            self.truth.publish(truth)
        if state.strut_lengths_m is not None:
            if self._strut_subscribers:
                joints = JointState(name=self.strut_names, position=state.strut_lengths_m.tolist(),
                                    velocity=state.strut_speeds_m_s.tolist())
                joints.header.stamp = stamp
                self.struts.publish(joints)
            if self.debug_streams:
                self.deflection.publish(Float64(data=state.deflection_mm))
        if state.centre_mm is not None and self.debug_streams:
            centre = PointStamped()
            centre.header.stamp, centre.header.frame_id = stamp, "bead"
            centre.point.x, centre.point.z = state.centre_mm
            self.centre.publish(centre)

    def hold(self, state) -> None:
        """Standing still: the state as a telemetry batch of its own, and the clock."""
        self.record(state, always=True)
        self.flush()
        self.clock.publish(Clock(clock=time_msg(state.time_s)))

    def record(self, state, always: bool = False) -> None:
        if not self.telemetry:  # a batch begins: is anyone listening?
            self._telemetry_subscribed = self.telemetry_publisher.get_subscription_count() > 0
        if not (always or self._telemetry_subscribed):
            return
        if self.telemetry and self.telemetry[-1][0] == state.time_s:
            return  # the same state sent again (lock-step start-up)
        centre = state.centre_mm or (math.nan, math.nan)
        self.telemetry.append((state.time_s, state.measured_force_n, state.force_n, state.table_position_mm,
                               state.deflection_mm, *centre, state.table_command_mm, state.strut_lengths_m))
        if len(self.telemetry) * self.period_s >= self.telemetry_period_s - 1e-9:
            self.flush()

    def flush(self) -> None:
        if not self.telemetry:
            return
        samples, self.telemetry = self.telemetry, []
        columns = list(zip(*samples))
        msg = PlantTelemetry(strut_names=self.strut_names, time_s=list(columns[0]), measured_force_n=list(columns[1]),
                             true_force_n=list(columns[2]), table_position_mm=list(columns[3]),
                             deflection_mm=list(columns[4]), centre_x_mm=list(columns[5]),
                             centre_height_mm=list(columns[6]), table_command_mm=list(columns[7]))
        if all(lengths is not None for lengths in columns[8]):
            msg.strut_lengths_m = np.concatenate(columns[8]).tolist()
        msg.header.stamp = time_msg(samples[-1][0])
        self.telemetry_publisher.publish(msg)
