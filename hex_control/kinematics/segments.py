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


def closest_parameters(a, b, c, e, f) -> tuple[np.ndarray, np.ndarray]:
    """Parameters s, t in [0, 1] of the closest points p1 + s d1 and p2 + t d2, from
    a = d1.d1, b = d1.d2, c = d1.r, e = d2.d2, f = d2.r with r = p1 - p2 (1-D arrays)."""
    a, b, c, e, f = (np.asarray(v, float) for v in (a, b, c, e, f))
    denom = a * e - b * b
    safe_a = np.where(a > _EPS, a, 1.0)
    safe_e = np.where(e > _EPS, e, 1.0)
    # closest point on line 1 to line 2, clamped; parallel lines (denom ~ 0): s = 0
    parallel = denom <= _EPS * np.maximum(a * e, _EPS)
    s = np.clip((b * f - c * e) / np.where(parallel, 1.0, denom), 0.0, 1.0)
    s[parallel] = 0.0
    t_free = (b * s + f) / safe_e
    t = np.clip(t_free, 0.0, 1.0)
    # t was clamped: recompute s for the clamped t
    clamped = t != t_free
    s[clamped] = np.clip((b[clamped] * t[clamped] - c[clamped]) / safe_a[clamped], 0.0, 1.0)
    degenerate = (a <= _EPS) | (e <= _EPS)
    if np.any(degenerate):  # a segment is a point (rare: never for struts)
        point1, point2 = a <= _EPS, e <= _EPS
        s[point1] = 0.0
        t[point1] = np.clip(f[point1] / safe_e[point1], 0.0, 1.0)
        t[point2] = 0.0
        only2 = point2 & ~point1
        s[only2] = np.clip(-c[only2] / safe_a[only2], 0.0, 1.0)
    return s, t


def segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Distance between segments p1-q1 and p2-q2; arrays of shape (..., 3) -> (...)."""
    p1, q1, p2, q2 = np.broadcast_arrays(*(np.asarray(v, float) for v in (p1, q1, p2, q2)))
    shape = p1.shape[:-1]
    p1, q1, p2, q2 = (v.reshape(-1, 3) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    dot = lambda u, v: np.einsum("ij,ij->i", u, v)  # noqa: E731
    s, t = closest_parameters(dot(d1, d1), dot(d1, d2), dot(d1, r), dot(d2, d2), dot(d2, r))
    return np.linalg.norm(r + d1 * s[:, None] - d2 * t[:, None], axis=-1).reshape(shape)
