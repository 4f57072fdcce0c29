"""Node force_controller over real topics against a lock-step force-table stand-in."""

import math
import time

import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from hex_control.nodes.force_controller import ForceControllerNode
from hex_control.plant.force_table import ForceTable, ForceTableParameters
from ros_harness import wait_until


class TablePlant:
    """Each command advances the table one control period (5 ms) and publishes the wrench."""

    def __init__(self, ros):
        self.table = ForceTable(ForceTableParameters(stiction_n=0.0, contact_mm=0.0), step_s=0.001)
        self.table.reset(-2.0)
        self.node = ros.node("table_plant")
        self.commands = []
        self.publisher = self.node.create_publisher(WrenchStamped, "/plant/wrench", 100)
        self.node.create_subscription(Float64, "/plant/force_axis_command", self.on_command, 100)
        self.silent = False

    def on_command(self, msg: Float64) -> None:
        self.commands.append(msg.data)
        for _ in range(5):
            self.table.step(msg.data)
        if not self.silent:
            wrench = WrenchStamped()
            wrench.wrench.force.z = self.table.measured_n
            self.publisher.publish(wrench)


@pytest.fixture
def loop(ros):
    plant = TablePlant(ros)
    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("kp_mm_per_n", value=0.0098), Parameter("ki_mm_per_n_s", value=0.48)]))  # ITAE-tuned
    setpoints = ros.node("setpoint_source").create_publisher(Float64, "/force_controller/setpoint", 10)
    ros.wait_for_match(plant.node, "/plant/force_axis_command", publishers=1)
    return plant, controller, setpoints


def hold(setpoints, value, seconds, until=None):
    """Keep publishing the setpoint for ``seconds`` (or, with ``until``, until it holds,
    for at most ``seconds`` -- the loop runs in wall time on a noisy machine)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        setpoints.publish(Float64(data=value))
        if until is not None and until():
            return
        time.sleep(0.05)


def test_tracks_a_force_step_then_the_watchdog_retracts(loop):
    plant, controller, setpoints = loop
    hold(setpoints, 20.0, 10.0, until=lambda: len(plant.commands) > 600)  # 3 s of control
    assert plant.table.force_n == pytest.approx(20.0, abs=1.0)
    assert max(plant.commands) <= 2.0 and min(plant.commands) >= -2.0
    count = len(plant.commands)
    # no more setpoints: stale after 0.5 s, then a ramp to -2 mm over 0.5 s
    wait_until(lambda: plant.commands[-1] == -2.0, 10.0, what="the retracted command")
    assert len(plant.commands) > count + 100 and plant.table.force_n == 0.0
    assert controller.diagnostics.counters["watchdog_trips"] == 1
    restart = len(plant.commands)
    hold(setpoints, 10.0, 10.0, until=lambda: len(plant.commands) > restart + 500)  # fresh again
    assert plant.table.force_n == pytest.approx(10.0, abs=1.0)


def test_stale_measurement_trips_and_nan_is_rejected(ros, loop):
    plant, controller, setpoints = loop
    hold(setpoints, 15.0, 10.0, until=lambda: len(plant.commands) > 300)
    bad = ros.node("bad_sensor").create_publisher(WrenchStamped, "/plant/wrench", 10)
    wrench = WrenchStamped()
    wrench.wrench.force.z = math.nan
    bad.publish(wrench)
    plant.silent = True
    hold(setpoints, 15.0, 10.0, until=lambda: plant.commands[-1] == -2.0)
    assert plant.commands[-1] == -2.0
    assert controller.diagnostics.counters["watchdog_trips"] >= 1
    wait_until(lambda: controller.diagnostics.counters["rejected_measurement"] >= 1, 2.0, what="NaN counted")


def test_negative_stamps_are_refused_not_a_crash(ros):
    """rclpy's Time.from_msg raises on sec < 0: a wrench or a force trajectory stamped before
    the epoch is refused and counted, and the controller answers the next good measurement."""
    from hex_control.nodes.interfaces import LATCHED
    from hex_control_msgs.msg import ForceTrajectory

    controller = ros.add(ForceControllerNode(context=ros.context, parameter_overrides=[
        Parameter("trigger", value="measurement")]))
    node = ros.node("negative_stamps")
    commands = ros.collect(Float64, "/plant/force_axis_command", 100)
    wrenches = node.create_publisher(WrenchStamped, "/plant/wrench", 10)
    trajectories = node.create_publisher(ForceTrajectory, "/grinding/force_trajectory", LATCHED)
    ros.wait_for_match(node, "/plant/wrench", subscribers=1)
    bad_trajectory = ForceTrajectory(time_from_start_s=[0.0, 1.0], normal_force_n=[10.0, 10.0])
    bad_trajectory.header.stamp.sec = -1
    trajectories.publish(bad_trajectory)
    bad_wrench = WrenchStamped()
    bad_wrench.header.stamp.sec = -5
    wrenches.publish(bad_wrench)
    good = WrenchStamped()
    good.header.stamp.sec = 1
    wait_until(lambda: controller.diagnostics.counters["rejected_measurement"] >= 1, 5.0, what="the bad wrench")
    wait_until(lambda: controller.diagnostics.counters["rejected_trajectory"] >= 1, 5.0, what="the bad trajectory")
    wrenches.publish(good)
    wait_until(lambda: commands, 5.0, what="the answer to the good wrench")
    assert commands[-1].data == -2.0  # no setpoint: retracted
