"""Project rules that a reviewer would otherwise check by hand."""

import ast
import re
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROS_MODULES = ("rclpy", "hex_control_msgs", "std_msgs", "geometry_msgs", "sensor_msgs",
               "diagnostic_msgs", "trajectory_msgs", "rcl_interfaces", "rosgraph_msgs")
ROS_ALLOWED = ("hex_control/ros/",)  # hexctl (hex_control/cli/) loads rclpy only inside a verb


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_library_does_not_import_ros():
    """DESIGN.md section 2: nothing outside nodes/ and the topic tools imports rclpy or messages."""
    offenders = []
    for path in sorted((ROOT / "hex_control").rglob("*.py")):
        relative = path.relative_to(ROOT).as_posix()
        if relative.startswith(ROS_ALLOWED):
            continue
        leaked = imported_modules(path) & set(ROS_MODULES)
        if leaked:
            offenders.append(f"{relative}: {sorted(leaked)}")
    assert not offenders, offenders
    # and the check itself sees an import where there is one
    assert "rclpy" in imported_modules(ROOT / "hex_control/ros/infra/runtime.py")


def test_package_manifests():
    package = ET.parse(ROOT / "package.xml").getroot()
    assert package.get("format") == "3"
    assert package.findtext("name") == "hex_control"
    assert package.find("export/build_type").text == "ament_python"
    msgs = ET.parse(ROOT / "msg_defs/package.xml").getroot()
    assert msgs.get("format") == "3"
    assert msgs.findtext("name") == "hex_control_msgs"
    assert msgs.findtext("member_of_group") == "rosidl_interface_packages"
    assert msgs.find("export/build_type").text == "ament_cmake"
    assert "script_dir=$base/lib/hex_control" in (ROOT / "setup.cfg").read_text()
    assert (ROOT / "resource/hex_control").exists()


UNIT = re.compile(r"_(mm|mm2|mm3|n|s|rad|hz|w|j|mm_s|n_s|rad_s|mm2_per_n_s)$")


def interface_fields():
    for path in sorted((ROOT / "msg_defs").rglob("*")):
        if path.suffix not in (".msg", ".srv", ".action"):
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code, _, comment = line.partition("#")
            parts = code.split()
            if len(parts) == 2 and "=" not in code:
                yield path.name, number, parts[0], parts[1], comment.strip()


def test_every_numeric_interface_field_states_its_unit():
    """Units in every field name or comment (DESIGN.md section 4)."""
    vague = []
    dimensionless = {"pass_index", "passes", "sample_count", "first_unreachable_index", "iterations",
                     "sector_count", "max_iterations", "val", "status", "reason", "gain", "model_a",
                     "expected_penalty", "total_charge"}
    for name, number, field_type, field, comment in interface_fields():
        numeric = field_type.rstrip("[]") in ("float64", "float32", "int32", "uint32", "uint64", "uint8")
        if numeric and not UNIT.search(field) and field not in dimensionless and not comment:
            vague.append(f"{name}:{number} {field}")
    assert not vague, f"fields without a unit in name or comment: {vague}"


def test_service_responses_carry_an_error_code():
    for path in (ROOT / "msg_defs/srv").glob("*.srv"):
        response = path.read_text().split("---")[1]
        assert "KinematicsErrorCode error_code" in response, path.name
        assert "bool " not in response.split("ConstraintReport")[0], f"{path.name}: bare bool result"
