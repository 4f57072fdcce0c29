"""The dynamic grinding model of seed 002 section 6.4 and its simulation (6.5).

A rigid, massless grinder on a rotational spring (stiffness K_S, relaxed angle theta_0)
grinds with the face of its disk (geometry in ``contact``). The power at the patch fixes
the removal rate (eq. 6.13, the static model's power law 4.4):

    Pi = omega mu K_S (theta_0 - theta)          F_N = K_S (theta_0 - theta) / R
    Q  = (Pi - K2) / K1                                                     (6.13)

and the face's motion normal to itself fixes it kinematically (eq. 6.14):

    Q  = A (R* dtheta/dt + V_f sin(theta) - dH/dt cos(theta))              (6.14)

with A the patch area (length along the face x bead width w) and R* the distance from the
disk centre to the patch centroid. Equating the two gives dtheta/dt (eq. 6.15); the tip
height is y = H - R sin(theta) (eq. 6.16). omega follows the air motor, eq. 4.8, when the
process has beta > 0.

What drives the spring is a ``drive``: the height PI of eq. 6.17 (planning), the relaxed-
angle PI (6.6's variant), or a force schedule (executing a planned force trajectory under
force control: the robot holds the planned height, the force loop winds the spring).

Integration is classical Runge-Kutta at a fixed step in feed distance. The contour is
truncated under the swept face between steps only, never inside the stages: a stage that
truncates removes material the next stage needs, which is the chatter of 6.5
(``truncate_in_stages`` reproduces it for the tests).

Out of contact the massless disk would jump to its equilibrium; here it relaxes towards it
with the time constant ``free_swing_s`` (no shorter than the step, which keeps RK4 stable).
Under force control (a force schedule) the table sets the spring's rest angle theta_r, and
the force loop moves it to restore the wanted force through the table's position loop:
first order with that loop's time constant ``approach_time_constant_s`` (eq. 7.3's poles,
1/(2 pi 9 Hz) + 1/(2 pi 40 Hz) = 21.7 ms),

    dtheta_r/dt = (theta + F_wanted R / K_S - theta_r) / tau,     F_N = K_S (theta_r - theta) / R,

so the force in contact lags a wanted force that changes faster than the table, and where
the surface falls away the wound spring keeps the disk on it (the force drops) until the
table has caught up; off the work the rest angle runs towards it by the wind-up F R / K_S
per tau. (An ad-hoc 5 mm/s approach stood here first: executed passes removed 20-40 % less
than planned at 40-75 mm/s. Then the rest angle was taken as always wound for the wanted
force, so the disk left the surface wherever it fell away: on 0.15 mm of ripple at 75 mm/s
it lifted off in every trough and removed 16 % less than planned.)

Units: mm, s, rad, N; power W; removal rate mm^3/s.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from hex_control.config import cell_configuration, cell_default
from hex_control.grinding.contact import DiskPose, LiveContour
from hex_control.grinding.contact_reference import ReferenceContour
from hex_control.grinding.contour import Contour
from hex_control.grinding.model import GrindingProcess


@dataclass(frozen=True)
class DiskModel:
    """The process of the static model plus the rotational spring (K_S and theta_0 default
    to config/cell.yaml's ``disk``: the thesis's test stand, 7.1 and 6.5)."""

    process: GrindingProcess = field(default_factory=GrindingProcess)
    spring_n_mm_rad: float = field(default_factory=cell_default("disk.spring_n_mm_rad"))
    relaxed_angle_rad: float = field(default_factory=lambda: math.radians(cell_configuration().value(
        "disk.relaxed_angle_deg")))
    free_swing_s: float = 0.01
    approach_time_constant_s: float = 1 / (2 * math.pi * 9.0) + 1 / (2 * math.pi * 40.0)  # the table, eq. 7.3

    def __post_init__(self):
        for name in ("spring_n_mm_rad", "relaxed_angle_rad", "free_swing_s", "approach_time_constant_s"):
            if not isinstance(getattr(self, name), (int, float)):
                raise ValueError(f"DiskModel.{name} must be a number, got {getattr(self, name)!r}")
        if not (self.spring_n_mm_rad > 0 and 0 < self.relaxed_angle_rad < math.pi / 2
                and self.free_swing_s > 0 and self.approach_time_constant_s > 0):
            raise ValueError("need K_S > 0, 0 < theta_0 < 90 deg, free_swing_s > 0, approach_time_constant_s > 0")

    @property
    def radius_mm(self) -> float:
        return self.process.disk_radius_mm

    def force_n(self, angle_rad: float, relaxed_angle_rad: float) -> float:
        """F_N = K_S (theta_0 - theta) / R: the spring torque carried at the rim."""
        return self.spring_n_mm_rad * (relaxed_angle_rad - angle_rad) / self.radius_mm

    def power_w(self, force_n: float) -> float:
        return float(self.process.power_w(max(force_n, 0.0)))

    def removal_rate_mm3_s(self, force_n: float) -> float:
        """Q = (Pi - K2) / K1 (eq. 6.13), never negative."""
        p = self.process
        return max(self.power_w(force_n) - p.wasted_power_w, 0.0) / p.specific_energy_j_mm3


class DriveState(NamedTuple):  # made five times a simulation step: a tuple, not a dataclass
    """What a drive sets at one instant: the centre height H = ``height_mm``; its rate
    dH/dt = ``height_rate_mm_s`` + ``height_rate_per_angle_rate_mm`` * dtheta/dt (a PI on
    the tip error couples the two); the normal force; the relaxed angle; the ``integrand``
    of the drive's one state (the tip error e in mm for the PI drives, the rest angle's
    rate in rad/s for a force schedule); and how far (rad) the free disk is from its
    equilibrium, scaled so that relaxing it over the free-swing time is one time constant."""

    height_mm: float
    height_rate_mm_s: float
    height_rate_per_angle_rate_mm: float
    force_n: float
    relaxed_angle_rad: float
    integrand: float
    free_offset_rad: float


class _TipTracking:
    """A PI drive on the tip error: the desired tip trajectory z_tip(x), a polyline (mm),
    and its slope; gains G1, G2. The disk starts at its relaxed angle with the tip on the
    trajectory, the centre at height H0."""

    GAINS: tuple[str, ...] = ("g1", "g2")  # the constructor's keywords for (G1, G2)

    @classmethod
    def gain_keywords(cls, gains) -> dict:
        """(G1, G2), or a prefix of it, as keyword arguments of the constructor (None: its defaults)."""
        if gains and len(gains) > len(cls.GAINS):
            raise TypeError(f"{cls.__name__} takes {len(cls.GAINS)} gains, {len(gains)} given")
        return dict(zip(cls.GAINS, gains or ()))

    def __init__(self, model: DiskModel, tip_x_mm, tip_z_mm, start_tip_x_mm: float, *, g1: float, g2: float):
        self.tip_x, self.tip_z = np.asarray(tip_x_mm, float), np.asarray(tip_z_mm, float)
        self.slope = np.diff(self.tip_z) / np.diff(self.tip_x)
        # the same values as plain floats: desired() runs five times a step (bisect, not numpy)
        self._x, self._z, self._slope = self.tip_x.tolist(), self.tip_z.tolist(), self.slope.tolist()
        self.model, self.g1, self.g2 = model, g1, g2
        self.initial_angle_rad = model.relaxed_angle_rad
        self.h0 = self.desired(start_tip_x_mm)[0] + model.radius_mm * math.sin(self.initial_angle_rad)

    def desired(self, x_mm: float) -> tuple[float, float]:
        i = bisect.bisect_left(self._x, x_mm) - 1
        if i < 0 or i >= len(self._slope):
            return (self._z[0] if i < 0 else self._z[-1]), 0.0
        return self._z[i] + self._slope[i] * (float(x_mm) - self._x[i]), self._slope[i]


class HeightControl(_TipTracking):
    """Eq. 6.17, dH/dt = G1 de/dt + G2 e with e = z_tip(x_tip) - y, integrated:
    H = H0 + G1 (e - e0) + G2 int e dt, solved for H (e depends on H through y)."""

    GAINS = ("proportional", "integral_per_s")

    def __init__(self, model: DiskModel, tip_x_mm, tip_z_mm, start_tip_x_mm: float,
                 *, proportional: float = 20.0, integral_per_s: float = 200.0):
        super().__init__(model, tip_x_mm, tip_z_mm, start_tip_x_mm, g1=proportional, g2=integral_per_s)

    def state(self, centre_x_mm, feed_mm_s, angle_rad, integral) -> DriveState:
        r, g1 = self.model.radius_mm, self.g1
        sin, cos = math.sin(angle_rad), math.cos(angle_rad)
        want, slope = self.desired(centre_x_mm - r * cos)
        height = (self.h0 + g1 * (want + r * sin) + self.g2 * integral) / (1 + g1)
        error = want - height + r * sin
        theta0 = self.model.relaxed_angle_rad
        return DriveState(height, (g1 * slope * feed_mm_s + self.g2 * error) / (1 + g1),
                          g1 * r * (slope * sin + cos) / (1 + g1), self.model.force_n(angle_rad, theta0),
                          theta0, error, theta0 - angle_rad)


class RelaxedAngleControl(_TipTracking):
    """6.6's variant: the height stays at H0 and a PI on the tip error winds the spring,
    theta_0 = theta_0,nominal - G1 e - G2 int e dt (gains in rad/mm, rad/(mm s))."""

    GAINS = ("proportional_rad_mm", "integral_rad_mm_s")

    def __init__(self, model: DiskModel, tip_x_mm, tip_z_mm, start_tip_x_mm: float,
                 *, proportional_rad_mm: float = 0.05, integral_rad_mm_s: float = 5.0):
        super().__init__(model, tip_x_mm, tip_z_mm, start_tip_x_mm, g1=proportional_rad_mm, g2=integral_rad_mm_s)

    def state(self, centre_x_mm, feed_mm_s, angle_rad, integral) -> DriveState:
        r = self.model.radius_mm
        want, _ = self.desired(centre_x_mm - r * math.cos(angle_rad))
        error = want - self.h0 + r * math.sin(angle_rad)
        theta0 = self.model.relaxed_angle_rad - self.g1 * error - self.g2 * integral
        # theta_0 falls as theta rises (through e): divide by the loop gain so the free
        # disk relaxes at one time constant whatever G1 is
        offset = (theta0 - angle_rad) / (1 + self.g1 * r * math.cos(angle_rad))
        return DriveState(self.h0, 0.0, 0.0, self.model.force_n(angle_rad, theta0), theta0, error, offset)


class ForceSchedule:
    """Execution under force control: the centre height and the wanted normal force follow
    planned trajectories of the feed position x_c (mm); the force loop winds the spring
    through the table (module docstring). The drive's integral state is the rest angle's
    change since the start (rad), where the spring was wound for the first wanted force."""

    def __init__(self, model: DiskModel, centre_x_mm, height_mm, force_n, initial_angle_rad: float):
        self.model = model
        self.x, self.h, self.f = (np.asarray(a, float) for a in (centre_x_mm, height_mm, force_n))
        if not (self.x.ndim == 1 and self.x.size >= 2 and self.x.shape == self.h.shape == self.f.shape
                and np.all(np.diff(self.x) > 0) and np.all(np.isfinite(self.h)) and np.all(np.isfinite(self.f))):
            raise ValueError("force schedule: need increasing centre x and finite heights and forces of one length")
        self.h_slope = np.diff(self.h) / np.diff(self.x)
        self.initial_angle_rad = initial_angle_rad
        self.initial_rest_rad = initial_angle_rad + self._windup_rad(max(float(self.f[0]), 0.0))

    def _windup_rad(self, force_n: float) -> float:
        return force_n * self.model.radius_mm / self.model.spring_n_mm_rad

    def state(self, centre_x_mm, feed_mm_s, angle_rad, integral_rad) -> DriveState:
        i = min(max(int(np.searchsorted(self.x, centre_x_mm)) - 1, 0), self.h_slope.size - 1)
        height = float(np.interp(centre_x_mm, self.x, self.h))
        # the force as sampled (held between samples), as the force controller receives it
        wanted = float(self.f[min(int(np.searchsorted(self.x, centre_x_mm, "right")) - 1, self.f.size - 1)]) \
            if centre_x_mm >= self.x[0] else 0.0
        rest = self.initial_rest_rad + integral_rad
        rest_rate = (angle_rad + self._windup_rad(max(wanted, 0.0)) - rest) / self.model.approach_time_constant_s
        return DriveState(height, float(self.h_slope[i]) * feed_mm_s, 0.0, self.model.force_n(angle_rad, rest), rest,
                          rest_rate, rest - angle_rad)


@dataclass(frozen=True)
class PassSimulation:
    """A simulated pass: per-step histories (arrays, units in the names) and the contour
    after it. ``removed_mm3`` is w times the area between the initial and final contours."""

    history: dict[str, np.ndarray]
    final: Contour
    removed_mm3: float
    multiple_patch_steps: int

    @property
    def peak_force_n(self) -> float:
        return float(np.max(self.history["force_n"], initial=0.0))

    @property
    def peak_power_w(self) -> float:
        return float(np.max(self.history["power_w"])) if self.history["power_w"].size else 0.0


HISTORY = ("time_s", "centre_x_mm", "tip_x_mm", "tip_z_mm", "height_mm", "angle_rad", "relaxed_angle_rad",
           "force_n", "power_w", "removal_rate_mm3_s", "patch_area_mm2", "patches", "integrand")


class FeedMotion:
    """The pass planner's motion (ch. 6): the disk centre moves along the bead at a constant
    ``feed_mm_s`` from ``start_centre_x_mm``; the drive (height or relaxed-angle control)
    sets its height and the spring's relaxed angle."""

    def __init__(self, drive, feed_mm_s: float, start_centre_x_mm: float):
        self.drive, self.feed_mm_s, self.start_centre_x_mm = drive, feed_mm_s, start_centre_x_mm

    def pose(self, model: DiskModel, time_s: float, angle_rad: float, integral: float):
        """(DriveState, DiskPose) at ``time_s`` with the disk at ``angle_rad``."""
        centre = self.start_centre_x_mm + self.feed_mm_s * time_s
        s = self.drive.state(centre, self.feed_mm_s, angle_rad, integral)
        return s, DiskPose(centre, s.height_mm, angle_rad, model.radius_mm)


