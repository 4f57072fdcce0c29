"""The workpiece on the simulated plant: the weld bead being ground, pass by pass, with the
machine setting the disk centre and the force table winding the grinder's spring
(DESIGN.md section 4, plant; seed 002 ch. 6-7).

Coupling. The dynamic model of seed 002 6.4 (:mod:`hex_control.grinding.dynamic`) grinds
with a massless disk on a rotational spring; here the machine holds the disk centre
(x, H in the bead's plane, from the struts by forward kinematics) and the force table
sets the spring's relaxed angle: a table displacement X turns it by X / R (eq. 7.1 with
the table along the force, so that K_x = K_theta / R^2), so

    theta_0(X) = theta_0,nom + (X - X_c) / R,     F_N = K_S (theta_0 - theta) / R
                                                     = K_x (X - X_c - R (theta - theta_0,nom)).

The table therefore sees the work surface at X_c + R (theta - theta_0,nom) while the disk
touches it, and nothing while it does not: that is what ``advance`` returns to the force
table, whose own model adds runout, stiction and the sensor. The disk angle follows eq. 6.15
in sub-steps of at most ``step_mm`` of feed; the contour is truncated between sub-steps.

Per pass the process coefficients are drawn (``ProcessVariation``: 10-20 % pass to pass,
dulling, wear), and the pass is measured: the scanner's profile after it, the removed
volume and mean cut depth (the state X of the thesis is the mean height), force, grinder
power and energy, the specific energy K1 that the power and the scans imply, burn
(eq. 5.11: F_N > C_B sqrt(V_f), on force and feed averaged over ``burn_window_s``, and only
above the force that removes anything: a light touch at rest grinds nothing) and stall
(power above 80 % of the maximum).

Units: mm, N, s, rad; power W, energy J, volume mm^3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.contact import DiskPose
from hex_control.grinding.contour import Contour
from hex_control.grinding.dynamic import DiskModel, DriveState, PassStepper
from hex_control.grinding.variation import ProcessVariation


class MachineMotion:
    """The disk as the plant moves it: its centre where the machine holds it, one straight
    segment (x, H in the bead frame) at a time, and its spring wound by the force table,
    whose position sets the relaxed angle (eq. 7.1: the table sees the work at
    X_c + R(theta - theta_0))."""

    def __init__(self, table_contact_mm: float):
        self.table_contact_mm = self.table_mm = table_contact_mm
        self.segment = (0.0, 1.0, 0.0, 0.0, 0.0, 0.0)  # start s, duration s, x0, H0, x1, H1 (mm)
        self.feed_mm_s = 0.0

    def relaxed_angle_rad(self, model: DiskModel, table_mm: float) -> float:
        return model.relaxed_angle_rad + (table_mm - self.table_contact_mm) / model.radius_mm

    def surface_mm(self, model: DiskModel, angle_rad: float) -> float:
        """Table position at which the spring is relaxed at the disk's angle ``angle_rad``."""
        return self.table_contact_mm + model.radius_mm * (angle_rad - model.relaxed_angle_rad)

    def pose(self, model: DiskModel, time_s: float, angle_rad: float, integral: float):
        start, duration, x0, h0, x1, h1 = self.segment
        f = (time_s - start) / duration
        centre, height = x0 + f * (x1 - x0), h0 + f * (h1 - h0)
        relaxed = self.relaxed_angle_rad(model, self.table_mm)
        force = model.force_n(angle_rad, relaxed)
        state = DriveState(height, (h1 - h0) / duration, 0.0, force, relaxed, 0.0, relaxed - angle_rad)
        return state, DiskPose(centre, height, angle_rad, model.radius_mm)


