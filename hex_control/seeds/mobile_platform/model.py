"""The two-wheeled mobile platform of seed 004 section 4 (Fig. 6): a rigid frame on two
driven wheels (1 left, 2 right) and a free castor, on a flat floor, without slip.

Coordinates: A is the middle of the wheel axle, beta the frame's heading (rad, from the x
axis), H the point d ahead of A on the frame's axis (the point the path is given for), C
the centre of mass a ahead of A. The non-holonomic constraints leave two velocities: the
speed of A, v = r (theta_1' + theta_2') / 2, and the turn rate w = beta' = r (theta_2' -
theta_1') / (2 b), b half the track.

Dynamics by the Appell-Gibbs equations: with C's acceleration (v' - a w^2) e + (v w + a w') n
the Gibbs function S = 1/2 m |a_C|^2 + 1/2 I_C w'^2 + 1/2 I_w (theta_1''^2 + theta_2''^2)
gives, for the pseudo-accelerations v', w' and wheel torques tau_1, tau_2,

    (m + 2 I_w / r^2) v' - m a w^2        = (tau_1 + tau_2) / r
    (I_C + m a^2 + 2 I_w b^2 / r^2) w' + m a v w = b (tau_2 - tau_1) / r

``lagrange_accelerations`` solves the same motion as Lagrange's equations with multipliers
in (x_A, y_A, beta, theta_1, theta_2) and returns the constraint forces as well: the test
shows both forms equal, and the forces give the friction each wheel needs. The drives are
DC motors through a gear: tau = N k_t (U - N k_e theta') / R_a - tau_friction (inductance
neglected: its time constant is far below the sampling time). SI units: m, kg, s, rad, V, N m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class PlatformParameters:
    mass_kg: float
    inertia_kg_m2: float           # I_C, about the vertical through C
    wheel_inertia_kg_m2: float     # I_w, wheel and gear-reflected rotor, about the axle
    wheel_radius_m: float
    half_track_m: float            # b
    mass_ahead_m: float            # a: C ahead of A
    point_h_ahead_m: float         # d: H ahead of A
    driven_load_fraction: float    # share of the weight on the two driven wheels (the castor takes the rest)
    gear_ratio: float
    torque_constant_n_m_a: float   # k_t = k_e (SI)
    armature_resistance_ohm: float
    gear_friction_n_m: float       # Coulomb friction at the wheel, per drive
    voltage_limit_v: float         # |U| <= U_max (eq. 10's limit)

    def __post_init__(self):
        for name, value in vars(self).items():
            if name != "mass_ahead_m" and not value >= 0:
                raise ValueError(f"{name} must be >= 0")
        if not (self.wheel_radius_m > 0 and self.half_track_m > 0 and self.point_h_ahead_m > 0 and self.mass_kg > 0):
            raise ValueError("wheel_radius_m, half_track_m, point_h_ahead_m and mass_kg must be > 0")

    @property
    def quasi_mass(self) -> np.ndarray:
        """diag of the Appell-Gibbs equations in (v, w): (kg, kg m^2)."""
        r, b = self.wheel_radius_m, self.half_track_m
        return np.array([self.mass_kg + 2 * self.wheel_inertia_kg_m2 / r ** 2,
                         self.inertia_kg_m2 + self.mass_kg * self.mass_ahead_m ** 2
                         + 2 * self.wheel_inertia_kg_m2 * b ** 2 / r ** 2])

    def wheel_rates(self, v_m_s: float, w_rad_s: float) -> tuple[float, float]:
        """(theta_1', theta_2') in rad/s."""
        r, b = self.wheel_radius_m, self.half_track_m
        return (v_m_s - b * w_rad_s) / r, (v_m_s + b * w_rad_s) / r

    def motor_torques(self, voltages_v, wheel_rates_rad_s) -> tuple[float, float]:
        """Wheel torques (N m) of the two drives at the given voltages and wheel rates; the
        Coulomb friction is smoothed over +-0.05 rad/s (tanh), so that it has no chatter at rest."""
        n, k, ra = self.gear_ratio, self.torque_constant_n_m_a, self.armature_resistance_ohm
        limit = self.voltage_limit_v
        return tuple(n * k * (min(max(u, -limit), limit) - n * k * rate) / ra
                     - self.gear_friction_n_m * math.tanh(rate / 0.05)
                     for u, rate in zip(voltages_v, wheel_rates_rad_s))


def appell_gibbs_accelerations(p: PlatformParameters, v: float, w: float, torques) -> tuple[float, float]:
    """(v', w') from the Appell-Gibbs equations above (m/s^2, rad/s^2)."""
    tau_1, tau_2 = torques
    r, b = p.wheel_radius_m, p.half_track_m
    m_v, m_w = p.quasi_mass
    ma = p.mass_kg * p.mass_ahead_m
    return ((tau_1 + tau_2) / r + ma * w * w) / m_v, (b * (tau_2 - tau_1) / r - ma * v * w) / m_w


def lagrange_accelerations(p: PlatformParameters, beta: float, q_dot, torques) -> tuple[np.ndarray, np.ndarray]:
    """q'' and the multipliers lambda of M q'' + c = B tau + A^T lambda, A q' = 0, in
    q = (x_A, y_A, beta, theta_1, theta_2). lambda[0]: the lateral force on the axle (N),
    lambda[1], lambda[2]: the floor's longitudinal forces on wheels 1 and 2 (N)."""
    m, ic, iw, a = p.mass_kg, p.inertia_kg_m2, p.wheel_inertia_kg_m2, p.mass_ahead_m
    r, b = p.wheel_radius_m, p.half_track_m
    s, c = math.sin(beta), math.cos(beta)
    x_dot, y_dot, beta_dot = q_dot[0], q_dot[1], q_dot[2]
    mass = np.array([[m, 0, -m * a * s, 0, 0], [0, m, m * a * c, 0, 0],
                     [-m * a * s, m * a * c, ic + m * a * a, 0, 0], [0, 0, 0, iw, 0], [0, 0, 0, 0, iw]])
    coriolis = np.array([-m * a * c * beta_dot ** 2, -m * a * s * beta_dot ** 2, 0, 0, 0])
    inputs = np.array([0, 0, 0, torques[0], torques[1]], float)
    # no side slip of A; wheel 1 (at A + b n) and wheel 2 (at A - b n) roll
    constraints = np.array([[-s, c, 0, 0, 0], [c, s, -b, -r, 0], [c, s, b, 0, -r]])
    constraints_dot_q_dot = beta_dot * np.array([-c * x_dot - s * y_dot, -s * x_dot + c * y_dot,
                                                 -s * x_dot + c * y_dot])
    kkt = np.block([[mass, -constraints.T], [constraints, np.zeros((3, 3))]])
    solution = np.linalg.solve(kkt, np.concatenate([inputs - coriolis, -constraints_dot_q_dot]))
    multipliers = solution[5:]
    # the rolling constraints' multipliers act on the wheels as -r lambda: the floor's force
    # on the wheel's rim is lambda along e; the axle takes lambda[0] along n
    return solution[:5], multipliers


def required_friction(p: PlatformParameters, multipliers) -> float:
    """The friction coefficient the worse driven wheel needs (its floor force over its
    normal load; the lateral force shared equally)."""
    normal = p.driven_load_fraction * p.mass_kg * GRAVITY_M_S2 / 2
    lateral = multipliers[0] / 2
    return float(max(math.hypot(multipliers[1], lateral), math.hypot(multipliers[2], lateral)) / normal)
