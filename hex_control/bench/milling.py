"""Benchmark of the milling simulation (seed 004 section 3): simulated seconds per wall
second for 1 s of cutting at constant 15 000 rev/min, against a naive baseline in the same
run: the full finite-element model (no modal reduction) stepped by its own matrix
exponential, and the delayed deflection found by interpolating the whole history each step."""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.linalg import expm

from hex_control.bench import benchmark
from hex_control.seeds.milling.case import ChatterCase
from hex_control.seeds.milling.cutting import cutting_force
from hex_control.seeds.milling.programmes import ConstantSpeed
from hex_control.seeds.milling.simulation import MillingSimulator


def naive_milling(case: ChatterCase, speed_rpm: float, duration_s: float) -> np.ndarray:
    """Tip deflection (T, 2) of the full FE model, damping proportional to stiffness (the
    case's ratio at the first mode), one interpolation of the whole history per step."""
    mass, stiffness = case.tool.plane_matrices()
    omega = case.modes.omega_rad_s[0]
    damping = 2 * case.tool.damping_ratio / omega * stiffness  # stiffness-proportional, zeta at mode 1
    n = mass.shape[0]
    m_inv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ stiffness, -m_inv @ damping]])
    block = np.zeros((2 * n + 1, 2 * n + 1))
    block[:2 * n, :2 * n] = a
    block[n:2 * n, 2 * n] = m_inv[:, -2]  # force at the tip deflection DOF
    e = expm(block * case.step_s)
    ad, bd = e[:2 * n, :2 * n], e[:2 * n, 2 * n:]
    steps, dt = int(round(duration_s / case.step_s)), case.step_s
    tau = case.cut.tooth_period_s(speed_rpm)
    omega_spindle = 2 * math.pi * speed_rpm / 60
    x = np.zeros((2 * n, 2))
    times, tips = [0.0], [np.zeros(2)]
    for k in range(steps):
        t = k * dt
        history = np.array(tips)
        delayed = [np.interp(t - tau, times, history[:, 0], left=0.0), np.interp(t - tau, times, history[:, 1],
                                                                                  left=0.0)]
        angles = [omega_spindle * t + 2 * math.pi * l / case.cut.teeth for l in range(case.cut.teeth)]
        f = cutting_force(case.cut, angles, tips[-1], delayed)
        x = ad @ x + bd * f
        times.append(t + dt)
        tips.append(x[n - 2].copy())
    return np.array(tips[1:])


@benchmark("milling")
def milling_speed(quick: bool) -> list[str]:
    case = ChatterCase.from_yaml()
    duration = 0.2 if quick else 1.0
    start = time.perf_counter()
    MillingSimulator(case.modes, case.cut, case.step_s).run(ConstantSpeed(case.low_rpm), duration)
    fast_s = time.perf_counter() - start
    naive_duration = duration / 10  # the naive history search is quadratic: a tenth of the cut, scaled
    start = time.perf_counter()
    naive_milling(case, case.low_rpm, naive_duration)
    naive_s = time.perf_counter() - start
    steps = int(round(duration / case.step_s))
    return [f"{duration:g} s of cutting ({steps} steps of {case.step_s * 1e6:.0f} us, {case.modes.omega_rad_s.size} "
            f"modes per plane): {fast_s:.2f} s wall, {duration / fast_s:.2f} simulated s per wall s",
            f"naive baseline (full FE model, {2 * case.tool.elements} DOF per plane, whole-history interpolation) "
            f"over {naive_duration:g} s: {naive_duration / naive_s:.3f} simulated s per wall s; "
            f"ratio {naive_s / naive_duration / (fast_s / duration):.1f} (grows with the cut's length)"]
