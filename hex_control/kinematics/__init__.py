"""Machine geometry: Stewart-Gough 6-6 hexapod (seed 000 part 1) and 3-PRU (seed 001).

Units: mm and rad. ``load_machine`` reads a machine YAML (``config/machines/``); what a
machine answers is :class:`~hex_control.kinematics.machine_kind.MachineKind`.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import yaml

from hex_control.kinematics.machine_kind import MachineKind
from hex_control.kinematics.pru3 import Pru3Geometry
from hex_control.kinematics.stewart import StewartGeometry

#: the kinds by the one name each has everywhere (machine YAML ``type``, ``hexctl demo --machine``)
MACHINE_TYPES = {"hexapod": StewartGeometry, "pru3": Pru3Geometry}
#: former spellings of a kind, still read from machine files: old name -> name
KIND_ALIASES = {"stewart": "hexapod"}


def machine_kind_name(kind: str) -> str:
    """The kind's name in ``MACHINE_TYPES`` for a YAML ``type`` (a former spelling: a
    DeprecationWarning that says the new one); ValueError for an unknown kind."""
    if kind in KIND_ALIASES:
        warnings.warn(f"machine type {kind!r} is now spelled {KIND_ALIASES[kind]!r} (as in hexctl demo --machine); "
                      f"{kind!r} is still read", DeprecationWarning, stacklevel=3)
        kind = KIND_ALIASES[kind]
    if kind not in MACHINE_TYPES:
        raise ValueError(f"unknown machine type {kind!r}; known: {sorted(MACHINE_TYPES)}")
    return kind


def load_machine(source) -> tuple[MachineKind, dict]:
    """(geometry, the whole YAML document) from a path or an already parsed dict.

    The document's ``machine.type`` picks the class (default ``hexapod``); other
    top-level sections (e.g. ``workspace``) are returned for the caller.
    """
    document = source if isinstance(source, dict) else yaml.safe_load(Path(source).read_text())
    machine = document.get("machine", document)
    return MACHINE_TYPES[machine_kind_name(machine.get("type", "hexapod"))].from_dict(machine), document


__all__ = ["KIND_ALIASES", "MACHINE_TYPES", "MachineKind", "Pru3Geometry", "StewartGeometry", "load_machine",
           "machine_kind_name"]
