"""3-PRU parallel head of seed 001 (sections 2.1, 4.1-4.2): kinematics.

Three vertical rails at radius R and angles theta_i carry sliders at heights L_i; a
rocker of length l joins each slider through a revolute joint (axis tangent to the
circle) to a platform joint b_i at radius r. The platform's free coordinates are
q = (z, alpha, beta) in mm and rad; its parasitic motions (x, y, gamma) follow from the
revolute joints, which keep each rocker -- hence platform joint i -- in the vertical
plane through rail i:  n_i . P_i = 0,  n_i = (-sin theta_i, cos theta_i, 0).

With P_i = (x, y, z) + R b_i, R = R_z(gamma) R_y(beta) R_x(alpha) (R_z leaves the
z-component unchanged), the slider height is seed eq. of 2.1.1:

    L_i = z - r cos(theta_i) sin(beta) + r sin(theta_i) sin(alpha) cos(beta)
          - sqrt(l^2 - S_ix^2 - S_iy^2),      S_i = P_i - (rail i at height L_i)

FK is Newton-Raphson with the analytic Jacobian (seed 2.1.2, steps 1-4).

The head alone cannot feed along a bead. With ``feed_stroke_mm`` it sits on a linear feed
stage along the machine's x (a hybrid machine): joint 4 is the stage position u, and the
tool's x is u plus the head's parasitic x (:func:`feed_positions_mm`, :func:`tool_positions_mm`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml

from hex_control.kinematics.machine_kind import CONSTRAINT_SETS, ConstraintCheck, JointPositionsFromConstraints
from hex_control.kinematics.rotation import rotation_derivatives, rotation_matrix

FK_MAX_ITERATIONS = 50  # Newton steps of the forward kinematics before it gives up

_INDEPENDENT = [2, 3, 4]  # z, alpha, beta in (x, y, z, alpha, beta, gamma)
_PARASITIC = [0, 1, 5]  # x, y, gamma
HOME_Q = (220.0, 0.0, 0.0)  # the head's start (z mm, alpha, beta rad): the plant's and the home pose


@dataclass(frozen=True)
class Pru3Geometry(JointPositionsFromConstraints):
    """Seed 001 section 4.2: R = 180 mm, r = 120 mm, l = 150 mm, rails at 0/120/240 deg,
    stroke 0..100 mm, tilts within +-30 deg (section 4.1)."""

    rail_radius_mm: float = 180.0
    platform_radius_mm: float = 120.0
    rocker_length_mm: float = 150.0
    rail_angles_rad: tuple = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
    stroke_mm: tuple = (0.0, 100.0)
    tilt_max_rad: float = math.radians(30.0)
    feed_stroke_mm: tuple | None = None  # the x feed stage's travel (min, max); None = head alone
    # the servos' limits in the plant (hex_control.plant.limits; the seed gives none)
    slider_speed_max_mm_s: float = math.inf
    slider_acceleration_max_mm_s2: float = math.inf
    feed_speed_max_mm_s: float = math.inf
    feed_acceleration_max_mm_s2: float = math.inf
    name: str = "pru3"

    def __post_init__(self):
        if not (self.rail_radius_mm > 0 and self.platform_radius_mm > 0 and self.rocker_length_mm > 0):
            raise ValueError("radii and rocker length must be positive")
        if not all(v > 0 for v in (self.slider_speed_max_mm_s, self.slider_acceleration_max_mm_s2,
                                   self.feed_speed_max_mm_s, self.feed_acceleration_max_mm_s2)):
            raise ValueError("the sliders' and the feed stage's speed and acceleration limits must be > 0")
        if len(self.rail_angles_rad) != 3 or not self.stroke_mm[0] < self.stroke_mm[1]:
            raise ValueError("need three rail angles and stroke (min < max)")
        if self.feed_stroke_mm is not None and not self.feed_stroke_mm[0] < self.feed_stroke_mm[1]:
            raise ValueError("feed_stroke_mm needs (min < max)")

    @property
    def joint_names(self) -> list[str]:
        """The sliders, then the feed stage if there is one."""
        return ["strut_0", "strut_1", "strut_2"] + (["feed_x"] if self.feed_stroke_mm is not None else [])

    plant_drive = "pru3_dynamics"
    maps_workspace = False  # x, y are parasitic: the head has no 6-DOF workspace to map
    constraint_sets = CONSTRAINT_SETS

    @property
    def home_pose(self) -> np.ndarray:
        """The start as a tool pose (6,): ``HOME_Q``, the feed stage (if any) at x = 0."""
        pose = np.zeros(6)
        pose[_INDEPENDENT] = HOME_Q
        return pose

    def constraint_check(self, poses) -> ConstraintCheck:
        """Strokes (sliders and feed stage) as set I, the tilt limit as set II; the head has
        no base-joint or strut-distance constraints. The head holds z, alpha = roll and
        beta = pitch; the feed stage, if any, carries x (:func:`joint_check`)."""
        check = joint_check(self, poses)
        # a pose the rockers cannot reach has no slider position: outside the stroke
        stroke = np.where(np.isfinite(check.stroke_margin_mm), check.stroke_margin_mm, -np.inf)
        n = len(stroke)
        margins = np.column_stack([stroke, check.tilt_margin_rad, np.full(n, np.inf), np.full(n, np.inf)])
        satisfied = np.column_stack([stroke >= 0, check.tilt_margin_rad >= 0, np.ones((n, 2), bool)])
        return ConstraintCheck(check.positions_mm, satisfied, margins)

    def check_joint_positions_mm(self, positions_mm, guess=(200.0, 0.0, 0.0)) -> None:
        """Raise ValueError unless the sliders and the feed stage are in stroke and place
        the platform within its tilt limits (the drives' soft limits); ``guess`` (z mm,
        alpha, beta rad) starts the forward kinematics."""
        joints = np.asarray(positions_mm, float).reshape(-1)
        if joints.shape != (len(self.joint_names),) or not np.all(np.isfinite(joints)):
            raise ValueError(f"need {len(self.joint_names)} finite joint positions (mm)")
        low, high = self.stroke_mm
        if not np.all((joints[:3] >= low) & (joints[:3] <= high)):
            raise ValueError(f"slider positions must be within the stroke {low:g}..{high:g} mm")
        feed = self.feed_stroke_mm
        if feed is not None and not feed[0] <= joints[3] <= feed[1]:
            raise ValueError(f"the feed stage must stay within {feed} mm")
        q, _ = forward_kinematics(self, joints[:3], guess, tolerance_mm=1e-6)
        if np.abs(q[1:]).max() > self.tilt_max_rad:
            raise ValueError(f"slider positions tilt the platform beyond {np.degrees(self.tilt_max_rad):g} deg")

    def check_joint_trajectory_mm(self, positions_mm, guess=(200.0, 0.0, 0.0)) -> None:
        """:meth:`check_joint_positions_mm` of every row (n, joints) at once, the forward
        kinematics of all rows by one vectorized Newton solve (a pass's 1,460 rows one by one
        took 0.6 s of the plant's executor); the ValueError names the first row out of limits."""
        rows = np.asarray(positions_mm, float)
        if rows.ndim != 2 or rows.shape[1] != len(self.joint_names) or not np.all(np.isfinite(rows)):
            raise ValueError(f"need rows of {len(self.joint_names)} finite joint positions (mm), got shape "
                             f"{rows.shape}")
        low, high = self.stroke_mm
        outside = ~np.all((rows[:, :3] >= low) & (rows[:, :3] <= high), axis=1)
        if outside.any():
            raise ValueError(f"row {int(np.argmax(outside))}: slider positions must be within the stroke "
                             f"{low:g}..{high:g} mm")
        feed = self.feed_stroke_mm
        if feed is not None and not np.all((rows[:, 3] >= feed[0]) & (rows[:, 3] <= feed[1])):
            k = int(np.argmax(~((rows[:, 3] >= feed[0]) & (rows[:, 3] <= feed[1]))))
            raise ValueError(f"row {k}: the feed stage must stay within {feed} mm")
        q = forward_kinematics_rows(self, rows[:, :3], guess, tolerance_mm=1e-6)
        tilted = np.abs(q[:, 1:]).max(axis=1) > self.tilt_max_rad
        if tilted.any():
            raise ValueError(f"row {int(np.argmax(tilted))}: slider positions tilt the platform beyond "
                             f"{np.degrees(self.tilt_max_rad):g} deg")

    def forward_pose(self, positions_mm, guess, tolerance_mm: float = 1e-9,
                     max_iterations: int = FK_MAX_ITERATIONS) -> tuple[np.ndarray, int, float]:
        """The tool pose from the sliders (and the feed stage): z, alpha, beta solved from
        ``guess``'s (or 220 mm level if it is all zeros), x and y from the parasitic motion."""
        positions_mm, guess = np.asarray(positions_mm, float), np.asarray(guess, float)
        start = guess[[2, 3, 4]] if np.any(guess) else (220.0, 0.0, 0.0)
        q, used, solved = _forward_kinematics_pose(self, positions_mm[:3], start, tolerance_mm, max_iterations)
        pose = solved.full[0].copy()
        pose[:3] = tool_positions_mm(solved, positions_mm[3] if len(positions_mm) > 3 else 0.0)[0]
        return pose, used, float(np.max(np.abs(solved.lengths_mm[0] - positions_mm[:3])))

    def tool_tracker(self) -> Pru3ToolTracker:
        """Forward kinematics of the head in motion, warm-started from the last pose:
        ``tool_position_mm(joint positions mm)`` -> the tool point (3,) mm."""
        return Pru3ToolTracker(self)

    @property
    def joint_speed_max_mm_s(self) -> np.ndarray:
        """Each joint's speed limit (mm/s), in ``joint_names`` order."""
        return self._per_joint(self.slider_speed_max_mm_s, self.feed_speed_max_mm_s)

    @property
    def joint_acceleration_max_mm_s2(self) -> np.ndarray:
        """Each joint's acceleration limit (mm/s^2), in ``joint_names`` order."""
        return self._per_joint(self.slider_acceleration_max_mm_s2, self.feed_acceleration_max_mm_s2)

    def _per_joint(self, slider: float, feed: float) -> np.ndarray:
        return np.array([slider] * 3 + ([feed] if self.feed_stroke_mm is not None else []), float)

    @classmethod
    def from_dict(cls, data: dict) -> Pru3Geometry:
        limits = {name: float(data.get(name, math.inf)) for name in (
            "slider_speed_max_mm_s", "slider_acceleration_max_mm_s2", "feed_speed_max_mm_s",
            "feed_acceleration_max_mm_s2")}
        return cls(float(data.get("rail_radius_mm", 180.0)), float(data.get("platform_radius_mm", 120.0)),
                   float(data.get("rocker_length_mm", 150.0)),
                   tuple(math.radians(a) for a in data.get("rail_angles_deg", (0.0, 120.0, 240.0))),
                   tuple(float(v) for v in data.get("stroke_mm", (0.0, 100.0))),
                   math.radians(float(data.get("tilt_max_deg", 30.0))),
                   None if data.get("feed_stroke_mm") is None else tuple(float(v) for v in data["feed_stroke_mm"]),
                   name=str(data.get("name", "pru3")), **limits)

    @classmethod
    def from_yaml(cls, path) -> Pru3Geometry:
        data = yaml.safe_load(Path(path).read_text())
        return cls.from_dict(data.get("machine", data))

    def __getstate__(self) -> dict:
        """The fields only: the cached arrays are computed again where it is unpickled
        (a copy would come back writeable)."""
        return {name: value for name, value in self.__dict__.items()
                if not isinstance(getattr(type(self), name, None), cached_property)}

    @cached_property
    def platform_joints_mm(self) -> np.ndarray:
        """b_i in the platform frame (3, 3); seed: b_1 = (120, 0, 0), b_2 = (-60, 103.923, 0)..."""
        a = np.array(self.rail_angles_rad)
        return _frozen(self.platform_radius_mm * np.stack([np.cos(a), np.sin(a), np.zeros(3)], axis=1))

    @cached_property
    def rails_mm(self) -> np.ndarray:
        """Rail foot points R_i (3, 3); seed: R_1 = (180, 0, 0), R_2 = (-90, 155.885, 0)..."""
        a = np.array(self.rail_angles_rad)
        return _frozen(self.rail_radius_mm * np.stack([np.cos(a), np.sin(a), np.zeros(3)], axis=1))

    @cached_property
    def plane_normals(self) -> np.ndarray:
        a = np.array(self.rail_angles_rad)
        return _frozen(np.stack([-np.sin(a), np.cos(a), np.zeros(3)], axis=1))


def _frozen(array: np.ndarray) -> np.ndarray:
    """A read-only array: the geometry's derived arrays are computed once (cached_property;
    each dynamics evaluation read them a few dozen times) and shared by every caller."""
    array.setflags(write=False)
    return array


def _as_q(q) -> np.ndarray:
    array = np.asarray(q, float)
    array = array[None] if array.ndim == 1 else array
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise ValueError(f"q must be finite (z_mm, alpha_rad, beta_rad) rows, got shape {np.shape(q)}")
    return array


def _joints(geometry: Pru3Geometry, full: np.ndarray) -> np.ndarray:
    """P_i = p + R b_i for full coordinates (N, 6) -> (N, 3, 3)."""
    rotation = rotation_matrix(full[:, 3], full[:, 4], full[:, 5])
    return full[:, None, :3] + np.einsum("nij,kj->nki", rotation, geometry.platform_joints_mm)


def _joint_jacobians(geometry: Pru3Geometry, full: np.ndarray) -> np.ndarray:
    """dP_i/du (N, 3, 3, 6) for u = (x, y, z, alpha, beta, gamma)."""
    n = len(full)
    derivatives = rotation_derivatives(full[:, 3], full[:, 4], full[:, 5])
    out = np.zeros((n, 3, 3, 6))
    out[:, :, :, :3] = np.eye(3)
    for k, d in enumerate(derivatives):
        out[:, :, :, 3 + k] = np.einsum("nij,kj->nki", d, geometry.platform_joints_mm)
    return out


def parasitic_motion(geometry: Pru3Geometry, q, tolerance: float = 1e-12) -> np.ndarray:
    """Full coordinates (x, y, z, alpha, beta, gamma) (N, 6): (x, y, gamma) solved from the
    three plane constraints n_i . P_i = 0 by Newton's method (a few iterations)."""
    q = _as_q(q)
    full = np.zeros((len(q), 6))
    full[:, _INDEPENDENT] = q
    normals = geometry.plane_normals
    for _ in range(30):
        residual = np.einsum("ki,nki->nk", normals, _joints(geometry, full))
        if np.max(np.abs(residual)) < tolerance * geometry.platform_radius_mm:
            break
        jac = np.einsum("ki,nkiu->nku", normals, _joint_jacobians(geometry, full))[:, :, _PARASITIC]
        full[:, _PARASITIC] -= np.linalg.solve(jac, residual[..., None])[..., 0]
    return full


@dataclass(frozen=True)
class Pru3Pose:
    full: np.ndarray  # (N, 6) x, y, z mm; alpha, beta, gamma rad
    joints_mm: np.ndarray  # (N, 3, 3) platform joints P_i
    horizontal_mm: np.ndarray  # (N, 3, 2) S_ix, S_iy
    lengths_mm: np.ndarray  # (N, 3) L_i
    reachable: np.ndarray  # (N,) stroke, tilt and rocker geometry within limits


def inverse_kinematics(geometry: Pru3Geometry, q) -> Pru3Pose:
    """Slider positions L_i (mm) for platform coordinates q = (z, alpha, beta), shape (N, 3)."""
    full = parasitic_motion(geometry, q)
    joints = _joints(geometry, full)
    horizontal = joints[..., :2] - geometry.rails_mm[:, :2]
    under = geometry.rocker_length_mm**2 - np.sum(horizontal**2, axis=-1)
    lengths = joints[..., 2] - np.sqrt(np.maximum(under, 0.0))
    low, high = geometry.stroke_mm
    reachable = ((under > 0).all(axis=1) & ((lengths >= low) & (lengths <= high)).all(axis=1)
                 & (np.abs(full[:, 3:5]) <= geometry.tilt_max_rad).all(axis=1))
    return Pru3Pose(full, joints, horizontal, np.where(under > 0, lengths, np.nan), reachable)


def velocity_jacobian(geometry: Pru3Geometry, q, pose: Pru3Pose | None = None) -> np.ndarray:
    """J_p (N, 3, 3) with dL/dt = J_p dq/dt (seed 2.1.1), parasitic motion included:
    dL_i = [S_ix/w_i, S_iy/w_i, 1] . dP_i, w_i = sqrt(l^2 - S_ix^2 - S_iy^2), and the
    constraints give d(x, y, gamma) = -C_d^-1 C_q dq (implicit function theorem).
    ``pose``: inverse_kinematics(geometry, q) if the caller has it."""
    pose = inverse_kinematics(geometry, q) if pose is None else pose
    joint_jac = _joint_jacobians(geometry, pose.full)
    w = np.sqrt(geometry.rocker_length_mm**2 - np.sum(pose.horizontal_mm**2, axis=-1))
    row = np.concatenate([pose.horizontal_mm / w[..., None], np.ones(w.shape + (1,))], axis=-1)
    a = np.einsum("nki,nkiu->nku", row, joint_jac)
    c = np.einsum("ki,nkiu->nku", geometry.plane_normals, joint_jac)
    dependent = -np.linalg.solve(c[:, :, _PARASITIC], c[:, :, _INDEPENDENT])
    return a[:, :, _INDEPENDENT] + a[:, :, _PARASITIC] @ dependent


def slider_accelerations(geometry: Pru3Geometry, q, q_dot, q_ddot, step: float = 1e-5) -> np.ndarray:
    """d2L/dt2 = J_p q_ddot + (dJ_p/dt) q_dot (N, 3); dJ_p/dt by a central difference of
    J_p along q_dot (seed 2.1.1, acceleration analysis)."""
    q, q_dot, q_ddot = _as_q(q), _as_q(q_dot), _as_q(q_ddot)
    jac = velocity_jacobian(geometry, q)
    ahead, behind = velocity_jacobian(geometry, q + step * q_dot), velocity_jacobian(geometry, q - step * q_dot)
    jac_dot = (ahead - behind) / (2 * step)
    return np.einsum("nij,nj->ni", jac, q_ddot) + np.einsum("nij,nj->ni", jac_dot, q_dot)


def feed_positions_mm(x_mm, pose: Pru3Pose) -> np.ndarray:
    """Feed-stage positions u (N,) that put the tool at machine x_mm: x minus the head's
    parasitic x."""
    return np.asarray(x_mm, float) - pose.full[:, 0]


def tool_positions_mm(pose: Pru3Pose, feed_mm=0.0) -> np.ndarray:
    """The platform origin (N, 3) in the machine frame, the feed stage at feed_mm."""
    feed = np.broadcast_to(np.asarray(feed_mm, float), (len(pose.full),))
    return pose.full[:, :3] + np.outer(feed, (1.0, 0.0, 0.0))


def forward_kinematics(geometry: Pru3Geometry, lengths_mm, initial_guess=(200.0, 0.0, 0.0),
                       tolerance_mm: float = 1e-10, max_iterations: int = FK_MAX_ITERATIONS) -> tuple[np.ndarray, int]:
    """q = (z, alpha, beta) from slider positions by Newton-Raphson (seed 2.1.2):
    dq = J_p^-1 (L - L(q)), q <- q + dq, until max |L(q) - L| < tolerance_mm.
    Returns (q, iterations); raises ValueError when it does not converge."""
    q, iterations, _ = _forward_kinematics_pose(geometry, lengths_mm, initial_guess, tolerance_mm, max_iterations)
    return q, iterations


def _forward_kinematics_pose(geometry: Pru3Geometry, lengths_mm, initial_guess, tolerance_mm: float,
                             max_iterations: int) -> tuple[np.ndarray, int, Pru3Pose]:
    """:func:`forward_kinematics`, and the inverse kinematics of the q found (its last check)."""
    target = np.asarray(lengths_mm, float).reshape(3)
    if not np.all(np.isfinite(target)):
        raise ValueError("slider positions must be finite")
    q = _as_q(initial_guess)[0].copy()
    for iteration in range(1, max_iterations + 1):
        pose = inverse_kinematics(geometry, q)
        error = target - pose.lengths_mm[0]
        if not np.all(np.isfinite(error)):
            raise ValueError(f"FK left the rocker geometry at q = {q} (no real solution)")
        if np.max(np.abs(error)) < tolerance_mm:
            return q, iteration - 1, pose
        jac = velocity_jacobian(geometry, q, pose)[0]
        if np.linalg.cond(jac) > 1e12:
            raise ValueError(f"singular Jacobian at q = {q}")
        q = q + np.linalg.solve(jac, error)
    raise ValueError(f"FK did not converge in {max_iterations} iterations")


def forward_kinematics_rows(geometry: Pru3Geometry, lengths_mm, initial_guess=(200.0, 0.0, 0.0),
                            tolerance_mm: float = 1e-10, max_iterations: int = FK_MAX_ITERATIONS) -> np.ndarray:
    """:func:`forward_kinematics` of n rows of slider positions (n, 3) at once, each from
    ``initial_guess``: the same Newton steps, vectorized, a row leaving the iteration once
    it is within ``tolerance_mm``. Returns q (n, 3); ValueError naming the first row that
    leaves the rocker geometry, meets a singular Jacobian or does not converge."""
    target = np.asarray(lengths_mm, float).reshape(-1, 3)
    if not np.all(np.isfinite(target)):
        raise ValueError("slider positions must be finite")
    q = np.repeat(_as_q(initial_guess), len(target), axis=0)
    active = np.arange(len(target))
    for iteration in range(max_iterations + 1):
        error = target[active] - inverse_kinematics(geometry, q[active]).lengths_mm
        lost = ~np.all(np.isfinite(error), axis=1)
        if lost.any():
            k = int(active[np.argmax(lost)])
            raise ValueError(f"row {k}: FK left the rocker geometry at q = {q[k]} (no real solution)")
        moving = np.max(np.abs(error), axis=1) >= tolerance_mm
        active, error = active[moving], error[moving]
        if not active.size:
            return q
        if iteration == max_iterations:
            break
        jac = velocity_jacobian(geometry, q[active])
        singular = np.linalg.cond(jac) > 1e12
        if singular.any():
            k = int(active[np.argmax(singular)])
            raise ValueError(f"row {k}: singular Jacobian at q = {q[k]}")
        q[active] += np.linalg.solve(jac, error[..., None])[..., 0]
    raise ValueError(f"row {int(active[0])}: FK did not converge in {max_iterations} iterations")


@dataclass(frozen=True)
class Pru3JointCheck:
    """Inverse kinematics of n tool poses on the head (and its feed stage)."""

    positions_mm: np.ndarray  # (n, joints): sliders L_1..L_3, then the feed stage's x
    reachable: np.ndarray  # (n,) within stroke, tilt and the rockers' geometry
    stroke_margin_mm: np.ndarray  # (n,) least distance of any joint to its stroke's ends (< 0: outside)
    tilt_margin_rad: np.ndarray  # (n,) tilt_max_rad minus the larger of |alpha|, |beta|


def joint_check(geometry: Pru3Geometry, poses) -> Pru3JointCheck:
    """Joint positions and margins of n tool poses (x, y, z mm, roll, pitch, yaw rad)."""
    rows = np.asarray(poses, float).reshape(-1, 6)
    pose = inverse_kinematics(geometry, rows[:, [2, 3, 4]])
    low, high = geometry.stroke_mm
    sliders = np.nan_to_num(pose.lengths_mm, nan=-np.inf)
    stroke = np.minimum(sliders - low, high - sliders).min(axis=1)
    reachable = pose.reachable.copy()
    positions = pose.lengths_mm
    if geometry.feed_stroke_mm is not None:  # the feed stage carries x
        feed = feed_positions_mm(rows[:, 0], pose)
        low, high = geometry.feed_stroke_mm
        stroke = np.minimum(stroke, np.minimum(feed - low, high - feed))
        reachable &= stroke >= 0
        positions = np.column_stack([pose.lengths_mm, feed])
    tilt = geometry.tilt_max_rad - np.abs(pose.full[:, 3:5]).max(axis=1)
    return Pru3JointCheck(positions, reachable, stroke, tilt)


class Pru3ToolTracker:
    """The tool point of the head in motion from its joint positions, forward kinematics
    warm-started from the last pose (the head moves little in one control period)."""

    def __init__(self, geometry: Pru3Geometry, guess=(200.0, 0.0, 0.0), tolerance_mm: float = 1e-7):
        self.geometry, self.tolerance_mm = geometry, tolerance_mm
        self.q = np.asarray(guess, float)

    def tool_position_mm(self, positions_mm) -> np.ndarray:
        """The tool point (3,) mm: sliders, then the feed stage if any."""
        positions_mm = np.asarray(positions_mm, float)
        self.q, _, pose = _forward_kinematics_pose(self.geometry, positions_mm[:3], self.q, self.tolerance_mm,
                                                    FK_MAX_ITERATIONS)
        return tool_positions_mm(pose, positions_mm[3] if len(positions_mm) > 3 else 0.0)[0]
