"""Machine geometry: Stewart-Gough 6-6 (seed 000 part 1) and 3-PRU (seed 001).

Units: mm and rad. ``load_machine`` reads a machine YAML (``config/machines/``).
"""

from __future__ import annotations

from pathlib import Path

import yaml

from hex_control.kinematics.pru3 import Pru3Geometry
from hex_control.kinematics.stewart import StewartGeometry

MACHINE_TYPES = {"stewart": StewartGeometry, "pru3": Pru3Geometry}


def load_machine(source) -> tuple[StewartGeometry | Pru3Geometry, dict]:
    """(geometry, the whole YAML document) from a path or an already parsed dict.

    The document's ``machine.type`` picks the class; other top-level sections (e.g.
    ``workspace``) are returned for the caller.
    """
    document = source if isinstance(source, dict) else yaml.safe_load(Path(source).read_text())
    machine = document.get("machine", document)
    kind = machine.get("type", "stewart")
    if kind not in MACHINE_TYPES:
        raise ValueError(f"unknown machine type {kind!r}; known: {sorted(MACHINE_TYPES)}")
    return MACHINE_TYPES[kind].from_dict(machine), document


__all__ = ["MACHINE_TYPES", "Pru3Geometry", "StewartGeometry", "load_machine"]
