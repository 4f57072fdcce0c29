"""Shortest distance between line segments (strut collision, constraint set IV).

Seed 000 part 1, section 3.3 measures D = r21 . (u1 x u2)/|u1 x u2|, the distance between
the infinite lines through two struts: it is too small when the closest points of the
lines fall outside the struts, and undefined for parallel struts. This is the true
segment-segment distance (Ericson, *Real-Time Collision Detection*, 2005, section 5.1.9),
clamped to both segments and well defined for parallel and degenerate segments.
"""

from __future__ import annotations

import numpy as np

_EPS = 1e-12


def segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Distance between segments p1-q1 and p2-q2; arrays of shape (..., 3) -> (...)."""
    p1, q1, p2, q2 = (np.asarray(v, float) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    denom = a * e - b * b
    safe_a = np.where(a > _EPS, a, 1.0)
    safe_e = np.where(e > _EPS, e, 1.0)
    # closest point on line 1 to line 2, clamped; parallel lines: pick s = 0
    s = np.where(denom > _EPS * np.maximum(a * e, _EPS),
                 np.clip((b * f - c * e) / np.where(denom > 0, denom, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / safe_e
    # t outside [0, 1]: clamp it and recompute s for the clamped t
    t_clamped = np.clip(t, 0.0, 1.0)
    s = np.where(t != t_clamped, np.clip((b * t_clamped - c) / safe_a, 0.0, 1.0), s)
    t = t_clamped
    # degenerate segments (points)
    s = np.where(a <= _EPS, 0.0, s)
    t = np.where(e <= _EPS, np.where(a <= _EPS, 0.0, t), t)
    t = np.where((e <= _EPS), 0.0, t)
    s = np.where((e <= _EPS) & (a > _EPS), np.clip(-c / safe_a, 0.0, 1.0), s)
    closest1 = p1 + d1 * s[..., None]
    closest2 = p2 + d2 * t[..., None]
    return np.linalg.norm(closest1 - closest2, axis=-1)
