"""Workspace of a Stewart-Gough platform at a fixed orientation (seed 000 part 1, 4.2-4.4, 5).

- centre: centroid of the reachable points of a cube of test positions (4.2);
- boundary: for every direction (theta, phi) of a spherical grid about the centre, the
  radius rho where TestPose turns false, by successive halving to precision eps (4.3),
  all directions at once;
- volume: the pyramidal-sector sum of 4.4;
- an independent check: a voxel count of TestPose over the bounding box;
- cross-sections at heights z (5.2, Fig. 12-13) and sweeps over roll (Fig. 14).

Sector grid: theta in steps of 360/n_theta deg, phi from -90 to +90 deg in n_phi rows,
so n_theta * n_phi sectors. The seed's pseudocode loops phi while phi < 90 deg and so
names one row fewer for the same step: its 40 / 180 / 760 / 1200 sectors are steps of
36 / 18 / 9 / 7.2 deg, here 10x5 / 20x10 / 40x20 / 50x25 sectors.

Lengths in mm, angles in rad, volumes in mm^3, areas in mm^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.kinematics.stewart import StewartGeometry, check_poses


def _poses(points: np.ndarray, orientation) -> np.ndarray:
    flat = points.reshape(-1, 3)
    return np.concatenate([flat, np.broadcast_to(np.asarray(orientation, float), (len(flat), 3))], axis=1)


def _reachable(geometry, points, orientation, chunk: int = 200_000) -> np.ndarray:
    flat = points.reshape(-1, 3)
    out = np.empty(len(flat), bool)
    for start in range(0, len(flat), chunk):
        out[start:start + chunk] = check_poses(geometry, _poses(flat[start:start + chunk], orientation)).reachable
    return out.reshape(points.shape[:-1])


def find_center(geometry: StewartGeometry, orientation, cube_mm, points_per_axis: int = 11) -> np.ndarray:
    """Approximate workspace centre (seed 4.2): centroid of the reachable cube grid points.

    ``cube_mm`` = ((x_min, x_max), (y_min, y_max), (z_min, z_max)).
    """
    axes = [np.linspace(lo, hi, points_per_axis) for lo, hi in cube_mm]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    ok = _reachable(geometry, grid, orientation)
    if not ok.any():
        raise ValueError(f"no reachable position in the search cube {cube_mm} at orientation {orientation}")
    return grid[ok].mean(axis=0)


def sphere_directions(n_theta: int, n_phi: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """theta (n_theta,), phi (n_phi + 1,) from -pi/2 to pi/2, unit vectors (n_phi + 1, n_theta, 3)."""
    if n_theta < 3 or n_phi < 2:
        raise ValueError("need n_theta >= 3 and n_phi >= 2")
    theta = np.arange(n_theta) * (2 * np.pi / n_theta)
    phi = np.linspace(-np.pi / 2, np.pi / 2, n_phi + 1)
    directions = np.stack([np.cos(phi)[:, None] * np.cos(theta), np.cos(phi)[:, None] * np.sin(theta),
                           np.broadcast_to(np.sin(phi)[:, None], (n_phi + 1, n_theta))], axis=-1)
    return theta, phi, directions


def boundary_radii(geometry, orientation, center, directions, eps_mm: float = 1.0,
                   *, rho_max_mm: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Boundary radius along each direction by successive approximation (seed 4.3).

    Keeps a tested-inside radius and a tested-outside radius per direction and halves the
    gap until it is below ``eps_mm``; returns the inside one -- the seed's final "pull in
    by eps" made exact: every returned point passed TestPose, error in (-eps, 0].
    Assumes, as the seed does, that beyond a violating radius every radius violates.

    Returns (rho_mm, limiting_set): the set (0..3 for I..IV) violated just outside.
    """
    center = np.asarray(center, float)
    if not _reachable(geometry, center[None], orientation)[0]:
        raise ValueError(f"the search centre {center} is not reachable")
    if rho_max_mm is None:
        rho_max_mm = 2.0 * geometry.strut_length_max_mm
    inside = np.zeros(directions.shape[:-1])
    outside = np.full(directions.shape[:-1], float(rho_max_mm))
    if _reachable(geometry, center + outside[..., None] * directions, orientation).any():
        raise ValueError(f"the workspace reaches beyond rho_max = {rho_max_mm} mm; raise it")
    while np.max(outside - inside) > eps_mm:
        middle = 0.5 * (inside + outside)
        ok = _reachable(geometry, center + middle[..., None] * directions, orientation)
        inside = np.where(ok, middle, inside)
        outside = np.where(ok, outside, middle)
    outer = check_poses(geometry, _poses(center + outside[..., None] * directions, orientation))
    return inside, outer.limiting_set().reshape(inside.shape)


