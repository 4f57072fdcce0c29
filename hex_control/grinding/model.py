"""Static grinding model of seed 002 (Brown's thesis), section 4.2, with its constraints.

    Pi = K1 Q + K2,  Q = w delta V_f,  Pi = omega R F_t,  F_t = mu F_N     (4.4a-d)
    delta = (omega R mu F_N - K2) / (K1 w V_f)                              (4.5)
          = (C1 C3 F_N + C2) / V_f,  never negative                         (4.6, 5.5)
    omega = omega_0 - beta R F_t                                            (4.8, air motor)

Units: mm, N, s; power in W = 1000 N mm/s, so K1 [J/mm^3] = 1000 K1 [N mm/mm^3]. Then
    C1 = 1/(1000 K1)   [mm^2/N]     -- the thesis prints 1e-4 mm^2/N: agrees
    C2 = -K2/(w K1)    [mm^2/s]     -- the thesis prints -0.8 mm^2/s: agrees
    C3 = mu R omega/w  [1/s]        -- the thesis prints 1e-3 s^-1 and defines C3 = R omega/w;
        neither is consistent with (4.5): C1 C3 must equal mu R omega/(w K1), which needs
        C3 = mu R omega / w = 1020 s^-1 for the typical values (3400 s^-1 without mu).
Check: 50 N at 10 mm/s removes (0.102 * 50 - 0.8)/10 = 0.43 mm, a plausible cut.

Constraints (seed 002 ch. 5, 6.6): F_N <= F_max; V_min <= V_f <= V_max; no burn
F_N <= C_B sqrt(V_f) (5.11); grinder power <= 80 % of its maximum (stall, 6.6).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np
import yaml

from hex_control.config import cell_default

WATT = 1000.0  # N mm/s per W


def _numbers(value):
    """A Python float (or int) as it is, anything else as a float array: the same IEEE
    arithmetic either way, and on one number a tenth of a 0-d array's cost (the pass
    simulation asks the power a dozen times a step)."""
    return value if isinstance(value, (float, int)) else np.asarray(value, float)


@dataclass(frozen=True)
class GrindingProcess:
    """Process coefficients, bead geometry and machine limits (thesis typical values, 5.5;
    the defaults of the cell's values are config/cell.yaml's ``process``).

    Attributes (units in the names): ``motor_beta_rad_s_per_n_mm`` is beta of eq. 4.8
    (0 = constant disk speed); ``burn_coefficient`` is C_B [N/sqrt(mm/s)] of eq. 5.11
    (None = no burn constraint); ``max_power_w`` the grinder's maximum power (the planner
    keeps below ``power_fraction`` of it).
    """

    # the cell's physical values default to config/cell.yaml's (hex_control.config.cell_configuration)
    specific_energy_j_mm3: float = field(default_factory=cell_default("process.specific_energy_j_mm3"))  # K1
    wasted_power_w: float = field(default_factory=cell_default("process.wasted_power_w"))  # K2
    bead_width_mm: float = field(default_factory=cell_default("process.bead_width_mm"))  # w
    disk_radius_mm: float = field(default_factory=cell_default("process.disk_radius_mm"))  # R
    disk_speed_rad_s: float = field(default_factory=cell_default("process.disk_speed_rad_s"))  # omega_0
    friction_coefficient: float = field(default_factory=cell_default("process.friction_coefficient"))  # mu
    motor_beta_rad_s_per_n_mm: float = field(default_factory=cell_default("process.motor_beta_rad_s_per_n_mm"))
    bead_length_mm: float = 300.0  # L: the job's (config/sequence_planner.yaml)
    reset_time_s: float = 2.0  # t_R: the job's
    force_max_n: float = field(default_factory=cell_default("process.force_max_n"))  # F_max
    feed_min_mm_s: float = field(default_factory=cell_default("process.feed_min_mm_s"))
    feed_max_mm_s: float = field(default_factory=cell_default("process.feed_max_mm_s"))
    burn_coefficient: float | None = None  # C_B
    max_power_w: float = field(default_factory=cell_default("process.max_power_w"))
    power_fraction: float = 0.8

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None:
                continue
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"GrindingProcess.{f.name} must be a finite number, got {value!r}")
            if value < 0:
                raise ValueError(f"GrindingProcess.{f.name} must be >= 0, got {value!r}")
        for name in ("specific_energy_j_mm3", "bead_width_mm", "disk_radius_mm", "disk_speed_rad_s",
                     "friction_coefficient", "bead_length_mm", "force_max_n", "feed_min_mm_s", "max_power_w"):
            if getattr(self, name) <= 0:
                raise ValueError(f"GrindingProcess.{name} must be > 0")
        if self.feed_max_mm_s < self.feed_min_mm_s:
            raise ValueError("feed_max_mm_s must be >= feed_min_mm_s")
        if self.zero_cut_force_n() >= self.force_max_n:
            raise ValueError("the maximum force removes no material (C1 C3 F_max + C2 <= 0)")

    @classmethod
    def from_dict(cls, data: dict) -> GrindingProcess:
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown process fields {sorted(unknown)}; known: {sorted(known)}")
        return cls(**data)

    @classmethod
    def from_yaml(cls, path) -> GrindingProcess:
        data = yaml.safe_load(Path(path).read_text()) or {}
        return cls.from_dict(data.get("process", data))

    def to_dict(self) -> dict:
        return asdict(self)

    # -- coefficients of eq. 4.6 -------------------------------------------------------------
    @property
    def c1(self) -> float:
        """C1 = 1/K1 in mm^2/N (K1 converted to N mm/mm^3)."""
        return 1.0 / (self.specific_energy_j_mm3 * WATT)

    @property
    def c2(self) -> float:
        """C2 = -K2/(w K1) in mm^2/s."""
        return -self.wasted_power_w / (self.bead_width_mm * self.specific_energy_j_mm3)

    def disk_speed(self, force_n):
        """omega = omega_0 - beta R mu F_N (eq. 4.8), rad/s."""
        return self.disk_speed_rad_s - self.motor_beta_rad_s_per_n_mm * self.disk_radius_mm \
            * self.friction_coefficient * _numbers(force_n)

    def c3(self, force_n=0.0):
        """C3 = mu R omega / w in 1/s (omega from the motor model at this force)."""
        return self.friction_coefficient * self.disk_radius_mm * self.disk_speed(force_n) / self.bead_width_mm

    def removal_numerator(self, force_n):
        """C1 C3 F_N + C2 (mm^2/s): the cut depth times the feed speed."""
        force_n = np.asarray(force_n, float)
        return self.c1 * self.c3(force_n) * force_n + self.c2

    def cut_depth_mm(self, force_n, feed_mm_s):
        """Mean cut depth delta = max(0, (C1 C3 F_N + C2)/V_f) (eq. 4.6; 5.5 prints min, a typo)."""
        return np.maximum(self.removal_numerator(force_n) / np.asarray(feed_mm_s, float), 0.0)

    def force_for_numerator_n(self, numerator_mm2_s: float) -> float:
        """The normal force F_N (N) whose removal numerator C1 C3 F_N + C2 is
        ``numerator_mm2_s`` (mm^2/s; eq. 4.6 inverted, as the planners ask of a depth and a
        feed), on the rising branch: the motor's speed drop (eq. 4.8) makes the numerator a
        quadratic in F_N, and this is its smaller root, in the form without cancellation.
        ValueError beyond the numerator's peak (the motor stalls first)."""
        a = self.c1 * self.friction_coefficient * self.disk_radius_mm / self.bead_width_mm
        k = self.motor_beta_rad_s_per_n_mm * self.disk_radius_mm * self.friction_coefficient
        b, rest = a * self.disk_speed_rad_s, numerator_mm2_s - self.c2
        disc = b * b - 4 * a * k * rest
        if not disc >= 0:
            raise ValueError(f"no force removes {numerator_mm2_s!r} mm^2/s: beyond the numerator's peak")
        return 2 * rest / (b + math.sqrt(disc))

    def zero_cut_force_n(self) -> float:
        """F_N below which nothing is removed (the pivot of the constant-cut lines, Fig. 5-13)."""
        if self.motor_beta_rad_s_per_n_mm == 0:
            return -self.c2 / (self.c1 * self.c3(0.0))
        # C1 mu R (omega_0 - beta R mu F) F / w + C2 = 0: smaller root of the quadratic
        a = self.c1 * self.friction_coefficient * self.disk_radius_mm / self.bead_width_mm
        k = self.motor_beta_rad_s_per_n_mm * self.disk_radius_mm * self.friction_coefficient
        disc = (a * self.disk_speed_rad_s) ** 2 + 4 * a * k * self.c2
        return (a * self.disk_speed_rad_s - math.sqrt(max(disc, 0.0))) / (2 * a * k)

    def power_w(self, force_n):
        """Power at the contact patch, omega R mu F_N (W)."""
        force_n = _numbers(force_n)
        return self.disk_speed(force_n) * self.disk_radius_mm * self.friction_coefficient * force_n / WATT

    def pass_duration_s(self, feed_mm_s):
        """L / V_f + t_R (eq. 5.6)."""
        return self.bead_length_mm / np.asarray(feed_mm_s, float) + self.reset_time_s

    def feasible(self, force_n, feed_mm_s):
        """All constraints: force, feed range, no burn (5.11), power below the stall margin."""
        force_n, feed_mm_s = np.broadcast_arrays(np.asarray(force_n, float), np.asarray(feed_mm_s, float))
        ok = (force_n <= self.force_max_n + 1e-9) & (feed_mm_s >= self.feed_min_mm_s - 1e-9) \
            & (feed_mm_s <= self.feed_max_mm_s + 1e-9)
        if self.burn_coefficient is not None:
            ok &= force_n <= self.burn_coefficient * np.sqrt(feed_mm_s) + 1e-9
        ok &= self.power_w(force_n) <= self.power_fraction * self.max_power_w + 1e-9
        return ok
