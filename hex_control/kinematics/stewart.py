"""Stewart-Gough 6-6 platform: inverse kinematics, the four constraint sets, TestPose and
forward kinematics (seed 000 part 1, sections 3-4; FK by the Newton-Raphson steps of
seed 001 section 2.1.2).

Conventions: lengths in mm, angles in rad. A pose is the row (x, y, z, roll, pitch, yaw)
of the tool point in the base frame, rotation R = R_z(yaw) R_y(pitch) R_x(roll). Every
function takes poses of shape (6,) or (N, 6) and is vectorized over N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from hex_control.kinematics.machine_kind import CONSTRAINT_SETS, ConstraintCheck, JointPositionsFromConstraints
from hex_control.kinematics.rotation import rotation_derivatives, rotation_matrix
from hex_control.kinematics.segments import closest_parameters

try:  # TrackingForwardKinematics' Newton steps compiled (_stewart_c.c, built by setup.py)
    from hex_control.kinematics import _stewart_c as _compiled
except ImportError:  # pragma: no cover - not built (no C compiler): the same steps in numpy
    _compiled = None


def _per_strut(value, name: str) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, float), (6,)).copy()
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return array


@dataclass(frozen=True)
class StewartGeometry(JointPositionsFromConstraints):
    """Joint coordinates and limits of a 6-6 Stewart-Gough platform (mm, rad).

    ``platform_joints_mm`` are in the platform frame, whose origin is the tool point
    when ``tool_offset_mm`` is zero; a tool offset moves the tool point in that frame.
    The nominal strut directions (zero joint angles, seed section 3.2) are those at
    ``home_pose``.
    """

    name: str
    base_joints_mm: np.ndarray  # (6, 3)
    platform_joints_mm: np.ndarray  # (6, 3)
    strut_length_min_mm: float
    strut_length_max_mm: float
    platform_joint_max_rad: np.ndarray  # (6,)
    base_joint_max_rad: np.ndarray  # (6,)
    strut_pairs: tuple[tuple[int, int], ...]
    strut_distance_min_mm: float
    home_pose: np.ndarray  # (6,)
    tool_offset_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    strut_speed_max_mm_s: float = math.inf  # the plant's servo limits (hex_control.plant.limits)
    strut_acceleration_max_mm_s2: float = math.inf

    def __post_init__(self):
        if not (self.strut_speed_max_mm_s > 0 and self.strut_acceleration_max_mm_s2 > 0):
            raise ValueError("need strut_speed_max_mm_s > 0 and strut_acceleration_max_mm_s2 > 0")
        for name in ("base_joints_mm", "platform_joints_mm"):
            array = np.asarray(getattr(self, name), float)
            if array.shape != (6, 3) or not np.all(np.isfinite(array)):
                raise ValueError(f"{name} must be 6 finite points (6 x 3), got shape {array.shape}")
            object.__setattr__(self, name, array)
        if not 0 < self.strut_length_min_mm < self.strut_length_max_mm:
            raise ValueError("need 0 < strut_length_min_mm < strut_length_max_mm")
        object.__setattr__(self, "platform_joint_max_rad", _per_strut(self.platform_joint_max_rad,
                                                                      "platform_joint_max_rad"))
        object.__setattr__(self, "base_joint_max_rad", _per_strut(self.base_joint_max_rad, "base_joint_max_rad"))
        for i, j in self.strut_pairs:
            if not (0 <= i < 6 and 0 <= j < 6 and i != j):
                raise ValueError(f"strut pair {(i, j)} must name two different struts 0..5")
        home = np.asarray(self.home_pose, float)
        tool = np.asarray(self.tool_offset_mm, float)
        if home.shape != (6,) or tool.shape != (3,):
            raise ValueError("home_pose must have 6 values and tool_offset_mm 3")
        object.__setattr__(self, "home_pose", home)
        object.__setattr__(self, "tool_offset_mm", tool)
        home_struts = _strut_vectors(self, home[None])[0]
        if np.any(np.linalg.norm(home_struts, axis=-1) < 1e-9):
            raise ValueError("home_pose puts a platform joint on its base joint")
        object.__setattr__(self, "_nominal_base", home_struts / np.linalg.norm(home_struts, axis=-1)[:, None])
        # the platform joint's reference direction is fixed in the platform frame
        r_home = rotation_matrix(*home[3:])
        object.__setattr__(self, "_nominal_platform", self._nominal_base @ r_home)  # rows: R_home^T s

    plant_drive = "strut_servos"
    maps_workspace = True
    constraint_sets = CONSTRAINT_SETS

    @property
    def joint_names(self) -> list[str]:
        """The struts, in the order of every strut array."""
        return [f"strut_{i}" for i in range(6)]

    def constraint_check(self, poses) -> ConstraintCheck:
        """Inverse kinematics and constraint sets I-IV (:func:`check_poses`)."""
        check = check_poses(self, poses)
        return ConstraintCheck(check.lengths_mm, check.satisfied, check.margins, check.platform_joint_angles_rad,
                               check.base_joint_angles_rad)

    def check_joint_positions_mm(self, positions_mm) -> None:
        """Raise ValueError unless every strut length (mm) is within the stroke."""
        lengths = np.asarray(positions_mm, float).reshape(-1)
        low, high = self.strut_length_min_mm, self.strut_length_max_mm
        if lengths.shape != (6,):
            raise ValueError(f"need 6 strut lengths, got {lengths.shape[0]}")
        outside = np.flatnonzero(~((lengths >= low) & (lengths <= high)))
        if outside.size:
            i = int(outside[0])
            raise ValueError(f"strut {i} at {lengths[i]:.1f} mm is outside its stroke {low:g}..{high:g} mm")

    def check_joint_trajectory_mm(self, positions_mm) -> None:
        """:meth:`check_joint_positions_mm` of every row (n, 6) at once; the ValueError names
        the first row out of the stroke."""
        rows = np.asarray(positions_mm, float)
        if rows.ndim != 2 or rows.shape[1] != 6:
            raise ValueError(f"need rows of 6 strut lengths, got shape {rows.shape}")
        low, high = self.strut_length_min_mm, self.strut_length_max_mm
        outside = np.argwhere(~((rows >= low) & (rows <= high)))
        if outside.size:
            k, i = (int(v) for v in outside[0])
            raise ValueError(f"row {k}: strut {i} at {rows[k, i]:.1f} mm is outside its stroke {low:g}..{high:g} mm")

    def forward_pose(self, positions_mm, guess, tolerance_mm: float = 1e-9,
                     max_iterations: int = 50) -> tuple[np.ndarray, int, float]:
        """Forward kinematics (:func:`forward_kinematics`) from ``guess``, or from the home
        pose if it is all zeros."""
        guess = np.asarray(guess, float)
        return forward_kinematics(self, positions_mm, guess if np.any(guess) else None, tolerance_mm, max_iterations)

    def tool_tracker(self) -> TrackingForwardKinematics:
        """Forward kinematics of the machine in motion, warm-started from the last pose:
        ``tool_position_mm(strut lengths mm)`` -> the tool point (3,) mm."""
        return TrackingForwardKinematics(self)

    @property
    def joint_speed_max_mm_s(self) -> np.ndarray:
        """Each strut's speed limit (mm/s)."""
        return np.full(6, self.strut_speed_max_mm_s)

    @property
    def joint_acceleration_max_mm_s2(self) -> np.ndarray:
        """Each strut's acceleration limit (mm/s^2)."""
        return np.full(6, self.strut_acceleration_max_mm_s2)

    @property
    def joints_from_tool_mm(self) -> np.ndarray:
        """Platform joints relative to the tool point, in the platform frame."""
        return self.platform_joints_mm - self.tool_offset_mm

    @classmethod
    def from_dict(cls, data: dict) -> StewartGeometry:
        deg = math.radians
        home = list(data.get("home_pose", [0, 0, 0, 0, 0, 0]))
        return cls(
            name=str(data.get("name", "stewart")),
            base_joints_mm=np.array(data["base_joints_mm"], float),
            platform_joints_mm=np.array(data["platform_joints_mm"], float),
            strut_length_min_mm=float(data["strut_length_mm"][0]),
            strut_length_max_mm=float(data["strut_length_mm"][1]),
            platform_joint_max_rad=np.radians(data["platform_joint_max_deg"]),
            base_joint_max_rad=np.radians(data["base_joint_max_deg"]),
            strut_pairs=tuple(tuple(int(k) for k in pair) for pair in data.get("strut_pairs", [])),
            strut_distance_min_mm=float(data.get("strut_distance_min_mm", 0.0)),
            home_pose=np.array(home[:3] + [deg(a) for a in home[3:]], float),
            tool_offset_mm=np.array(data.get("tool_offset_mm", [0, 0, 0]), float),
            strut_speed_max_mm_s=float(data.get("strut_speed_max_mm_s", math.inf)),
            strut_acceleration_max_mm_s2=float(data.get("strut_acceleration_max_mm_s2", math.inf)),
        )

    @classmethod
    def from_yaml(cls, path) -> StewartGeometry:
        data = yaml.safe_load(Path(path).read_text())
        return cls.from_dict(data.get("machine", data))


