"""Process-coefficient estimation (seed 002 section 6.5) and the per-pass model update.

- K1, K2 by least squares on (removal rate Q, power Pi) pairs, Pi = K1 Q + K2 (eq. 4.4a),
  with standard errors and the correlation coefficient (the thesis: K1 = 12.8 J/mm^3,
  K2 = 114 W, r = 0.81).
- After each pass: the measured mean cut gives an observation of C1 (K1) with K2 held;
  ``PassModelUpdate`` carries the planner's current process and says when the estimate has
  moved far enough to re-solve the policy (the thesis had to regenerate its whole solution
  offline when the process changed, 8.1). The pass-rate load predictor smooths these
  observations in the end-to-end graph.
- From each plan of the pass planner: the force its plans can reach on the bead as it
  is (``achievable_mean_force_n``), which the policy takes as its F_max (issue 20).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.model import WATT, GrindingProcess


@dataclass(frozen=True)
class PowerFit:
    specific_energy_j_mm3: float  # K1
    wasted_power_w: float  # K2
    specific_energy_se: float
    wasted_power_se: float
    correlation: float
    samples: int


def fit_power_law(removal_rate_mm3_s, power_w) -> PowerFit:
    """Least-squares K1, K2 from Pi = K1 Q + K2 with ordinary standard errors."""
    q, p = np.asarray(removal_rate_mm3_s, float), np.asarray(power_w, float)
    if q.shape != p.shape or q.ndim != 1 or q.size < 3:
        raise ValueError("need two equal 1-D series of at least 3 (Q, power) pairs")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(p))) or np.ptp(q) == 0:
        raise ValueError("the pairs must be finite and Q must vary")
    design = np.column_stack([q, np.ones_like(q)])
    coefficients, *_ = np.linalg.lstsq(design, p, rcond=None)
    residual = p - design @ coefficients
    variance = residual @ residual / (q.size - 2)
    covariance = variance * np.linalg.inv(design.T @ design)
    return PowerFit(float(coefficients[0]), float(coefficients[1]), float(math.sqrt(covariance[0, 0])),
                    float(math.sqrt(covariance[1, 1])), float(np.corrcoef(q, p)[0, 1]), int(q.size))


def measured_specific_energy(process: GrindingProcess, force_n: float, feed_mm_s: float, cut_mm: float) -> float:
    """K1 (J/mm^3) that explains a measured mean cut at (F_N, V_f), K2 held (eq. 4.5)."""
    if not (cut_mm > 0 and feed_mm_s > 0 and force_n > 0):
        raise ValueError("need a positive cut, feed and force to infer K1")
    power = process.power_w(force_n)  # W
    removal = process.bead_width_mm * cut_mm * feed_mm_s  # mm^3/s
    return float((power - process.wasted_power_w) / removal) if power > process.wasted_power_w else math.inf


#: a K1 estimate further than this factor from the nominal one is not a disk that dulled or
#: sharpened but a broken measurement (a fresh and a glazed disk differ by about 3x)
PLAUSIBLE_K1_FACTOR = 10.0


def plausible_specific_energy(estimate_j_mm3: float, nominal_j_mm3: float) -> bool:
    """Whether a K1 estimate (J/mm^3) is within PLAUSIBLE_K1_FACTOR of the nominal K1."""
    return (math.isfinite(estimate_j_mm3)
            and nominal_j_mm3 / PLAUSIBLE_K1_FACTOR <= estimate_j_mm3 <= nominal_j_mm3 * PLAUSIBLE_K1_FACTOR)


def achievable_mean_force_n(process: GrindingProcess, force_n: float, commanded_depth_mm: float,
                            planned_depth_mm: float, planned_peak_force_n: float) -> float:
    """The highest force (N) of the static model (eq. 4.6) that the pass planner can plan on
    the bead as it now is, from one of its plans: the force that removes the depth it
    planned (its force guard may have cut the commanded depth so that no point of the
    pass needs more than F_max), scaled by F_max over the plan's peak force. A rough bead
    needs force peaks above the mean to cut its crests, so its mean force stays below F_max."""
    values = (force_n, commanded_depth_mm, planned_depth_mm, planned_peak_force_n)
    if not all(math.isfinite(v) for v in values) or min(force_n, commanded_depth_mm, planned_peak_force_n) <= 0:
        raise ValueError(f"need a positive force, commanded depth and peak force, and a finite planned depth: {values}")
    zero_cut = process.zero_cut_force_n()
    if force_n <= zero_cut:
        raise ValueError(f"force {force_n:g} N removes nothing (zero-cut force {zero_cut:.1f} N)")
    # the depth is the removal numerator over the feed (eq. 4.6): the feed cancels
    wanted = float(process.removal_numerator(force_n)) * min(max(planned_depth_mm / commanded_depth_mm, 0.0), 1.0)
    planned_force = process.force_for_numerator_n(wanted) if wanted > 0 else zero_cut
    return min(planned_force * process.force_max_n / planned_peak_force_n, process.force_max_n)


@dataclass
class PassModelUpdate:
    """Holds the planner's process model: K1 and the force the plans can reach (F_max of
    the policy, ``achievable_mean_force_n``); ``observe`` and ``observe_force_limit`` fold in
    an estimate and return True when the model has moved more than ``threshold``
    (relative) since the last solve."""

    process: GrindingProcess
    threshold: float = 0.05
    solved_with: float = dataclasses.field(init=False)
    nominal: float = dataclasses.field(init=False)  # K1 of the process it started with (J/mm^3)
    solved_force_max_n: float = dataclasses.field(init=False)
    nominal_force_max_n: float = dataclasses.field(init=False)  # the machine's F_max (N)

    def __post_init__(self):
        self.solved_with = self.nominal = self.process.specific_energy_j_mm3
        self.solved_force_max_n = self.nominal_force_max_n = self.process.force_max_n

    def plausible(self, specific_energy_j_mm3: float) -> bool:
        return plausible_specific_energy(specific_energy_j_mm3, self.nominal)

    def observe(self, specific_energy_j_mm3: float) -> bool:
        if not self.plausible(specific_energy_j_mm3):
            raise ValueError(f"K1 estimate {specific_energy_j_mm3!r} J/mm^3 is not within {PLAUSIBLE_K1_FACTOR:g}x "
                             f"of the nominal {self.nominal:g}")
        self.process = dataclasses.replace(self.process, specific_energy_j_mm3=specific_energy_j_mm3)
        return self.needs_solve

    def observe_plan(self, force_n: float, commanded_depth_mm: float, planned_depth_mm: float,
                     planned_peak_force_n: float) -> bool:
        """Fold in the force a plan of the pass planner reaches (``achievable_mean_force_n``
        against the machine's F_max, not the limit the policy has now)."""
        machine = dataclasses.replace(self.process, force_max_n=self.nominal_force_max_n)
        return self.observe_force_limit(achievable_mean_force_n(machine, force_n, commanded_depth_mm,
                                                                planned_depth_mm, planned_peak_force_n))

    def observe_force_limit(self, force_max_n: float) -> bool:
        """The force (N) the plans can reach, kept within F_max and at least halfway from the
        zero-cut force to it (one odd plan must not leave the policy nearly nothing to do)."""
        if not math.isfinite(force_max_n):
            raise ValueError(f"force limit {force_max_n!r} N is not finite")
        zero_cut = self.process.zero_cut_force_n()
        floor = zero_cut + 0.5 * (self.nominal_force_max_n - zero_cut)
        self.process = dataclasses.replace(self.process, force_max_n=min(max(force_max_n, floor),
                                                                         self.nominal_force_max_n))
        return self.needs_solve

    @property
    def needs_solve(self) -> bool:
        """Whether K1 or the force limit moved more than ``threshold`` since the last solve."""
        return (abs(self.process.specific_energy_j_mm3 / self.solved_with - 1.0) > self.threshold
                or abs(self.process.force_max_n / self.solved_force_max_n - 1.0) > self.threshold)

    def mark_solved(self, process: GrindingProcess | None = None) -> None:
        """The policy is now solved with this process's K1 and F_max (the latest if None)."""
        process = process or self.process
        self.solved_with, self.solved_force_max_n = process.specific_energy_j_mm3, process.force_max_n

    @property
    def solved_process(self) -> GrindingProcess:
        """The process the current policy was solved with."""
        return dataclasses.replace(self.process, specific_energy_j_mm3=self.solved_with,
                                   force_max_n=self.solved_force_max_n)

    def restore(self, specific_energy_j_mm3: float, solved_with_j_mm3: float, force_max_n: float | None = None,
                solved_force_max_n: float | None = None) -> None:
        """Back to a logged state (a restarted planner): the latest estimates and those of the
        solve (K1 in J/mm^3, force limits in N; a log without force limits keeps F_max)."""
        self.observe(solved_with_j_mm3)
        if solved_force_max_n is not None:
            self.observe_force_limit(solved_force_max_n)
        self.mark_solved()
        self.observe(specific_energy_j_mm3)
        if force_max_n is not None:
            self.observe_force_limit(force_max_n)


assert WATT == 1000.0  # K1 J/mm^3 against power in W: the unit bookkeeping above relies on it
