"""In a full ROS 2 install the workspace builds with colcon and `ros2 run hex_control <node>`
finds the executables in lib/hex_control; package.xml declares every package the code
imports, so `rosdep install --from-paths src` installs them.

colcon's crawl (colcon_recursive_crawl: a directory identified as a package is not descended
into) stops at the repository's root, the package hex_control, so the interface package in
msg_defs/ is found only through a link beside the repository in the workspace's src/
(docs/nodes.md). The workspace of these tests, build/colcon_ws, is the one `make setup`
builds the interface package in before installing it into the venv (the command of both is
scripts/colcon_workspace.py): colcon finds it built and rebuilds only what changed, as it does
for a user (a first build of hex_control_msgs takes about 30 s and 42 CPU s)."""

import ast
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from conftest import load_script
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
               "ray": "pip: ray", "foxglove": "pip: foxglove-sdk"}


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


colcon_workspace = load_script("colcon_workspace")


def _packages(workspace: Path) -> dict[str, str]:
    """Package name -> type as `colcon build` discovers them by default: its recursive crawl
    of the workspace (``--base-paths .``) with every installed identification extension."""
    from argparse import Namespace

    from colcon_core.package_identification import get_package_identification_extensions
    from colcon_recursive_crawl.package_discovery.recursive_crawl import RecursiveDiscoveryExtension

    found = RecursiveDiscoveryExtension().discover(args=Namespace(base_paths=[str(workspace)]),
                                                   identification_extensions=get_package_identification_extensions())
    return {desc.name: desc.type for desc in found}


def test_colcon_finds_the_interface_package_only_through_the_link(tmp_path):
    """What colcon discovers: the repository alone is one package (the crawl does not enter
    it); with the link both, and never the nested tf2_msgs (a ROS 2 install has its own)."""
    alone = colcon_workspace.workspace(tmp_path / "alone", with_link=False)
    assert _packages(alone) == {"hex_control": "ros.ament_python"}
    linked = colcon_workspace.workspace(tmp_path / "linked")
    assert _packages(linked) == {"hex_control": "ros.ament_python", "hex_control_msgs": "ros.ament_cmake"}


def test_colcon_builds_both_packages_and_the_nodes_start_from_setup_bash(tmp_path, ros, ros_env):
    """`colcon build` of the workspace builds both packages; the installed nodes (plant,
    kinematics) start from a shell that sourced install/setup.bash and answer.

    The interface package is built with `make setup`'s command, its C and Python parts only
    (HEX_PYTHON_ONLY): the C++ generators a user's plain build adds are rosidl's own code,
    untouched by ours, and on a fresh checkout they cost 33 of the build's 75 CPU s. colcon
    finds `make setup`'s build of it and does not configure it again: a command that drifted
    from the set-up's would (and cost a fresh clone's suite 42 CPU s)."""
    workspace = colcon_workspace.workspace()
    cache = workspace / "build/hex_control_msgs/CMakeCache.txt"
    configured = cache.stat().st_mtime_ns if cache.exists() else None
    result = colcon_workspace.build(path=workspace)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "2 packages finished" in result.stdout
    assert configured is not None and cache.stat().st_mtime_ns == configured, \
        "colcon configured hex_control_msgs again: not built by make setup, with other arguments " \
        "(build/colcon_ws/build/hex_control_msgs/cmake_args.last), or msg_defs changed since make setup"
    install = workspace / "install"
    assert (install / "setup.bash").exists() and (install / "hex_control/share/hex_control/package.bash").exists()
    executables = {p.name for p in (install / "hex_control/lib/hex_control").iterdir()}
    assert {"load_predictor", "synthetic_load", "plant", "kinematics", "robot_state", "hexctl"} <= executables
    assert (install / "hex_control/share/ament_index/resource_index/packages/hex_control").exists()
    assert (install / "hex_control/share/hex_control/config/load_predictor.yaml").exists()
    assert (install / "hex_control/share/hex_control/config/machines/nist_ingersoll.yaml").exists()
    assert (install / "hex_control_msgs/share/hex_control_msgs/msg/LoadPrediction.msg").exists()

    # a shell that sourced setup.bash over the underlay finds the installed package, its
    # configuration (through the ament index) and its interface package
    shell = dict(ros_env, AMENT_PREFIX_PATH=str(Path(sys.prefix)))
    shell.pop("PYTHONPATH", None)
    sourced = f"source {install / 'setup.bash'} && "
    probe = subprocess.run(
        ["bash", "-c", sourced + "python -c 'import hex_control, hex_control_msgs; from hex_control.config import "
                                 "config_file; print(hex_control.__file__, hex_control_msgs.__file__, "
                                 "config_file(\"load_predictor.yaml\"))'"],
        env=dict(shell, PATH=f"{Path(sys.prefix) / 'bin'}:{os.environ['PATH']}"), cwd=tmp_path, capture_output=True,
        text=True, timeout=120)
    assert probe.returncode == 0, probe.stderr
    package, messages, config = probe.stdout.split()
    assert package.startswith(str(install / "hex_control")) and messages.startswith(str(install / "hex_control_msgs"))
    assert config == str(install / "hex_control/share/hex_control/config/load_predictor.yaml")

    # the plant and the kinematics node start from it, with their configuration, and answer
    nodes = [NodeProcess(["bash", "-c", sourced + f"exec {install / 'hex_control/lib/hex_control' / name}"],
                         shell, tmp_path / f"{name}.log") for name in ("plant", "kinematics")]
    try:
        client = ros.node("installed_client").create_client(InverseKinematics, "/kinematics/inverse_kinematics")
        response = ros.call(client, InverseKinematics.Request(poses=[ToolPose(z_mm=-2100.0)]), timeout_s=60.0)
        assert response.error_code.val == Code.SUCCESS and response.reports[0].reachable
        ros.wait_for_message(WrenchStamped, "/plant/wrench", timeout_s=60.0)  # its state, re-sent until answered
        assert all(node.alive() for node in nodes), [node.output()[-2000:] for node in nodes]
    finally:
        for node in nodes:
            node.stop()
