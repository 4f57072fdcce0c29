"""The shipped configuration: each physical value of the cell is defined once, in
config/cell.yaml, and every node that needs it reads it from there (issue 22 item 2)."""

import math

import yaml

from hex_control.config import config_file, node_parameters
from hex_control.grinding.config import cell_value, load_cell, load_pass_planner_config, load_planner_config
from hex_control.plant.force_table import ForceTableParameters

#: the same quantities under the names other files would give them
ALIASES = {"rotational_stiffness_n_mm_rad": "spring_n_mm_rad", "relaxed_angle_rad": "relaxed_angle_deg"}


def _keys(node, path=()):
    if isinstance(node, dict):
        for key, value in node.items():
            yield (*path, str(key))
            yield from _keys(value, (*path, str(key)))


def test_every_physical_value_of_the_cell_is_defined_once():
    cell = load_cell()
    physical = {name for section in cell.values() for name in section}
    assert {"specific_energy_j_mm3", "spring_n_mm_rad", "disk_radius_mm", "force_max_n"} <= physical
    for path in sorted(config_file("cell.yaml").parent.glob("*.yaml")):
        if path.name == "cell.yaml":
            continue
        for keys in _keys(yaml.safe_load(path.read_text()) or {}):
            name = ALIASES.get(keys[-1], keys[-1])
            assert name not in physical, f"{path.name}: {'.'.join(keys)} is the cell's (config/cell.yaml)"


def test_every_node_reads_the_cells_values():
    process, _, _, _ = load_planner_config("sequence_planner.yaml")
    disk = load_pass_planner_config("pass_planner.yaml").model
    for name, value in load_cell()["process"].items():
        assert getattr(process, name) == value == getattr(disk.process, name), name
    assert disk.spring_n_mm_rad == cell_value("disk.spring_n_mm_rad")
    assert disk.relaxed_angle_rad == math.radians(cell_value("disk.relaxed_angle_deg"))
    assert process.bead_length_mm == 300.0 and process.reset_time_s == 2.0  # the sequence planner's own
    # the plant's force table and the pass predictor take theirs from the cell (nodes/plant.py,
    # load_predictor.yaml's mean_from_cell); its dataclass defaults agree with the cell
    assert ForceTableParameters().rotational_stiffness_n_mm_rad == disk.spring_n_mm_rad
    predictor = node_parameters("load_predictor.yaml", "load_predictor/pass")
    assert cell_value(predictor["mean_from_cell"]) == process.specific_energy_j_mm3
    # the force controller's ceiling is a setting of its own that starts at the cell's F_max
    from hex_control.ros.nodes.force_controller import PARAMETERS

    assert PARAMETERS["max_force_n"].default == process.force_max_n
