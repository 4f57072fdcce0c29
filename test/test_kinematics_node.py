"""Node kinematics over real processes: services, bad requests, the setpoint stream."""

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

from hex_control.config import config_file
from hex_control.kinematics import load_machine
from hex_control.kinematics.rotation import quaternion_from_rpy
from hex_control.kinematics.stewart import strut_lengths
from hex_control.kinematics.workspace import compute_workspace
from hex_control_msgs.msg import KinematicsErrorCode as Code
from hex_control_msgs.msg import ToolPose
from hex_control_msgs.srv import ComputeWorkspace, ForwardKinematics, InverseKinematics, TestPose
from ros_harness import wait_until

NIST, NIST_DOC = load_machine(config_file("machines/nist_ingersoll.yaml"))
REACHABLE = ToolPose(x_mm=100.0, y_mm=-50.0, z_mm=-2100.0, roll_rad=0.05)
UNREACHABLE = ToolPose(z_mm=-5000.0)


@pytest.fixture(scope="module")
def kinematics_process(ros_env, tmp_path_factory):
    from ros_harness import NodeProcess

    process = NodeProcess(["hex-kinematics", "--ros-args", "-r", "__ns:=/kin"], ros_env,
                          tmp_path_factory.mktemp("kin") / "kinematics.log")
    yield process
    code = process.stop()
    assert code in (0, -2), f"exit code {code}: {process.output()[-3000:]}"


@pytest.fixture
def client(ros, kinematics_process):
    node = ros.node("kinematics_client")
    clients = {name: node.create_client(kind, f"/kin/kinematics/{name}") for name, kind in (
        ("inverse_kinematics", InverseKinematics), ("test_pose", TestPose),
        ("forward_kinematics", ForwardKinematics), ("compute_workspace", ComputeWorkspace))}
    return lambda name, request, timeout_s=30.0: ros.call(clients[name], request, timeout_s)


def test_inverse_kinematics_and_test_pose(client):
    response = client("inverse_kinematics", InverseKinematics.Request(poses=[REACHABLE, UNREACHABLE]))
    assert response.error_code.val == Code.SUCCESS
    good, bad = response.reports
    expected = strut_lengths(NIST, [100.0, -50.0, -2100.0, 0.05, 0.0, 0.0])[0]
    np.testing.assert_allclose(good.strut_lengths_mm, expected, atol=1e-9)
    assert good.reachable and not bad.reachable and not bad.strut_lengths_ok
    assert bad.strut_length_margin_mm < 0 < good.strut_length_margin_mm
    test = client("test_pose", TestPose.Request(poses=[REACHABLE, REACHABLE, UNREACHABLE]))
    assert test.error_code.val == Code.UNREACHABLE and test.first_unreachable_index == 2
    assert client("test_pose", TestPose.Request(poses=[REACHABLE])).first_unreachable_index == -1


def test_forward_kinematics_round_trip_and_failures(client):
    pose = [100.0, -50.0, -2100.0, 0.05, -0.02, 0.1]
    lengths = strut_lengths(NIST, pose)[0].tolist()
    response = client("forward_kinematics", ForwardKinematics.Request(strut_lengths_mm=lengths))
    assert response.error_code.val == Code.SUCCESS
    found = [response.pose.x_mm, response.pose.y_mm, response.pose.z_mm,
             response.pose.roll_rad, response.pose.pitch_rad, response.pose.yaw_rad]
    np.testing.assert_allclose(found, pose, atol=1e-7)
    assert response.residual_mm < 1e-6
    impossible = client("forward_kinematics", ForwardKinematics.Request(strut_lengths_mm=[100.0] * 6))
    assert impossible.error_code.val == Code.NO_CONVERGENCE
    wrong_count = client("forward_kinematics", ForwardKinematics.Request(strut_lengths_mm=[2500.0] * 5))
    assert wrong_count.error_code.val == Code.INVALID_INPUT


def test_compute_workspace_matches_the_library(client):
    request = ComputeWorkspace.Request(sector_count=1250, slice_heights_mm=[-2100.0, -9000.0])
    response = client("compute_workspace", request)
    assert response.error_code.val == Code.SUCCESS
    library = compute_workspace(NIST, (0.0, 0.0, 0.0), NIST_DOC["workspace"]["search_cube_mm"], 50, 25, 1.0)
    assert response.volume_mm3 == pytest.approx(library.volume_mm3, rel=1e-12)
    assert len(response.boundary_x_mm) == len(response.limiting_constraint) == 26 * 50
    assert set(response.limiting_constraint) == {"I", "III"}
    assert response.slice_area_mm2[0] > 1e6 and response.slice_area_mm2[1] == 0.0