def sector_volume(rho: np.ndarray, phi: np.ndarray) -> float:
    """Pyramidal-sector volume (seed 4.4) of radii rho (n_phi + 1, n_theta) on the grid of
    :func:`sphere_directions`. Each sector of four adjacent points is a four-sided pyramid
    with apex at the centre: l = mean of the four radii, base = dphi l, width = the theta
    arc dtheta l taken at the mean cos(phi) of the sector's two latitudes, height
    sqrt(l^2 - (width^2 + base^2)/4), volume base width height / 3."""
    n_theta = rho.shape[1]
    d_theta, d_phi = 2 * np.pi / n_theta, phi[1] - phi[0]
    nxt = np.roll(rho, -1, axis=1)
    length = (rho[:-1] + nxt[:-1] + rho[1:] + nxt[1:]) / 4
    base = d_phi * length
    width = d_theta * length * (0.5 * (np.cos(phi[:-1]) + np.cos(phi[1:])))[:, None]
    height = np.sqrt(np.maximum(length**2 - (width**2 + base**2) / 4, 0.0))
    return float(np.sum(base * width * height / 3))


def voxel_volume(geometry, orientation, bounds_mm, spacing_mm: float) -> float:
    """Independent volume estimate: TestPose on a grid of voxel centres in ``bounds_mm``
    ((x_min, x_max), (y_min, y_max), (z_min, z_max)), count x spacing^3."""
    axes = [np.arange(lo + spacing_mm / 2, hi, spacing_mm) for lo, hi in bounds_mm]
    count = 0
    for x in axes[0]:  # one slab at a time keeps memory small
        slab = np.stack(np.meshgrid([x], axes[1], axes[2], indexing="ij"), axis=-1)
        count += int(_reachable(geometry, slab, orientation).sum())
    return count * spacing_mm**3


@dataclass(frozen=True)
class Workspace:
    """A workspace map at one orientation (roll, pitch, yaw rad)."""

    orientation: np.ndarray  # (3,)
    center_mm: np.ndarray  # (3,)
    theta: np.ndarray  # (n_theta,)
    phi: np.ndarray  # (n_phi + 1,)
    rho_mm: np.ndarray  # (n_phi + 1, n_theta)
    limiting_set: np.ndarray  # (n_phi + 1, n_theta), 0..3 = I..IV
    volume_mm3: float

    @property
    def sectors(self) -> int:
        return self.rho_mm.shape[1] * (self.rho_mm.shape[0] - 1)

    @property
    def boundary_mm(self) -> np.ndarray:
        """Boundary points (n_phi + 1, n_theta, 3)."""
        _, _, directions = sphere_directions(len(self.theta), len(self.phi) - 1)
        return self.center_mm + self.rho_mm[..., None] * directions


def compute_workspace(geometry: StewartGeometry, orientation, search_cube_mm, n_theta: int = 50,
                      n_phi: int = 25, *, eps_mm: float = 1.0, center_mm=None) -> Workspace:
    """Centre search, spherical boundary search and sector volume at one orientation."""
    orientation = np.asarray(orientation, float)
    center = find_center(geometry, orientation, search_cube_mm) if center_mm is None else np.asarray(center_mm)
    theta, phi, directions = sphere_directions(n_theta, n_phi)
    rho, limiting = boundary_radii(geometry, orientation, center, directions, eps_mm)
    return Workspace(orientation, center, theta, phi, rho, limiting, sector_volume(rho, phi))


def cross_section(geometry: StewartGeometry, orientation, z_mm: float, center_xy_mm,
                  n_angles: int = 360, *, eps_mm: float = 1.0) -> tuple[float, np.ndarray]:
    """Area (mm^2) and boundary polygon (n_angles, 2) of the workspace slice at height z,
    by the same successive approximation in the plane from ``center_xy_mm`` (seed 5.2).
    Zero area if that point of the slice is not reachable."""
    angles = np.arange(n_angles) * (2 * np.pi / n_angles)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(n_angles)], axis=-1)
    center = np.array([center_xy_mm[0], center_xy_mm[1], z_mm], float)
    if not _reachable(geometry, center[None], orientation)[0]:
        return 0.0, np.repeat(center[None, :2], n_angles, axis=0)
    rho, _ = boundary_radii(geometry, orientation, center, directions, eps_mm)
    polygon = center[:2] + rho[:, None] * directions[:, :2]
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))), polygon


def roll_sweep(geometry: StewartGeometry, rolls_rad, search_cube_mm, n_theta: int = 50, n_phi: int = 25,
               *, eps_mm: float = 1.0, progress=None) -> list[Workspace]:
    """Workspaces over a sweep of roll angles (pitch = yaw = 0), seed Fig. 14.
    ``progress`` (optional) is called once per roll, e.g. a tqdm update."""
    result = []
    for roll in rolls_rad:
        result.append(compute_workspace(geometry, (roll, 0.0, 0.0), search_cube_mm, n_theta, n_phi, eps_mm=eps_mm))
        if progress is not None:
            progress()
    return result
