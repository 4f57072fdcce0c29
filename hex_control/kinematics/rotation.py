"""Roll-pitch-yaw rotations of seed 000 part 1, section 3: R = R_gamma R_beta R_alpha.

The platform is rotated first about x (roll alpha), then about y (pitch beta), then about
z (yaw gamma), all about the fixed base axes. Angles in rad; vectorized over leading axes.
"""

from __future__ import annotations

import numpy as np


def _axis_matrices(angle, axis: int):
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(c) + (3, 3))
    i, j = [k for k in range(3) if k != axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = out[..., j, j] = c
    # about y the sine's sign is the other way round (z x x = y)
    out[..., i, j], out[..., j, i] = (s, -s) if axis == 1 else (-s, s)
    return out


def _axis_derivatives(angle, axis: int):
    """d/d(angle) of the elementary rotation about ``axis``."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(c) + (3, 3))
    i, j = [k for k in range(3) if k != axis]
    out[..., i, i] = out[..., j, j] = -s
    # entry by entry: the derivative's is the rotation's with (c, s) -> (-s, c); np.stack
    # per row cost a fifth of the 3-PRU head's dynamics
    out[..., i, j], out[..., j, i] = (c, -c) if axis == 1 else (-c, c)
    return out


def rotation_matrix(roll, pitch, yaw) -> np.ndarray:
    """R = R_z(yaw) R_y(pitch) R_x(roll), shape (..., 3, 3)."""
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, float) for a in (roll, pitch, yaw)))
    return _axis_matrices(yaw, 2) @ _axis_matrices(pitch, 1) @ _axis_matrices(roll, 0)


def rotation_derivatives(roll, pitch, yaw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dR/droll, dR/dpitch, dR/dyaw), each of shape (..., 3, 3)."""
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, float) for a in (roll, pitch, yaw)))
    rx, ry, rz = _axis_matrices(roll, 0), _axis_matrices(pitch, 1), _axis_matrices(yaw, 2)
    return (rz @ ry @ _axis_derivatives(roll, 0), rz @ _axis_derivatives(pitch, 1) @ rx,
            _axis_derivatives(yaw, 2) @ ry @ rx)


def rpy_from_quaternion(x, y, z, w) -> np.ndarray:
    """(roll, pitch, yaw) rad of a unit quaternion, for R = R_z(yaw) R_y(pitch) R_x(roll)."""
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array([roll, pitch, yaw], float)


def quaternion_from_rpy(roll, pitch, yaw) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of R = R_z(yaw) R_y(pitch) R_x(roll)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy], float)