def as_poses(poses) -> np.ndarray:
    """(N, 6) float array of poses; raises ValueError on a wrong shape or non-finite values."""
    array = np.asarray(poses, float)
    if array.ndim == 1:
        array = array[None]
    if array.ndim != 2 or array.shape[1] != 6:
        raise ValueError(f"poses must have shape (6,) or (N, 6), got {np.shape(poses)}")
    if not np.all(np.isfinite(array)):
        raise ValueError("poses must be finite")
    return array


def _strut_vectors(geometry: StewartGeometry, poses: np.ndarray) -> np.ndarray:
    """S_i = T + R P_i - B_i, shape (N, 6, 3) (seed section 3)."""
    rotation = rotation_matrix(poses[:, 3], poses[:, 4], poses[:, 5])
    joints = np.einsum("nij,kj->nki", rotation, geometry.joints_from_tool_mm)
    return poses[:, None, :3] + joints - geometry.base_joints_mm


def strut_lengths(geometry: StewartGeometry, poses) -> np.ndarray:
    """L_i = |T + R P_i - B_i| (mm), shape (N, 6): inverse kinematics (seed 3.1)."""
    return np.linalg.norm(_strut_vectors(geometry, as_poses(poses)), axis=-1)


@dataclass(frozen=True)
class PoseCheck:
    """Inverse kinematics and the four constraint sets for N poses (seed 3.1-3.3, TestPose 4.1).

    Margins are limit minus value on the binding side, per set: positive = inside.
    """

    lengths_mm: np.ndarray  # (N, 6)
    platform_joint_angles_rad: np.ndarray  # (N, 6)
    base_joint_angles_rad: np.ndarray  # (N, 6)
    strut_distances_mm: np.ndarray  # (N, pairs)
    margins: np.ndarray  # (N, 4): mm, rad, rad, mm

    @property
    def satisfied(self) -> np.ndarray:
        """(N, 4) bool: sets I-IV hold (I strictly, as L_min < L_i < L_max)."""
        ok = self.margins > 0
        ok[:, 3] = self.margins[:, 3] >= 0
        return ok

    @property
    def reachable(self) -> np.ndarray:
        return self.satisfied.all(axis=1)

    def limiting_set(self) -> np.ndarray:
        """Index 0..3 of the first violated set per pose (-1 where all hold)."""
        violated = ~self.satisfied
        return np.where(violated.any(axis=1), violated.argmax(axis=1), -1)