def advance_by_machine(stepper: PassStepper, motion: MachineMotion, duration_s: float, start_mm, end_mm,
                       *, table_mm: float, step_mm: float):
    """Move the centre from ``start_mm`` to ``end_mm`` ((x, H), bead frame) in ``duration_s``
    with the table at ``table_mm``, in sub-steps of at most ``step_mm`` along the bead;
    returns the (force N, power W, in contact) samples at the sub-step starts."""
    (x0, h0), (x1, h1) = start_mm, end_mm
    substeps = max(1, math.ceil(abs(x1 - x0) / step_mm))
    motion.table_mm, stepper.dt = table_mm, duration_s / substeps
    motion.feed_mm_s = (x1 - x0) / duration_s
    samples = []
    for k in range(substeps):
        f0, f1 = k / substeps, (k + 1) / substeps
        motion.segment = (stepper.time_s, stepper.dt, x0 + f0 * (x1 - x0), h0 + f0 * (h1 - h0),
                          x0 + f1 * (x1 - x0), h0 + f1 * (h1 - h0))
        now = stepper.evaluate()
        _, state, _, patch = now
        force = max(state.force_n, 0.0) if patch.length_mm > 0 else 0.0
        samples.append((force, stepper.model.power_w(force), patch.length_mm > 0))
        stepper.step(now)
    return samples


@dataclass(frozen=True)
class PassMeasurement:
    """What the cell measured over one pass (units in the names)."""

    job_id: str
    pass_index: int
    contour_before: Contour
    contour_after: Contour
    removed_volume_mm3: float
    measured_cut_depth_mm: float  # removed volume / (w L): the change of the mean height X
    contact_time_s: float
    mean_normal_force_n: float  # over the time in contact
    peak_normal_force_n: float
    mean_feed_mm_s: float  # over the time in contact
    energy_j: float  # grinder power above K2, integrated over the contact
    specific_energy_j_mm3: float  # energy / removed volume: the pass's K1 as measured (nan if nothing removed)
    peak_power_w: float
    burn_detected: bool
    stall_detected: bool
    # the removal the drawn process gives against the nominal one at the same force: mu / K1
    # of the pass over the nominal's (its dulling trend excluded); what a planner that knew
    # only the nominal would see as its pass's deviation (plant.pass_verdict)
    expected_removal_factor: float = 1.0


