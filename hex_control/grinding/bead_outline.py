"""The bead's cross-section along its length as one closed outline, for viewers that draw a
polygon (geometry_msgs/PolygonStamped in Foxglove or RViz): along the contour from x = 0 to
L, then back along the parent surface under it. In the bead frame (x along, z up), metres."""

from __future__ import annotations

import numpy as np

MM = 1e-3


def bead_outline_m(x_mm, z_mm, parent_mm=()) -> np.ndarray:
    """(2n, 3) points (m): the contour's top (the height above the parent plus the parent),
    then the parent surface in reverse; an empty ``parent_mm`` is a flat parent at 0.
    ValueError for lengths that differ, fewer than two points or non-finite values."""
    x, z = np.asarray(x_mm, float), np.asarray(z_mm, float)
    parent = np.zeros_like(x) if len(parent_mm) == 0 else np.asarray(parent_mm, float)
    if not (x.ndim == 1 and len(x) >= 2 and x.shape == z.shape == parent.shape):
        raise ValueError(f"need two or more points, x, z and parent alike: {x.shape}, {z.shape}, {parent.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z)) and np.all(np.isfinite(parent))):
        raise ValueError("the contour must be finite")
    top = np.column_stack([x, np.zeros_like(x), z + parent])
    bottom = np.column_stack([x, np.zeros_like(x), parent])[::-1]
    return np.vstack([top, bottom]) * MM
