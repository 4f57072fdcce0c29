"""The planners' YAML: the sequence planner's process, charges, grid and cut-depth model;
the pass planner's process, spring, controller, compliance and bead frame.

The physical values of the cell -- the process and the disk -- are in one file,
``config/cell.yaml``, which a planner file names with ``cell:``; its own ``process`` and
``disk`` entries (the job's bead, the planning choices, a goal's overrides) go on top.
The whole cell configuration (with the force table and the machine's structural mode) is
:class:`hex_control.config.CellConfiguration`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import yaml

from hex_control.config import CELL_SECTIONS, config_path
from hex_control.grinding.dynamic import DiskModel
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.pass_plan import CONTROLS, Compliance, SearchStart
from hex_control.grinding.sdp import Charges, PlannerGrid, charges_from_dict
from hex_control.grinding.stochastic import CutDepthModel
from hex_control.grinding.tool_path import BeadFrame, PathTiming


def load_cell(source="cell.yaml") -> dict:
    """The cell's physical values (``process``, ``disk``, ``table``) from a path or a name under config/."""
    path = config_path(source)
    data = yaml.safe_load(path.read_text()) or {}
    unknown = set(data) - set(CELL_SECTIONS)
    if unknown:
        raise ValueError(f"unknown cell sections {sorted(unknown)} in {path}")
    return data


def cell_value(key: str, source="cell.yaml") -> float:
    """One of the cell's values by its dotted name, e.g. ``process.specific_energy_j_mm3``."""
    section, _, name = key.partition(".")
    try:
        return float(load_cell(source)[section][name])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"the cell ({source}) has no number {key!r}") from None


def with_cell(data: dict, sections=("process",)) -> dict:
    """``data`` with the cell file it names (``cell``) under its ``sections``."""
    if not data.get("cell"):
        return data
    cell = load_cell(data["cell"])
    merged = {k: v for k, v in data.items() if k != "cell"}
    for section in sections:
        merged[section] = {**(cell.get(section) or {}), **(data.get(section) or {})}
    return merged


def parse_planner_config(data: dict) -> tuple[GrindingProcess, Charges, PlannerGrid, CutDepthModel]:
    unknown = set(data) - {"cell", "process", "charges", "grid", "cut_model"}
    if unknown:
        raise ValueError(f"unknown planner sections {sorted(unknown)}")
    data = with_cell(data)
    return (GrindingProcess.from_dict(data.get("process", {})), charges_from_dict(data.get("charges", {})),
            PlannerGrid(**data.get("grid", {})), CutDepthModel(**data.get("cut_model", {})))


def load_planner_config(source) -> tuple[GrindingProcess, Charges, PlannerGrid, CutDepthModel]:
    """From a path, or a file name under config/."""
    path = config_path(source)
    return parse_planner_config(yaml.safe_load(path.read_text()) or {})


@dataclass(frozen=True)
class PassPlannerConfig:
    """The pass planner's YAML (config/pass_planner.yaml)."""

    model: DiskModel
    planner: str  # dynamic | static
    control: str  # height | relaxed_angle
    gains: tuple[float, float] | None
    step_mm: float
    compliance: Compliance
    frame: BeadFrame
    path: PathTiming
    search_start: SearchStart | None = None  # where a job's first guarded search starts (pass_plan)


def parse_pass_planner_config(data: dict) -> PassPlannerConfig:
    known = {"cell", "process", "disk", "planner", "control", "gains", "step_mm", "compliance", "bead_frame", "path",
             "search_start"}
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"unknown pass planner sections {sorted(unknown)}")
    data = with_cell(data, ("process", "disk"))
    disk = dict(data.get("disk") or {})
    if "relaxed_angle_deg" in disk:
        disk["relaxed_angle_rad"] = math.radians(disk.pop("relaxed_angle_deg"))
    model = DiskModel(GrindingProcess.from_dict(data.get("process") or {}), **disk)
    planner, control = data.get("planner", "dynamic"), data.get("control", "height")
    if planner not in ("dynamic", "static") or control not in CONTROLS:
        raise ValueError(f"planner must be dynamic|static and control one of {CONTROLS}")
    table = data.get("compliance")
    compliance = Compliance(table["deflection_rad"], table["torque_n_mm"]) if table \
        else Compliance.linear(model.spring_n_mm_rad)
    gains = data.get("gains")
    path = data.get("path") or {}
    unknown = set(path) - {f.name for f in fields(PathTiming)}
    if unknown:
        raise ValueError(f"unknown path fields {sorted(unknown)}")
    start = data.get("search_start")
    if start is not None:
        unknown = set(start) - {f.name for f in fields(SearchStart)} if isinstance(start, dict) else {"(not a map)"}
        if unknown:
            raise ValueError(f"unknown search_start fields {sorted(unknown)}")
    return PassPlannerConfig(model, planner, control, tuple(map(float, gains)) if gains else None,
                             float(data.get("step_mm", 0.1)), compliance,
                             BeadFrame(**{k: tuple(v) for k, v in (data.get("bead_frame") or {}).items()}),
                             PathTiming(**path), SearchStart(**start) if start is not None else None)


def load_pass_planner_config(source, machine_document: dict | None = None) -> PassPlannerConfig:
    """The pass planner's YAML (a path or a name under config/); a machine document (see
    :func:`hex_control.kinematics.load_machine`) with its own ``bead_frame`` places the bead
    for that machine."""
    path = config_path(source)
    data = yaml.safe_load(path.read_text()) or {}
    if machine_document and machine_document.get("bead_frame"):
        data = {**data, "bead_frame": machine_document["bead_frame"]}
    return parse_pass_planner_config(data)
