"""The planner's YAML: process, charges, grid and cut-depth model in one file."""

from __future__ import annotations

from pathlib import Path

import yaml

from hex_control.config import config_file
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.sdp import Charges, PlannerGrid, charges_from_dict
from hex_control.grinding.stochastic import CutDepthModel


def parse_planner_config(data: dict) -> tuple[GrindingProcess, Charges, PlannerGrid, CutDepthModel]:
    unknown = set(data) - {"process", "charges", "grid", "cut_model"}
    if unknown:
        raise ValueError(f"unknown planner sections {sorted(unknown)}")
    return (GrindingProcess.from_dict(data.get("process", {})), charges_from_dict(data.get("charges", {})),
            PlannerGrid(**data.get("grid", {})), CutDepthModel(**data.get("cut_model", {})))


def load_planner_config(source) -> tuple[GrindingProcess, Charges, PlannerGrid, CutDepthModel]:
    """From a path, or a file name under config/."""
    path = Path(source)
    if not path.is_file():
        path = config_file(str(source))
    return parse_planner_config(yaml.safe_load(path.read_text()) or {})
