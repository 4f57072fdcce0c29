"""The shipped configuration: each physical value of the cell is defined once, and every node
and library class that needs it reads it from there (issue 22 item 2, issue 38 item 3).

The design, in one paragraph: the cell's physical values are in config/cell.yaml (``process``,
``disk``, the force ``table``) and in the machine file's ``structure`` block (the lightly damped
structural mode, config/machines/*.yaml); :class:`hex_control.config.CellConfiguration` reads
both once (:func:`~hex_control.config.cell_configuration`). Library dataclasses that need one of
them (GrindingProcess, DiskModel, ForceTableParameters, MachineParameters) take it as a
``default_factory`` from that configuration, so ``GrindingProcess()`` is still the shipped cell
and a node started by hand starts with it; node parameters take their defaults from the
configuration or from those dataclasses, never from a number of their own. A value only the
simulated hardware has (the table's stiction and sensor, the servos, K1's scatter) keeps its
dataclass default as its one source; node YAML files do not restate it. Derived values are
computed, not written: K_x = K_theta / R^2 and the overload trip = table.overload_ratio x F_max.
"""

import ast
import dataclasses
import math
import re
from pathlib import Path

import yaml

from hex_control.config import (
    CELL_SECTIONS,
    STRUCTURE_FIELDS,
    cell_configuration,
    config_file,
    load_cell_configuration,
    node_parameters,
)
from hex_control.control.force_loop import ForceLoopSettings
from hex_control.grinding.config import cell_value, load_cell, load_pass_planner_config, load_planner_config
from hex_control.grinding.dynamic import DiskModel
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.variation import ProcessVariation
from hex_control.plant.force_table import ForceTableParameters
from hex_control.plant.limits import ForceAxisLimits
from hex_control.plant.machine import MachineParameters

REPO = Path(__file__).resolve().parent.parent

#: the same quantities under the names other files would give them
ALIASES = {"rotational_stiffness_n_mm_rad": "spring_n_mm_rad", "relaxed_angle_rad": "relaxed_angle_deg"}
#: the library's parameter dataclasses of the cell and its plant: every field a physical value
PHYSICAL_DATACLASSES = (GrindingProcess, DiskModel, ForceTableParameters, MachineParameters, ProcessVariation)
#: and those whose defaults are scanned too (their physical fields are named by the ones above)
SCANNED_DATACLASSES = (*PHYSICAL_DATACLASSES, ForceLoopSettings, ForceAxisLimits)
#: the job's, not the cell's: the bead of a job (sequence planner's file, the plant's generated bead)
JOB = {"bead_length_mm", "reset_time_s", "burn_coefficient", "power_fraction"}
#: duplicates known and left to files this change could not touch: (name, source) -> what removes it
PENDING: dict = {}


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


def _physical_names() -> set[str]:
    cell = cell_configuration()
    names = {n for section in CELL_SECTIONS for n in getattr(cell, section)} | set(STRUCTURE_FIELDS)
    names |= {f.name for cls in PHYSICAL_DATACLASSES for f in dataclasses.fields(cls)}
    return {ALIASES.get(n, n) for n in names | {"overload_n", "stiffness_n_per_mm"}} - JOB


def _leaves(node, path=()):
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _leaves(value, (*path, str(key)))
    else:
        yield path, node


def _number(value) -> bool:
    # 0 is an origin or "off", not a measured quantity; a list is a set of choices
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value != 0


def _written_values(config: Path | None = None) -> dict[str, list[tuple[str, float, str]]]:
    """name -> [(source, value, group)] of every physical number written as a literal: the
    YAML files and the dataclass defaults (a default_factory is not a literal), plus the
    derived values the cell computes. Machine files are one group each (another machine may
    well have the same mode); everything else is the shipped cell's group. ``config``: a
    config folder other than the shipped one (its YAML files instead)."""
    physical, found = _physical_names(), {}

    def add(name, source, value, group="cell"):
        name = ALIASES.get(name, name)
        if name in physical and _number(value):
            found.setdefault(name, []).append((source, float(value), group))

    config = config or config_file("cell.yaml").parent
    for path in sorted(config.glob("*.yaml")) + sorted(config.glob("machines/*.yaml")):
        group = path.name if path.parent.name == "machines" else "cell"
        for keys, value in _leaves(yaml.safe_load(path.read_text()) or {}):
            add(keys[-1], path.name, value, group)
    for cls in SCANNED_DATACLASSES:
        for f in dataclasses.fields(cls):
            if f.default is not dataclasses.MISSING:
                add(f.name, cls.__name__, f.default)
    cell = cell_configuration()
    add("overload_n", "cell.yaml (table.overload_ratio x F_max)", cell.overload_n)
    add("stiffness_n_per_mm", "cell.yaml (K_theta / R^2)", cell.stiffness_n_per_mm)
    return found


def _duplicates(written_values: dict) -> tuple[set[str], set]:
    """The physical values written twice within a group (named), and the PENDING ones met."""
    duplicates, pending = set(), set()
    for name, written in written_values.items():
        for group in {g for _, _, g in written}:
            # a machine file is compared with the cell's files, not with another machine
            scope = [(s, v) for s, v, g in written if g in (group, "cell")]
            for i, (source, value) in enumerate(scope):
                for other, again in scope[i + 1:]:
                    if math.isclose(value, again, rel_tol=1e-12):
                        known = {(name, source), (name, other)} & set(PENDING)
                        pending.update(known)
                        if not known:
                            duplicates.add(f"{name} = {value:g} in {source} and {other}")
    return duplicates, pending