_CHUNK = 8192  # poses per block: keeps the (N, 6) temporaries in cache


def _rotation_entries(poses: np.ndarray):
    """R = R_z R_y R_x entries (r00, r01, ..., r22), each (N, 1) for broadcasting."""
    ca, sa = np.cos(poses[:, 3:4]), np.sin(poses[:, 3:4])
    cb, sb = np.cos(poses[:, 4:5]), np.sin(poses[:, 4:5])
    cg, sg = np.cos(poses[:, 5:6]), np.sin(poses[:, 5:6])
    return (cg * cb, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa,
            sg * cb, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa,
            -sb, cb * sa, cb * ca)


def _rotate(r, v: np.ndarray):
    """Components of R v for fixed vectors v (6, 3) -> three (N, 6) arrays."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return (r[0] * x + r[1] * y + r[2] * z, r[3] * x + r[4] * y + r[5] * z, r[6] * x + r[7] * y + r[8] * z)


def _check_block(geometry: StewartGeometry, poses: np.ndarray):
    r = _rotation_entries(poses)
    jx, jy, jz = _rotate(r, geometry.joints_from_tool_mm)
    tops = (poses[:, 0:1] + jx, poses[:, 1:2] + jy, poses[:, 2:3] + jz)  # platform joints (N, 6) each
    base = geometry.base_joints_mm
    sx, sy, sz = tops[0] - base[:, 0], tops[1] - base[:, 1], tops[2] - base[:, 2]
    lengths = np.sqrt(sx * sx + sy * sy + sz * sz)
    inverse = 1.0 / np.maximum(lengths, 1e-300)
    nominal = geometry._nominal_base
    cos_base = (sx * nominal[:, 0] + sy * nominal[:, 1] + sz * nominal[:, 2]) * inverse
    px, py, pz = _rotate(r, geometry._nominal_platform)
    cos_platform = (sx * px + sy * py + sz * pz) * inverse
    # arccos is accurate to ~1e-8 rad near 0, ample against joint limits of tens of degrees
    base_angles = np.arccos(np.clip(cos_base, -1.0, 1.0))
    platform_angles = np.arccos(np.clip(cos_platform, -1.0, 1.0))
    if geometry.strut_pairs:
        # segments from base joint B to platform joint: d = strut vector S, |d|^2 = L^2,
        # and r = B_i - B_j is fixed, so only the dot products with S are per pose
        i, j = np.array(geometry.strut_pairs).T
        r = base[i] - base[j]
        s1, s2 = (sx[:, i], sy[:, i], sz[:, i]), (sx[:, j], sy[:, j], sz[:, j])
        b = s1[0] * s2[0] + s1[1] * s2[1] + s1[2] * s2[2]
        c = s1[0] * r[:, 0] + s1[1] * r[:, 1] + s1[2] * r[:, 2]
        f = s2[0] * r[:, 0] + s2[1] * r[:, 1] + s2[2] * r[:, 2]
        a, e = lengths[:, i] ** 2, lengths[:, j] ** 2
        u, v = closest_parameters(a.ravel(), b.ravel(), c.ravel(), e.ravel(), f.ravel())
        u, v = u.reshape(a.shape), v.reshape(a.shape)
        gap = [r[:, k] + s1[k] * u - s2[k] * v for k in range(3)]
        distances = np.sqrt(gap[0] ** 2 + gap[1] ** 2 + gap[2] ** 2)
        distance_margin = distances.min(axis=1) - geometry.strut_distance_min_mm
    else:
        distances = np.zeros((len(poses), 0))
        distance_margin = np.full(len(poses), np.inf)
    margins = np.stack([
        np.minimum(lengths - geometry.strut_length_min_mm, geometry.strut_length_max_mm - lengths).min(axis=1),
        (geometry.platform_joint_max_rad - platform_angles).min(axis=1),
        (geometry.base_joint_max_rad - base_angles).min(axis=1),
        distance_margin,
    ], axis=1)
    return lengths, platform_angles, base_angles, distances, margins


def check_poses(geometry: StewartGeometry, poses) -> PoseCheck:
    """Strut lengths, joint angles and strut distances of N poses, with the margin to each set.

    Base joint angle: between the strut and its nominal direction; platform joint angle:
    between the strut and the nominal direction carried along by the platform rotation
    (seed 3.2). Strut distance: true segment distance of the configured pairs (3.3).
    """
    poses = as_poses(poses)
    blocks = [_check_block(geometry, poses[k:k + _CHUNK]) for k in range(0, len(poses), _CHUNK)]
    return PoseCheck(*(np.concatenate(parts) for parts in zip(*blocks)))


def test_pose(geometry: StewartGeometry, poses) -> np.ndarray:
    """TestPose (seed 4.1): True where a pose satisfies all four constraint sets, shape (N,)."""
    return check_poses(geometry, poses).reachable


test_pose.__test__ = False  # not a pytest test, despite the seed's name


def jacobian(geometry: StewartGeometry, poses) -> np.ndarray:
    """dL/dq (N, 6, 6): rows struts, columns (x, y, z mm; roll, pitch, yaw rad).

    dL_i/dT = s_i (unit strut vector); dL_i/dangle = s_i . (dR/dangle P_i).
    """
    poses = as_poses(poses)
    struts = _strut_vectors(geometry, poses)
    units = struts / np.linalg.norm(struts, axis=-1)[..., None]
    derivatives = rotation_derivatives(poses[:, 3], poses[:, 4], poses[:, 5])
    angular = [np.einsum("nki,nij,kj->nk", units, d, geometry.joints_from_tool_mm) for d in derivatives]
    return np.concatenate([units, np.stack(angular, axis=-1)], axis=-1)


class ForwardKinematicsError(ValueError):
    """Newton-Raphson did not reach a pose: ``reason`` is 'no_convergence' or 'singular'."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True)
