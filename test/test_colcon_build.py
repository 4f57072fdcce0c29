"""In a full ROS 2 install the workspace builds with colcon and `ros2 run hex_control <node>`
finds the executables in lib/hex_control; package.xml declares every package the code
imports, so `rosdep install --from-paths src` installs them."""

import ast
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from geometry_msgs.msg import WrenchStamped

from hex_control_msgs.msg import KinematicsErrorCode as Code
from hex_control_msgs.msg import ToolPose
from hex_control_msgs.srv import InverseKinematics
from ros_harness import NodeProcess

ROOT = Path(__file__).resolve().parent.parent

#: what package.xml must name for an imported module that is neither the standard library's
#: nor ours: a rosdep key (rosdistro's rosdep/python.yaml; '-pip' keys install from PyPI), or
#: "pip: <name>" in a comment where rosdep has no key. A ROS package's module is its key.
IMPORT_KEYS = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml",
               "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "filterpy": "python3-filterpy-pip",
               "control": "python-control-pip", "mcap_ros2": "mcap-ros2-support", "mcap": "pip: mcap",
               "ray": "pip: ray"}


def _imported_top_modules() -> set[str]:
    modules = set()
    for path in (ROOT / "hex_control").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                modules |= {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                modules.add(node.module.split(".")[0])
    return modules - set(sys.stdlib_module_names) - {"hex_control", "__future__"}


def test_package_xml_declares_every_import():
    text = (ROOT / "package.xml").read_text()
    manifest = ET.parse(ROOT / "package.xml").getroot()
    keys = {e.text for tag in ("depend", "exec_depend") for e in manifest.iter(tag)}
    missing = []
    for module in sorted(_imported_top_modules()):
        key = IMPORT_KEYS.get(module, module)
        if not (key in keys or key.startswith("pip: ") and key in text):
            missing.append(f"{module} (as {key})")
    assert not missing, f"package.xml does not declare: {missing}"
    assert {"ament_index_python", "rclpy", "hex_control_msgs", "mcap-ros2-support"} <= keys


def test_colcon_builds_both_packages(tmp_path, ros, ros_env):
    """A workspace as the README sets it up: the repository under src/, and beside it the
    link to its interface package (colcon's crawl does not descend into a package, so a
    plain `colcon build` would not find msg_defs/ inside the repository's package root)."""
    venv = Path(sys.prefix)
    env = dict(os.environ, AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    workspace = tmp_path / "ws"
    (workspace / "src").mkdir(parents=True)
    (workspace / "src/hex_control").symlink_to(ROOT)
    (workspace / "src/hex_control_msgs").symlink_to("hex_control/msg_defs")
    result = subprocess.run(
        [str(venv / "bin/colcon"), "build",
         "--cmake-args", "-DBUILD_TESTING=OFF", f"-DPython3_EXECUTABLE={sys.executable}"],
        cwd=workspace, env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "2 packages finished" in result.stdout
    install = workspace / "install"
    assert (install / "setup.sh").exists() and (install / "hex_control/share/hex_control/package.sh").exists()
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