def test_no_physical_quantity_is_written_twice():
    """Issue 38's acceptance: a physical number written as a default in two places fails,
    naming both (the shipped YAML files and the library's dataclass defaults)."""
    duplicates, pending = _duplicates(_written_values())
    assert not duplicates, f"physical values written twice: {sorted(duplicates)}"
    stale = set(PENDING) - pending
    assert not stale, f"no longer duplicated, drop from PENDING: {sorted(stale)}"


def test_a_duplicate_is_found_and_named(tmp_path):
    """The scan can fail: a machine file's mode restated in the plant's file is found."""
    import shutil

    planted = tmp_path / "config"
    shutil.copytree(config_file("cell.yaml").parent, planted)
    plant = planted / "plant.yaml"
    plant.write_text(plant.read_text().replace("    grinding: true", "    mode_frequency_hz: 5.0\n    grinding: true"))
    duplicates, _ = _duplicates(_written_values(planted))
    assert "mode_frequency_hz = 5 in plant.yaml and nist_ingersoll.yaml" in duplicates, duplicates
    found = _written_values()
    assert not [s for s, _, _ in found["force_max_n"] if s != "cell.yaml"]  # F_max: the cell's alone
    assert not [s for s, _, _ in found["spring_n_mm_rad"] if s != "cell.yaml"]  # K_theta likewise


def test_node_parameters_write_no_physical_number():
    """A node's parameter defaults come from the cell configuration or a library dataclass:
    no ``"<physical name>": Spec(<number>, ...)`` in a node module."""
    physical, found = _physical_names(), []
    for path in sorted((REPO / "hex_control" / "ros" / "nodes").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Dict):
                for key, value in zip(node.keys, node.values):
                    if (isinstance(key, ast.Constant) and key.value in physical and isinstance(value, ast.Call)
                            and value.args and isinstance(value.args[0], ast.Constant)
                            and _number(value.args[0].value)):
                        found.append(f"{path.name}: {key.value} = {value.args[0].value}")
    assert not found, found


def test_the_cell_configuration_is_the_defaults_of_every_class_and_node():
    cell = cell_configuration()
    assert GrindingProcess().force_max_n == cell.force_max_n == 60.0
    assert DiskModel().spring_n_mm_rad == ForceTableParameters().rotational_stiffness_n_mm_rad == 6e5
    assert DiskModel().relaxed_angle_rad == math.radians(20.0)
    assert ForceTableParameters().stiffness_n_per_mm == cell.stiffness_n_per_mm == 6e5 / 85.0**2
    assert cell.overload_n == 2.5 * cell.force_max_n == 150.0
    params = MachineParameters()
    assert (params.mode_frequency_hz, params.mode_damping) == (5.0, 0.02)  # the machine file's
    assert cell.structure == {"mode_frequency_hz": 5.0, "mode_damping": 0.02}
    from hex_control.ros.nodes import force_controller, input_shaper, plant_setup

    assert force_controller.PARAMETERS["overload_n"].default == plant_setup.PARAMETERS["overload_n"].default == 150.0
    assert force_controller.PARAMETERS["contact_mm"].default == plant_setup.PARAMETERS["contact_mm"].default == 0.0
    assert input_shaper.PARAMETERS["frequency_hz"].default == plant_setup.PARAMETERS["mode_frequency_hz"].default
    assert input_shaper.PARAMETERS["damping"].default == plant_setup.PARAMETERS["mode_damping"].default


def test_every_machine_file_gives_its_structural_mode(tmp_path):
    for path in sorted(config_file("cell.yaml").parent.glob("machines/*.yaml")):
        assert load_cell_configuration(machine=path).structure.keys() == set(STRUCTURE_FIELDS), path.name
    bare = tmp_path / "bare.yaml"
    bare.write_text("machine: {type: pru3}\n")
    try:
        load_cell_configuration(machine=bare)
    except ValueError as exc:
        assert "structure" in str(exc)
    else:
        raise AssertionError("a machine file without its structural mode was taken")


#: ``_n_mm`` is N*mm (a torque or moment, or per N*mm); a stiffness in N/mm is ``_n_per_mm``
N_MM = re.compile(r"\b([a-z0-9_]+)_n_mm\b")


def test_one_unit_suffix_convention():
    wrong = []
    for path in sorted([*REPO.glob("hex_control/**/*.py"), *REPO.glob("config/**/*.yaml"), *REPO.glob("docs/*.md"),
                        *REPO.glob("test/*.py")]):
        if path.name == "test_config.py":
            continue
        for match in N_MM.finditer(path.read_text()):
            name = match.group(0)
            if not re.search(r"torque|moment|per_n_mm$", name):
                wrong.append(f"{path.relative_to(REPO)}: {name}")
    assert not wrong, f"_n_mm is N*mm; a stiffness is _n_per_mm: {sorted(set(wrong))}"
