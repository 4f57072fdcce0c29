"""Stochastic cut depth (seed 002 section 4.2, eq. 4.9-4.10, Table 4-1, Fig. 4-2).

The standard deviation of the cut depth follows from the variation of one coefficient:
    C1:  sigma_delta = C3 F_N sigma_C1 / V_f                          (4.9a)
    C2:  sigma_delta = sigma_C2 / V_f                                  (4.9b)
    mu:  sigma_delta = C1 omega R F_N sigma_mu / (w V_f)               (4.9c)
and sigma_Xf = sigma_delta (4.10). Variations are given relative to the coefficient
(``relative_variation``, the thesis's 10-20 %). A fourth source, ``cut``, takes sigma_delta
proportional to the mean cut itself -- the "independence of dimension" the thesis assumes
in its footnote to section 5.4; with 4.9a-c the smallest pass keeps a noise floor (the
force never falls to zero while cutting), which breaks the convexity of J near X = 0.

PDF of the cut depth with that mean m and standard deviation s:
    normal     -- N(m, s^2) (allows negative cuts, which the thesis rejects);
    lognormal  -- the log-normal with mean m and variance s^2;
    rayleigh   -- the thesis's choice: a Rayleigh of variance s^2 shifted right to mean m
                  when its own mean sigma_R sqrt(pi/2) is below m (mean and variance
                  independent); otherwise scaled down to mean m with its origin at zero cut
                  depth (variance then tied to the mean).
The expectation of eq. 5.3 over J interpolated linearly between material nodes is taken
exactly, from the integrated CDF G(a) = E[(a - delta)+] (:meth:`CutDepthModel.integrated_cdf`).
An equal-probability quadrature (n nodes at the quantiles (j + 1/2)/n) is not enough: the
optimisation places its last passes so that overgrinding lies beyond the outermost node,
where the quadrature sees no probability -- with 32 nodes the policy's J at the start of
the shipped job was 0.0005 while simulating that policy on this same model cost 0.21.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.model import GrindingProcess

PDFS = ("normal", "lognormal", "rayleigh")
SOURCES = ("c1", "c2", "mu", "cut")
_RAYLEIGH_MEAN = math.sqrt(math.pi / 2)  # mean / sigma_R
_RAYLEIGH_STD = math.sqrt(2 - math.pi / 2)  # std / sigma_R


def _special():
    """scipy.special, imported where a cut PDF is evaluated: the nodes that only read the
    configuration (the plant, the robot state) need not start it (0.2 s CPU each)."""
    from scipy import special

    return special


@dataclass(frozen=True)
class CutDepthModel:
    """Which coefficient varies, by how much, and the PDF shape."""

    source: str = "c1"
    relative_variation: float = 0.15
    pdf: str = "rayleigh"

    def __post_init__(self):
        if self.source not in SOURCES:
            raise ValueError(f"source must be one of {SOURCES}, got {self.source!r}")
        if self.pdf not in PDFS:
            raise ValueError(f"pdf must be one of {PDFS}, got {self.pdf!r}")
        if not (0 <= self.relative_variation < 1):
            raise ValueError(f"relative_variation must be in [0, 1), got {self.relative_variation}")

    def std_mm(self, process: GrindingProcess, force_n, feed_mm_s):
        """sigma_delta of eq. 4.9a-c (mm)."""
        force_n, feed_mm_s = np.asarray(force_n, float), np.asarray(feed_mm_s, float)
        if self.source == "c1":
            return process.c3(force_n) * force_n * self.relative_variation * process.c1 / feed_mm_s
        if self.source == "c2":
            return np.abs(process.c2) * self.relative_variation / feed_mm_s + 0 * force_n
        if self.source == "cut":
            return self.relative_variation * process.cut_depth_mm(force_n, feed_mm_s)
        mu = process.friction_coefficient
        return (process.c1 * process.disk_speed(force_n) * process.disk_radius_mm * force_n
                * self.relative_variation * mu / (process.bead_width_mm * feed_mm_s))

    def sample(self, mean_mm: float, std_mm: float, rng: np.random.Generator) -> float:
        """One cut depth drawn from the PDF (for Monte-Carlo rollouts of a policy)."""
        return float(self.ppf(np.asarray(mean_mm, float), np.asarray(std_mm, float), rng.uniform()))

    def ppf(self, mean, std, u):
        """Quantile function of the cut-depth PDF at probabilities u (broadcasting)."""
        if self.pdf == "normal":
            return mean + std * _special().ndtri(u)
        if self.pdf == "lognormal":
            safe_mean = np.maximum(mean, 1e-300)
            sigma2 = np.log1p((std / safe_mean) ** 2)
            nodes = np.exp(np.log(safe_mean) - sigma2 / 2 + np.sqrt(sigma2) * _special().ndtri(u))
            return np.where(mean > 0, nodes, 0.0)
        return rayleigh_quantiles(mean, std, u)

    def integrated_cdf(self, mean, std, a):
        """G(a) = E[(a - delta)+] = integral of the CDF up to ``a`` (mm), broadcasting.

        For J linear between nodes h apart, E[J(X - delta)] = sum_j J_j E[hat_j(X - delta)]
        and E[hat(z - delta)] = (G(z + h) - 2 G(z) + G(z - h)) / h: exact, tails included.
        """
        mean, std, a = (np.asarray(v, float) for v in (mean, std, a))
        certain = np.maximum(a - mean, 0.0)  # std 0: delta = mean
        safe_std = np.where(std > 0, std, 1.0)
        if self.pdf == "normal":
            z = (a - mean) / safe_std
            value = (a - mean) * _special().ndtr(z) + safe_std * np.exp(-z * z / 2) / math.sqrt(2 * math.pi)
        elif self.pdf == "lognormal":
            # E[(a - delta)+] of a log-normal: the put-option formula
            safe_mean = np.maximum(mean, 1e-300)
            s = np.sqrt(np.log1p((safe_std / safe_mean) ** 2))
            log_a = np.log(np.maximum(a, 1e-300))
            d = (log_a - np.log(safe_mean) + s * s / 2) / s
            value = np.where(a > 0, a * _special().ndtr(d) - safe_mean * _special().ndtr(d - s), 0.0)
            value = np.where(mean > 0, value, certain)
        else:
            sigma, shift = rayleigh_parameters(mean, safe_std)
            r = np.maximum((a - shift) / np.where(sigma > 0, sigma, 1.0), 0.0)
            # integral_0^r (1 - exp(-u^2/2)) du
            value = sigma * (r - math.sqrt(math.pi / 2) * _special().erf(r / math.sqrt(2)))
            value = np.where(sigma > 0, value, certain)
        return np.where(std > 0, value, certain)


def rayleigh_parameters(mean_mm, std_mm):
    """(sigma_R, shift) of the thesis's shifted-or-scaled Rayleigh with this mean and std."""
    mean, std = np.asarray(mean_mm, float), np.asarray(std_mm, float)
    sigma_for_std = std / _RAYLEIGH_STD
    shift = mean - sigma_for_std * _RAYLEIGH_MEAN
    scaled = shift < 0  # cannot shift left of zero cut depth: scale to the mean instead
    sigma = np.where(scaled, mean / _RAYLEIGH_MEAN, sigma_for_std)
    return sigma, np.where(scaled, 0.0, shift)


