"""The kinematics node's behaviour without ROS (hex_control.kinematics.service): requests,
their bounds, the tool-path relay and the setpoint's checks, in milliseconds."""

import math

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.kinematics import load_machine
from hex_control.kinematics.rotation import quaternion_from_rpy
from hex_control.kinematics.service import MAX_SLICES, KinematicsCore, KinematicsSettings
from hex_control.kinematics.stewart import strut_lengths

NIST, NIST_DOC = load_machine(config_file("machines/nist_ingersoll.yaml"))
CORE = KinematicsCore(NIST, NIST_DOC)
REACHABLE = [100.0, -50.0, -2100.0, 0.05, 0.0, 0.0]
UNREACHABLE = [0.0, 0.0, -5000.0, 0.0, 0.0, 0.0]


def test_inverse_kinematics_reports_every_pose_and_test_pose_the_first_out_of_reach():
    answer = CORE.inverse([REACHABLE, UNREACHABLE])
    assert answer.outcome == "SUCCESS"  # some poses out of reach: read the check
    check = answer.check
    np.testing.assert_allclose(check.positions_mm[0], strut_lengths(NIST, REACHABLE)[0], atol=1e-9)
    assert check.reachable.tolist() == [True, False] and not check.satisfied[1, 0]
    assert check.margins[1, 0] < 0 < check.margins[0, 0]
    test = CORE.test_pose([REACHABLE, REACHABLE, UNREACHABLE])
    assert (test.outcome, test.first_unreachable) == ("UNREACHABLE", 2)
    assert (CORE.test_pose([REACHABLE]).outcome, CORE.test_pose([REACHABLE]).first_unreachable) == ("SUCCESS", -1)
    empty = CORE.test_pose(np.zeros((0, 6)))
    assert empty.outcome == "SUCCESS" and empty.check.positions_mm.shape == (0, 6)


def test_a_request_beyond_the_cap_is_refused_before_any_work():
    core = KinematicsCore(NIST, NIST_DOC, KinematicsSettings(max_poses=3))
    assert core.pose_count_refusal(3) == ""
    assert core.pose_count_refusal(1_000_000) == "1000000 poses exceed the limit of 3 per request"
    refused = core.inverse([REACHABLE] * 4)
    assert (refused.outcome, refused.check, refused.reason) == ("INVALID_INPUT", None,
                                                               "4 poses exceed the limit of 3 per request")
    assert core.test_pose([REACHABLE] * 3).outcome == "SUCCESS"
    nan = CORE.test_pose([[0.0, 0.0, math.nan, 0.0, 0.0, 0.0]])
    assert (nan.outcome, nan.first_unreachable, nan.reason) == ("INVALID_INPUT", -1, "non-finite pose field")
    with pytest.raises(ValueError, match="max_poses 0"):
        KinematicsCore(NIST, NIST_DOC, KinematicsSettings(max_poses=0))


def test_forward_kinematics_round_trip_and_failures():
    pose = [100.0, -50.0, -2100.0, 0.05, -0.02, 0.1]
    answer = CORE.forward(strut_lengths(NIST, pose)[0], np.zeros(6))
    assert answer.outcome == "SUCCESS" and answer.residual_mm < 1e-6 and answer.iterations >= 1
    np.testing.assert_allclose(answer.pose, pose, atol=1e-7)
    assert CORE.forward([100.0] * 6, np.zeros(6)).outcome == "NO_CONVERGENCE"
    for lengths, guess, tolerance in (([2500.0] * 5, np.zeros(6), 0.0), ([2500.0] * 6, np.zeros(6), -1.0),
                                      ([2500.0] * 6, np.full(6, math.nan), 0.0), ([math.inf] * 6, np.zeros(6), 0.0)):
        assert CORE.forward(lengths, guess, tolerance).outcome == "INVALID_INPUT"


