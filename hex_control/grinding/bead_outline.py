"""The bead's cross-section along its length as one closed outline, for viewers that draw a
polygon (geometry_msgs/PolygonStamped in Foxglove or RViz): along the contour from x = 0 to
L, then back along the parent surface under it. In the bead frame (x along, z up), metres.

A contour comes off the wire: it is refused beyond ``MAX_CONTOUR_POINTS`` (the pass
planner's limit) before any conversion, and a long one is drawn with at most
``MAX_OUTLINE_POINTS`` vertices a side, so that the work per scan is bounded (a viewer's
outline needs no more)."""

from __future__ import annotations

import numpy as np

from hex_control.grinding.contour import MAX_CONTOUR_POINTS

MM = 1e-3
MAX_OUTLINE_POINTS = 2_000  # vertices per side of the outline (the shipped scans have fewer)


def spaced_indices(n: int, max_points: int) -> np.ndarray:
    """All ``n`` indices, or at most ``max_points`` (>= 2) evenly spaced ones, first and last kept."""
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_points).round().astype(int))


def bead_outline_m(x_mm, z_mm, parent_mm=(), *, max_points: int = MAX_OUTLINE_POINTS) -> np.ndarray:
    """(2n, 3) points (m): the contour's top (the height above the parent plus the parent),
    then the parent surface in reverse; an empty ``parent_mm`` is a flat parent at 0. Beyond
    ``max_points`` points a side, evenly spaced samples of them (the first and last kept).
    ValueError for lengths that differ, fewer than two or more than MAX_CONTOUR_POINTS
    points, or non-finite values."""
    sizes = (len(x_mm), len(z_mm), len(parent_mm) or len(x_mm))
    if not (2 <= sizes[0] <= MAX_CONTOUR_POINTS and sizes[0] == sizes[1] == sizes[2]):
        raise ValueError(f"need 2 to {MAX_CONTOUR_POINTS} points, x, z and parent alike: {sizes}")
    x, z = np.asarray(x_mm, float), np.asarray(z_mm, float)
    parent = np.zeros_like(x) if len(parent_mm) == 0 else np.asarray(parent_mm, float)
    if not (x.ndim == z.ndim == parent.ndim == 1):
        raise ValueError("x, z and parent must be flat arrays")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z)) and np.all(np.isfinite(parent))):
        raise ValueError("the contour must be finite")
    keep = spaced_indices(len(x), max_points)
    x, z, parent = x[keep], z[keep], parent[keep]
    top = np.column_stack([x, np.zeros_like(x), z + parent])
    bottom = np.column_stack([x, np.zeros_like(x), parent])[::-1]
    return np.vstack([top, bottom]) * MM