class PassStepper:
    """One pass being ground, one RK4 step at a time: the disk state (angle, the drive's
    integral state), the time, and the contour as cut so far. ``motion`` places the disk
    and sets the spring (``pose(model, t, angle, integral)`` -> (DriveState, DiskPose), and
    its ``feed_mm_s`` along the bead): :class:`FeedMotion` for the pass planner's passes, the
    machine itself in the plant's grinding cell, which changes it and ``dt`` between steps.
    ``simulate_pass`` runs a :class:`FeedMotion` pass to the end of the bead."""

    def __init__(self, contour: Contour, model: DiskModel, motion, dt_s: float, *, initial_angle_rad: float,
                 step_mm: float, swing_floor_s: float | None = None, truncate_in_stages: bool = False,
                 contact_search=None):
        self.model, self.motion, self.dt, self.step_mm = model, motion, dt_s, step_mm
        self.truncate_in_stages = truncate_in_stages
        # the incremental kernel (contact.LiveContour); a contact search given: the old
        # whole-contour kernel with it (contact_reference, the benchmark's baseline)
        self.work = LiveContour(contour) if contact_search is None else ReferenceContour(contour, contact_search)
        # out of contact the disk swings back no faster than the spring allows, nor within a step
        self.free_swing_s = max(model.free_swing_s, dt_s if swing_floor_s is None else swing_floor_s)
        self.time_s, self.angle_rad, self.integral = 0.0, initial_angle_rad, 0.0

    @property
    def contour(self) -> Contour:
        return self.work.contour

    def _pose(self, time_s, angle_rad, integral):
        return self.motion.pose(self.model, time_s, angle_rad, integral)

    def _rates(self, time_s, angle_rad, integral):
        s, pose = self._pose(time_s, angle_rad, integral)
        patch = self.work.contact(pose)
        free_rate = s.free_offset_rad / self.free_swing_s
        if patch.length_mm == 0:
            rate = free_rate
        else:
            q = self.model.removal_rate_mm3_s(s.force_n)
            cos = math.cos(angle_rad)
            feed = self.motion.feed_mm_s
            rate = (q / (patch.length_mm * self.model.process.bead_width_mm) - feed * math.sin(angle_rad)
                    + s.height_rate_mm_s * cos) / (patch.centroid_mm - s.height_rate_per_angle_rate_mm * cos)  # 6.15
            rate = min(rate, free_rate)
        if self.truncate_in_stages:
            self._truncate([pose.tip_x_mm, pose.centre_x_mm], [pose.tip_z_mm, pose.centre_z_mm])
        return rate, s, pose, patch

    def _truncate(self, cutter_x, cutter_z):
        self.work.clip(np.array(cutter_x), np.array(cutter_z))

    def evaluate(self):
        """(dtheta/dt, DriveState, DiskPose, ContactPatch) now."""
        return self._rates(self.time_s, self.angle_rad, self.integral)

    def step(self, now=None) -> None:
        """One RK4 step of ``dt``, then the truncation; ``now`` is ``evaluate()``'s result if
        the caller has it already."""
        dt, t, angle, integral = self.dt, self.time_s, self.angle_rad, self.integral
        k1, s1, pose, _ = now or self.evaluate()
        k2, s2, _, _ = self._rates(t + dt / 2, angle + dt / 2 * k1, integral + dt / 2 * s1.integrand)
        k3, s3, _, _ = self._rates(t + dt / 2, angle + dt / 2 * k2, integral + dt / 2 * s2.integrand)
        k4, s4, _, _ = self._rates(t + dt, angle + dt * k3, integral + dt * s3.integrand)
        self.angle_rad = angle + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        self.integral = integral + dt / 6 * (s1.integrand + 2 * s2.integrand + 2 * s3.integrand + s4.integrand)
        self.time_s = t + dt
        if not 0 < self.angle_rad < math.pi / 2:
            raise FloatingPointError(f"integration diverged at tip x {pose.tip_x_mm:.1f} mm (disk angle "
                                     f"{self.angle_rad:.3g} rad); use a smaller step_mm than {self.step_mm}")
        # between steps: the swept tip path and the face now; all above them is gone
        _, new = self._pose(self.time_s, self.angle_rad, self.integral)
        self._truncate([pose.tip_x_mm, new.tip_x_mm, new.centre_x_mm], [pose.tip_z_mm, new.tip_z_mm, new.centre_z_mm])


