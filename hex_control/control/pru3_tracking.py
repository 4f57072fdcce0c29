"""Contour tracking on the 3-PRU head (seed 001 sections 3 and 4.3): four strategies and
ITAE gain optimization.

- CTC: computed torque, tau = A(q) (q_d'' + K_v e' + K_p e) + b(q, q'), e = q_d - q.
- CTC+CC: the same with cross-coupled contour compensation: + K_c e_c inside the bracket,
  e_c the part of e normal to the path (the tracking error minus its component along the
  path's tangent q_d'/|q_d'|).
- LSPD: link-space PD on the slider errors e_L = L_d - L with the partial dynamics the
  seed names "M q''": tau = A(q_d) q_d'' + K_v e_L' + K_p e_L. Velocity and gravity terms
  are left to the PD, which is why its errors are an order above CTC's (Tables 1-4).
- LSPD+CC (eq. of 3.1): tau = M q'' + K_v e_L' + K_p e_L + K_c e_cL, with the link-space
  contour-error model e_cL = J(q) e_c.

The loop is digital: the torque is computed every ``control_period_s`` from the sampled
state and held (zero-order hold) while the forward dynamics are integrated by RK4 over
the period. The motion starts at rest at the path's first point, so the velocity jump of
the seed's circular path is what the controllers must take up (``start_on_path`` removes it).

Error measures as in Tables 1-4: IAE = integral of |error| dt per axis, of the tracking
error and of the contour error (task space: z mm, alpha and beta rad; link space: mm).
ITAE (3.2): cost = sum |in - out| t over the samples.

Units: mm, rad, s, N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution

from hex_control.kinematics.pru3 import Pru3Geometry, inverse_kinematics, velocity_jacobian
from hex_control.kinematics.pru3_dynamics import Pru3Inertia, actuator_dynamics, forward_dynamics

STRATEGIES = ("ctc", "ctc_cc", "lspd", "lspd_cc")


@dataclass(frozen=True)
class CircularTilt:
    """Seed 4.2: z fixed, alpha = a cos(w t), beta = a sin(w t)."""

    z_mm: float = 220.0
    amplitude_rad: float = 0.15
    frequency_rad_s: float = 4 * math.pi

    def __call__(self, t: float):
        w, a = self.frequency_rad_s, self.amplitude_rad
        c, s = math.cos(w * t), math.sin(w * t)
        return (np.array([self.z_mm, a * c, a * s]), np.array([0.0, -a * w * s, a * w * c]),
                np.array([0.0, -a * w * w * c, -a * w * w * s]))


@dataclass(frozen=True)
class Gains:
    """Diagonal gains: task space (1/s^2, 1/s, 1/s^2) for CTC; link space (N/mm, N s/mm,
    N/mm) for LSPD. One value is used for all three axes."""

    proportional: float
    derivative: float
    contour: float = 0.0


DEFAULT_GAINS = {"ctc": Gains(100.0, 20.0), "ctc_cc": Gains(100.0, 20.0, 300.0),
                 "lspd": Gains(60.0, 1.5), "lspd_cc": Gains(60.0, 1.5, 120.0)}


def contour_error(error, tangent) -> np.ndarray:
    """The part of a task-space error normal to the path (tangent need not be unit)."""
    norm = np.linalg.norm(tangent)
    if norm == 0:
        return np.asarray(error, float).copy()
    unit = np.asarray(tangent, float) / norm
    return error - (error @ unit) * unit


@dataclass(frozen=True)
class TrackingRun:
    time_s: np.ndarray
    q: np.ndarray  # (n, 3) z mm, alpha rad, beta rad
    desired: np.ndarray
    lengths_mm: np.ndarray  # (n, 3)
    desired_lengths_mm: np.ndarray
    tau_n: np.ndarray
    geometry: Pru3Geometry

    def task_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """(tracking, contour) errors in task space, (n, 3) each."""
        tracking = self.desired - self.q
        tangent = np.gradient(self.desired, self.time_s, axis=0)
        return tracking, np.array([contour_error(e, d) for e, d in zip(tracking, tangent)])

    def link_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """(tracking, contour) errors in link space: e_L, and J e_c."""
        jacobians = velocity_jacobian(self.geometry, self.q)
        _, contour = self.task_errors()
        return self.desired_lengths_mm - self.lengths_mm, np.einsum("nij,nj->ni", jacobians, contour)

    def iae(self, space: str = "task") -> dict[str, np.ndarray]:
        tracking, contour = self.task_errors() if space == "task" else self.link_errors()
        dt = np.diff(self.time_s, prepend=self.time_s[0])
        return {"tracking": np.sum(np.abs(tracking) * dt[:, None], axis=0),
                "contour": np.sum(np.abs(contour) * dt[:, None], axis=0)}

    def itae(self) -> float:
        """Seed 3.2: sum |in - out| t, over the three task coordinates (mm and rad summed
        as numbers, as the seed does)."""
        return float(np.sum(np.abs(self.desired - self.q) * self.time_s[:, None]))


def track(strategy: str, gains: Gains | None = None, **options) -> TrackingRun:
    """Run one strategy on the machine's dynamics; ``options`` as for ``track_batch``."""
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    return track_batch([strategy], [gains or DEFAULT_GAINS[strategy]], **options)[0]