class ForwardSolution:
    poses: np.ndarray  # (N, 6)
    iterations: np.ndarray  # (N,)
    residual_mm: np.ndarray  # (N,) max |L(pose) - L|
    converged: np.ndarray  # (N,) bool
    singular: np.ndarray  # (N,) bool


def forward_kinematics_batch(geometry: StewartGeometry, lengths_mm, initial_guess,
                             tolerance_mm: float = 1e-9, max_iterations: int = 50,
                             *, max_condition: float = 1e12) -> ForwardSolution:
    """Poses from strut lengths by Newton-Raphson, seed 001 section 2.1.2 steps 1-4,
    for N length sets at once: q <- q + dq with J(q) dq = L - L(q), from ``initial_guess``
    (so the solution nearest the guess is found), until max |L(q) - L| < tolerance_mm.
    A step that does not reduce the residual is halved (up to 10 times).
    """
    target = np.asarray(lengths_mm, float).reshape(-1, 6)
    if not np.all(np.isfinite(target)) or np.any(target <= 0):
        raise ValueError("strut lengths must be positive and finite")
    q = as_poses(initial_guess).copy()
    if len(q) == 1 and len(target) > 1:
        q = np.repeat(q, len(target), axis=0)
    if len(q) != len(target):
        raise ValueError(f"{len(target)} length sets but {len(q)} initial guesses")
    n = len(target)
    iterations = np.zeros(n, int)
    converged = np.zeros(n, bool)
    singular = np.zeros(n, bool)
    residual = np.abs(strut_lengths(geometry, q) - target).max(axis=1)
    active = residual >= tolerance_mm
    converged[~active] = True
    for _ in range(max_iterations):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        jac = jacobian(geometry, q[idx])
        bad = np.linalg.cond(jac) > max_condition
        singular[idx[bad]] = True
        active[idx[bad]] = False
        idx, jac = idx[~bad], jac[~bad]
        if idx.size == 0:
            break
        error = target[idx] - strut_lengths(geometry, q[idx])
        step = np.linalg.solve(jac, error[..., None])[..., 0]
        scale = np.ones(idx.size)
        for _ in range(10):
            trial = q[idx] + scale[:, None] * step
            new_residual = np.abs(strut_lengths(geometry, trial) - target[idx]).max(axis=1)
            worse = new_residual > residual[idx]
            if not worse.any():
                break
            scale[worse] *= 0.5
        q[idx] = trial
        residual[idx] = new_residual
        iterations[idx] += 1
        done = new_residual < tolerance_mm
        converged[idx[done]] = True
        active[idx[done]] = False
    return ForwardSolution(q, iterations, residual, converged, singular)


