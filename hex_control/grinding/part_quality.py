"""The finished part as its buyer measures it (seed 002 section 3): a bead "ground smooth with
the parent material so as to be undetectable after painting", which "implies dimensional
accuracies of less than 0.1 mm"; grinding into the parent (a gouge) is worse than leaving
material. The job's own state X is the mean removal (section 5.1) and cannot see either.

The deviation of a scanned profile is d(x) = z(x) - z_f(x), z_f the desired final contour
(the parent surface unless given). Figures are over the whole bead and over its two ends,
the first and last ``end_zone_mm`` of it, where the disk runs on and off. Units: mm.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from hex_control.grinding.contour import Contour

TOLERANCE_MM = 0.1  # seed 002 section 3


@dataclass(frozen=True)
class PartQuality:
    """Local figures of one scanned profile (mm; positions along the bead in mm)."""

    gouge_mm: float  # deepest point below the desired contour, >= 0 (0: nowhere below it)
    gouge_x_mm: float  # where it is
    highest_mm: float  # highest point above the desired contour (negative if gouged everywhere)
    highest_x_mm: float
    rms_mm: float  # RMS deviation over the whole bead (length-weighted)
    max_deviation_mm: float  # max |d| over the whole bead
    ends_rms_mm: float  # the same over the two end zones only
    ends_max_deviation_mm: float
    ends_gouge_mm: float

    def within(self, tolerance_mm: float = TOLERANCE_MM) -> bool:
        """Undetectable after painting: every point within the band |d| <= tolerance."""
        return self.max_deviation_mm <= tolerance_mm

    def as_dict(self) -> dict:
        return asdict(self)


def part_quality(contour: Contour, end_zone_mm: float, desired_mm=None) -> PartQuality:
    """The figures of ``contour`` against ``desired_mm`` (heights at its x, mm; default its
    parent surface), with end zones of ``end_zone_mm`` at each end of the bead."""
    x = contour.x_mm
    if not (np.isfinite(end_zone_mm) and 0 <= 2 * end_zone_mm <= contour.length_mm):
        raise ValueError(f"end zone {end_zone_mm!r} mm: need 0 <= 2 zones <= the bead's {contour.length_mm:g} mm")
    desired = contour.parent_mm if desired_mm is None else np.broadcast_to(np.asarray(desired_mm, float), x.shape)
    d = contour.z_mm - desired
    low, high = int(np.argmin(d)), int(np.argmax(d))
    ends = (x - x[0] <= end_zone_mm) | (x[-1] - x <= end_zone_mm)
    return PartQuality(gouge_mm=max(0.0, -float(d[low])), gouge_x_mm=float(x[low]),
                       highest_mm=float(d[high]), highest_x_mm=float(x[high]),
                       rms_mm=_rms(x, d), max_deviation_mm=float(np.max(np.abs(d))),
                       ends_rms_mm=_rms(x, np.where(ends, d, 0.0), ends),
                       ends_max_deviation_mm=float(np.max(np.abs(d[ends]), initial=0.0)),
                       ends_gouge_mm=max(0.0, -float(np.min(d[ends], initial=0.0))))


def _rms(x_mm: np.ndarray, d_mm: np.ndarray, mask=None) -> float:
    """sqrt(int d^2 dx / int dx) on the polyline's samples (trapezoid weights), over the
    samples in ``mask`` (all by default)."""
    weights = np.zeros_like(x_mm)
    h = np.diff(x_mm) / 2
    weights[:-1] += h
    weights[1:] += h
    if mask is not None:
        weights = np.where(mask, weights, 0.0)
    total = float(np.sum(weights))
    return float(np.sqrt(np.sum(weights * d_mm**2) / total)) if total > 0 else 0.0
