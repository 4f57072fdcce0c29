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

import bisect
import math
from typing import NamedTuple

import numpy as np

from hex_control.grinding.contour import Contour

try:  # the compiled kernel (_contact_c.c, built by setup.py); the functions below are its reference
    from hex_control.grinding import _contact_c as _compiled
except ImportError:  # pragma: no cover - not built (no C compiler): the plain Python kernel, slower
    _compiled = None

TOUCH_MM = 1e-7
SCALAR_POINTS = 40  # a contact search over at most this many points runs in plain floats
COLLINEAR_MM = 1e-12  # a point this close to the line between its neighbours adds nothing to a polyline

NO_CONTACT, TIP, FACE, MULTIPLE = "none", "tip", "face", "multiple"


class DiskPose(NamedTuple):  # a value made five times a simulation step: a tuple, not a dataclass
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


class ContactPatch(NamedTuple):
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


def contact_patch(x_mm: np.ndarray, z_mm: np.ndarray, pose: DiskPose, touch_mm: float = TOUCH_MM, *,
                  top_mm: float | None = None) -> ContactPatch:
    """The part of the face with the contour on or above it, exactly for the polyline.

    Only the contour points under the face where it is lower than the contour's highest
    point ``top_mm`` (an upper bound of ``z_mm``: its max if None) are visited, found by
    bisection: a face at theta rises above a bead of height h within h / tan(theta) of its
    tip (3 mm on a 1 mm bead at 20 deg, of the face's 80 mm), so a call costs O(log n +
    points in that reach), nothing when the whole face is above the contour (the approach
    and the reset move)."""
    top = float(z_mm.max()) if top_mm is None else top_mm
    if _compiled is not None:
        x, z = np.ascontiguousarray(x_mm, float), np.ascontiguousarray(z_mm, float)  # the buffers it reads
        length, centroid, runs, tip_inside = _compiled.contact_patch(
            x, z, pose.centre_x_mm, pose.centre_z_mm, pose.angle_rad, pose.radius_mm, touch_mm, top)
        return NO_PATCH if runs == 0 else ContactPatch(length, centroid, runs,
                                                       MULTIPLE if runs > 1 else (TIP if tip_inside else FACE))
    tip_z = pose.tip_z_mm
    if tip_z - touch_mm > top:
        return NO_PATCH
    tip_x, centre_x, tan = pose.tip_x_mm, pose.centre_x_mm, math.tan(pose.angle_rad)
    # beyond reach the face is above top + touch (by a hair, so no point there is inside)
    reach = (top + touch_mm - tip_z) / tan * (1 + 1e-9) + 1e-9 if tan > 0 else math.inf
    end_x = min(centre_x, tip_x + reach)
    lo = int(x_mm.searchsorted(tip_x, "right"))
    hi = int(x_mm.searchsorted(end_x, "left"))
    if hi - lo <= SCALAR_POINTS:
        return _patch_of_few(x_mm[lo:hi].tolist(), z_mm[lo:hi].tolist(), pose, tip_x=tip_x,
                             tip_height=_height(x_mm, z_mm, lo, tip_x), end_x=end_x,
                             end_height=_height(x_mm, z_mm, hi, end_x), touch_mm=touch_mm)
    xs = np.empty(hi - lo + 2)
    zs = np.empty_like(xs)
    xs[0], xs[-1] = tip_x, end_x
    xs[1:-1] = x_mm[lo:hi]
    zs[0] = _height(x_mm, z_mm, lo, tip_x)
    zs[-1] = _height(x_mm, z_mm, hi, end_x)
    zs[1:-1] = z_mm[lo:hi]
    depth = zs - (pose.centre_z_mm - (centre_x - xs) * tan) + touch_mm  # > 0: inside the disk
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


