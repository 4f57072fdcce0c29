"""Checks that a spindle programme is the seed's, from what it does in a simulation, not
from its code (seed 004 section 3). The tests run deliberately wrong variants through them
(a plain ramp, always the maximum acceleration, Z04 with a 0.25 s rise) and assert that
they are rejected.

- :func:`eq18_conformance`: the optimal-linear programme. Each control period the applied
  speed change must be eq. 18's command computed here, independently, from the
  simulator's state at that instant and limited by eq. 10; at n_max the speed must fall
  linearly to n0 in fall_s; between commands it must hold.
- :func:`triangle_timing`: a triangular programme's low and high speeds and its rise and
  fall times, measured on the speed record (Z04: 0.4 s and 0.4 s, Z05: 0.5 s and 0.5 s).
Units: s, rev/min, m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from hex_control.seeds.milling.cutting import Cut
from hex_control.seeds.milling.optimal_speed import mean_cutting_force
from hex_control.seeds.milling.semi_discretization import directional_matrix
from hex_control.seeds.milling.simulation import MillingSimulator
from hex_control.seeds.milling.tool_beam import ToolModes

#: the seed's triangular programmes (section 3): rising and falling time, s
SEED_TRIANGLES = {"Z04": (0.4, 0.4), "Z05": (0.5, 0.5)}


class _Probe:
    """Wraps a programme; records what the simulator held when each speed was asked for."""

    def __init__(self, programme):
        self.programme, self.initial_rpm = programme, programme.initial_rpm
        self.samples = []

    def speed_rpm(self, time_s, simulator):
        state = (simulator.modal_state.copy(), simulator.delay_s, tuple(simulator.delayed_velocity_m_s),
                 simulator.tooth_angles_rad[0])
        speed = float(self.programme.speed_rpm(time_s, simulator))
        self.samples.append((time_s, speed, state))
        return speed


def transition_samples(modes: ToolModes, period_s: float, nodes: int = 81) -> tuple[np.ndarray, np.ndarray]:
    """(Simpson weights (s), Phi(s) = e^(A s) at the nodes) over one control period, for the
    state x = [q'; q] of both planes (velocities first, as the seed's eq. 1); A is the tool's
    (the cut's 5 % stiffness is left out of Phi over 1 ms, as in optimal_speed)."""
    m = modes.omega_rad_s.size
    n = 2 * m
    omega2 = np.kron(np.eye(2), np.diag(modes.omega_rad_s ** 2))
    damping = np.kron(np.eye(2), np.diag(2 * modes.damping * modes.omega_rad_s))
    a = np.block([[-damping, -omega2], [np.eye(n), np.zeros((n, n))]])
    times = np.linspace(0.0, period_s, nodes)
    weights = np.full(nodes, 2.0)
    weights[1:-1:2], weights[0], weights[-1] = 4.0, 1.0, 1.0
    return weights * period_s / (3 * (nodes - 1)), np.array([expm(a * s) for s in times])


def eq18_command(modes: ToolModes, cut: Cut, state, speed_rpm: float, *, q1: float, q2: float, r: float,
                 period_s: float, cutting_stiffness: bool = True, transitions=None) -> float:
    """u = dn (rev/min) of eq. 18 over one control period, unlimited, written out in the seed's
    matrices: x = [q'; q], B of eq. 15-16 in both planes, int B^T Phi^T by Simpson's rule,
    Q1 = q1 I, Q2 = q2 I, R = r, K* of eq. 14 (``transitions``: transition_samples, reused)."""
    x_modal, delay_s, delayed_velocity, angle = state
    m = modes.omega_rad_s.size
    n = 2 * m  # both planes: q = [eta_x; eta_y]
    omega2 = np.kron(np.eye(2), np.diag(modes.omega_rad_s ** 2))
    shape = np.kron(np.eye(2), modes.tip_shape[:, None])  # (n, 2): tip force (x, y) -> modal forces
    kbar = cut.depth_m * cut.cutting_pressure_pa * directional_matrix(cut, [angle])[0]
    k_star = omega2 - shape @ kbar @ shape.T if cutting_stiffness else omega2
    # eq. 16: B_u = D_O w'(t - tau) (-tau / n): the delayed term's force per rev/min
    b_u = -kbar @ np.asarray(delayed_velocity) * delay_s / speed_rpm
    b = np.concatenate([shape @ b_u, np.zeros(n)])
    weights, phis = transitions if transitions is not None else transition_samples(modes, period_s)
    g = weights @ (phis @ b)  # int_0^Delta e^(A s) B ds
    q_dot = x_modal[m:].T.reshape(-1)
    q = x_modal[:m].T.reshape(-1)
    q_static = np.linalg.solve(k_star, shape @ mean_cutting_force(cut))  # K*^-1 f0
    bracket = np.concatenate([q1 * q_dot, 0.5 * (k_star * q2 + q2 * k_star.T) @ (q - q_static)])
    return float(-(g @ bracket) / r)


@dataclass(frozen=True)
class Eq18Conformance:
    """steps: simulator steps checked; mismatched: steps whose speed is not the rule's;
    worst_rpm: the largest difference; commands: control instants; at_limit: the share of
    eq. 18's commands that eq. 10 limits; reached_max: whether n_max was reached."""

    steps: int
    mismatched: int
    worst_rpm: float
    commands: int
    at_limit: float
    reached_max: bool

    @property
    def conforms(self) -> bool:
        return self.mismatched == 0 and self.commands > 0


def eq18_conformance(case, programme, duration_s: float, *, acceleration_rpm_s: float,
                     tolerance: float = 0.02) -> Eq18Conformance:
    """Run ``programme`` in the case's cut for ``duration_s`` and replay the optimal-linear
    rule beside it (case.optimal: n_max, fall_s, control period, q1, q2, r). A speed counts
    as the rule's within ``tolerance`` x the per-period limit (the quadrature here and the
    programme's closed-form integral differ by about 1e-3 of it)."""
    o = case.optimal
    probe = _Probe(programme)
    MillingSimulator(case.modes, case.cut, case.step_s).run(probe, duration_s)
    n0, n_max, period = case.low_rpm, o["max_rpm"], o["control_period_s"]
    limit, fall_rpm_s = acceleration_rpm_s * period, (n_max - n0) / o["fall_s"]
    tolerance_rpm = tolerance * limit
    speed, falling, next_control, last_time = n0, False, 0.0, 0.0
    mismatched, worst, commands, limited, reached = 0, 0.0, 0, 0, False
    transitions = transition_samples(case.modes, period)
    for time_s, applied, state in probe.samples:
        if falling:
            speed -= fall_rpm_s * (time_s - last_time)
            if speed <= n0:
                speed, falling = n0, False
        elif time_s >= next_control:
            next_control += period
            u = eq18_command(case.modes, case.cut, state, speed, q1=o["q1"], q2=o["q2"], r=o["r"], period_s=period,
                             cutting_stiffness=o["cutting_stiffness"], transitions=transitions)
            commands += 1
            limited += abs(u) >= limit
            speed = max(n0, speed + min(max(u, -limit), limit))
            if speed >= n_max:
                speed, falling, reached = n_max, True, True
        last_time = time_s
        error = abs(applied - speed)
        worst = max(worst, error)
        if error > tolerance_rpm:
            mismatched += 1
            speed = applied  # follow what ran, so that one wrong step is counted once
    return Eq18Conformance(len(probe.samples), mismatched, worst, commands, limited / max(commands, 1), reached)


def triangle_timing(time_s: np.ndarray, speed_rpm: np.ndarray) -> dict:
    """low_rpm, high_rpm, rise_s, fall_s of a repeating triangle, measured on the record:
    the mean durations of the rising and falling runs between its extremes."""
    speed = np.asarray(speed_rpm, float)
    low, high = float(speed.min()), float(speed.max())
    tolerance = 1e-6 * high
    step = float(time_s[1] - time_s[0])
    slope = np.sign(np.round(np.diff(speed) / tolerance))
    runs, start = {1.0: [], -1.0: []}, 0
    for k in range(1, slope.size + 1):
        if k == slope.size or slope[k] != slope[start]:
            if slope[start] != 0 and start > 0 and k < slope.size:  # whole runs only, not the cut ends
                runs[float(slope[start])].append((k - start) * step)
            start = k
    rise = float(np.mean(runs[1.0])) if runs[1.0] else math.nan
    fall = float(np.mean(runs[-1.0])) if runs[-1.0] else math.nan
    return {"low_rpm": low, "high_rpm": high, "rise_s": rise, "fall_s": fall}


def is_seed_triangle(name: str, timing: dict, low_rpm: float, high_rpm: float, *, tolerance_s: float = 0.01) -> bool:
    """Whether a measured triangle is the seed's ``name`` (Z04, Z05) between its two speeds."""
    rise, fall = SEED_TRIANGLES[name]
    return (abs(timing["low_rpm"] - low_rpm) < 1.0 and abs(timing["high_rpm"] - high_rpm) < 1.0
            and abs(timing["rise_s"] - rise) < tolerance_s and abs(timing["fall_s"] - fall) < tolerance_s)
