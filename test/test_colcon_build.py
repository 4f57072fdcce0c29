"""In a full ROS 2 install the workspace builds with `colcon build --base-paths . msg_defs`
and `ros2 run hex_control <node>` finds the executables in lib/hex_control."""

import os
import subprocess
import sys
from pathlib import Path

from geometry_msgs.msg import WrenchStamped

from hex_control_msgs.msg import KinematicsErrorCode as Code
from hex_control_msgs.msg import ToolPose
from hex_control_msgs.srv import InverseKinematics
from ros_harness import NodeProcess

ROOT = Path(__file__).resolve().parent.parent


def test_colcon_builds_both_packages(tmp_path, ros, ros_env):
    venv = Path(sys.prefix)
    env = dict(os.environ, AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    result = subprocess.run(
        [str(venv / "bin/colcon"), "--log-base", str(tmp_path / "log"), "build",
         "--base-paths", ".", "msg_defs",
         "--build-base", str(tmp_path / "build"), "--install-base", str(tmp_path / "install"),
         "--cmake-args", "-DBUILD_TESTING=OFF", f"-DPython3_EXECUTABLE={sys.executable}"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "2 packages finished" in result.stdout
    install = tmp_path / "install"
    executables = {p.name for p in (install / "hex_control/lib/hex_control").iterdir()}
    assert {"load_predictor", "synthetic_load", "hexctl"} <= executables
    assert (install / "hex_control/share/ament_index/resource_index/packages/hex_control").exists()
    assert (install / "hex_control/share/hex_control/config/load_predictor.yaml").exists()
    assert (install / "hex_control/share/hex_control/config/machines/nist_ingersoll.yaml").exists()
    assert (install / "hex_control_msgs/share/hex_control_msgs/msg/LoadPrediction.msg").exists()
    # the installed package finds its configuration through the ament index
    site = next((install / "hex_control/lib").glob("python3*/site-packages"))
    probe = subprocess.run(
        [sys.executable, "-c", "from hex_control.config import config_file; "
                               "print(config_file('load_predictor.yaml'))"],
        env=dict(env, AMENT_PREFIX_PATH=f"{install / 'hex_control'}:{venv}", PYTHONPATH=str(site)),
        cwd=tmp_path, capture_output=True, text=True)
    assert probe.stdout.strip() == str(install / "hex_control/share/hex_control/config/load_predictor.yaml")

    # the plant and the kinematics node start from the install, with its configuration, and answer
    installed = dict(ros_env, AMENT_PREFIX_PATH=f"{install / 'hex_control'}:{install / 'hex_control_msgs'}:{venv}",
                     PYTHONPATH=os.pathsep.join(str(p) for p in install.glob("*/lib/python3*/site-packages")))
    executables = install / "hex_control/lib/hex_control"
    nodes = [NodeProcess([str(executables / name)], installed, tmp_path / f"{name}.log")
             for name in ("plant", "kinematics")]
    try:
        client = ros.node("installed_client").create_client(InverseKinematics, "/kinematics/inverse_kinematics")
        response = ros.call(client, InverseKinematics.Request(poses=[ToolPose(z_mm=-2100.0)]), timeout_s=60.0)
        assert response.error_code.val == Code.SUCCESS and response.reports[0].reachable
        ros.wait_for_message(WrenchStamped, "/plant/wrench", timeout_s=60.0)  # its state, re-sent until answered
        assert all(node.alive() for node in nodes), [node.output()[-2000:] for node in nodes]
    finally:
        for node in nodes:
            node.stop()
