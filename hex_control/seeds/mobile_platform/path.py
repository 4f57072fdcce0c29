"""The path of point H (seed 004 Fig. 7): a straight on which the platform accelerates from
rest to v_A, a curve of clothoid - circular arc - clothoid (the clothoids keep the
curvature, hence the centripetal acceleration, continuous), and a final straight on which
it stops; Fig. 10's test path adds a second curve the other way. The seed gives no
dimensions; ``config/mobile_platform/platform.yaml`` states the ones used. SI units: m, s, rad.

The desired heading beta_bar is not the path's tangent: a platform whose point H follows
the path exactly turns by w = (-sin beta x_H' + cos beta y_H') / d (d: H ahead of the axle),
integrated here along the path; that is the orientation the seed's Fig. 8 compares with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Curve:
    """Clothoid - arc - clothoid turning by turn_rad (> 0 left), then a straight."""

    clothoid_m: float
    radius_m: float
    turn_rad: float
    straight_after_m: float

    def __post_init__(self):
        if min(self.clothoid_m, self.radius_m, self.straight_after_m) <= 0:
            raise ValueError("clothoid, radius and straight lengths must be > 0")
        if not 0 < self.clothoid_m / self.radius_m < abs(self.turn_rad):
            raise ValueError("the two clothoids must turn less than the whole curve")

    @property
    def arc_m(self) -> float:
        return self.radius_m * (abs(self.turn_rad) - self.clothoid_m / self.radius_m)

    @property
    def length_m(self) -> float:
        return 2 * self.clothoid_m + self.arc_m + self.straight_after_m


@dataclass(frozen=True)
class PathSpec:
    start_straight_m: float
    curves: tuple[Curve, ...]
    speed_m_s: float         # v_A on the straights
    ramp_s: float            # the start's acceleration and the end's stop (sinusoidal ramps)

    def __post_init__(self):
        if min(self.start_straight_m, self.speed_m_s, self.ramp_s) <= 0 or not self.curves:
            raise ValueError("need a start straight, speed and ramp > 0 and at least one curve")
        if self.speed_m_s * self.ramp_s / 2 > min(self.start_straight_m, self.curves[-1].straight_after_m):
            raise ValueError("the ramps must fit on the first and last straights")

    @classmethod
    def from_dict(cls, data: dict) -> PathSpec:
        return cls(float(data["start_straight_m"]), tuple(Curve(**{k: float(v) for k, v in c.items()})
                                                          for c in data["curves"]),
                   float(data["speed_m_s"]), float(data["ramp_s"]))


@dataclass(frozen=True)
class DesiredMotion:
    """Sampled at time_s: H's position (T, 2) and velocity (T, 2), the platform's heading
    beta_bar (T,), its speed v and turn rate w (T,) and their rates (T, 2), and the path
    as a dense polyline."""

    time_s: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    heading_rad: np.ndarray
    speed_m_s: np.ndarray
    turn_rate_rad_s: np.ndarray
    accelerations: np.ndarray
    path_m: np.ndarray

    def at(self, time_s: float):
        """(H, H', beta_bar, v, w, (v', w')) at ``time_s`` (linear interpolation; held after the end)."""
        i = min(int(time_s / (self.time_s[1] - self.time_s[0])), self.time_s.size - 2)
        f = min(max((time_s - self.time_s[i]) / (self.time_s[i + 1] - self.time_s[i]), 0.0), 1.0)

        def lerp(a):
            return a[i] + f * (a[i + 1] - a[i])

        return (lerp(self.position_m), lerp(self.velocity_m_s), lerp(self.heading_rad), lerp(self.speed_m_s),
                lerp(self.turn_rate_rad_s), lerp(self.accelerations))


def curvature(spec: PathSpec, s_m: np.ndarray) -> np.ndarray:
    """kappa(s) (1/m) along the path's length."""
    s = np.asarray(s_m, float)
    k = np.zeros_like(s)
    begin = spec.start_straight_m
    for curve in spec.curves:
        kappa = math.copysign(1 / curve.radius_m, curve.turn_rad)
        edges = begin + np.cumsum([0.0, curve.clothoid_m, curve.arc_m, curve.clothoid_m])
        k = np.where((s >= edges[0]) & (s < edges[1]), kappa * (s - edges[0]) / curve.clothoid_m, k)
        k = np.where((s >= edges[1]) & (s < edges[2]), kappa, k)
        k = np.where((s >= edges[2]) & (s < edges[3]), kappa * (edges[3] - s) / curve.clothoid_m, k)
        begin += curve.length_m
    return k


def path_length(spec: PathSpec) -> float:
    return spec.start_straight_m + sum(curve.length_m for curve in spec.curves)


def distance_profile(spec: PathSpec, time_s: np.ndarray) -> np.ndarray:
    """s(t) (m): a sinusoidal ramp up to speed_m_s, cruise, a mirrored ramp down to the end."""
    v, ramp, length = spec.speed_m_s, spec.ramp_s, path_length(spec)
    ramp_m = v * ramp / 2
    cruise_s = (length - 2 * ramp_m) / v
    t = np.asarray(time_s, float)

    def ramp_distance(tau):  # distance covered tau into a ramp from 0 to v
        tau = np.clip(tau, 0, ramp)
        return v / 2 * (tau - ramp / math.pi * np.sin(math.pi * tau / ramp))

    s = np.where(t < ramp, ramp_distance(t), ramp_m + v * (t - ramp))
    stop = t - ramp - cruise_s
    return np.where(stop > 0, length - ramp_m + v * np.minimum(stop, ramp) - ramp_distance(stop), s)


def total_time(spec: PathSpec) -> float:
    return (path_length(spec) - spec.speed_m_s * spec.ramp_s) / spec.speed_m_s + 2 * spec.ramp_s


def desired_motion(spec: PathSpec, point_h_ahead_m: float, step_s: float, hold_s: float = 2.0) -> DesiredMotion:
    """The motion of H along the path, from rest at the origin heading along +x, sampled
    every step_s, held at the end point for hold_s."""
    s_grid = np.linspace(0.0, path_length(spec), int(math.ceil(path_length(spec) / 1e-4)) + 1)
    grid_m = s_grid[1]
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (curvature(spec, s_grid[1:]) + curvature(spec, s_grid[:-1]))
                                               * grid_m)])
    tangent = np.column_stack([np.cos(heading), np.sin(heading)])
    points = np.concatenate([[[0.0, 0.0]], np.cumsum(0.5 * (tangent[1:] + tangent[:-1]) * grid_m, axis=0)])
    time = np.arange(0.0, total_time(spec) + hold_s, step_s)
    s = distance_profile(spec, time)
    position = np.column_stack([np.interp(s, s_grid, points[:, 0]), np.interp(s, s_grid, points[:, 1])])
    velocity = np.gradient(position, step_s, axis=0)
    velocity[0] = 0.0
    beta = np.zeros(time.size)

    def turn_rate_of(b, velocity_m_s):  # H followed exactly: beta' = (-sin beta x_H' + cos beta y_H') / d
        return (-math.sin(b) * velocity_m_s[0] + math.cos(b) * velocity_m_s[1]) / point_h_ahead_m

    for i in range(1, time.size):  # midpoint rule, the velocity linear over the step
        middle = beta[i - 1] + 0.5 * step_s * turn_rate_of(beta[i - 1], velocity[i - 1])
        beta[i] = beta[i - 1] + step_s * turn_rate_of(middle, 0.5 * (velocity[i - 1] + velocity[i]))
    speed = np.cos(beta) * velocity[:, 0] + np.sin(beta) * velocity[:, 1]
    turn_rate = (-np.sin(beta) * velocity[:, 0] + np.cos(beta) * velocity[:, 1]) / point_h_ahead_m
    accelerations = np.column_stack([np.gradient(speed, step_s), np.gradient(turn_rate, step_s)])
    polyline = points[np.r_[0:len(points) - 1:50, len(points) - 1]]
    return DesiredMotion(time, position, velocity, beta, speed, turn_rate, accelerations, polyline)