class GrindingCell:
    """The bead on the plant. ``start_pass`` draws the pass's process, ``advance`` grinds
    one control period, ``finish_pass`` scans and measures."""

    def __init__(self, contour: Contour, model: DiskModel, variation: ProcessVariation = ProcessVariation(),
                 seed: int = 0, *, table_contact_mm: float = 0.0, step_mm: float = 0.1, control_period_s: float = 0.005,
                 burn_coefficient: float | None = None, burn_window_s: float = 0.1):
        if not (step_mm > 0 and control_period_s > 0 and burn_window_s > 0):
            raise ValueError("need step_mm, control_period_s and burn_window_s > 0")
        self.nominal, self.variation = model, variation
        self.rng = np.random.default_rng(seed)
        self.table_contact_mm, self.step_mm, self.control_period_s = table_contact_mm, step_mm, control_period_s
        self.burn_coefficient, self.burn_window_s = burn_coefficient, burn_window_s
        self.model = model
        self.motion = MachineMotion(table_contact_mm)
        self.stepper = PassStepper(contour, model, self.motion, 1.0, initial_angle_rad=model.relaxed_angle_rad,
                                   step_mm=step_mm, swing_floor_s=control_period_s)
        self.centre_mm = None  # (x, H) at the end of the last advance
        self.current = None  # the pass being measured: dict of accumulators
        self.passes_started = 0
        self.removal_factor = 1.0  # of the pass being ground (PassMeasurement.expected_removal_factor)

    @property
    def contour(self) -> Contour:
        return self.stepper.contour

    @property
    def width_mm(self) -> float:
        return self.model.process.bead_width_mm

    def start_pass(self, job_id: str, pass_index: int) -> None:
        """Draw the process of this pass (the disk dulls and wears with every pass started)."""
        self.model = self.variation.draw(self.nominal, self.passes_started, self.rng)
        self.zero_cut_force_n = float(self.model.process.zero_cut_force_n())
        drawn, nominal = self.model.process, self.nominal.process
        dulled_energy = nominal.specific_energy_j_mm3 * (1 + self.variation.dulling_per_pass) ** self.passes_started
        friction = drawn.friction_coefficient / nominal.friction_coefficient if nominal.friction_coefficient else 1.0
        self.removal_factor = friction * dulled_energy / drawn.specific_energy_j_mm3
        self.passes_started += 1
        self.stepper.model = self.model
        self.current = {"job_id": job_id, "pass_index": pass_index, "before": self.contour, "contact_s": 0.0,
                        "force_s": 0.0, "peak_force": 0.0, "feed_s": 0.0, "energy": 0.0, "peak_power": 0.0,
                        "window": [], "burn": False}

    def advance(self, duration_s: float, centre_mm, table_mm: float) -> float:
        """Grind for ``duration_s`` while the centre moves to ``centre_mm`` = (x, H) (bead
        frame) with the table at ``table_mm``. Returns the table position of the work
        surface (``inf`` while the disk does not touch)."""
        centre = (float(centre_mm[0]), float(centre_mm[1]))
        if not all(math.isfinite(v) for v in centre + (table_mm, duration_s)) or duration_s <= 0:
            raise ValueError("need a finite centre, table position and a positive duration")
        start = self.centre_mm or centre
        self.centre_mm = centre
        samples = advance_by_machine(self.stepper, self.motion, duration_s, start, centre, table_mm=table_mm,
                                     step_mm=self.step_mm)
        if self.current is not None:
            self._accumulate(samples, duration_s / len(samples), abs(centre[0] - start[0]) / duration_s)
        _, _, _, patch = self.stepper.evaluate()
        return self.surface_mm() if patch.length_mm > 0 else math.inf

    def surface_mm(self) -> float:
        """Table position at which the spring is relaxed at the disk's present angle."""
        return self.motion.surface_mm(self.model, self.stepper.angle_rad)

    def _accumulate(self, samples, dt: float, feed_mm_s: float) -> None:
        c, k2 = self.current, self.model.process.wasted_power_w
        window = c["window"]
        for force, power, touching in samples:
            window.append((force, feed_mm_s))
            if len(window) * dt > self.burn_window_s:
                window.pop(0)
            if not touching:
                continue
            c["contact_s"] += dt
            c["force_s"] += force * dt
            c["feed_s"] += feed_mm_s * dt
            c["energy"] += max(power - k2, 0.0) * dt
            c["peak_force"] = max(c["peak_force"], force)
            c["peak_power"] = max(c["peak_power"], power)
            if self.burn_coefficient is not None and len(window) * dt >= self.burn_window_s - 1e-12:
                force_mean, feed_mean = np.mean(window, axis=0)
                # eq. 5.11 on the window's means; below the zero-cut force nothing is ground
                if force_mean > max(self.burn_coefficient * math.sqrt(feed_mean), self.zero_cut_force_n):
                    c["burn"] = True

    def finish_pass(self) -> PassMeasurement:
        """Scan the profile and measure the pass just ground."""
        c, self.current = self.current, None
        if c is None:
            raise RuntimeError("no pass is being ground")
        before, after = c["before"], self.contour
        width = self.model.process.bead_width_mm
        removed = width * (np.trapezoid(before.z_mm, before.x_mm) - np.trapezoid(after.z_mm, after.x_mm))
        contact = c["contact_s"]
        process = self.model.process
        return PassMeasurement(
            c["job_id"], c["pass_index"], before, after, float(removed), float(removed / (width * before.length_mm)),
            contact, c["force_s"] / contact if contact else 0.0, c["peak_force"],
            c["feed_s"] / contact if contact else 0.0, c["energy"],
            c["energy"] / removed if removed > 1e-9 else math.nan, c["peak_power"], c["burn"],
            c["peak_power"] > process.power_fraction * process.max_power_w, self.removal_factor)