def _patch_of_few(xs: list, zs: list, pose: DiskPose, *, tip_x: float, tip_height: float, end_x: float,
                  end_height: float, touch_mm: float) -> ContactPatch:
    """:func:`contact_patch` over a few points, one at a time: the same sums in plain floats
    (numpy's per-call cost is most of a call on a dozen points)."""
    centre_x, centre_z, tan = pose.centre_x_mm, pose.centre_z_mm, math.tan(pose.angle_rad)
    x0 = tip_x
    d0 = tip_height - (centre_z - (centre_x - x0) * tan) + touch_mm
    runs = 1 if d0 > 0 else 0
    first_inside = d0 > 0
    length = moment = 0.0
    xs.append(end_x)
    zs.append(end_height)
    for x1, z1 in zip(xs, zs):
        d1 = z1 - (centre_z - (centre_x - x1) * tan) + touch_mm
        if d0 > 0 or d1 > 0:
            start = x0 if d0 > 0 else x0 + (x1 - x0) * d0 / (d0 - d1)
            end = x1 if d1 > 0 else x0 + (x1 - x0) * d0 / (d0 - d1)
            length += end - start
            moment += (end - start) * (centre_x - (start + end) / 2)
            if d1 > 0 >= d0:
                runs += 1
        x0, d0 = x1, d1
    if runs == 0:
        return NO_PATCH
    secant = 1.0 / math.cos(pose.angle_rad)
    length *= secant
    if length <= 0:
        return NO_PATCH
    kind = MULTIPLE if runs > 1 else (TIP if first_inside else FACE)
    return ContactPatch(length, moment * secant * secant / length, runs, kind)


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


def _below(cutter_x: np.ndarray, cutter_z: np.ndarray, top: float) -> tuple[np.ndarray, np.ndarray]:
    """The cutter polyline trimmed to where it can be below ``top`` (it ends a hair above
    it, where nothing is cut): the rising face's 80 mm become the few mm that can cut."""
    below = np.nonzero(cutter_z < top)[0]
    i, j, last = int(below[0]), int(below[-1]), cutter_x.size - 1
    if i == 0 and j == last:
        return cutter_x, cutter_z
    level = top + 1e-9 * (1.0 + abs(top))
    xs, zs = list(cutter_x[i:j + 1]), list(cutter_z[i:j + 1])
    if i > 0:
        f = (level - cutter_z[i]) / (cutter_z[i - 1] - cutter_z[i])
        xs.insert(0, cutter_x[i] + f * (cutter_x[i - 1] - cutter_x[i]))
        zs.insert(0, level)
    if j < last:
        f = (level - cutter_z[j]) / (cutter_z[j + 1] - cutter_z[j])
        xs.append(cutter_x[j] + f * (cutter_x[j + 1] - cutter_x[j]))
        zs.append(level)
    return np.array(xs), np.array(zs)


