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

from dataclasses import dataclass

from hex_control.unit_commitment.commitments import Commitment, cheapest_commitments
from hex_control.unit_commitment.fleet import Fleet


@dataclass(frozen=True)
class TableRow:
    total_mw: float
    candidates: list[Commitment]  # cheapest first

    @property
    def cheapest(self) -> Commitment:
        return self.candidates[0]


def commitment_class(fleet: Fleet, on) -> tuple[int, ...]:
    """How many units of each kind are on: commitments that differ only in which of several
    identical units (the same bounds and running cost) are on cost the same and are one."""
    kinds = {}
    for unit, state in zip(fleet.units, on):
        key = (unit.g_min_mw, unit.g_max_mw, unit.a1, unit.a2, unit.a3)
        kinds[key] = kinds.get(key, 0) + bool(state)
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
                     start_mw: float | None = None, end_mw: float | None = None, progress=None) -> list[TableRow]:
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
