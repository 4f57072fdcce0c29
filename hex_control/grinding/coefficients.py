"""Process-coefficient estimation (seed 002 section 6.5) and the per-pass model update.

- K1, K2 by least squares on (removal rate Q, power Pi) pairs, Pi = K1 Q + K2 (eq. 4.4a),
  with standard errors and the correlation coefficient (the thesis: K1 = 12.8 J/mm^3,
  K2 = 114 W, r = 0.81).
- After each pass: the measured mean cut gives an observation of C1 (K1) with K2 held;
  ``PassModelUpdate`` carries the planner's current process and says when the estimate has
  moved far enough to re-solve the policy (the thesis had to regenerate its whole solution
  offline when the process changed, 8.1). The pass-rate load predictor smooths these
  observations in the end-to-end graph.
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


@dataclass
class PassModelUpdate:
    """Holds the planner's process model; ``observe`` folds in a coefficient estimate and
    returns True when it moved more than ``threshold`` (relative) since the last solve."""

    process: GrindingProcess
    threshold: float = 0.05
    solved_with: float = dataclasses.field(init=False)
    nominal: float = dataclasses.field(init=False)  # K1 of the process it started with (J/mm^3)

    def __post_init__(self):
        self.solved_with = self.nominal = self.process.specific_energy_j_mm3

    def plausible(self, specific_energy_j_mm3: float) -> bool:
        return plausible_specific_energy(specific_energy_j_mm3, self.nominal)

    def observe(self, specific_energy_j_mm3: float) -> bool:
        if not self.plausible(specific_energy_j_mm3):
            raise ValueError(f"K1 estimate {specific_energy_j_mm3!r} J/mm^3 is not within {PLAUSIBLE_K1_FACTOR:g}x "
                             f"of the nominal {self.nominal:g}")
        self.process = dataclasses.replace(self.process, specific_energy_j_mm3=specific_energy_j_mm3)
        return abs(specific_energy_j_mm3 / self.solved_with - 1.0) > self.threshold

    def mark_solved(self, specific_energy_j_mm3: float | None = None) -> None:
        """The policy is now solved with this K1 (J/mm^3; the latest estimate if None)."""
        self.solved_with = self.process.specific_energy_j_mm3 if specific_energy_j_mm3 is None else specific_energy_j_mm3

    @property
    def solved_process(self) -> GrindingProcess:
        """The process the current policy was solved with."""
        return dataclasses.replace(self.process, specific_energy_j_mm3=self.solved_with)

    def restore(self, specific_energy_j_mm3: float, solved_with_j_mm3: float) -> None:
        """Back to a logged state (a restarted planner): the latest estimate and the K1 of the solve."""
        self.observe(solved_with_j_mm3)
        self.mark_solved()
        self.observe(specific_energy_j_mm3)


assert WATT == 1000.0  # K1 J/mm^3 against power in W: the unit bookkeeping above relies on it