def test_workspace_matches_the_library_and_refuses_bad_requests():
    from hex_control.kinematics.workspace import compute_workspace

    answer = CORE.workspace((0.0, 0.0, 0.0), [-2100.0, -9000.0], 1250)
    library = compute_workspace(NIST, (0.0, 0.0, 0.0), NIST_DOC["workspace"]["search_cube_mm"], 50, 25, eps_mm=1.0)
    assert answer.outcome == "SUCCESS" and answer.volume_mm3 == pytest.approx(library.volume_mm3, rel=1e-12)
    assert answer.boundary_mm.shape == (26 * 50, 3) and set(answer.limiting_constraint) == {"I", "III"}
    assert answer.slice_area_mm2[0] > 1e6 and answer.slice_area_mm2[1] == 0.0
    np.testing.assert_allclose(answer.center_pose[3:], 0.0)
    for bad in (dict(sector_count=10_000_000), dict(orientation_rad=(math.inf, 0, 0)), dict(resolution_mm=-1.0),
                dict(slice_heights_mm=[-2100.0] * (MAX_SLICES + 1)), dict(slice_heights_mm=[math.nan])):
        request = {"orientation_rad": (0.0, 0.0, 0.0), **bad}
        assert CORE.workspace(**request).outcome == "INVALID_INPUT", bad
    assert CORE.workspace((1.5, 0.0, 0.0)).outcome == "UNREACHABLE"
    pru3 = KinematicsCore(*load_machine(config_file("machines/pru3.yaml")))
    assert pru3.workspace((0.0, 0.0, 0.0)).outcome == "UNSUPPORTED_MACHINE"


def test_a_tool_path_becomes_strut_lengths_or_is_refused_whole():
    poses = np.column_stack([np.linspace(-50, 50, 400), np.zeros(400), np.full(400, -2100.0),
                             np.full(400, 0.02), np.zeros(400), np.zeros(400)])
    relay = CORE.strut_trajectory(poses)
    assert relay.counter == "paths"
    np.testing.assert_array_equal(relay.positions_mm, strut_lengths(NIST, poses))
    far = poses.copy()
    far[200, 2] = -5000.0
    refused = CORE.strut_trajectory(far)
    assert (refused.positions_mm, refused.counter) == (None, "refused_unreachable_paths")
    assert refused.reason.startswith("sample 200 [0.125, 0.0, -5000.0")
    for bad in (poses[:, :5], np.where(np.arange(6) == 2, math.nan, poses)):
        assert CORE.strut_trajectory(bad).counter == "rejected_paths"


def test_a_setpoint_becomes_one_strut_command_or_is_refused():
    relay = CORE.setpoint((0.1, -0.05, -2.1), quaternion_from_rpy(0.05, 0.0, 0.0))
    assert relay.counter == "commands"
    np.testing.assert_allclose(relay.positions_mm, strut_lengths(NIST, REACHABLE)[0], atol=1e-9)
    cases = {((0.0, 0.0, -5.0), (0, 0, 0, 1)): "refused_unreachable",
             ((math.nan, 0.0, -2.1), (0, 0, 0, 1)): "rejected_malformed",
             ((0.0, 0.0, -2.1), (0, 0, 0, 2)): "rejected_malformed",  # not a unit quaternion
             ((1e306, 0.0, -2.1), (0, 0, 0, 1)): "rejected_malformed"}  # finite in m, not in mm
    for (position, quaternion), counter in cases.items():
        refused = CORE.setpoint(position, quaternion)
        assert (refused.positions_mm, refused.counter) == (None, counter), position
    loose = KinematicsCore(NIST, NIST_DOC, KinematicsSettings(quaternion_tolerance=0.5))
    assert loose.setpoint((0.0, 0.0, -2.1), (0, 0, 0, 1.4)).counter == "commands"


def test_the_pru3_head_and_its_feed_stage():
    pru3 = KinematicsCore(*load_machine(config_file("machines/pru3.yaml")))
    ik = pru3.inverse([[0.0, 0.0, 220.0, 0.1, -0.05, 0.0]])
    assert ik.outcome == "SUCCESS" and ik.check.reachable[0] and ik.check.positions_mm.shape == (1, 3)
    fk = pru3.forward(ik.check.positions_mm[0], np.zeros(6))
    assert fk.outcome == "SUCCESS" and fk.pose[2:5] == pytest.approx((220.0, 0.1, -0.05), abs=1e-9)
    feed = KinematicsCore(*load_machine(config_file("machines/pru3_feed.yaml")))
    assert feed.joint_names[3] == "feed_x" and feed.strut_count == 4
    far = feed.test_pose([[120.0, 0.0, 200.0, 0.1, -0.05, 0.0], [600.0, 0.0, 200.0, 0.0, 0.0, 0.0]])
    assert (far.outcome, far.first_unreachable) == ("UNREACHABLE", 1)
    assert far.check.margins[1, 0] == pytest.approx(450.0 - 600.0, abs=1.0)
