"""The scheduling table (seed 000 part 2, section 4, Fig. 2): for total generation levels
from the fleet's least to its greatest, the K cheapest commitments with their dispatch and
cost (starting costs left out). Levels are spaced by rule 4.1, delta G(j) = min(delta G,
X[G]): the nominal step, or less where the cheapest commitment changes within it (X[G], the
smallest increment with a different cheapest commitment: looked for on a grid of the step,
then found by bisection to ``resolution_mw``). K is fixed (the paper's rule 2: the first 2 or 3 are the ones used, so
4 or 5 suffice).

Units: MW, cost units per hour.
"""

from __future__ import annotations

import bisect
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hex_control.seeds.unit_commitment.commitments import Commitment, cheapest_commitments
from hex_control.seeds.unit_commitment.fleet import Fleet


@dataclass(frozen=True)
class TableRow:
    total_mw: float
    candidates: list[Commitment]  # cheapest first

    @property
    def cheapest(self) -> Commitment:
        return self.candidates[0]


def commitment_class(fleet: Fleet, on) -> tuple[int, ...]:
    """How many units of each kind are on: commitments that differ only in which of several
    identical units (the same in every figure) are on are one."""
    kinds = {}
    for unit, state in zip(fleet.units, on):
        kinds[unit] = kinds.get(unit, 0) + bool(state)
    return tuple(kinds.values())


def _cheapest_on(fleet: Fleet, total_mw: float) -> tuple[int, ...]:
    return commitment_class(fleet, cheapest_commitments(fleet, total_mw, 1)[0].on)


def next_level_mw(fleet: Fleet, total_mw: float, step_mw: float, resolution_mw: float, probes: int = 10) -> float:
    """G + min(delta G, X[G]) (eq. 4.1). X[G] is looked for on ``probes`` points of the step
    (the cheapest commitment may change and change back within it), then found by bisection
    to ``resolution_mw`` between the last point that keeps the commitment and the first
    that does not."""
    top = sum(u.g_max_mw for u in fleet.units)
    end = min(total_mw + step_mw, top)
    here = _cheapest_on(fleet, total_mw)
    low = total_mw
    for probe in range(1, probes + 1):
        high = total_mw + (end - total_mw) * probe / probes
        if _cheapest_on(fleet, high) != here:
            break
        low = high
    else:
        return end
    while high - low > resolution_mw:  # ``here`` at low, another commitment at high
        middle = 0.5 * (low + high)
        if _cheapest_on(fleet, middle) == here:
            low = middle
        else:
            high = middle
    return high


def scheduling_table(fleet: Fleet, k: int = 5, step_mw: float = 100.0, resolution_mw: float = 1.0,
                     start_mw: float | None = None, *, end_mw: float | None = None, progress=None) -> list[TableRow]:
    """The table's rows from ``start_mw`` (the least a single unit can give) to ``end_mw``
    (the fleet's capacity); ``progress(level_mw, end_mw)`` after each row."""
    if not (step_mw > 0 and resolution_mw > 0):
        raise ValueError("need a step and a resolution > 0 (MW)")
    top = sum(u.g_max_mw for u in fleet.units)
    level = min(u.g_min_mw for u in fleet.units) if start_mw is None else start_mw
    level = max(level, resolution_mw)
    end = top if end_mw is None else min(end_mw, top)
    rows = []
    while True:
        rows.append(TableRow(level, cheapest_commitments(fleet, level, k)))
        if progress:
            progress(level, end)
        if level >= end - 1e-9:
            return rows
        level = min(next_level_mw(fleet, level, step_mw, resolution_mw), end)


def candidates_at(rows: list[TableRow], total_mw: float) -> list[tuple[bool, ...]]:
    """The commitments the table offers for ``total_mw`` between its levels: those of the
    rows at and above it (cheapest first, each once). The caller dispatches them at the
    total; one may be unable to generate it (the dispatch says so)."""
    levels = [row.total_mw for row in rows]
    if not levels[0] - 1e-9 <= total_mw <= levels[-1] + 1e-9:
        raise ValueError(f"{total_mw} MW is outside the table's {levels[0]:g}..{levels[-1]:g} MW")
    j = max(bisect.bisect_right(levels, total_mw) - 1, 0)
    seen = {}
    for row in rows[j:j + 2]:
        for candidate in row.candidates:
            seen.setdefault(candidate.on, None)
    return list(seen)


def save_table(rows: list[TableRow], path) -> None:
    """Write the table as JSON: per level its candidates' on-bits ('1' on), levels, costs."""
    document = {"rows": [{"total_mw": row.total_mw,
                          "candidates": [{"on": "".join("1" if x else "0" for x in c.on),
                                          "levels_mw": [round(float(g), 6) for g in c.levels_mw],
                                          "cost_per_h": c.cost_per_h, "incremental_cost": c.incremental_cost}
                                         for c in row.candidates]} for row in rows]}
    Path(path).write_text(json.dumps(document))


def load_table(path, fleet: Fleet) -> list[TableRow]:
    """A table written by :func:`save_table`; ValueError if it is not of ``fleet``."""
    rows = []
    for row in json.loads(Path(path).read_text())["rows"]:
        candidates = [Commitment(tuple(bit == "1" for bit in c["on"]), np.array(c["levels_mw"], float),
                                 float(c["cost_per_h"]), float(c["incremental_cost"])) for c in row["candidates"]]
        if any(len(c.on) != len(fleet) for c in candidates):
            raise ValueError(f"{path} is a table of another fleet than {fleet.name}'s {len(fleet)} units")
        rows.append(TableRow(float(row["total_mw"]), candidates))
    return rows