def rayleigh_quantiles(mean, std, u):
    sigma, shift = rayleigh_parameters(mean, std)
    return shift + sigma * np.sqrt(-2.0 * np.log1p(-u))


def planned_on_estimate(model: CutDepthModel, estimate_cv: float) -> tuple[CutDepthModel, float]:
    """The cut of a pass planned on an estimate of K1 (issue 42 item 2): (the cut model, the mean factor).

    The sequence planner plans each pass with eq. 4.6 at K-hat, the pass-rate predictor's K1,
    and the pass grinds with its own K1: the thesis's pass-to-pass variation
    (``model.relative_variation``, 10-20 %) about a level that K-hat itself misses by
    ``estimate_cv`` (relative; the predictor's own prediction error). Both C1 and C2 of eq.
    4.6 are proportional to 1/K1, so the cut is exactly delta-hat K-hat / K1: with K1
    log-normal of mean K-hat and coefficient of variation c = sqrt(cv_pass^2 + cv_est^2),
    the cut is log-normal with the same c and mean delta-hat (1 + c^2) (E[1/K1] > 1/E[K1]).
    Returned: the ``cut`` source with that c and the log-normal PDF, and 1 + c^2, by which
    the policy's mean cuts are scaled (the SDP solved with K1 / (1 + c^2)).

    Why (measured, docs/results/issue42_grid.md): the planner's K1 follows the last pass's
    draw (its first gain is about 0.85), so a pass after a hard one is planned shallow and
    cut deep; jobs re-solved on it overground 0.7-1.8 % of the time against the 0.3 % the
    thesis's model (``c1``, shifted Rayleigh, the mean at 1/E[K1]) promised.
    """
    if not (math.isfinite(estimate_cv) and 0 <= estimate_cv < 1):
        raise ValueError(f"estimate_cv must be in [0, 1), got {estimate_cv!r}")
    cv = math.hypot(model.relative_variation, estimate_cv)
    if not cv < 1:
        raise ValueError(f"the combined variation {cv:.3f} must be below 1")
    return CutDepthModel("cut", cv, "lognormal"), 1.0 + cv * cv
