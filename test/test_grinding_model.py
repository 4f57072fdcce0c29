"""Static and stochastic grinding model (seed 002 section 4.2, eq. 4.4-4.10, Table 4-1)."""

import math

import numpy as np
import pytest

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.stochastic import CutDepthModel, rayleigh_parameters

TYPICAL = GrindingProcess()  # section 5.5: K1 10 J/mm^3, K2 100 W, w 12.5, R 85, omega 500, mu 0.3


def test_typical_coefficients_and_the_printed_ones():
    """Section 5.5 prints C1 = 1e-4 mm^2/N, C2 = -0.8 mm^2/s, C3 = 1e-3 1/s. C1 and C2 follow
    from K1, K2, w; C3 does not: eq. 4.5 needs C1 C3 = mu R omega/(w K1), i.e. C3 = 1020 1/s."""
    assert TYPICAL.c1 == pytest.approx(1e-4)
    assert TYPICAL.c2 == pytest.approx(-0.8)
    assert TYPICAL.c3() == pytest.approx(1020.0)
    assert TYPICAL.c3() != pytest.approx(1e-3)


def test_cut_depth_is_eq_4_5_and_never_negative():
    force, feed = np.array([5.0, 20.0, 60.0]), np.array([10.0, 10.0, 25.0])
    k1_nmm = TYPICAL.specific_energy_j_mm3 * 1000  # J/mm^3 -> N mm/mm^3
    direct = (TYPICAL.disk_speed_rad_s * TYPICAL.disk_radius_mm * TYPICAL.friction_coefficient * force
              - TYPICAL.wasted_power_w * 1000) / (k1_nmm * TYPICAL.bead_width_mm * feed)
    np.testing.assert_allclose(TYPICAL.cut_depth_mm(force, feed), np.maximum(direct, 0.0), rtol=1e-12)
    assert TYPICAL.cut_depth_mm(TYPICAL.zero_cut_force_n(), 10.0) == pytest.approx(0.0, abs=1e-12)
    assert TYPICAL.cut_depth_mm(50.0, 10.0) == pytest.approx(0.43)


def test_air_motor_slows_the_disk_and_the_cut():
    """Eq. 4.8: omega = omega_0 - beta R F_t lowers the cut depth at a given force."""
    motor = GrindingProcess(motor_beta_rad_s_per_n_mm=0.005)
    assert motor.disk_speed(60.0) == pytest.approx(500 - 0.005 * 85 * 0.3 * 60)
    assert motor.cut_depth_mm(60.0, 10.0) < TYPICAL.cut_depth_mm(60.0, 10.0)
    assert motor.cut_depth_mm(motor.zero_cut_force_n(), 10.0) == pytest.approx(0.0, abs=1e-9)


def test_the_force_of_a_removal_numerator_inverts_eq_4_6_on_its_rising_branch():
    """F_N from C1 C3 F_N + C2 (the planners' depth times feed), closed form, against
    scipy's brentq on the rising branch; with the motor's drop (eq. 4.8) and without it; the
    zero-cut force at a numerator of 0; beyond the peak of the quadratic, no force."""
    from scipy.optimize import brentq

    for process in (TYPICAL, GrindingProcess(motor_beta_rad_s_per_n_mm=0.005),
                    GrindingProcess(motor_beta_rad_s_per_n_mm=0.05)):
        zero_cut = process.zero_cut_force_n()
        assert process.force_for_numerator_n(0.0) == pytest.approx(zero_cut, rel=1e-12)
        for force in (zero_cut + 0.1, 20.0, 45.0, 60.0):
            wanted = float(process.removal_numerator(force))
            solved = process.force_for_numerator_n(wanted)
            assert solved == pytest.approx(force, rel=1e-12)
            assert solved == pytest.approx(brentq(lambda f, w=wanted, p=process: float(p.removal_numerator(f)) - w,
                                                  zero_cut, 60.0 + 1e-9), rel=1e-10)
    stalling = GrindingProcess(motor_beta_rad_s_per_n_mm=0.05)  # its numerator peaks at F = omega_0 / (2 beta R mu)
    peak = float(stalling.removal_numerator(stalling.disk_speed_rad_s / (2 * 0.05 * stalling.disk_radius_mm
                                                                          * stalling.friction_coefficient)))
    with pytest.raises(ValueError, match="beyond the numerator's peak"):
        stalling.force_for_numerator_n(peak * 1.01)