def test_bad_requests_get_error_codes_and_the_node_survives(client):
    nan_pose = ToolPose(z_mm=math.nan)
    answer = client("inverse_kinematics", InverseKinematics.Request(poses=[nan_pose]))
    assert answer.error_code.val == Code.INVALID_INPUT
    assert client("test_pose", TestPose.Request(poses=[nan_pose])).error_code.val == Code.INVALID_INPUT
    for bad in (ComputeWorkspace.Request(sector_count=10_000_000), ComputeWorkspace.Request(roll_rad=math.inf),
                ComputeWorkspace.Request(resolution_mm=-1.0),
                ComputeWorkspace.Request(slice_heights_mm=[-2100.0] * 10_000)):  # about 5 min of slices
        assert client("compute_workspace", bad).error_code.val == Code.INVALID_INPUT
    assert client("compute_workspace", ComputeWorkspace.Request(roll_rad=1.5)).error_code.val == Code.UNREACHABLE
    assert client("test_pose", TestPose.Request(poses=[REACHABLE])).error_code.val == Code.SUCCESS


def test_a_long_workspace_request_does_not_block_the_other_services(ros, client):
    node = ros.node("impatient")
    workspace = node.create_client(ComputeWorkspace, "/kin/kinematics/compute_workspace")
    inverse = node.create_client(InverseKinematics, "/kin/kinematics/inverse_kinematics")
    ros.wait_for_service(workspace)
    ros.wait_for_service(inverse)
    slow = workspace.call_async(ComputeWorkspace.Request(sector_count=40_000, resolution_mm=0.02))
    time.sleep(0.3)  # the workspace computation is under way
    fast = inverse.call_async(InverseKinematics.Request(poses=[REACHABLE]))
    wait_until(fast.done, 10.0, what="the IK answer")
    assert not slow.done(), "the workspace request was not long enough to show anything"
    wait_until(slow.done, 60.0, what="the workspace answer")
    assert slow.result().error_code.val == Code.SUCCESS


def test_setpoint_stream_commands_struts_and_refuses_bad_poses(ros, kinematics_process):
    commands = ros.collect(JointState, "/kin/plant/strut_command", publishers=1)
    diagnostics = ros.collect(DiagnosticArray, "/diagnostics")
    node = ros.node("setpoints")
    publisher = node.create_publisher(PoseStamped, "/kin/motion/setpoint", 10)
    ros.wait_for_match(node, "/kin/motion/setpoint", subscribers=1)

    def setpoint(x_m, y_m, z_m, rpy=(0.0, 0.0, 0.0), quaternion=None):
        msg = PoseStamped()
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x_m, y_m, z_m
        qx, qy, qz, qw = quaternion_from_rpy(*rpy) if quaternion is None else quaternion
        msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w = qx, qy, qz, qw
        return msg

    publisher.publish(setpoint(0.1, -0.05, -2.1, (0.05, 0.0, 0.0)))     # reachable
    publisher.publish(setpoint(0.0, 0.0, -5.0))                          # unreachable
    publisher.publish(setpoint(math.nan, 0.0, -2.1))                     # malformed
    publisher.publish(setpoint(0.0, 0.0, -2.1, quaternion=(0, 0, 0, 2)))  # not a unit quaternion
    publisher.publish(setpoint(0.0, 0.0, -2.0))                          # reachable
    wait_until(lambda: len(commands) >= 2, 10.0, what="two strut commands")
    time.sleep(0.3)
    assert len(commands) == 2
    np.testing.assert_allclose(commands[0].position, strut_lengths(NIST, [100, -50, -2100, 0.05, 0, 0])[0] / 1000,
                               atol=1e-12)
    assert list(commands[0].name) == [f"strut_{i}" for i in range(6)]

    def counters():
        for array in reversed(list(diagnostics)):
            for status in array.status:
                if status.name == "/kin/kinematics":
                    return {kv.key: kv.value for kv in status.values}
        return {}
    values = wait_until(lambda: (c := counters()).get("commands") == "2" and c, 5.0, what="diagnostics")
    assert values["refused_unreachable"] == "1" and values["rejected_malformed"] == "2"


