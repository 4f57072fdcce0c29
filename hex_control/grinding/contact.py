"""Disk-face / contour geometry of the dynamic grinding model (seed 002 section 6.5).

In two dimensions the cutting face of the rigid disk is a segment of length R from the
disk centre (x_c, H) down to the trailing tip at angle theta below the horizontal:

    tip = (x_c - R cos(theta), H - R sin(theta))       (the tip height is y of eq. 6.16)
    face(x) = H - (x_c - x) tan(theta),  tip_x <= x <= x_c

The disk advances in +x. Material of the contour above the face lies inside the disk: that
is the contact patch. Fig. 6-7's types are told apart by where the patch lies: none, one
patch reaching the tip, one patch along the face, or several (which are summed here, and
counted). A contour point on the face counts as touching (``touch_mm``): right after a
truncation the cut surface lies exactly on the face, and it is in contact.

Units: mm, rad. Contours are polylines (x strictly increasing), constant beyond their ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TOUCH_MM = 1e-7

NO_CONTACT, TIP, FACE, MULTIPLE = "none", "tip", "face", "multiple"


@dataclass(frozen=True)
class DiskPose:
    """Centre x (mm), centre height H (mm), face angle theta (rad), face length R (mm)."""

    centre_x_mm: float
    centre_z_mm: float
    angle_rad: float
    radius_mm: float

    @property
    def tip_x_mm(self) -> float:
        return self.centre_x_mm - self.radius_mm * math.cos(self.angle_rad)

    @property
    def tip_z_mm(self) -> float:
        return self.centre_z_mm - self.radius_mm * math.sin(self.angle_rad)

    def face_z(self, x_mm):
        return self.centre_z_mm - (self.centre_x_mm - np.asarray(x_mm, float)) * math.tan(self.angle_rad)


@dataclass(frozen=True)
class ContactPatch:
    """Patch length along the face (mm), its centroid's distance from the disk centre R*
    (mm, eq. 6.14; 0 without contact), the number of separate patches and Fig. 6-7's type."""

    length_mm: float
    centroid_mm: float
    patches: int
    kind: str

    def area_mm2(self, width_mm: float) -> float:
        return self.length_mm * width_mm


NO_PATCH = ContactPatch(0.0, 0.0, 0, NO_CONTACT)


def _height(x, z, i, at):
    """Polyline height at ``at`` given i = searchsorted(x, at): clamped beyond the ends."""
    if i <= 0:
        return z[0]
    if i >= len(x):
        return z[-1]
    x0, x1 = x[i - 1], x[i]
    return z[i - 1] + (z[i] - z[i - 1]) * (at - x0) / (x1 - x0)


def contact_patch(x_mm: np.ndarray, z_mm: np.ndarray, pose: DiskPose, touch_mm: float = TOUCH_MM) -> ContactPatch:
    """The part of the face with the contour on or above it, exactly for the polyline.

    Only the contour points under the face's span are visited (found by bisection), so a
    call costs O(log n + points under the face), and less when the whole face (whose lowest
    point is the tip) is above the whole contour: the approach and the reset move."""
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
    depth = zs - (pose.centre_z_mm - (centre_x - xs) * math.tan(pose.angle_rad)) + touch_mm  # > 0: inside the disk
    inside = depth > 0
    if not inside.any():
        return NO_PATCH
    a, b, h = depth[:-1], depth[1:], xs[1:] - xs[:-1]
    # the inside part of each segment [x_i, x_i+1] is [start, end]
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


def contact_patch_sampled(x_mm, z_mm, pose: DiskPose, samples: int = 200_001,
                          touch_mm: float = TOUCH_MM) -> ContactPatch:
    """Brute force: sample the face densely and count the samples under the contour.
    Slow and approximate (to about R / samples); for tests and the benchmark baseline."""
    xs = np.linspace(pose.tip_x_mm, pose.centre_x_mm, samples)
    inside = np.interp(xs, x_mm, z_mm) - pose.face_z(xs) + touch_mm > 0
    if not inside.any():
        return NO_PATCH
    secant = 1.0 / math.cos(pose.angle_rad)
    dx = (xs[-1] - xs[0]) / (samples - 1)
    length = np.count_nonzero(inside) * dx * secant
    centroid = float(np.mean(pose.centre_x_mm - xs[inside])) * secant
    runs = int(np.count_nonzero(np.diff(inside.astype(np.int8)) == 1)) + int(inside[0])
    kind = MULTIPLE if runs > 1 else (TIP if inside[0] else FACE)
    return ContactPatch(float(length), centroid, runs, kind)