def test_constraints():
    burn = GrindingProcess(burn_coefficient=10.0, max_power_w=800.0)
    assert burn.feasible(30.0, 9.0) and not burn.feasible(31.0, 9.0)  # F <= C_B sqrt(V) (5.11)
    assert not burn.feasible(60.0, 75.0)  # 765 W > 80 % of 800 W (stall margin, 6.6)
    assert not TYPICAL.feasible(61.0, 20.0) and not TYPICAL.feasible(30.0, 80.0)
    with pytest.raises(ValueError):
        GrindingProcess(bead_width_mm=-1.0)
    with pytest.raises(ValueError, match="removes no material"):
        GrindingProcess(force_max_n=5.0)


@pytest.mark.parametrize("source", ["c1", "c2", "mu"])
def test_cut_depth_spread_eq_4_9(source):
    """sigma_delta from eq. 4.9a-c equals the first-order change of delta under a change of
    the varying coefficient by its standard deviation."""
    model = CutDepthModel(source=source, relative_variation=0.1)
    force, feed, r = 40.0, 20.0, 1e-6
    base = TYPICAL.cut_depth_mm(force, feed)
    if source == "c1":
        bumped = GrindingProcess(specific_energy_j_mm3=TYPICAL.specific_energy_j_mm3 / (1 + r))
        shifted = bumped.cut_depth_mm(force, feed) - (bumped.c2 - TYPICAL.c2) / feed  # C1 only
    elif source == "c2":
        shifted = base + abs(TYPICAL.c2) * r / feed
    else:
        shifted = GrindingProcess(friction_coefficient=0.3 * (1 + r)).cut_depth_mm(force, feed)
    assert model.std_mm(TYPICAL, force, feed) == pytest.approx(abs(shifted - base) / r * 0.1, rel=1e-5)


U = (np.arange(40_000) + 0.5) / 40_000  # equal-probability points


@pytest.mark.parametrize("pdf", ["normal", "lognormal", "rayleigh"])
def test_pdfs_have_the_requested_mean_and_variance(pdf):
    """Table 4-1 shapes with the mean and standard deviation the model asks for."""
    nodes = CutDepthModel(pdf=pdf).ppf(0.4, 0.06, U)
    assert nodes.mean() == pytest.approx(0.4, rel=2e-3)
    assert nodes.std() == pytest.approx(0.06, rel=2e-2)
    if pdf != "normal":
        assert nodes.min() >= 0.0


def test_rayleigh_shift_or_scale_rule():
    """Section 4.2: shift a Rayleigh of the right variance to the mean where possible; where
    that would need a shift to negative depths, scale it to the mean (variance then tied)."""
    sigma, shift = rayleigh_parameters(0.4, 0.06)
    assert shift > 0 and sigma == pytest.approx(0.06 / math.sqrt(2 - math.pi / 2))
    sigma, shift = rayleigh_parameters(0.02, 0.06)
    assert shift == 0 and sigma * math.sqrt(math.pi / 2) == pytest.approx(0.02)
    small = CutDepthModel().ppf(0.02, 0.06, U)
    assert small.mean() == pytest.approx(0.02, rel=2e-3) and small.std() < 0.06


@pytest.mark.parametrize("pdf", ["normal", "lognormal", "rayleigh"])
@pytest.mark.parametrize("mean, std", [(0.4, 0.06), (0.02, 0.06), (0.05, 0.0)])
def test_the_integrated_cdf_is_the_expected_shortfall(pdf, mean, std):
    """G(a) = E[(a - delta)+], checked against the quantile function integrated numerically;
    its slope is the CDF (G(ppf(u))' = u) and it tends to a - mean far right."""
    model = CutDepthModel(pdf=pdf)
    depths = model.ppf(mean, std, U)
    for a in (-0.1, 0.0, mean - std, mean, mean + 2 * std, mean + 8 * std + 0.01):
        shortfall = np.mean(np.maximum(a - depths, 0.0))
        assert model.integrated_cdf(mean, std, a) == pytest.approx(shortfall, rel=1e-3, abs=1e-7)
    if std > 0:
        for u in (0.1, 0.5, 0.9):
            a, h = model.ppf(mean, std, u), 1e-6
            slope = (model.integrated_cdf(mean, std, a + h) - model.integrated_cdf(mean, std, a - h)) / (2 * h)
            assert slope == pytest.approx(u, abs=1e-4)
    far = mean + 50 * max(std, 0.01)  # the log-normal of cv 3 still has 1e-5 of its shortfall beyond
    assert model.integrated_cdf(mean, std, far) == pytest.approx(far - mean, rel=1e-4)
