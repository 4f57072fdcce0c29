"""The contact search and truncation as they were before the incremental kernel (issue 39
item 1), kept verbatim as the baseline of ``hexctl bench pass-planning`` and of the tests
that check the new kernel against them: every call visits the whole face's span (80 mm of
the contour at R = 85 mm, theta = 20 deg) with ``np.unique`` / ``np.isin``, and every
truncation copies the whole contour. Units: mm, rad.
"""

from __future__ import annotations

import math

import numpy as np

from hex_control.grinding.contact import FACE, MULTIPLE, NO_PATCH, TIP, TOUCH_MM, ContactPatch, DiskPose, _height
from hex_control.grinding.contour import Contour


def contact_patch_reference(x_mm: np.ndarray, z_mm: np.ndarray, pose: DiskPose,
                            touch_mm: float = TOUCH_MM) -> ContactPatch:
    """The old ``contact_patch``: every contour point under the face's whole span."""
    if pose.tip_z_mm - touch_mm > z_mm.max():
        return NO_PATCH
    tip_x, centre_x = pose.tip_x_mm, pose.centre_x_mm
    lo = int(x_mm.searchsorted(tip_x, "right"))
    hi = int(x_mm.searchsorted(centre_x, "left"))
    xs = np.empty(hi - lo + 2)
    zs = np.empty_like(xs)
    xs[0], xs[-1] = tip_x, centre_x
    xs[1:-1] = x_mm[lo:hi]
    zs[0] = _height(x_mm, z_mm, lo, tip_x)
    zs[-1] = _height(x_mm, z_mm, hi, centre_x)
    zs[1:-1] = z_mm[lo:hi]
    depth = zs - (pose.centre_z_mm - (centre_x - xs) * math.tan(pose.angle_rad)) + touch_mm
    inside = depth > 0
    if not inside.any():
        return NO_PATCH
    a, b, h = depth[:-1], depth[1:], xs[1:] - xs[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = xs[:-1] + h * a / (a - b)
    start = np.where(a > 0, xs[:-1], cross)
    end = np.where(b > 0, xs[1:], cross)
    used = inside[:-1] | inside[1:]
    start, end = start[used], end[used]
    secant = 1.0 / math.cos(pose.angle_rad)
    length = float(np.sum(end - start)) * secant
    if length <= 0:
        return NO_PATCH
    moment = float(np.sum((end - start) * (centre_x - (start + end) / 2))) * secant * secant
    runs = int(np.count_nonzero(inside[1:] & ~inside[:-1])) + int(inside[0])
    kind = MULTIPLE if runs > 1 else (TIP if inside[0] else FACE)
    return ContactPatch(length, moment / length, runs, kind)


def clip_below_reference(x_mm: np.ndarray, z_mm: np.ndarray, cutter_x: np.ndarray, cutter_z: np.ndarray,
                         extra: tuple[np.ndarray, ...] = ()) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """The old ``clip_below``: the cutter's whole span, merged with np.unique, the whole contour copied."""
    first, last = max(cutter_x[0], x_mm[0]), min(cutter_x[-1], x_mm[-1])
    if first >= last or cutter_z.min() >= z_mm.max():
        return x_mm, z_mm, extra
    lo = int(np.searchsorted(x_mm, first, "left"))
    hi = int(np.searchsorted(x_mm, last, "right"))
    window_x = x_mm[lo:hi]
    contour_at_cutter = np.interp(cutter_x, x_mm, z_mm)
    cutter_under = (cutter_z < contour_at_cutter) & (cutter_x >= first) & (cutter_x <= last)
    window_over = z_mm[lo:hi] > np.interp(window_x, cutter_x, cutter_z)
    if not (cutter_under.any() or window_over.any()):
        return x_mm, z_mm, extra
    merged_x = np.unique(np.concatenate([window_x, cutter_x[cutter_under], [first, last]]))
    depth = np.interp(merged_x, x_mm, z_mm) - np.interp(merged_x, cutter_x, cutter_z)
    crossing = np.nonzero(((depth[:-1] > 0) & (depth[1:] < 0)) | ((depth[:-1] < 0) & (depth[1:] > 0)))[0]
    fraction = depth[crossing] / (depth[crossing] - depth[crossing + 1])
    crossing_x = merged_x[crossing] + fraction * (merged_x[crossing + 1] - merged_x[crossing])
    new_x = np.sort(np.concatenate([merged_x, crossing_x]))
    new_x = new_x[np.concatenate([[True], np.diff(new_x) > 1e-9])]
    original_z, cutter_at = np.interp(new_x, x_mm, z_mm), np.interp(new_x, cutter_x, cutter_z)
    keep = ((new_x != first) & (new_x != last)) | (cutter_at <= original_z) | np.isin(new_x, window_x)
    new_x, new_z = new_x[keep], np.minimum(original_z, cutter_at)[keep]
    out_x = np.concatenate([x_mm[:lo], new_x, x_mm[hi:]])
    out_z = np.concatenate([z_mm[:lo], new_z, z_mm[hi:]])
    out_extra = tuple(np.concatenate([e[:lo], np.interp(new_x, x_mm, e), e[hi:]]) for e in extra)
    return out_x, out_z, out_extra


class ReferenceContour:
    """The stepper's contour as it was: whole arrays, the old search and truncation on
    them at every call (the interface of :class:`hex_control.grinding.contact.LiveContour`)."""

    def __init__(self, contour: Contour, contact_search=contact_patch_reference):
        self.x, self.z, self.parent = contour.x_mm, contour.z_mm, contour.parent_mm
        self.contact_search = contact_search

    def contact(self, pose: DiskPose) -> ContactPatch:
        return self.contact_search(self.x, self.z, pose)

    def clip(self, cutter_x: np.ndarray, cutter_z: np.ndarray) -> None:
        self.x, self.z, (self.parent,) = clip_below_reference(self.x, self.z, cutter_x, cutter_z, (self.parent,))

    @property
    def contour(self) -> Contour:
        return Contour(self.x, self.z, self.parent)
