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


def matrix_from_quaternion(x, y, z, w) -> np.ndarray:
    """The rotation matrix (3, 3) of a quaternion (x, y, z, w), normalized first."""
    q = np.array([x, y, z, w], float)
    norm = np.linalg.norm(q)
    if not np.isfinite(norm) or norm == 0:
        raise ValueError(f"a quaternion needs a finite, nonzero norm: {q}")
    x, y, z, w = q / norm
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rpy_from_matrix(rotation) -> np.ndarray:
    """(roll, pitch, yaw) rad of R = R_z(yaw) R_y(pitch) R_x(roll). At pitch = +-pi/2 only
    roll - yaw (or roll + yaw) is defined: yaw is then 0, as scipy's ``as_euler`` chooses."""
    r = np.asarray(rotation, float)
    cos_pitch = np.hypot(r[0, 0], r[1, 0])
    # atan2, not arcsin of r[2, 0]: exact to the last bits near +-pi/2 too; + 0.0: no -0 in a URDF
    pitch = np.arctan2(-r[2, 0], cos_pitch) + 0.0
    if cos_pitch < 1e-12:
        return np.array([np.arctan2(-r[2, 0] * r[0, 1], r[1, 1]) + 0.0, pitch, 0.0])
    return np.array([np.arctan2(r[2, 1], r[2, 2]), pitch, np.arctan2(r[1, 0], r[0, 0])]) + 0.0