def clip_region(x_mm: np.ndarray, z_mm: np.ndarray, cutter_x: np.ndarray, cutter_z: np.ndarray,
                top_mm: float | None = None):
    """The truncation of :func:`clip_below` as a replacement: (lo, hi, new_x, new_z) whose
    points replace ``x_mm[lo:hi]``, or None if the cutter cuts nothing. ``top_mm``: an
    upper bound of ``z_mm`` (its max if None); only the cutter's part below it is visited,
    and the vertices are merged by bisection (no np.unique / np.isin over the span). All
    the cutter's vertices in the span are merged, not only those under the contour: the old
    truncation (``contact_reference``) interpolated the depth across a vertex above the
    contour and misplaced a crossing next to it (by 0.2 um where the tip left the work)."""
    top = float(z_mm.max()) if top_mm is None else top_mm
    if _compiled is not None:
        region = _compiled.clip_region(*(np.ascontiguousarray(a, float) for a in (x_mm, z_mm, cutter_x, cutter_z)),
                                       top, TOUCH_MM * 1e-2)
        return None if region is None else (region[0], region[1], np.frombuffer(region[2]), np.frombuffer(region[3]))
    if cutter_z.min() >= top:  # the tool is clear of the whole contour
        return None
    cutter_x, cutter_z = _below(cutter_x, cutter_z, top)
    first, last = max(cutter_x[0], x_mm[0]), min(cutter_x[-1], x_mm[-1])
    if first >= last:  # nothing to cut
        return None
    lo = int(x_mm.searchsorted(first, "left"))
    hi = int(x_mm.searchsorted(last, "right"))
    near = slice(max(lo - 1, 0), hi + 1)  # the window and its neighbours: all interpolation needs
    if hi - lo <= SCALAR_POINTS:
        return _clip_few(x_mm[near].tolist(), z_mm[near].tolist(), lo - near.start, cutter_x.tolist(),
                         cutter_z.tolist(), first=first, last=last, lo=lo, hi=hi)
    near_x, near_z = x_mm[near], z_mm[near]
    window_x = x_mm[lo:hi]
    contour_at_cutter = np.interp(cutter_x, near_x, near_z)
    cutter_under = (cutter_z < contour_at_cutter) & (cutter_x >= first) & (cutter_x <= last)
    window_over = z_mm[lo:hi] > np.interp(window_x, cutter_x, cutter_z)
    if not (cutter_under.any() or window_over.any()):
        return None
    # the span's ends and the cutter's vertices inside it are kept while looking for
    # crossings (between them both polylines are straight, so the crossings are exact), and
    # dropped after where nothing is cut
    added = [first, *cutter_x[(cutter_x > first) & (cutter_x < last)].tolist(), last]
    at = window_x.searchsorted(added)
    added = [x for x, i in zip(added, at) if i == window_x.size or window_x[i] != x]
    merged_x = np.insert(window_x, window_x.searchsorted(added), added) if added else window_x
    depth = np.interp(merged_x, near_x, near_z) - np.interp(merged_x, cutter_x, cutter_z)
    crossing = np.nonzero(((depth[:-1] > 0) & (depth[1:] < 0)) | ((depth[:-1] < 0) & (depth[1:] > 0)))[0]
    if crossing.size:
        fraction = depth[crossing] / (depth[crossing] - depth[crossing + 1])
        crossing_x = merged_x[crossing] + fraction * (merged_x[crossing + 1] - merged_x[crossing])
        new_x = np.sort(np.insert(merged_x, crossing + 1, crossing_x))
        new_x = new_x[np.concatenate([[True], np.diff(new_x) > 1e-9])]  # a crossing at a vertex
    else:
        new_x = merged_x
    original_z, cutter_at = np.interp(new_x, near_x, near_z), np.interp(new_x, cutter_x, cutter_z)
    keep = cutter_at <= original_z + TOUCH_MM * 1e-2  # touching (within 1e-9 mm): a crossing there
    # ... and every point that is not an added one (with none added, every point: it dropped
    # the uncut contour points then, found against the compiled kernel on 2026-12-07)
    keep |= ~np.isin(new_x, added, kind="sort") if len(added) > 4 else ~np.any(
        new_x[:, None] == np.array(added, float)[None, :], axis=1)
    return lo, hi, new_x[keep], np.minimum(original_z, cutter_at)[keep]


def _interp_sorted(at: list, xs: list, zs: list) -> list:
    """np.interp at increasing points, in plain floats (one walk): clamped beyond the ends."""
    out, j, n = [], 0, len(xs)
    for x in at:
        while j < n - 1 and xs[j + 1] <= x:
            j += 1
        if x < xs[0]:
            out.append(zs[0])
        elif j >= n - 1:
            out.append(zs[-1])
        else:
            out.append((zs[j + 1] - zs[j]) / (xs[j + 1] - xs[j]) * (x - xs[j]) + zs[j])
    return out


