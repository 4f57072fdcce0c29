"""The machines of a generation system (seed 000 part 2, section 2): bounds, the quadratic
running cost of eq. 2.5 and the starting cost as a function of the hours down (the
appendix tables give CS(1..6); eq. 2.6's exponential form where coefficients are given).

Units: MW, hours, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import yaml

from hex_control.config import config_path


@dataclass(frozen=True)
class Unit:
    """One machine: G_min <= G <= G_max when on (MW), CG = a1 + a2 G + a3 G^2 (eq. 2.5),
    and ``start_cost[k]`` the cost of a start after k + 1 hours down (the last for longer)."""

    g_min_mw: float
    g_max_mw: float
    a1: float
    a2: float
    a3: float
    start_cost: tuple[float, ...] = (0.0,)

    def __post_init__(self):
        values = (self.g_min_mw, self.g_max_mw, self.a1, self.a2, self.a3, *self.start_cost)
        if not all(math.isfinite(v) for v in values) or not self.start_cost:
            raise ValueError(f"a unit needs finite bounds, coefficients and start costs, got {values}")
        if not 0 <= self.g_min_mw <= self.g_max_mw:
            raise ValueError(f"need 0 <= G_min <= G_max, got {self.g_min_mw}, {self.g_max_mw} MW")
        if min(self.a1, self.a2, self.a3, *self.start_cost) < 0:
            raise ValueError("cost coefficients are non-negative (section 2)")

    def running_cost(self, g_mw):
        """CG(G) = a1 + a2 G + a3 G^2 (eq. 2.5), per hour."""
        g = np.asarray(g_mw, float)
        return self.a1 + self.a2 * g + self.a3 * g**2

    def incremental_cost(self, g_mw):
        """dCG/dG = a2 + 2 a3 G (eq. 2.7's lambda at G), per MWh."""
        return self.a2 + 2.0 * self.a3 * np.asarray(g_mw, float)

    def starting_cost(self, hours_down: int) -> float:
        """CS after ``hours_down`` hours off (>= 1): the table's entry, its last beyond it."""
        if hours_down < 1:
            raise ValueError(f"a unit that starts has been down at least 1 hour, got {hours_down}")
        return float(self.start_cost[min(int(hours_down), len(self.start_cost)) - 1])


def exponential_start_cost(b1: float, b2: float, b3: float, hours_down) -> np.ndarray:
    """CS = b1 (1 - b2 exp(-b3 d)) (eq. 2.6) after d hours down."""
    return b1 * (1.0 - b2 * np.exp(-b3 * np.asarray(hours_down, float)))


@dataclass(frozen=True)
class Fleet:
    name: str
    units: tuple[Unit, ...]

    def __len__(self) -> int:
        return len(self.units)

    @property
    def capacity_mw(self) -> tuple[float, float]:
        """(sum of G_min, sum of G_max) with every unit on."""
        return (sum(u.g_min_mw for u in self.units), sum(u.g_max_mw for u in self.units))

    @classmethod
    def from_yaml(cls, source) -> Fleet:
        """A fleet file (``config/unit_commitment/fleet_*.yaml``): a path or a name there."""
        path = config_path(source, "unit_commitment")
        data = yaml.safe_load(path.read_text())
        units = [Unit(float(u["g_min_mw"]), float(u["g_max_mw"]), float(u["a1"]), float(u["a2"]), float(u["a3"]),
                      tuple(float(c) for c in u["start_cost"])) for u in data["units"]]
        return cls(str(data.get("fleet", path.stem)), tuple(units))
