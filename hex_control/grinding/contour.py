"""Weld-bead contours in two dimensions (seed 002 section 6.1): a polyline z(x) over
0 <= x <= L along the bead, with the parent surface under it, and the final contour that
removes a given volume (eq. 6.1-6.2). Units: mm (volumes mm^3, areas mm^2).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: a contour's points at most, as a scan may hold them: planning a pass costs time in
#: proportion to its points, and a 10^6-point contour kept the pass planner busy for minutes
MAX_CONTOUR_POINTS = 100_000
BRACKET_DOUBLINGS = 64  # a final contour's level is searched at most this many doublings below the top


@dataclass(frozen=True)
class Contour:
    """Heights ``z_mm`` at increasing positions ``x_mm``; ``parent_mm`` is the parent
    surface under the bead (zeros when not given)."""

    x_mm: np.ndarray
    z_mm: np.ndarray
    parent_mm: np.ndarray | None = None

    def __post_init__(self):
        x, z = np.asarray(self.x_mm, float), np.asarray(self.z_mm, float)
        parent = np.zeros_like(z) if self.parent_mm is None else np.asarray(self.parent_mm, float)
        if x.ndim != 1 or x.size < 2 or x.shape != z.shape or parent.shape != z.shape:
            raise ValueError("need at least two points and equal-length x, z (and parent) arrays")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z)) and np.all(np.isfinite(parent))):
            raise ValueError("contour values must be finite")
        if np.any(np.diff(x) <= 0):
            raise ValueError("x_mm must be strictly increasing")
        object.__setattr__(self, "x_mm", x)
        object.__setattr__(self, "z_mm", z)
        object.__setattr__(self, "parent_mm", parent)

    @property
    def length_mm(self) -> float:
        return float(self.x_mm[-1] - self.x_mm[0])

    def height_at(self, x_mm) -> np.ndarray:
        return np.interp(x_mm, self.x_mm, self.z_mm)

    def area_above(self, floor_mm) -> float:
        """Integral of g(z - floor) dx (mm^2), g(z) = max(z, 0), exact for polylines."""
        return positive_area(self.x_mm, self.z_mm - np.broadcast_to(floor_mm, self.z_mm.shape))

    @classmethod
    def from_csv(cls, path) -> "Contour":
        """A measured profile: columns x_mm, z_mm and optionally parent_mm, with a header."""
        with Path(path).open(newline="") as stream:
            rows = list(csv.DictReader(stream))
        if not rows or not {"x_mm", "z_mm"} <= set(rows[0]):
            raise ValueError(f"{path}: need a header with x_mm and z_mm columns")
        column = lambda name: np.array([float(r[name]) for r in rows])  # noqa: E731
        return cls(column("x_mm"), column("z_mm"), column("parent_mm") if "parent_mm" in rows[0] else None)

    def to_csv(self, path) -> None:
        with Path(path).open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["x_mm", "z_mm", "parent_mm"])
            writer.writerows(zip(self.x_mm, self.z_mm, self.parent_mm))


def positive_area(x_mm: np.ndarray, d_mm: np.ndarray) -> float:
    """Integral of max(d, 0) over a polyline d(x), exactly: on a segment whose ends have
    opposite signs only the triangle on the positive side counts."""
    a, b, h = d_mm[:-1], d_mm[1:], np.diff(x_mm)
    both = np.where((a >= 0) & (b >= 0), h * (a + b) / 2, 0.0)
    mixed = ((a > 0) & (b < 0)) | ((a < 0) & (b > 0))
    top = np.maximum(a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        crossing = np.where(mixed & (top > 0), h * top**2 / (2 * np.abs(a - b)), 0.0)
    return float(np.sum(both) + np.sum(crossing))


def weld_bead(length_mm: float = 150.0, height_mm: float = 3.0, end_ramp_mm: float = 12.0,
              spacing_mm: float = 0.5, parent_curvature_per_mm: float = 0.0, *, ripple_mm: float = 0.1,
              ripple_wavelength_mm: float = 8.0, seed: int = 0) -> Contour:
    """A test bead: a flat-topped bead of ``height_mm`` whose ends round off over
    ``end_ramp_mm`` (a quarter-sine), on a parent surface of the given curvature (its sag
    c (x - L/2)^2 / 2), with a smooth random ripple of RMS about ``ripple_mm`` (noise
    filtered to ``ripple_wavelength_mm``), seeded."""
    if not (length_mm > 2 * end_ramp_mm >= 0 and height_mm >= 0 and spacing_mm > 0):
        raise ValueError("need length > 2 end ramps, height >= 0, spacing > 0")
    x = np.linspace(0.0, length_mm, int(round(length_mm / spacing_mm)) + 1)
    parent = parent_curvature_per_mm * (x - length_mm / 2) ** 2 / 2
    edge = np.minimum(x, length_mm - x)
    shape = np.sin(np.clip(edge / end_ramp_mm, 0, 1) * math.pi / 2) if end_ramp_mm > 0 else np.ones_like(x)
    rng = np.random.default_rng(seed)
    width = max(1, int(round(ripple_wavelength_mm / spacing_mm)))
    noise = np.convolve(rng.normal(size=x.size + width), np.ones(width) / math.sqrt(width), mode="same")[:x.size]
    ripple = ripple_mm * noise * shape
    return Contour(x, parent + height_mm * shape + ripple, parent)


@dataclass(frozen=True)
class FinalContour:
    offset_mm: float  # N of eq. 6.2b: the desired shape's height adjustment
    tip_mm: np.ndarray  # the disk-tip trajectory max(z_f + N, Z_i - cap) at the initial x (may lie below Z_i's dips)
    contour: Contour  # Z_f = min(tip, Z_i), eq. 6.2c, with the crossings added to its x
    removed_mm3: float
    max_cut_mm: float = math.inf  # the local cut's cap (inf: eq. 6.2 as printed)


def final_contour(initial: Contour, cut_depth_mm: float, width_mm: float, shape_mm=None,
                  tolerance: float = 1e-9, *, max_cut_mm: float = math.inf, cap_slope: float = 0.05) -> FinalContour:
    """Eq. 6.1-6.2: Delta V = delta w L; find N by bisection so that
    w int_0^L g(Z_i(x) - z_f(x) - N) dx = Delta V, then Z_f = min(z_f + N, Z_i).

    The desired shape z_f defaults to the parent surface (a final contour parallel to it).
    Eq. 6.2a prints g(Z_i - z_f + eta); with 6.2c's z_f + N as the final height the removed
    depth is Z_i - z_f - N, the sign used here.

    ``max_cut_mm`` caps the local cut, so that no point needs more than the force that cuts
    it (F_max, seed 002 ch. 5): a shallow level top on a rippled bead would cut the crests
    several times deeper than the mean. Capped, the tip runs no lower than the cap under the
    bead's upper envelope of slope ``cap_slope`` (a cone rolled over Z_i - z_f, so that
    the tip rises and falls no steeper than that, over ripple and bead ends alike); the
    crests keep what the cap leaves for later passes and N sinks to keep the volume, but not
    below the cap over the shape (nor below eq. 6.2's N where that is lower): the cap does not
    finish the bead's ends and troughs down to the parent while crests still stand, where
    every later pass would run on the finished surface. When that cannot remove Delta V,
    ``removed_mm3`` is smaller.
    """
    if not (math.isfinite(cut_depth_mm) and cut_depth_mm >= 0 and width_mm > 0):
        raise ValueError("need a finite cut depth >= 0 and a width > 0 (mm)")
    if not (max_cut_mm > 0 and math.isfinite(cap_slope) and cap_slope >= 0):
        raise ValueError(f"need a cap on the local cut > 0 mm and a slope >= 0, got {max_cut_mm!r}, {cap_slope!r}")
    shape = initial.parent_mm if shape_mm is None else np.broadcast_to(np.asarray(shape_mm, float), initial.z_mm.shape)
    wanted = cut_depth_mm * width_mm * initial.length_mm  # eq. 6.1
    above = initial.z_mm - shape
    level = lambda n: np.full_like(above, n)  # noqa: E731 -- eq. 6.2's tip above the shape
    offset = _offset_for(initial.x_mm, above, level, wanted, width_mm, depth_mm=cut_depth_mm, tolerance=tolerance)
    if float(np.max(above)) - offset > max_cut_mm:  # the cap binds somewhere
        floor = _cone_envelope(initial.x_mm, above, cap_slope) - max_cut_mm
        capped = lambda n: np.maximum(n, floor)  # noqa: E731
        lowest = min(offset, max_cut_mm)
        if width_mm * positive_area(initial.x_mm, above - capped(lowest)) <= wanted:
            offset = lowest
        else:
            offset = _offset_for(initial.x_mm, above, capped, wanted, width_mm, depth_mm=cut_depth_mm,
                                 tolerance=tolerance, low=lowest)
        level = capped
    tip = shape + level(offset)
    return FinalContour(offset, tip, _lower_envelope(initial, tip),
                        width_mm * positive_area(initial.x_mm, initial.z_mm - tip), max_cut_mm)


def _offset_for(x_mm, above_mm, level, wanted_mm3: float, width_mm: float, *, depth_mm: float, tolerance: float,
                low: float | None = None) -> float:
    """N where w int g(above - level(N)) dx = wanted, ``level`` increasing in N (bisection)."""
    removed = lambda n: width_mm * positive_area(x_mm, above_mm - level(n))  # noqa: E731
    high = float(np.max(above_mm))  # nothing is removed above the highest point
    if low is None:
        low = high - depth_mm * 2 - 1.0
        for _ in range(BRACKET_DOUBLINGS):  # the bisection needs a bracket: go deeper until it holds
            if removed(low) >= wanted_mm3:
                break
            low = high - 2 * (high - low)
        else:  # (heights of 1e16 mm and more: the doubling no longer moves in floats)
            raise ValueError(f"no level removes {wanted_mm3:g} mm^3 in {BRACKET_DOUBLINGS} doublings below the top")
    for _ in range(200):
        middle = (low + high) / 2
        if removed(middle) > wanted_mm3:
            low = middle
        else:
            high = middle
        if high - low <= tolerance * max(1.0, abs(middle)):
            break
    return (low + high) / 2


def _cone_envelope(x_mm: np.ndarray, z_mm: np.ndarray, slope: float) -> np.ndarray:
    """max_j (z_j - slope |x - x_j|): the lowest curve of slope <= ``slope`` on or above z
    (two running maxima, exact on the samples)."""
    forward = np.maximum.accumulate(z_mm + slope * x_mm) - slope * x_mm
    backward = np.maximum.accumulate((z_mm - slope * x_mm)[::-1])[::-1] + slope * x_mm
    return np.maximum(forward, backward)


def _lower_envelope(initial: Contour, tip_mm: np.ndarray) -> Contour:
    """min(tip, Z_i) as a polyline, with the points where the two cross inserted, so that
    it is exact between the samples too."""
    d = initial.z_mm - tip_mm
    crossing = np.nonzero((d[:-1] > 0) != (d[1:] > 0))[0]
    crossing = crossing[(d[crossing] != 0) & (d[crossing + 1] != 0)]
    fraction = d[crossing] / (d[crossing] - d[crossing + 1])
    x_new = initial.x_mm[crossing] + fraction * np.diff(initial.x_mm)[crossing]
    x = np.concatenate([initial.x_mm, x_new])
    order = np.argsort(x, kind="stable")
    z = np.concatenate([np.minimum(tip_mm, initial.z_mm), initial.height_at(x_new)])
    parent = np.interp(x, initial.x_mm, initial.parent_mm)
    return Contour(x[order], z[order], parent[order])