def _clip_few(xs: list, zs: list, offset: int, cutter_x: list, cutter_z: list, *, first: float, last: float,
              lo: int, hi: int):
    """:func:`clip_region` over a few points (``xs``, ``zs``: the window with a neighbour on
    each side where the contour has one; the window starts at ``offset``), in plain floats."""
    window = xs[offset:offset + hi - lo]
    contour_at_cutter = _interp_sorted(cutter_x, xs, zs)
    if not (any(first <= x <= last and z < c for x, z, c in zip(cutter_x, cutter_z, contour_at_cutter))
            or any(z > c for z, c in zip(zs[offset:offset + hi - lo], _interp_sorted(window, cutter_x, cutter_z)))):
        return None
    merged = list(window)
    added = []  # the span's ends and the cutter's vertices inside it, where not contour points
    for x in (first, *(x for x in cutter_x if first < x < last), last):
        i = bisect.bisect_left(merged, x)
        if i == len(merged) or merged[i] != x:
            merged.insert(i, x)
            added.append(x)
    depth = [a - b for a, b in zip(_interp_sorted(merged, xs, zs), _interp_sorted(merged, cutter_x, cutter_z))]
    new = [merged[0]]
    crossed = False
    for k in range(len(merged) - 1):
        a, b = depth[k], depth[k + 1]
        if (a > 0 > b) or (a < 0 < b):
            new.append(merged[k] + a / (a - b) * (merged[k + 1] - merged[k]))
            crossed = True
        new.append(merged[k + 1])
    if crossed:  # a crossing at a vertex (within 1e-9 mm) is the vertex
        new.sort()
        new = [new[0]] + [new[k] for k in range(1, len(new)) if new[k] - new[k - 1] > 1e-9]
    out_x, out_z = [], []
    for x, original, cutter in zip(new, _interp_sorted(new, xs, zs), _interp_sorted(new, cutter_x, cutter_z)):
        if cutter <= original + TOUCH_MM * 1e-2 or x not in added:
            out_x.append(x)
            out_z.append(min(original, cutter))
    return lo, hi, np.array(out_x), np.array(out_z)


def clip_below(x_mm: np.ndarray, z_mm: np.ndarray, cutter_x: np.ndarray, cutter_z: np.ndarray,
               extra: tuple[np.ndarray, ...] = (), *,
               top_mm: float | None = None) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """Truncate the contour down to a cutter polyline over the cutter's span:
    z = min(z, cutter), with the cutter's vertices that lie under the contour and the
    crossings inserted, so the result is exact between samples too. ``extra`` arrays on
    the same x (the parent surface) are interpolated onto the new points. The contour's
    own span is not extended. ``top_mm``: an upper bound of ``z_mm`` (its max if None)."""
    region = clip_region(x_mm, z_mm, cutter_x, cutter_z, top_mm)
    if region is None:
        return x_mm, z_mm, extra
    lo, hi, new_x, new_z = region
    out_x = np.concatenate([x_mm[:lo], new_x, x_mm[hi:]])
    out_z = np.concatenate([z_mm[:lo], new_z, z_mm[hi:]])
    out_extra = tuple(np.concatenate([e[:lo], np.interp(new_x, x_mm, e), e[hi:]]) for e in extra)
    return out_x, out_z, out_extra


def _without_collinear(xs: list, zs: list, parents: list, tolerance_mm: float = COLLINEAR_MM):
    """The polyline without its interior points that lie on the line between their kept
    neighbours, in height and in the parent surface alike (within ``tolerance_mm``): the
    points a cut laid on the face's line. The same polyline (to the tolerance) in fewer
    points, so that the next steps visit fewer."""
    keep_x, keep_z, keep_p = [xs[0]], [zs[0]], [parents[0]]
    for k in range(1, len(xs) - 1):
        x0, x1, x2 = keep_x[-1], xs[k], xs[k + 1]
        # (not on a near-vertical step: its neighbours closer than the crossings' 1e-9 mm)
        f = (x1 - x0) / (x2 - x0) if x2 - x0 > 1e-9 else math.nan
        if not (abs(keep_z[-1] + (zs[k + 1] - keep_z[-1]) * f - zs[k]) <= tolerance_mm
                and abs(keep_p[-1] + (parents[k + 1] - keep_p[-1]) * f - parents[k]) <= tolerance_mm):
            keep_x.append(x1)
            keep_z.append(zs[k])
            keep_p.append(parents[k])
    keep_x.append(xs[-1])
    keep_z.append(zs[-1])
    keep_p.append(parents[-1])
    return np.array(keep_x), np.array(keep_z), np.array(keep_p)