def test_pru3_machine(ros, spawn):
    spawn(["hex-kinematics", "--ros-args", "-r", "__ns:=/pru", "-p",
           f"machine_file:={config_file('machines/pru3.yaml')}"])
    node = ros.node("pru_client")
    inverse = node.create_client(InverseKinematics, "/pru/kinematics/inverse_kinematics")
    forward = node.create_client(ForwardKinematics, "/pru/kinematics/forward_kinematics")
    workspace = node.create_client(ComputeWorkspace, "/pru/kinematics/compute_workspace")
    ik = ros.call(inverse, InverseKinematics.Request(poses=[ToolPose(z_mm=220.0, roll_rad=0.1, pitch_rad=-0.05)]))
    lengths = ik.reports[0].strut_lengths_mm
    assert ik.error_code.val == Code.SUCCESS and ik.reports[0].reachable and len(lengths) == 3
    fk = ros.call(forward, ForwardKinematics.Request(strut_lengths_mm=lengths))
    assert fk.error_code.val == Code.SUCCESS
    assert (fk.pose.z_mm, fk.pose.roll_rad, fk.pose.pitch_rad) == pytest.approx((220.0, 0.1, -0.05), abs=1e-9)
    assert ros.call(workspace, ComputeWorkspace.Request()).error_code.val == Code.UNSUPPORTED_MACHINE


def test_pru3_on_a_feed_stage(ros, spawn):
    """The stage is joint 4 (feed_x): IK gives it, FK takes it, TestPose holds it to its travel."""
    spawn(["hex-kinematics", "--ros-args", "-r", "__ns:=/feed", "-p",
           f"machine_file:={config_file('machines/pru3_feed.yaml')}"])
    node = ros.node("feed_client")
    inverse = node.create_client(InverseKinematics, "/feed/kinematics/inverse_kinematics")
    forward = node.create_client(ForwardKinematics, "/feed/kinematics/forward_kinematics")
    test_pose = node.create_client(TestPose, "/feed/kinematics/test_pose")
    pose = ToolPose(x_mm=120.0, z_mm=200.0, roll_rad=0.1, pitch_rad=-0.05)
    ik = ros.call(inverse, InverseKinematics.Request(poses=[pose]))
    joints = ik.reports[0].strut_lengths_mm
    assert ik.error_code.val == Code.SUCCESS and ik.reports[0].reachable and len(joints) == 4
    fk = ros.call(forward, ForwardKinematics.Request(strut_lengths_mm=joints))
    assert (fk.pose.x_mm, fk.pose.z_mm, fk.pose.roll_rad) == pytest.approx((120.0, 200.0, 0.1), abs=1e-9)
    far = ros.call(test_pose, TestPose.Request(poses=[pose, ToolPose(x_mm=600.0, z_mm=200.0)]))
    assert far.error_code.val == Code.UNREACHABLE and far.first_unreachable_index == 1
    assert far.reports[1].strut_length_margin_mm == pytest.approx(450.0 - 600.0, abs=1.0)


def test_a_tool_path_becomes_one_strut_trajectory_or_is_refused_whole(ros, kinematics_process):
    """DESIGN.md 4.1: a pass's path is converted whole, by one vectorized IK call, into the
    JointTrajectory the plant holds; a path with one pose out of reach is refused whole."""
    from trajectory_msgs.msg import JointTrajectory

    from hex_control.nodes.interfaces import LATCHED, PATH_FIELDS
    from hex_control_msgs.msg import ToolPath

    node = ros.node("path_source")
    publisher = node.create_publisher(ToolPath, "/kin/motion/tool_path", LATCHED)
    trajectories = ros.collect(JointTrajectory, "/kin/plant/strut_trajectory", LATCHED, publishers=1)
    ros.wait_for_match(node, "/kin/motion/tool_path", subscribers=1)
    poses = np.column_stack([np.linspace(-50, 50, 400), np.zeros(400), np.full(400, -2100.0),
                             np.full(400, 0.02), np.zeros(400), np.zeros(400)])

    def path(rows, pass_index):
        msg = ToolPath(job_id="job-k", pass_index=pass_index, sample_period_s=0.005)
        msg.header.stamp.sec, msg.header.stamp.nanosec = 7, 500_000_000
        for k, name in enumerate(PATH_FIELDS):
            setattr(msg, name, rows[:, k].tolist())
        return msg
    unreachable = poses.copy()
    unreachable[200, 2] = -5000.0
    publisher.publish(path(unreachable, 0))
    publisher.publish(path(poses, 1))
    trajectory = wait_until(lambda: trajectories[-1] if trajectories else None, 10.0, what="a strut trajectory")
    assert len(trajectories) == 1  # the first path was refused whole
    assert (trajectory.header.stamp.sec, trajectory.header.stamp.nanosec) == (7, 500_000_000)
    assert list(trajectory.joint_names) == [f"strut_{i}" for i in range(6)] and len(trajectory.points) == 400
    times = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in trajectory.points]
    np.testing.assert_allclose(times, np.arange(400) * 0.005, atol=1e-9)
    np.testing.assert_allclose([p.positions for p in trajectory.points], strut_lengths(NIST, poses) / 1000.0,
                               atol=1e-12)
