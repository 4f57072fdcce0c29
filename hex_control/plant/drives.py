"""The drives that move a machine's joints in the plant, by the name its geometry gives
(``plant_drive``, :mod:`hex_control.kinematics.machine_kind`): each takes the joint
commands (m) once an internal step and has the structural mode (seed 002 App. B).

- ``strut_servos``: one generic second-order servo per joint (:class:`Machine`), every
  joint driving the mode -- the hexapod's struts, or any machine without dynamics of its own.
- ``pru3_dynamics``: the 3-PRU head's rigid-body dynamics under its slider drives
  (:class:`Pru3Machine`, ``pru3_drive`` lspd or ctc), its feed stage a servo.
"""

from __future__ import annotations

from dataclasses import replace

from hex_control.kinematics.machine_kind import MachineKind
from hex_control.plant.machine import Machine, MachineParameters
from hex_control.plant.pru3_machine import Pru3Inertia, Pru3Machine


def strut_servos(geometry: MachineKind, parameters: MachineParameters, step_s: float, refresh_s: float,
                 pru3_drive: str) -> Machine:
    joints = len(geometry.joint_names)
    return Machine(replace(parameters, struts=joints, participation=1.0 / joints), step_s)


def pru3_dynamics(geometry, parameters: MachineParameters, step_s: float, refresh_s: float,
                  pru3_drive: str) -> Pru3Machine:
    return Pru3Machine(geometry, Pru3Inertia(), replace(parameters, struts=3, participation=1.0 / 3), step_s,
                       drive=pru3_drive, refresh_s=refresh_s)


PLANT_DRIVES = {"strut_servos": strut_servos, "pru3_dynamics": pru3_dynamics}


def make_drive(geometry: MachineKind, parameters: MachineParameters = MachineParameters(), step_s: float = 1e-3,
               refresh_s: float = 0.005, pru3_drive: str = "lspd") -> Machine | Pru3Machine:
    """The drive ``geometry.plant_drive`` for this machine, stepping every ``step_s``;
    ``refresh_s``: how often a drive with dynamics re-evaluates them."""
    if geometry.plant_drive not in PLANT_DRIVES:
        raise ValueError(f"machine {geometry.name!r} needs the drive {geometry.plant_drive!r}; "
                         f"known: {sorted(PLANT_DRIVES)}")
    return PLANT_DRIVES[geometry.plant_drive](geometry, parameters, step_s, refresh_s, pru3_drive)
