"""The plant's held strut trajectory (hex_control/plant/strut_trajectory.py) and its
message conversion: sampled linearly, held before its start and after its end, refused
when malformed; a JointTrajectory in any joint order comes back in the machine's order."""

import math

import numpy as np
import pytest

from hex_control.plant.strut_trajectory import StrutTrajectory
from hex_control.ros.infra.interfaces import joint_trajectory_message, strut_trajectory_from_message, time_msg


def test_sampled_linearly_and_held_at_both_ends():
    trajectory = StrutTrajectory(2.0, np.array([0.0, 0.5, 1.0]), np.array([[1.0, 2.0], [1.5, 2.0], [1.5, 3.0]]))
    assert trajectory.end_s == 3.0
    np.testing.assert_allclose(trajectory.at(0.0), [1.0, 2.0])
    np.testing.assert_allclose(trajectory.at(2.25), [1.25, 2.0])
    np.testing.assert_allclose(trajectory.at(2.75), [1.5, 2.5])
    np.testing.assert_allclose(trajectory.at(9.0), [1.5, 3.0])


@pytest.mark.parametrize("start, times, lengths", [
    (-1.0, [0.0, 1.0], [[1.0], [1.0]]),         # before the clock began
    (0.0, [0.0, 0.0], [[1.0], [1.0]]),          # not increasing
    (0.0, [0.0, 1.0], [[1.0], [math.nan]]),     # non-finite
    (0.0, [0.0, 1.0], [[1.0]]),                 # one row short
    (math.inf, [0.0], [[1.0]]),
])
def test_malformed_trajectories_are_refused(start, times, lengths):
    with pytest.raises(ValueError):
        StrutTrajectory(start, np.array(times), np.array(lengths))


def test_the_message_round_trip_reorders_joints_and_keeps_stamps():
    positions = np.arange(12.0).reshape(4, 3) / 10 + 1
    msg = joint_trajectory_message(time_msg(12.345), ["c", "a", "b"], 0.005, positions)
    trajectory = strut_trajectory_from_message(msg, ["a", "b", "c"])
    assert trajectory.start_s == pytest.approx(12.345, abs=1e-9)
    np.testing.assert_allclose(trajectory.time_s, [0.0, 0.005, 0.01, 0.015], atol=1e-12)
    np.testing.assert_allclose(trajectory.lengths_m, positions[:, [1, 2, 0]])
    with pytest.raises(ValueError, match="joint names"):
        strut_trajectory_from_message(msg, ["a", "b", "d"])
    msg.header.stamp.sec = -3  # a negative stamp is refused, not a crash (rclpy's Time.from_msg raises)
    with pytest.raises(ValueError, match="negative"):
        strut_trajectory_from_message(msg, ["a", "b", "c"])
