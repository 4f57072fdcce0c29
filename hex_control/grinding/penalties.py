"""Charges of the grinding sequence planner (seed 002 sections 2.4, 5.2, 5.5, Fig. 5-3, 5-25).

Deadline charge C(X) on the material remaining X (mm; negative = overground): zero on the
tolerance band 0 <= X <= tolerance, each side constant / linear / quadratic and chosen
independently (the thesis combined them the same way); overgrinding is meant to be
charged more heavily than undergrinding. Lateness charge on the overrun time (s), linear
or quadratic. In-path charges (eq. 5.1): a fixed charge per pass, and a surface-finish
charge on the last pass (section 5.4 proposes it; the thesis did not implement it). The
thesis says the last pass would be "charged inversely to their feedspeeds" and wants the
effect of biasing last passes to slow feeds (Ivers: the slowest feed leaves the finest
surface); that effect needs a charge that grows with the feed, so it is c * V_f.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("constant", "linear", "quadratic")


@dataclass(frozen=True)
class SideCharge:
    """``kind`` of one side of the deadline charge: constant c, linear c*d, quadratic c*d^2,
    with d the distance (mm or s) beyond the zero-charge band."""

    kind: str = "linear"
    coefficient: float = 1.0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"charge kind must be one of {KINDS}, got {self.kind!r}")
        if not (np.isfinite(self.coefficient) and self.coefficient >= 0):
            raise ValueError(f"charge coefficient must be finite and >= 0, got {self.coefficient!r}")

    def __call__(self, distance):
        d = np.asarray(distance, float)
        if self.kind == "constant":
            return np.where(d > 0, self.coefficient, 0.0)
        if self.kind == "linear":
            return self.coefficient * np.maximum(d, 0.0)
        return self.coefficient * np.maximum(d, 0.0) ** 2


@dataclass(frozen=True)
class DeadlineCharge:
    """C(X): ``over`` for X < 0, zero for 0 <= X <= tolerance_mm, ``under`` beyond.

    Defaults follow the numbers of the thesis's Fig. 5-4 (deadline row): 5 per overground
    state, 2 per mm of undergrind.
    """

    over: SideCharge = SideCharge("constant", 5.0)
    under: SideCharge = SideCharge("linear", 2.0)
    tolerance_mm: float = 0.02

    def __post_init__(self):
        if not (np.isfinite(self.tolerance_mm) and self.tolerance_mm >= 0):
            raise ValueError("tolerance_mm must be finite and >= 0")

    def __call__(self, material_mm):
        x = np.asarray(material_mm, float)
        return np.where(x < 0, self.over(-x), self.under(x - self.tolerance_mm))


@dataclass(frozen=True)
class LatenessCharge:
    """Charge on the time overrun past the deadline (linear or quadratic)."""

    charge: SideCharge = SideCharge("linear", 1.0)

    def __call__(self, late_s):
        return self.charge(late_s)


@dataclass(frozen=True)
class InPathCharges:
    """G of eq. 5.1: ``per_pass`` on every pass; ``surface_finish_per_mm_s`` * V_f on a pass
    after which the policy grinds no more (slow last passes leave the finer surface, 5.4)."""

    per_pass: float = 0.0
    surface_finish_per_mm_s: float = 0.0

    def __post_init__(self):
        if self.per_pass < 0 or self.surface_finish_per_mm_s < 0:
            raise ValueError("in-path charges must be >= 0")