def track_batch(strategies, gains, path=CircularTilt(), duration_s: float = 1.0, control_period_s: float = 1e-3,
                *, geometry: Pru3Geometry = Pru3Geometry(), inertia: Pru3Inertia = Pru3Inertia(),
                start_on_path: bool = False) -> list[TrackingRun]:
    """Run several (strategy, gains) machines side by side along ``path``: one batched
    dynamics evaluation serves them all. A machine that leaves the workspace or diverges
    raises FloatingPointError. The machines start at rest at the path's first point, or with
    ``start_on_path`` already moving with it (no start transient)."""
    strategies, gains = list(strategies), list(gains)
    unknown = set(strategies) - set(STRATEGIES)
    if unknown or len(strategies) != len(gains) or not strategies:
        raise ValueError(f"need one Gains per strategy, strategies from {STRATEGIES}; got {sorted(unknown)}")
    n = len(strategies)
    computed = np.array([s.startswith("ctc") for s in strategies])
    kp, kv, kc = (np.array([getattr(g, name) for g in gains])[:, None] for name in ("proportional", "derivative",
                                                                                     "contour"))
    steps = int(round(duration_s / control_period_s))
    q, q_dot = np.tile(path(0.0)[0], (n, 1)), np.tile(path(0.0)[1] if start_on_path else np.zeros(3), (n, 1))
    rows = {k: [] for k in ("t", "q", "qd", "L", "Ld", "tau")}
    for k in range(steps + 1):
        t = k * control_period_s
        q_d, q_d_dot, q_d_ddot = path(t)
        pose = inverse_kinematics(geometry, np.vstack([q, q_d]))
        if not np.all(np.isfinite(pose.lengths_mm)):
            raise FloatingPointError(f"a machine left the workspace at t = {t:.3f} s")
        lengths, desired_lengths = pose.lengths_mm[:n], pose.lengths_mm[n]
        jacobians = velocity_jacobian(geometry, np.vstack([q, q_d]), pose)
        error, error_dot = q_d - q, q_d_dot - q_dot
        contour = np.array([contour_error(e, q_d_dot) for e in error])
        # CTC: tau = A(q) (q_d'' + K_v e' + K_p e + K_c e_c) + b(q, q')
        a, b = actuator_dynamics(geometry, inertia, q, q_dot)
        command = q_d_ddot + kv * error_dot + kp * error + kc * contour
        tau_ctc = np.einsum("nij,nj->ni", a, command) + b
        # LSPD: tau = A(q_d) q_d'' + K_v e_L' + K_p e_L + K_c J e_c
        a_desired, _ = actuator_dynamics(geometry, inertia, q_d, q_d_dot)
        link_error_dot = jacobians[n] @ q_d_dot - np.einsum("nij,nj->ni", jacobians[:n], q_dot)
        tau_lspd = a_desired[0] @ q_d_ddot + kv * link_error_dot + kp * (desired_lengths - lengths) \
            + kc * np.einsum("nij,nj->ni", jacobians[:n], contour)
        tau = np.where(computed[:, None], tau_ctc, tau_lspd)
        for name, value in zip(rows, (t, q.copy(), q_d, lengths, desired_lengths, tau)):
            rows[name].append(value)
        if k == steps:
            break
        q, q_dot = _rk4(geometry, inertia, q, q_dot, tau, dt=control_period_s)
    t, desired, desired_lengths = (np.array(rows[name]) for name in ("t", "qd", "Ld"))
    q, lengths, tau = (np.array(rows[name]) for name in ("q", "L", "tau"))  # (steps, n, 3)
    return [TrackingRun(t, q[:, m], desired, lengths[:, m], desired_lengths, tau[:, m], geometry) for m in range(n)]


def _rk4(geometry, inertia, q, q_dot, tau, *, dt):
    def rates(position, velocity):
        # an unstable loop's stage can leave the workspace, where the rockers have no pose
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
            raise FloatingPointError("a machine's state diverged")
        return velocity, forward_dynamics(geometry, inertia, position, velocity, tau)

    k1 = rates(q, q_dot)
    k2 = rates(q + dt / 2 * k1[0], q_dot + dt / 2 * k1[1])
    k3 = rates(q + dt / 2 * k2[0], q_dot + dt / 2 * k2[1])
    k4 = rates(q + dt * k3[0], q_dot + dt * k3[1])
    return (q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
            q_dot + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]))


