"""The contact search and the truncation of :mod:`hex_control.grinding.contact`, compiled
(numba): the two calls a pass simulation makes five times a step, which were two thirds of
its time in plain Python (issue 39 item 1: the clock stands while the pass planner plans).

Each function is the plain-float algorithm of ``contact._patch_of_few`` /
``contact._clip_few`` (with ``contact._below`` and ``contact._interp_sorted``), in the same
operations and order, for any number of points: on a few points the results are the
Python kernel's to the last bit, on many its numpy path's to rounding (its sums are
pairwise). ``contact`` calls them when numba imports and keeps the Python kernel as the
reference and the fallback (``test_contact.py`` holds the two together).

Compiled once, on import, for the one signature used, and cached beside the module (or in
numba's user cache when that is read-only), so a node forked from a process that imported
it pays nothing. Units: mm, rad.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: no contact, or no cut: a kernel's ``runs`` of 0 / ``lo`` of -1
NONE = -1

_VECTOR = "float64[::1]"


@njit(cache=True)
def _height(x, z, i, at):
    """``contact._height``: the polyline at ``at`` given i = searchsorted(x, at)."""
    if i <= 0:
        return z[0]
    if i >= x.size:
        return z[x.size - 1]
    x0, x1 = x[i - 1], x[i]
    return z[i - 1] + (z[i] - z[i - 1]) * (at - x0) / (x1 - x0)


@njit(cache=True)
def _interp_sorted(at, xs, zs):
    """``contact._interp_sorted``: np.interp at increasing points, in one walk."""
    out = np.empty(at.size)
    j, n = 0, xs.size
    for k in range(at.size):
        x = at[k]
        while j < n - 1 and xs[j + 1] <= x:
            j += 1
        if x < xs[0]:
            out[k] = zs[0]
        elif j >= n - 1:
            out[k] = zs[n - 1]
        else:
            out[k] = (zs[j + 1] - zs[j]) / (xs[j + 1] - xs[j]) * (x - xs[j]) + zs[j]
    return out


@njit(cache=True)
def _below(cutter_x, cutter_z, top):
    """``contact._below``: the cutter trimmed to where it can be below ``top``."""
    below = np.nonzero(cutter_z < top)[0]
    i, j, last = below[0], below[-1], cutter_x.size - 1
    if i == 0 and j == last:
        return cutter_x, cutter_z
    level = top + 1e-9 * (1.0 + abs(top))
    size = j - i + 1 + (1 if i > 0 else 0) + (1 if j < last else 0)
    xs, zs = np.empty(size), np.empty(size)
    at = 0
    if i > 0:
        f = (level - cutter_z[i]) / (cutter_z[i - 1] - cutter_z[i])
        xs[0], zs[0] = cutter_x[i] + f * (cutter_x[i - 1] - cutter_x[i]), level
        at = 1
    xs[at:at + j - i + 1] = cutter_x[i:j + 1]
    zs[at:at + j - i + 1] = cutter_z[i:j + 1]
    if j < last:
        f = (level - cutter_z[j]) / (cutter_z[j + 1] - cutter_z[j])
        xs[size - 1], zs[size - 1] = cutter_x[j] + f * (cutter_x[j + 1] - cutter_x[j]), level
    return xs, zs


@njit(f"Tuple((float64, float64, int64, boolean))({_VECTOR}, {_VECTOR}, float64, float64, float64, float64, "
      "float64, float64)", cache=True)
def contact_patch(x, z, centre_x, centre_z, angle, radius, touch, top):  # noqa: PLR0917 - numba: no keyword-only
    """(length mm, centroid mm, runs, the tip inside) of the face of the disk at (centre_x,
    centre_z, angle, radius) against the contour (x, z) whose heights are at most ``top``;
    runs 0 (or a length <= 0) is no contact. ``contact.contact_patch`` without its types."""
    tip_z = centre_z - radius * math.sin(angle)
    if tip_z - touch > top:
        return 0.0, 0.0, 0, False
    tip_x = centre_x - radius * math.cos(angle)
    tan = math.tan(angle)
    reach = (top + touch - tip_z) / tan * (1 + 1e-9) + 1e-9 if tan > 0 else math.inf
    end_x = min(centre_x, tip_x + reach)
    lo = np.searchsorted(x, tip_x, side="right")
    hi = np.searchsorted(x, end_x, side="left")
    x0 = tip_x
    d0 = _height(x, z, lo, tip_x) - (centre_z - (centre_x - x0) * tan) + touch
    tip_inside = d0 > 0
    runs = 1 if tip_inside else 0
    length = moment = 0.0
    points = max(hi - lo, 0)  # the contour's points under the face's reach, then its end
    for k in range(points + 1):
        if k < points:
            x1, z1 = x[lo + k], z[lo + k]
        else:
            x1, z1 = end_x, _height(x, z, hi, end_x)
        d1 = z1 - (centre_z - (centre_x - x1) * tan) + touch
        if d0 > 0 or d1 > 0:
            start = x0 if d0 > 0 else x0 + (x1 - x0) * d0 / (d0 - d1)
            end = x1 if d1 > 0 else x0 + (x1 - x0) * d0 / (d0 - d1)
            length += end - start
            moment += (end - start) * (centre_x - (start + end) / 2)
            if d1 > 0 >= d0:
                runs += 1
        x0, d0 = x1, d1
    if runs == 0:
        return 0.0, 0.0, 0, False
    secant = 1.0 / math.cos(angle)
    length *= secant
    if length <= 0:
        return 0.0, 0.0, 0, False
    return length, moment * secant * secant / length, runs, tip_inside


@njit(f"Tuple((int64, int64, float64[::1], float64[::1]))({_VECTOR}, {_VECTOR}, {_VECTOR}, {_VECTOR}, float64, "
      "float64)", cache=True)
def clip_region(x, z, cutter_x, cutter_z, top, keep_mm):  # noqa: PLR0917 - numba: no keyword-only
    """``contact.clip_region`` of the contour (x, z), heights at most ``top``, under the
    cutter polyline (x increasing): (lo, hi, new x, new z) whose points replace x[lo:hi],
    lo = NONE if it cuts nothing. ``keep_mm``: how far under the contour a cutter point at a
    vertex of the cutter still touches it (``TOUCH_MM * 1e-2``)."""
    empty = np.empty(0)
    if cutter_z.min() >= top:
        return NONE, NONE, empty, empty
    cx, cz = _below(cutter_x, cutter_z, top)
    n = x.size
    first, last = max(cx[0], x[0]), min(cx[cx.size - 1], x[n - 1])
    if first >= last:
        return NONE, NONE, empty, empty
    lo = np.searchsorted(x, first, side="left")
    hi = np.searchsorted(x, last, side="right")
    start = max(lo - 1, 0)
    xs, zs = x[start:min(hi + 1, n)], z[start:min(hi + 1, n)]
    window, window_z = x[lo:hi], z[lo:hi]
    contour_at_cutter = _interp_sorted(cx, xs, zs)
    cuts = False
    for k in range(cx.size):
        if first <= cx[k] <= last and cz[k] < contour_at_cutter[k]:
            cuts = True
            break
    if not cuts:
        cutter_at_window = _interp_sorted(window, cx, cz)
        for k in range(window.size):
            if window_z[k] > cutter_at_window[k]:
                cuts = True
                break
    if not cuts:
        return NONE, NONE, empty, empty
    # the span's ends and the cutter's vertices inside it, where not contour points: kept
    # while looking for crossings, dropped after where nothing is cut (as a bisect insertion)
    candidates = np.empty(cx.size + 2)
    count = 0
    candidates[count] = first
    count += 1
    for k in range(cx.size):
        if first < cx[k] < last:
            candidates[count] = cx[k]
            count += 1
    candidates[count] = last
    count += 1
    merged = np.empty(window.size + count)
    merged[:window.size] = window
    size = window.size
    added = np.empty(count)
    n_added = 0
    for k in range(count):
        value = candidates[k]
        i = np.searchsorted(merged[:size], value, side="left")
        if i == size or merged[i] != value:
            merged[i + 1:size + 1] = merged[i:size].copy()
            merged[i] = value
            size += 1
            added[n_added] = value
            n_added += 1
    merged = merged[:size]
    depth = _interp_sorted(merged, xs, zs) - _interp_sorted(merged, cx, cz)
    new = np.empty(2 * size)
    new[0] = merged[0]
    m = 1
    crossed = False
    for k in range(size - 1):
        a, b = depth[k], depth[k + 1]
        if (a > 0 > b) or (a < 0 < b):
            new[m] = merged[k] + a / (a - b) * (merged[k + 1] - merged[k])
            m += 1
            crossed = True
        new[m] = merged[k + 1]
        m += 1
    new = new[:m]
    if crossed:  # a crossing at a vertex (within 1e-9 mm) is the vertex
        ordered = np.sort(new)
        keep = np.empty(m, np.bool_)
        keep[0] = True
        for k in range(1, m):
            keep[k] = ordered[k] - ordered[k - 1] > 1e-9
        new = ordered[keep]
    original, cutter = _interp_sorted(new, xs, zs), _interp_sorted(new, cx, cz)
    out_x, out_z = np.empty(new.size), np.empty(new.size)
    m = 0
    for k in range(new.size):
        kept = cutter[k] <= original[k] + keep_mm
        if not kept:
            kept = True
            for a in range(n_added):
                if added[a] == new[k]:
                    kept = False
                    break
        if kept:
            out_x[m], out_z[m] = new[k], min(original[k], cutter[k])
            m += 1
    return lo, hi, out_x[:m].copy(), out_z[:m].copy()
