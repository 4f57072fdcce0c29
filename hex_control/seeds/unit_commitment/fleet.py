"""The machines of a generation system (seed 000 part 2, section 2): bounds, the quadratic
running cost of eq. 2.5 and the starting cost as a function of the hours down (the
appendix tables give CS(1..6); a fleet file may instead give eq. 2.6's exponential form,
which is then tabulated over the same hours).

:attr:`Fleet.arrays` is the one place the fleet becomes numpy arrays (the dispatch, the
branch and bound, the transfers and the DP over down times all read it).

Units: MW, hours, cost units (per hour for running costs, per start for starting costs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml

from hex_control.config import config_path

#: the appendix tables' columns: CS after 1..6 hours down (a longer down time costs as the 6th)
TABLE_HOURS = 6


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


def tabulated_start_cost(b1: float, b2: float, b3: float, hours: int = TABLE_HOURS) -> tuple[float, ...]:
    """Eq. 2.6 as the appendix tables give start costs: CS(1..``hours``) (the last for longer)."""
    if not (b1 >= 0 and 0 <= b2 <= 1 and b3 >= 0):
        raise ValueError(f"eq. 2.6 needs b1 >= 0, 0 <= b2 <= 1, b3 >= 0 (non-negative costs), got {b1}, {b2}, {b3}")
    return tuple(float(c) for c in exponential_start_cost(b1, b2, b3, np.arange(1, hours + 1)))


class FleetArrays:
    """The fleet as arrays (M units): bounds, cost coefficients, every unit's output at each
    of the fleet's incremental-cost breakpoints (for the exact dispatch), start costs by
    hours down with the hours beyond which they stop changing, and the groups of identical
    units."""

    def __init__(self, units):
        self.units = tuple(units)
        self.g_min, self.g_max, self.a1, self.a2, self.a3 = (
            np.array([getattr(u, name) for u in self.units], float)
            for name in ("g_min_mw", "g_max_mw", "a1", "a2", "a3"))
        self.size = len(self.units)
        # lambda at which each unit reaches G_min and G_max (eq. 2.7); between consecutive
        # ones every unit's output, and so any total, is linear in lambda
        self.breakpoints = np.unique(np.concatenate([self.a2 + 2 * self.a3 * self.g_min,
                                                     self.a2 + 2 * self.a3 * self.g_max]))
        with np.errstate(divide="ignore", invalid="ignore"):
            self.outputs_at_breakpoints = self.outputs(self.breakpoints)  # (K, M)
        self.start_costs = [unit.start_cost for unit in self.units]
        self.caps = [1 + max([j for j in range(1, len(c)) if c[j] != c[j - 1]], default=0) for c in self.start_costs]
        # (M, max cap + 1): a start's cost after d hours down (column d; 0 for d = 0, on)
        self.start_by_down = np.array([[0.0] + [c[min(d, len(c)) - 1] for d in range(1, max(self.caps) + 1)]
                                       for c in self.start_costs]).reshape(self.size, -1)
        groups = {}
        for i, unit in enumerate(self.units):
            groups.setdefault(unit, []).append(i)
        self.twins = [members for members in groups.values() if len(members) > 1]
        # (M, M): whether units j and k are identical (j itself included), and whether k comes before j
        self.same_kind = np.zeros((self.size, self.size), bool)
        for members in groups.values():
            self.same_kind[np.ix_(members, members)] = True
        self.earlier = np.tri(self.size, k=-1, dtype=bool)
        self.cache = {}  # tables derived from these arrays by other modules (the branch and bound's grid)

    def outputs(self, lam) -> np.ndarray:
        """(..., M) every unit's output at incremental cost(s) ``lam`` (eq. 2.7), on or off."""
        return np.clip((np.asarray(lam, float)[..., None] - self.a2) / (2.0 * self.a3), self.g_min, self.g_max)


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

    @cached_property
    def arrays(self) -> FleetArrays:
        """The fleet as arrays, built once (the dataclass is frozen, its units fixed)."""
        return FleetArrays(self.units)

    @classmethod
    def from_yaml(cls, source) -> Fleet:
        """A fleet file (``config/unit_commitment/fleet_*.yaml``): a path or a name there.
        ValueError (one line: what is wrong, in which file and machine) for a file that is
        not a fleet; FileNotFoundError for one that is not there."""
        path = find_config(source, "fleet file")
        data = read_mapping(path)
        units = data.get("units")
        if not isinstance(units, list) or not units:
            raise ValueError(f"{path}: 'units' must be a non-empty list of machines, got {_short(units)}")
        return cls(str(data.get("fleet", path.stem)), tuple(_unit(path, n, entry) for n, entry in enumerate(units, 1)))


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _unit(path: Path, number: int, entry) -> Unit:
    """Machine ``number`` (from 1) of a fleet file; ValueError naming the file and machine."""
    where = f"{path}: machine {number}"
    if not isinstance(entry, dict):
        raise ValueError(f"{where} must be a mapping of g_min_mw, g_max_mw, a1, a2, a3, start_cost, "
                         f"got {_short(entry)}")

    def number_of(key):
        if key not in entry:
            raise ValueError(f"{where} has no {key!r}")
        value = entry[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{where}: {key} must be a number, got {_short(value)}")
        return float(value)

    bounds_and_costs = [number_of(key) for key in ("g_min_mw", "g_max_mw", "a1", "a2", "a3")]
    if "start_cost_eq_2_6" in entry:  # b1, b2, b3 of eq. 2.6 instead of the table's CS(1..6)
        coefficients = entry["start_cost_eq_2_6"]
        if not isinstance(coefficients, dict) or set(coefficients) != {"b1", "b2", "b3"}:
            raise ValueError(f"{where}: start_cost_eq_2_6 must be {{b1, b2, b3}}, got {_short(coefficients)}")
        try:
            starts = tabulated_start_cost(*(float(coefficients[b]) for b in ("b1", "b2", "b3")))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: {exc}") from None
    else:
        starts = entry.get("start_cost", None)
        if not isinstance(starts, list) or not starts or not all(
                isinstance(c, (int, float)) and not isinstance(c, bool) for c in starts):
            raise ValueError(f"{where}: start_cost must be a non-empty list of numbers (CS after 1, 2, ... hours "
                             f"down) or start_cost_eq_2_6 given, got {_short(starts)}")
        starts = tuple(float(c) for c in starts)
    try:
        return Unit(*bounds_and_costs, starts)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def find_config(source, what: str) -> Path:
    """``source`` if it is a file, else the shipped ``config/unit_commitment/<source>``;
    FileNotFoundError naming what was looked for, as given (a path is not looked for in
    the shipped folder)."""
    path = Path(str(source))
    if path.is_file():
        return path
    if path.is_absolute() or len(path.parts) != 1 or not str(source):
        raise FileNotFoundError(f"no {what} {str(source)!r}")
    try:
        return config_path(path.name, "unit_commitment")
    except FileNotFoundError:
        raise FileNotFoundError(f"no {what} {str(source)!r} (neither a file here nor one of "
                                "config/unit_commitment/)") from None


def read_mapping(path: Path) -> dict:
    """The YAML (or JSON) mapping in ``path``; ValueError in one line if it is not one."""
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ValueError(f"{path}: not valid YAML or JSON{at}: {problem}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    if not isinstance(data, dict):
        got = "an empty file" if data is None else _short(data)
        raise ValueError(f"{path}: must be a mapping (YAML or JSON), got {got}")
    return data