def forward_kinematics(geometry: StewartGeometry, lengths_mm, initial_guess=None,
                       tolerance_mm: float = 1e-9, max_iterations: int = 50) -> tuple[np.ndarray, int, float]:
    """One pose (6,) from six strut lengths; raises ForwardKinematicsError rather than
    return a pose that does not reproduce the lengths. Returns (pose, iterations, residual_mm)."""
    guess = geometry.home_pose if initial_guess is None else initial_guess
    solution = forward_kinematics_batch(geometry, lengths_mm, guess, tolerance_mm, max_iterations)
    if solution.singular[0]:
        raise ForwardKinematicsError("singular", "the Jacobian is singular at an iterate")
    if not solution.converged[0]:
        raise ForwardKinematicsError(
            "no_convergence", f"no convergence in {max_iterations} iterations "
                              f"(residual {solution.residual_mm[0]:.3g} mm)")
    return solution.poses[0], int(solution.iterations[0]), float(solution.residual_mm[0])


def _lengths_and_jacobian(geometry: StewartGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """L (6,) and dL/dq (6, 6) of one pose, with R = R_z R_y R_x and its derivatives written
    out entry by entry (the batch functions' einsum set-up costs more than the arithmetic for
    a single pose)."""
    cr, sr = math.cos(q[3]), math.sin(q[3])
    cp, sp = math.cos(q[4]), math.sin(q[4])
    cy, sy = math.cos(q[5]), math.sin(q[5])
    # rows: R, dR/droll, dR/dpitch, dR/dyaw, each 3 x 3
    terms = np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
        [0.0, cy * sp * cr + sy * sr, -cy * sp * sr + sy * cr],
        [0.0, sy * sp * cr - cy * sr, -sy * sp * sr - cy * cr],
        [0.0, cp * cr, -cp * sr],
        [-cy * sp, cy * cp * sr, cy * cp * cr],
        [-sy * sp, sy * cp * sr, sy * cp * cr],
        [-cp, -sp * sr, -sp * cr],
        [-sy * cp, -sy * sp * sr - cy * cr, -sy * sp * cr + cy * sr],
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [0.0, 0.0, 0.0]]) @ geometry.joints_from_tool_mm.T  # (12, 6)
    struts = q[:3, None] + terms[:3] - geometry.base_joints_mm.T
    lengths = np.sqrt((struts * struts).sum(axis=0))
    units = struts / lengths
    angular = (terms[3:].reshape(3, 3, 6) * units).sum(axis=1)  # (3 angles, 6 struts)
    return lengths, np.vstack([units, angular]).T


