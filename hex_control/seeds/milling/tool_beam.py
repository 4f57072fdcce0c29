"""The slender ball-end mill as Euler-Bernoulli beam finite elements clamped in the holder
(seed 004 section 3: "the FFE is the Euler-Bernoulli bar element fixed at its one end in the
tool holder"; Przemieniecki 1985 for the element matrices).

SI units throughout this package: m, kg, N, s; spindle speeds in rev/min. The round section
bends alike in the two planes normal to the tool axis, x_e1 and x_e2, so one plane's
matrices serve both; eq. 14's M, L, K are block-diagonal in (x_e1, x_e2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh


@dataclass(frozen=True)
class BeamTool:
    """A uniform solid round tool, clamped at the holder, free at the ball end.

    diameter_m, overhang_m: section and free length; young_pa, density_kg_m3: the material;
    damping_ratio: modal damping of every retained mode; elements: finite elements along
    the overhang."""

    diameter_m: float
    overhang_m: float
    young_pa: float
    density_kg_m3: float
    damping_ratio: float
    elements: int = 8

    def __post_init__(self):
        for name in ("diameter_m", "overhang_m", "young_pa", "density_kg_m3"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0")
        if not 0 < self.damping_ratio < 1:
            raise ValueError("damping_ratio must be in (0, 1)")
        if self.elements < 1:
            raise ValueError("elements must be >= 1")

    @property
    def area_m2(self) -> float:
        return math.pi * self.diameter_m ** 2 / 4

    @property
    def second_moment_m4(self) -> float:
        return math.pi * self.diameter_m ** 4 / 64

    def plane_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """(M, K) of one bending plane, clamped DOFs removed. DOFs per node: deflection (m),
        slope (rad), node 1 next to the holder, the last node at the tip."""
        n, el = self.elements, self.overhang_m / self.elements
        ei, rho_a = self.young_pa * self.second_moment_m4, self.density_kg_m3 * self.area_m2
        k_e = ei / el ** 3 * np.array([[12, 6 * el, -12, 6 * el], [6 * el, 4 * el ** 2, -6 * el, 2 * el ** 2],
                                       [-12, -6 * el, 12, -6 * el], [6 * el, 2 * el ** 2, -6 * el, 4 * el ** 2]])
        m_e = rho_a * el / 420 * np.array([[156, 22 * el, 54, -13 * el], [22 * el, 4 * el ** 2, 13 * el, -3 * el ** 2],
                                           [54, 13 * el, 156, -22 * el],
                                           [-13 * el, -3 * el ** 2, -22 * el, 4 * el ** 2]])
        size = 2 * (n + 1)
        mass, stiffness = np.zeros((size, size)), np.zeros((size, size))
        for e in range(n):
            dofs = slice(2 * e, 2 * e + 4)
            mass[dofs, dofs] += m_e
            stiffness[dofs, dofs] += k_e
        return mass[2:, 2:], stiffness[2:, 2:]  # node 0 clamped: deflection and slope zero

    def modes(self, count: int) -> "ToolModes":
        """The ``count`` lowest bending modes of one plane, mass-normalized, at the tip."""
        mass, stiffness = self.plane_matrices()
        if not 1 <= count <= mass.shape[0]:
            raise ValueError(f"count must be in 1..{mass.shape[0]}")
        eigenvalues, shapes = eigh(stiffness, mass, subset_by_index=(0, count - 1))
        return ToolModes(np.sqrt(eigenvalues), np.full(count, self.damping_ratio), shapes[-2, :].copy())


@dataclass(frozen=True)
class ToolModes:
    """Modal model of one bending plane: natural angular frequencies (rad/s), damping
    ratios, and the mass-normalized mode shapes' tip deflections (m/sqrt(kg))."""

    omega_rad_s: np.ndarray
    damping: np.ndarray
    tip_shape: np.ndarray

    def tip_frf(self, omega_rad_s) -> np.ndarray:
        """Tip receptance G(i w) = sum_r phi_r^2 / (w_r^2 - w^2 + 2 i zeta_r w_r w), in m/N."""
        w = np.asarray(omega_rad_s, float)[..., None]
        return np.sum(self.tip_shape ** 2 / (self.omega_rad_s ** 2 - w ** 2
                                            + 2j * self.damping * self.omega_rad_s * w), axis=-1)

    @property
    def tip_stiffness_n_m(self) -> float:
        """Static tip stiffness of the retained modes, 1/G(0)."""
        return float(1 / np.sum(self.tip_shape ** 2 / self.omega_rad_s ** 2))
