"""Benchmarks of the kinematics layer (issue targets: >= 1e6 poses/s for IK + the four
constraint sets; a 1200-sector map at eps = 1 mm under 0.2 s; a 0-30 deg roll sweep in
1 deg steps under 5 s)."""

from __future__ import annotations

import time

import numpy as np

from hex_control.bench import benchmark, best_time
from hex_control.config import config_file
from hex_control.kinematics import load_machine
from hex_control.kinematics.stewart import (
    TrackingForwardKinematics,
    check_poses,
    forward_kinematics,
    forward_kinematics_batch,
    strut_lengths,
)
from hex_control.kinematics.workspace import compute_workspace, find_center, sphere_directions


def _nist():
    geometry, document = load_machine(config_file("machines/nist_ingersoll.yaml"))
    return geometry, document["workspace"]["search_cube_mm"]


def _random_poses(n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    return np.array([0, 0, -2100, 0, 0, 0]) + rng.uniform(-1, 1, (n, 6)) * [800, 800, 600, 0.3, 0.3, 0.3]


@benchmark("ik")
def ik_throughput(quick: bool) -> list[str]:
    geometry, _ = _nist()
    poses = _random_poses(50_000 if quick else 400_000)
    loop_poses = poses[:500 if quick else 3000]
    vectorized = best_time(lambda: check_poses(geometry, poses), repeat=3)
    loop = best_time(lambda: [check_poses(geometry, p) for p in loop_poses], repeat=1)
    rate, loop_rate = len(poses) / vectorized, len(loop_poses) / loop
    return [f"IK + constraint sets I-IV, {len(poses)} poses",
            f"vectorized check_poses: {rate:12,.0f} poses/s",
            f"per-pose Python loop : {loop_rate:12,.0f} poses/s   (baseline)",
            f"ratio: {rate / loop_rate:.0f}x   (target >= 1,000,000 poses/s)"]


def _seed_style_boundary(geometry, orientation, center, directions, eps_mm, *, rho_max_mm):
    """The seed's pseudocode as written: one direction at a time, one TestPose per step."""
    rho = np.empty(directions.shape[:-1])
    for index in np.ndindex(rho.shape):
        inside, outside = 0.0, rho_max_mm
        while outside - inside > eps_mm:
            middle = 0.5 * (inside + outside)
            point = center + middle * directions[index]
            if check_poses(geometry, [*point, *orientation]).reachable[0]:
                inside = middle
            else:
                outside = middle
        rho[index] = inside
    return rho


@benchmark("workspace")
def workspace_speed(quick: bool) -> list[str]:
    geometry, cube = _nist()
    level = (0.0, 0.0, 0.0)
    one_map = best_time(lambda: compute_workspace(geometry, level, cube, 50, 24, eps_mm=1.0), repeat=3)
    center = find_center(geometry, level, cube)
    _, _, directions = sphere_directions(50, 24)
    subset = directions[:, :5] if not quick else directions[:, :1]  # the loop is slow: time part of it
    start = time.perf_counter()
    _seed_style_boundary(geometry, level, center, subset, 1.0, rho_max_mm=2 * geometry.strut_length_max_mm)
    loop_per_direction = (time.perf_counter() - start) / subset[..., 0].size
    loop_map = loop_per_direction * directions[..., 0].size
    rolls = np.radians(np.arange(0, 31, 1))
    start = time.perf_counter()
    for roll in rolls[: 4 if quick else None]:
        compute_workspace(geometry, (roll, 0.0, 0.0), cube, 50, 24, eps_mm=1.0)
    sweep = (time.perf_counter() - start) * (len(rolls) / (4 if quick else len(rolls)))
    return [f"1200-sector map (50 x 24), eps = 1 mm, centre search included: {one_map * 1000:.0f} ms "
            f"(target < 200 ms)",
            f"seed-style loop, one direction at a time: {loop_map:.2f} s per map (baseline, "
            f"extrapolated from {subset[..., 0].size} directions)",
            f"ratio: {loop_map / one_map:.0f}x",
            f"roll sweep 0-30 deg in 1 deg steps (31 maps): {sweep:.2f} s (target < 5 s)"
            + (" (extrapolated from 4)" if quick else "")]


@benchmark("fk")
def fk_speed(quick: bool) -> list[str]:
    geometry, _ = _nist()
    poses = _random_poses(4000 if quick else 20_000)
    poses = poses[check_poses(geometry, poses).reachable][:1000 if quick else 5000]
    lengths = strut_lengths(geometry, poses)
    batch_time = best_time(lambda: forward_kinematics_batch(geometry, lengths, geometry.home_pose), repeat=3)
    solution = forward_kinematics_batch(geometry, lengths, geometry.home_pose)
    few = lengths[:200]
    loop = best_time(lambda: [forward_kinematics(geometry, row) for row in few], repeat=1)
    error = np.abs(solution.poses - poses)
    return [f"{len(poses)} random reachable poses, guess = home pose, tolerance 1e-9 mm",
            f"batch Newton-Raphson: {len(poses) / batch_time:10,.0f} solves/s, "
            f"mean {solution.iterations.mean():.2f} iterations, converged {solution.converged.mean():.1%}, "
            f"max pose error {error[:, :3].max():.1e} mm / {error[:, 3:].max():.1e} rad",
            f"one solve at a time : {len(few) / loop:10,.0f} solves/s   (baseline)",
            f"ratio: {(len(poses) / batch_time) / (len(few) / loop):.0f}x", *_tracking_lines(geometry, quick)]


def _tracking_lines(geometry, quick: bool) -> list[str]:
    """The plant's per-period FK (TrackingForwardKinematics) along a machine-like move
    (50 um and 0.05 mrad a period), its Newton steps compiled against numpy's."""
    home = np.asarray(geometry.home_pose, float)
    periods = 500 if quick else 2000
    lengths = strut_lengths(geometry, home + np.outer(np.linspace(0.0, 1.0, periods),
                                                      [100.0, 20.0, -30.0, 0.1, 0.05, -0.02]))

    def follow(compiled: bool):
        tracker = TrackingForwardKinematics(geometry, home, compiled=compiled)
        return lambda: [tracker.solve(row) for row in lengths]
    numpy_s, compiled_s = (best_time(follow(compiled), repeat=3) for compiled in (False, True))
    return [f"tracking FK, one solve a control period over {periods} periods: compiled "
            f"{compiled_s / periods * 1e6:.1f} us, numpy {numpy_s / periods * 1e6:.1f} us (baseline), "
            f"ratio {numpy_s / compiled_s:.0f}x"]


@benchmark("pru3_dynamics")
def pru3_dynamics_speed(quick: bool) -> list[str]:
    from hex_control.kinematics.pru3 import Pru3Geometry
    from hex_control.kinematics.pru3_dynamics import Pru3Inertia, inverse_dynamics

    geometry, inertia = Pru3Geometry(), Pru3Inertia()
    omega = 4 * np.pi
    t = np.linspace(0.0, 1.0, 1000 if quick else 5000)
    c, s = np.cos(omega * t), np.sin(omega * t)
    q = np.stack([np.full_like(t, 220.0), 0.15 * c, 0.15 * s], -1)
    q_dot = np.stack([0 * t, -0.15 * omega * s, 0.15 * omega * c], -1)
    q_ddot = np.stack([0 * t, -0.15 * omega**2 * c, -0.15 * omega**2 * s], -1)
    batch = best_time(lambda: inverse_dynamics(geometry, inertia, q, q_dot, q_ddot), repeat=3)
    few = 100
    loop = best_time(lambda: [inverse_dynamics(geometry, inertia, q[k], q_dot[k], q_ddot[k]) for k in range(few)],
                     repeat=1)
    return [f"seed 4.2 trajectory, {len(t)} samples: vectorized {len(t) / batch:10,.0f} evaluations/s",
            f"one sample at a time : {few / loop:10,.0f} evaluations/s   (baseline)",
            f"ratio: {(len(t) / batch) / (few / loop):.0f}x"]