class TrackingForwardKinematics:
    """Forward kinematics of a machine in motion, one solve per control period: Newton
    steps from the last pose with the lengths and Jacobian it already evaluated there, so
    that a small move costs one evaluation (no conditioning check or step halving of the
    batch solver). Falls back to :func:`forward_kinematics` (which raises
    ForwardKinematicsError) when a few steps do not reach ``tolerance_mm``.

    The steps run compiled (``_stewart_c.c``: about 2 us a solve where numpy takes 35-65,
    ``hexctl bench fk``) unless ``compiled`` is False or the module is not built; the two
    agree to about 1e-12 mm (test_kinematics_stewart.py), not to the bit."""

    def __init__(self, geometry: StewartGeometry, guess=None, tolerance_mm: float = 1e-7, max_iterations: int = 4,
                 compiled: bool = True):
        self.geometry, self.tolerance_mm, self.max_iterations = geometry, tolerance_mm, max_iterations
        self._compiled = _compiled if compiled else None
        self._joints = np.ascontiguousarray(geometry.joints_from_tool_mm, float)
        self._base = np.ascontiguousarray(geometry.base_joints_mm, float)
        self._reset(np.asarray(geometry.home_pose if guess is None else guess, float))

    def _reset(self, pose: np.ndarray) -> None:
        self.pose = np.array(pose, float)  # a contiguous copy: the compiled steps write it in place
        lengths, jacobian = _lengths_and_jacobian(self.geometry, self.pose)
        self._lengths, self._jacobian = np.ascontiguousarray(lengths), np.ascontiguousarray(jacobian)

    def tool_position_mm(self, lengths_mm) -> np.ndarray:
        """The tool point (3,) mm where strut lengths ``lengths_mm`` hold it."""
        return self.solve(lengths_mm)[:3]

    def solve(self, lengths_mm) -> np.ndarray:
        """The pose (6,) whose strut lengths are ``lengths_mm`` (within tolerance_mm)."""
        target = np.ascontiguousarray(lengths_mm, float)
        if target.shape != (6,):
            raise ValueError(f"need 6 strut lengths, got shape {target.shape}")
        if self._compiled is not None:
            reached = self._compiled.track(self._joints, self._base, self.pose, self._lengths, self._jacobian,
                                           target, self.tolerance_mm, self.max_iterations)
        else:
            reached = self._numpy_steps(target)
        if reached:
            return self.pose.copy()
        self._reset(forward_kinematics(self.geometry, target, self.pose, self.tolerance_mm)[0])
        return self.pose.copy()

    def _numpy_steps(self, target: np.ndarray) -> bool:
        """The Newton steps in numpy: True, with the state moved to the solution, if they reach
        ``tolerance_mm``; the state as it was if not."""
        q, lengths, jac = self.pose, self._lengths, self._jacobian
        for step in range(self.max_iterations + 1):
            error = target - lengths
            if np.abs(error).max() < self.tolerance_mm:
                self.pose, self._lengths, self._jacobian = q, lengths, jac
                return True
            if step == self.max_iterations:
                break
            try:
                q = q + np.linalg.solve(jac, error)
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(q)):
                break
            lengths, jac = _lengths_and_jacobian(self.geometry, q)
        return False