def simulate_pass(contour: Contour, model: DiskModel, drive, feed_mm_s: float, start_tip_x_mm: float | None = None,
                  *, end_tip_x_mm: float | None = None, step_mm: float = 0.05,
                  truncate_in_stages: bool = False, contact_search=None) -> PassSimulation:
    """Grind one pass at constant feed from the tip at ``start_tip_x_mm`` until the tip
    reaches ``end_tip_x_mm`` (the contour's ends by default), by RK4 at ``step_mm`` of feed
    per step, truncating between steps. ``contact_search``: None for the incremental kernel
    (:class:`contact.LiveContour`), or a search on the whole contour for the old kernel
    (the benchmark's baselines: ``contact_reference``, the naive scan)."""
    start = contour.x_mm[0] if start_tip_x_mm is None else start_tip_x_mm
    end = contour.x_mm[-1] if end_tip_x_mm is None else end_tip_x_mm
    if not (math.isfinite(feed_mm_s) and feed_mm_s > 0 and step_mm > 0):
        raise ValueError("need a feed speed > 0 (mm/s) and a step > 0 (mm)")
    motion = FeedMotion(drive, feed_mm_s, start + model.radius_mm * math.cos(drive.initial_angle_rad))
    stepper = PassStepper(contour, model, motion, step_mm / feed_mm_s, initial_angle_rad=drive.initial_angle_rad,
                          step_mm=step_mm, truncate_in_stages=truncate_in_stages, contact_search=contact_search)
    rows = {name: [] for name in HISTORY}
    multiple = 0
    while True:
        now = stepper.evaluate()
        _, s, pose, patch = now
        _record(rows, model, stepper.time_s, pose, s, patch=patch)
        multiple += patch.patches > 1
        if pose.tip_x_mm >= end:
            break
        stepper.step(now)
    final = stepper.contour
    removed = model.process.bead_width_mm * (np.trapezoid(contour.z_mm, contour.x_mm)
                                             - np.trapezoid(final.z_mm, final.x_mm))
    history = {name: np.asarray(values, float) for name, values in rows.items()}
    return PassSimulation(history, final, float(removed), int(multiple))


def _record(rows, model, time, pose, s, *, patch):
    force = max(s.force_n, 0.0) if patch.length_mm > 0 else 0.0
    for name, value in (("time_s", time), ("centre_x_mm", pose.centre_x_mm), ("tip_x_mm", pose.tip_x_mm),
                        ("tip_z_mm", pose.tip_z_mm), ("height_mm", pose.centre_z_mm), ("angle_rad", pose.angle_rad),
                        ("relaxed_angle_rad", s.relaxed_angle_rad), ("force_n", force),
                        ("power_w", model.power_w(force)), ("removal_rate_mm3_s", model.removal_rate_mm3_s(force)),
                        ("patch_area_mm2", patch.area_mm2(model.process.bead_width_mm)),
                        ("patches", patch.patches), ("integrand", s.integrand)):
        rows[name].append(value)