class LiveContour:
    """A contour being ground, cut near the tool at every step without copying the rest.

    Points, with the parent surface under them, sit in one buffer (rows x, z, parent): the
    part the tool has left behind at its start (``done``), the live part from just behind
    the tool to the contour's end at its end, and a gap between them that takes the points
    a cut inserts. A cut writes only its own points and the few the tool has passed; a
    pose behind the live part's start (the disk swinging back, the plant's next pass)
    moves points back from the done part first. ``top_mm`` bounds the heights from above
    (the highest point as given: a cut never raises one), which narrows every search to
    where the face and the cutter are below it. Units: mm."""

    SPARE = 4096  # points of gap: a pass inserts 1-3 a step; the buffer grows by half when full

    def __init__(self, contour, contact_search=contact_patch):
        n = contour.x_mm.size
        self.buffer = np.empty((3, n + self.SPARE))
        self.buffer[:, self.SPARE:] = contour.x_mm, contour.z_mm, contour.parent_mm
        self.done, self.live = 0, self.SPARE  # the done part is buffer[:, :done], the live one buffer[:, live:]
        self.top_mm = float(contour.z_mm.max())
        self.contact_search = contact_search

    def _expose(self, x_mm: float) -> None:
        """The live part starts at or before ``x_mm`` (or at the contour's start)."""
        b = self.buffer
        if self.done == 0 or b[0, self.live] <= x_mm:
            return
        j = max(int(b[0, :self.done].searchsorted(x_mm, "right")) - 1, 0)
        k = self.done - j
        b[:, self.live - k:self.live] = b[:, j:self.done]
        self.live -= k
        self.done = j
        if k > 256:  # a jump back (the plant's next pass): the top as cut so far, the searches' reach
            self.top_mm = float(max(b[1, :self.done].max(initial=-math.inf), b[1, self.live:].max()))

    def contact(self, pose: DiskPose) -> ContactPatch:
        if pose.tip_z_mm - TOUCH_MM > self.top_mm:
            return NO_PATCH
        self._expose(pose.tip_x_mm)
        b = self.buffer
        return self.contact_search(b[0, self.live:], b[1, self.live:], pose, top_mm=self.top_mm)

    def clip(self, cutter_x: np.ndarray, cutter_z: np.ndarray) -> None:
        if cutter_z.min() >= self.top_mm:
            return
        self._expose(float(cutter_x.min()))
        b = self.buffer
        x, z = b[0, self.live:], b[1, self.live:]
        region = clip_region(x, z, cutter_x, cutter_z, self.top_mm)
        if region is None:
            return
        lo, hi, new_x, new_z = region
        near = slice(max(lo - 1, 0), hi + 1)
        new_parent = np.interp(new_x, x[near], b[2, self.live:][near])
        if 2 < new_x.size <= 4 * SCALAR_POINTS:
            new_x, new_z, new_parent = _without_collinear(new_x.tolist(), new_z.tolist(), new_parent.tolist())
        self._replace(lo, hi, new_x, new_z, new_parent)

    def _replace(self, lo: int, hi: int, new_x, new_z, new_parent) -> None:
        """Live points [lo, hi) replaced by the new ones; those before lo - 1 go to the done part."""
        passed = max(lo - 1, 0)
        if passed:
            b = self.buffer
            b[:, self.done:self.done + passed] = b[:, self.live:self.live + passed]
            self.done, self.live, lo, hi = self.done + passed, self.live + passed, lo - passed, hi - passed
        m = new_x.size
        start = self.live + hi - lo - m  # the live part's start once the region is replaced
        if start < self.done:  # the gap is used up: a bigger buffer
            self._grow(m - (hi - lo))
            start = self.live + hi - lo - m
        b = self.buffer
        if lo:
            b[:, start] = b[:, self.live]  # the point before the region
        b[0, start + lo:start + lo + m] = new_x
        b[1, start + lo:start + lo + m] = new_z
        b[2, start + lo:start + lo + m] = new_parent
        self.live = start

    def _grow(self, more: int) -> None:
        n = self.done + self.buffer.shape[1] - self.live
        spare = max(self.SPARE, n // 2, 2 * more)
        grown = np.empty((3, n + spare))
        grown[:, :self.done] = self.buffer[:, :self.done]
        grown[:, self.done + spare:] = self.buffer[:, self.live:]
        self.buffer, self.live = grown, self.done + spare

    @property
    def contour(self) -> Contour:
        b = self.buffer
        return Contour(*(np.concatenate([b[k, :self.done], b[k, self.live:]]) for k in range(3)))
