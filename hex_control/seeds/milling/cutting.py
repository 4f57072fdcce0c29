"""The cutting-force law of the coupling elements, seed 004 eq. 11-13.

Tooth l at angle phi_l (from the y axis, clockwise; x is the feed direction) cuts the
chip thickness

    h_l(t) = h_D sin(phi_l) - dh_l(t) + dh_l(t - tau_l),   dh_l = -w . (sin phi_l, cos phi_l),

with w the tool tip's deflection (m) in (x, y) and dh_l its part away from the material
along the tooth's radius: the static chip of the feed per tooth, thinned by the deflection
now (proportional feedback, the cutting stiffness) and thickened where the previous tooth
was pushed away and left material (delayed feedback, the regeneration). While the tooth is in the
immersion and h_l > 0 the forces are F_y1 = k_d a_p h_l (11) along the cutting speed and
F_y2 = mu F_y1 (12) along the radius; F_y3 = 0 (13); with h_l <= 0 the tooth has left the
material and both are zero (11-12's second branch). SI units: m, N, Pa, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Cut:
    """The cutting conditions.

    teeth: cutting edges z; depth_m: a_p; feed_per_tooth_m: h_D; cutting_pressure_pa: k_d
    (average dynamic specific cutting pressure); force_ratio: mu; start_rad / exit_rad:
    the immersion (0 .. pi is full immersion, the seed's slotting)."""

    teeth: int
    depth_m: float
    feed_per_tooth_m: float
    cutting_pressure_pa: float
    force_ratio: float
    start_rad: float = 0.0
    exit_rad: float = math.pi

    def __post_init__(self):
        if self.teeth < 1:
            raise ValueError("teeth must be >= 1")
        for name in ("depth_m", "feed_per_tooth_m", "cutting_pressure_pa"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0")
        if not 0 <= self.start_rad < self.exit_rad <= 2 * math.pi:
            raise ValueError("need 0 <= start_rad < exit_rad <= 2 pi")

    def tooth_period_s(self, speed_rpm: float) -> float:
        """tau = 60 / (n z) at a constant speed (s)."""
        return 60.0 / (speed_rpm * self.teeth)


def cutting_force(cut: Cut, tooth_angles_rad, deflection_m, delayed_deflection_m) -> tuple[float, float]:
    """The force (N) on the tool tip in (x, y), summed over the teeth (eq. 11-13).

    tooth_angles_rad: the z teeth's angles; deflection_m: (x, y) tip deflection now;
    delayed_deflection_m: (x, y) one tooth period ago. Scalar arithmetic: a simulation calls
    this every step for a handful of teeth, where numpy's per-call cost would dominate."""
    regeneration_x = deflection_m[0] - delayed_deflection_m[0]
    regeneration_y = deflection_m[1] - delayed_deflection_m[1]
    gain, ratio = cut.cutting_pressure_pa * cut.depth_m, cut.force_ratio
    force_x = force_y = 0.0
    for angle in tooth_angles_rad:
        phi = angle % (2 * math.pi)
        if not cut.start_rad <= phi <= cut.exit_rad:
            continue
        s, c = math.sin(phi), math.cos(phi)
        chip = (cut.feed_per_tooth_m + regeneration_x) * s + regeneration_y * c
        if chip <= 0:
            continue  # the tooth has left the material (eq. 11-12, second branch)
        tangential = gain * chip
        force_x += -tangential * c - ratio * tangential * s
        force_y += tangential * s - ratio * tangential * c
    return force_x, force_y
