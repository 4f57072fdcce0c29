"""What every machine kind answers, whatever it is (issue 22 item 1): its joint names and
limits, inverse kinematics of tool poses to joint positions, and a warm-started forward
kinematics of the tool point. The nodes, the tool locator and the reset-time measurement
ask these and never the machine's type."""

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.kinematics import load_machine

MACHINES = ["nist_ingersoll", "generic_6_6", "pru3", "pru3_feed"]


def _poses(machine_file: str) -> np.ndarray:
    """A few reachable tool poses (x, y, z mm, roll, pitch, yaw rad) and one far away."""
    if machine_file.startswith("pru3"):
        x = [-50.0, 0.0, 120.0] if machine_file == "pru3_feed" else [0.0, 0.0, 0.0]
        good = [[x[0], 0.0, 200.0, 0.0, 0.0, 0.0], [x[1], 0.0, 215.0, 0.08, -0.05, 0.0],
                [x[2], 0.0, 190.0, -0.1, 0.1, 0.0]]
    else:
        machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
        home = machine.home_pose
        good = [home, home + [20.0, -10.0, 30.0, 0.02, 0.0, 0.01], home + [-30.0, 25.0, -20.0, 0.0, -0.03, 0.0]]
    return np.vstack([good, [[0.0, 0.0, 1e5, 0.0, 0.0, 0.0]]])


@pytest.mark.parametrize("machine_file", MACHINES)
def test_joint_positions_and_the_tool_tracker_agree(machine_file):
    machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
    poses = _poses(machine_file)
    positions, reachable = machine.joint_positions_mm(poses)
    joints = len(machine.joint_names)
    assert positions.shape == (len(poses), joints) and reachable.tolist() == [True, True, True, False]
    assert machine.joint_speed_max_mm_s.shape == machine.joint_acceleration_max_mm_s2.shape == (joints,)
    assert len(set(machine.joint_names)) == joints
    # the coordinates the machine holds: all three on a hexapod; z on the 3-PRU head, whose x
    # and y are its parasitic motion, and x too on its feed stage, which takes that up
    held = {"pru3": [2], "pru3_feed": [0, 2]}.get(machine_file, [0, 1, 2])
    tracker = machine.tool_tracker()
    for pose, joint_mm in zip(poses[:3], positions[:3]):  # a moving machine: each solve starts at the last
        np.testing.assert_allclose(tracker.tool_position_mm(joint_mm)[held], pose[held], atol=1e-6)