def optimize_gains(strategy: str, bounds=None, duration_s: float = 0.5, control_period_s: float = 2e-3,
                   generations: int = 10, *, population: int = 12, seed: int = 0):
    """Seed 3.2: minimize the ITAE of a run over the gains by differential evolution on
    log10-gains within ``bounds`` (per gain: (low, high)); each generation is simulated as
    one batch. Returns (best gains, its ITAE, ITAE of the default gains)."""
    names = ("proportional", "derivative") + (("contour",) if strategy.endswith("_cc") else ())
    default = DEFAULT_GAINS[strategy]
    if bounds is None:
        bounds = [(getattr(default, name) / 10, getattr(default, name) * 10) for name in names]
    log_bounds = [(math.log10(low), math.log10(high)) for low, high in bounds]

    def gains_of(x):
        return Gains(**{"contour": 0.0, **{name: float(10.0 ** v) for name, v in zip(names, x)}})

    def costs(xs):  # xs: (dims, candidates)
        candidates = [gains_of(x) for x in np.atleast_2d(xs).T]
        try:
            runs = track_batch([strategy] * len(candidates), candidates, duration_s=duration_s,
                               control_period_s=control_period_s)
            return np.array([run.itae() for run in runs])
        except FloatingPointError:  # one unstable candidate: score them one by one
            return np.array([_itae_or_inf(strategy, g, duration_s, control_period_s) for g in candidates])

    result = differential_evolution(costs, log_bounds, maxiter=generations, popsize=max(1, population // len(names)),
                                    seed=seed, vectorized=True, polish=False, tol=0.0, updating="deferred")
    start = track(strategy, default, duration_s=duration_s, control_period_s=control_period_s).itae()
    return gains_of(result.x), float(result.fun), start


def iae_table(strategy: str, run: TrackingRun) -> str:
    """Tables 1-4 of the seed: IAE of the tracking and contour errors per axis, in task
    space (z, alpha, beta) for the CTC strategies and link space (L1-L3) for LSPD."""
    space, axes = ("task", ("Z", "alpha", "beta")) if strategy.startswith("ctc") else ("link", ("L1", "L2", "L3"))
    iae = run.iae(space)
    lines = [f"{strategy.upper().replace('_', '+')}: IAE ({space} space)",
             "                " + "".join(f"{a:>12}" for a in axes)]
    for name in ("tracking", "contour"):
        lines.append(f"{name + ' error':16}" + "".join(f"{v:12.4g}" for v in iae[name]))
    return "\n".join(lines)


def _itae_or_inf(strategy, gains, duration_s, control_period_s):
    try:
        return track(strategy, gains, duration_s=duration_s, control_period_s=control_period_s).itae()
    except FloatingPointError:
        return math.inf


def exact_ctc_error_iae(kp, kv, *, start=(0.0, 0.15, 0.0), path: CircularTilt = CircularTilt(),
                        duration_s: float = 0.5, step_s: float = 1e-4) -> dict[str, np.ndarray]:
    """IAE of the tracking and contour errors (z, alpha, beta) that the seed's CTC leaves with
    an exact model, for arrays of gains (kp, kv broadcast together), starting at rest at
    ``start`` (z offset mm, alpha, beta rad). With A(q), b(q, q') exact, tau = A (q_d'' +
    K_v e' + K_p e) + b leaves e'' + K_v e' + K_p e = 0 on every axis, whatever the
    machine: each axis's error is fixed by its own start (e0, e0') and the gains, and decays.
    Integrated here exactly per step (the ODE is linear), in continuous time."""
    kp, kv = np.broadcast_arrays(np.asarray(kp, float), np.asarray(kv, float))
    q_d, q_d_dot, _ = path(0.0)
    e0 = np.array([0.0, q_d[1] - start[1], q_d[2] - start[2]])
    e0[0] = -start[0]
    de0 = q_d_dot.copy()  # the machine starts at rest
    shape = kp.shape + (3,)
    e = np.broadcast_to(e0, shape).copy()
    de = np.broadcast_to(de0, shape).copy()
    steps = int(round(duration_s / step_s))
    tracking, contour = np.zeros(shape), np.zeros(shape)
    kp3, kv3 = kp[..., None], kv[..., None]
    for k in range(steps):
        t = k * step_s
        tangent = path(t)[1]
        unit = tangent / np.linalg.norm(tangent)
        tracking += np.abs(e) * step_s
        contour += np.abs(e - (e @ unit)[..., None] * unit) * step_s
        # RK4 on the linear error dynamics: at 0.1 ms far below every time constant searched
        def rates(x, v):
            return v, -kv3 * v - kp3 * x
        a1, b1 = rates(e, de)
        a2, b2 = rates(e + step_s / 2 * a1, de + step_s / 2 * b1)
        a3, b3 = rates(e + step_s / 2 * a2, de + step_s / 2 * b2)
        a4, b4 = rates(e + step_s * a3, de + step_s * b3)
        e = e + step_s / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        de = de + step_s / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
    return {"tracking": tracking, "contour": contour}
