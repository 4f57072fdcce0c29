"""The machine's struts and its lightly damped structural mode (DESIGN.md section 4, plant).

Each strut follows its length command through a second-order servo,
    l_i'' + 2 zeta_s w_s l_i' + w_s^2 l_i = w_s^2 c_i,
and the structure carries one lightly damped mode y (the tool's deflection) that the
struts' accelerations drive as a base excitation,
    y'' + 2 zeta_m w_m y' + w_m^2 y = -sum_i p_i l_i''.
The whole is linear in the strut commands, so it is discretized once, exactly (zero-order
hold), and stepped as one matrix product. Unshaped moves ring the mode at w_m; moves through
an input shaper designed for it (:mod:`hex_control.shaping`) do not.
Units: strut lengths and commands in m, the deflection in mm, time in s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hex_control.config import cell_default
from hex_control.control.discretize import zero_order_hold


@dataclass(frozen=True)
class MachineParameters:
    struts: int = 6
    servo_frequency_hz: float = 30.0
    servo_damping: float = 0.9
    # the structural mode: the machine file's (config/machines/*.yaml structure), the input shaper's design mode
    mode_frequency_hz: float = field(default_factory=cell_default("structure.mode_frequency_hz"))
    mode_damping: float = field(default_factory=cell_default("structure.mode_damping"))
    participation: float = 1.0 / 6.0  # p_i: share of each strut's acceleration in the mode


class Machine:
    """``step(commands_m)`` one internal step; read ``lengths_m``, ``speeds_m_s``, ``deflection_mm``."""

    def __init__(self, parameters: MachineParameters = MachineParameters(), step_s: float = 1e-3):
        if not (step_s > 0 and parameters.struts >= 1):
            raise ValueError("need step_s > 0 and at least one strut")
        self.p, self.step_s = parameters, step_s
        n = parameters.struts
        ws, zs = 2 * math.pi * parameters.servo_frequency_hz, parameters.servo_damping
        wm, zm = 2 * math.pi * parameters.mode_frequency_hz, parameters.mode_damping
        # state [l (n), l' (n), y, y'], input c (n); strut acceleration a = w_s^2 (c - l) - 2 zeta_s w_s l'
        a = np.zeros((2 * n + 2, 2 * n + 2))
        b = np.zeros((2 * n + 2, n))
        a[:n, n:2 * n] = np.eye(n)
        a[n:2 * n, :n] = -ws**2 * np.eye(n)
        a[n:2 * n, n:2 * n] = -2 * zs * ws * np.eye(n)
        b[n:2 * n] = ws**2 * np.eye(n)
        a[2 * n, 2 * n + 1] = 1.0
        a[2 * n + 1, 2 * n] = -wm**2
        a[2 * n + 1, 2 * n + 1] = -2 * zm * wm
        a[2 * n + 1] -= parameters.participation * a[n:2 * n].sum(axis=0)
        b[2 * n + 1] = -parameters.participation * b[n:2 * n].sum(axis=0)
        ad, bd = zero_order_hold(a, b, step_s)
        self._ad, self._bd = ad, bd
        self.reset(np.zeros(n))

    def reset(self, lengths_m) -> None:
        lengths = np.asarray(lengths_m, float).reshape(-1)
        if lengths.shape != (self.p.struts,):
            raise ValueError(f"need {self.p.struts} strut lengths")
        self.time_s = 0.0
        self._x = np.concatenate([lengths, np.zeros(self.p.struts + 2)])

    @property
    def lengths_m(self) -> np.ndarray:
        return self._x[:self.p.struts].copy()

    @property
    def speeds_m_s(self) -> np.ndarray:
        return self._x[self.p.struts:2 * self.p.struts].copy()

    @property
    def deflection_mm(self) -> float:
        return float(self._x[2 * self.p.struts]) * 1e3

    def step(self, commands_m) -> None:
        self.advance(commands_m, 1)

    def advance(self, commands_m, steps: int) -> None:
        """``steps`` internal steps holding ``commands_m``: bit for bit ``steps`` calls of
        :meth:`step`, the commands checked and their input term formed once."""
        commands = np.asarray(commands_m, float).reshape(-1)
        if commands.shape != (self.p.struts,) or not np.all(np.isfinite(commands)):
            raise ValueError(f"need {self.p.struts} finite strut commands")
        ad, x, driven = self._ad, self._x, self._bd @ commands
        for _ in range(steps):
            x = ad @ x + driven
            self.time_s += self.step_s
        self._x = x
