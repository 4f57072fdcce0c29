"""Pass-to-pass variation of the grinding process (seed 002 3.2 item 3 and 6.5).

The coefficients vary 10-20 % from pass to pass; the simulation predicts a pass within
10 % with the pass's own coefficients and within up to 50 % with those of earlier passes
(6.5). The plant draws each pass's coefficients here: K1 and mu scaled by independent
log-normal factors of mean 1 and the given coefficients of variation, K1 drifting upwards
as the disk dulls, and the disk's radius shrinking by its wear. Seeded, so a run repeats.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from hex_control.grinding.dynamic import DiskModel


@dataclass(frozen=True)
class ProcessVariation:
    specific_energy_cv: float = 0.15  # K1, pass to pass
    friction_cv: float = 0.10  # mu, pass to pass
    dulling_per_pass: float = 0.0  # K1 grows by this fraction each pass (a disk that dulls)
    wear_mm_per_pass: float = 0.0  # disk radius lost each pass

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"ProcessVariation.{f.name} must be finite and >= 0, got {value!r}")

    def draw(self, nominal: DiskModel, pass_index: int, rng: np.random.Generator) -> DiskModel:
        """The process of pass ``pass_index`` (0-based)."""
        process = nominal.process
        radius = process.disk_radius_mm - self.wear_mm_per_pass * pass_index
        if radius <= 0:
            raise ValueError(f"the disk is worn away by pass {pass_index}")
        energy = process.specific_energy_j_mm3 * (1 + self.dulling_per_pass) ** pass_index \
            * _unit_lognormal(rng, self.specific_energy_cv)
        friction = process.friction_coefficient * _unit_lognormal(rng, self.friction_cv)
        return dataclasses.replace(nominal, process=dataclasses.replace(
            process, specific_energy_j_mm3=energy, friction_coefficient=friction, disk_radius_mm=radius))


def _unit_lognormal(rng: np.random.Generator, cv: float) -> float:
    """A log-normal factor of mean 1 and coefficient of variation ``cv``."""
    if cv == 0:
        return 1.0
    sigma = math.sqrt(math.log1p(cv * cv))
    return float(rng.lognormal(-sigma * sigma / 2, sigma))