def contact_patch_scan(x_mm, z_mm, pose: DiskPose, touch_mm: float = TOUCH_MM) -> ContactPatch:
    """The naive search: the same exact geometry over the whole contour at every call,
    instead of only the points under the face. The benchmark's baseline."""
    full_x = np.concatenate([[pose.tip_x_mm], x_mm, [pose.centre_x_mm]])
    order = np.argsort(full_x, kind="stable")
    xs = full_x[order]
    zs = np.interp(xs, x_mm, z_mm)
    keep = (xs >= pose.tip_x_mm) & (xs <= pose.centre_x_mm)
    return contact_patch(xs[keep], zs[keep], pose, touch_mm)


def clip_below(x_mm: np.ndarray, z_mm: np.ndarray, cutter_x: np.ndarray, cutter_z: np.ndarray,
               extra: tuple[np.ndarray, ...] = ()) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """Truncate the contour down to a cutter polyline over the cutter's span:
    z = min(z, cutter), with the cutter's vertices that lie under the contour and the
    crossings inserted, so the result is exact between samples too. ``extra`` arrays on
    the same x (the parent surface) are interpolated onto the new points. The contour's
    own span is not extended."""
    first, last = max(cutter_x[0], x_mm[0]), min(cutter_x[-1], x_mm[-1])
    if first >= last or cutter_z.min() >= z_mm.max():  # nothing to cut (the second: the tool is clear)
        return x_mm, z_mm, extra
    lo = int(np.searchsorted(x_mm, first, "left"))
    hi = int(np.searchsorted(x_mm, last, "right"))
    window_x = x_mm[lo:hi]
    contour_at_cutter = np.interp(cutter_x, x_mm, z_mm)
    cutter_under = (cutter_z < contour_at_cutter) & (cutter_x >= first) & (cutter_x <= last)
    window_over = z_mm[lo:hi] > np.interp(window_x, cutter_x, cutter_z)
    if not (cutter_under.any() or window_over.any()):
        return x_mm, z_mm, extra
    # the span's ends are kept while looking for crossings (the contour may cross the cutter
    # between an end and the first vertex inside), and dropped after if nothing is cut there
    merged_x = np.unique(np.concatenate([window_x, cutter_x[cutter_under], [first, last]]))
    depth = np.interp(merged_x, x_mm, z_mm) - np.interp(merged_x, cutter_x, cutter_z)
    crossing = np.nonzero(((depth[:-1] > 0) & (depth[1:] < 0)) | ((depth[:-1] < 0) & (depth[1:] > 0)))[0]
    fraction = depth[crossing] / (depth[crossing] - depth[crossing + 1])
    crossing_x = merged_x[crossing] + fraction * (merged_x[crossing + 1] - merged_x[crossing])
    new_x = np.sort(np.concatenate([merged_x, crossing_x]))
    new_x = new_x[np.concatenate([[True], np.diff(new_x) > 1e-9])]  # a crossing at a vertex
    original_z, cutter_at = np.interp(new_x, x_mm, z_mm), np.interp(new_x, cutter_x, cutter_z)
    keep = ((new_x != first) & (new_x != last)) | (cutter_at <= original_z) | np.isin(new_x, window_x)
    new_x, new_z = new_x[keep], np.minimum(original_z, cutter_at)[keep]
    out_x = np.concatenate([x_mm[:lo], new_x, x_mm[hi:]])
    out_z = np.concatenate([z_mm[:lo], new_z, z_mm[hi:]])
    out_extra = tuple(np.concatenate([e[:lo], np.interp(new_x, x_mm, e), e[hi:]]) for e in extra)
    return out_x, out_z, out_extra
