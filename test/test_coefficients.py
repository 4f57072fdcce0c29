"""Process-coefficient estimation (seed 002 section 6.5) and the per-pass model update."""

import numpy as np
import pytest

from hex_control.grinding.coefficients import (
    PassModelUpdate,
    achievable_mean_force_n,
    fit_power_law,
    measured_specific_energy,
)
from hex_control.grinding.model import GrindingProcess


def test_least_squares_recovers_k1_k2_within_their_standard_errors():
    """Synthetic pairs around the thesis's fit (K1 = 12.8 J/mm^3, K2 = 114 W) with noise
    giving a correlation near its 0.81."""
    rng = np.random.default_rng(0)
    q = rng.uniform(5, 60, 40)
    power = 12.8 * q + 114 + rng.normal(0, 110, q.size)
    fit = fit_power_law(q, power)
    assert abs(fit.specific_energy_j_mm3 - 12.8) < 4 * fit.specific_energy_se
    assert abs(fit.wasted_power_w - 114) < 4 * fit.wasted_power_se
    assert 0.7 < fit.correlation < 0.95
    with pytest.raises(ValueError):
        fit_power_law([1, 1, 1], [2, 3, 4])


def test_a_measured_cut_gives_back_k1():
    process = GrindingProcess()
    cut = process.cut_depth_mm(40.0, 20.0)
    assert measured_specific_energy(process, 40.0, 20.0, cut) == pytest.approx(10.0)
    dull = GrindingProcess(specific_energy_j_mm3=13.0)
    assert measured_specific_energy(process, 40.0, 20.0, dull.cut_depth_mm(40.0, 20.0)) == pytest.approx(13.0)


def test_re_solve_only_when_the_estimate_moves():
    update = PassModelUpdate(GrindingProcess(), threshold=0.05)
    assert not update.observe(10.3)
    assert update.observe(10.8)
    update.mark_solved()
    assert not update.observe(11.0) and update.process.specific_energy_j_mm3 == 11.0
    with pytest.raises(ValueError):
        update.observe(float("nan"))


@pytest.mark.parametrize("estimate, plausible", [(10.0, True), (1.0, True), (100.0, True), (30.0, True),
                                                 (0.99, False), (101.0, False), (1e300, False), (5e-324, False),
                                                 (0.0, False), (-10.0, False), (float("inf"), False)])
def test_an_estimate_beyond_ten_times_the_nominal_k1_is_refused(estimate, plausible):
    update = PassModelUpdate(GrindingProcess(specific_energy_j_mm3=10.0))
    assert update.plausible(estimate) is plausible
    if not plausible:
        with pytest.raises(ValueError, match="nominal 10"):
            update.observe(estimate)
        assert update.process.specific_energy_j_mm3 == 10.0


def test_a_restored_update_is_where_it_was_logged():
    """A restarted planner: the latest estimate for the cuts, the solved K1 for the policy."""
    update = PassModelUpdate(GrindingProcess(specific_energy_j_mm3=10.0), threshold=0.05)
    update.restore(12.3, 12.0)
    assert update.process.specific_energy_j_mm3 == 12.3 and update.solved_with == 12.0
    assert update.solved_process.specific_energy_j_mm3 == 12.0 and update.nominal == 10.0
    assert not update.observe(12.5) and update.observe(12.7)  # threshold against the solved 12.0


def test_the_force_a_guarded_plan_reaches_is_the_one_that_cuts_its_planned_depth():
    """Issue 20 item 4: a plan whose force guard cut the commanded depth to 76 % (the first
    pass of the 20 seeded jobs at 60 N, 9.8 mm/s) reaches the force that cuts 76 % as deep
    in eq. 4.6; a plan that peaks below F_max could take F_max / peak times more."""
    process = GrindingProcess()
    wanted = process.cut_depth_mm(60.0, 9.8)
    guarded = achievable_mean_force_n(process, 60.0, wanted, 0.76 * wanted, 60.0)
    assert process.cut_depth_mm(guarded, 9.8) == pytest.approx(0.76 * wanted, rel=1e-9)
    zero_cut = process.zero_cut_force_n()
    assert guarded == pytest.approx(zero_cut + 0.76 * (60.0 - zero_cut), rel=1e-9)  # linear for beta = 0
    assert achievable_mean_force_n(process, 30.0, 0.1, 0.1, 40.0) == pytest.approx(45.0)
    assert achievable_mean_force_n(process, 30.0, 0.1, 0.1, 20.0) == 60.0  # never beyond F_max
    assert achievable_mean_force_n(process, 30.0, 0.1, -0.01, 40.0) == pytest.approx(zero_cut * 1.5)
    with pytest.raises(ValueError):
        achievable_mean_force_n(process, 30.0, 0.1, 0.1, float("nan"))


def test_the_force_limit_triggers_a_re_solve_and_is_solved_with():
    update = PassModelUpdate(GrindingProcess(force_max_n=60.0), threshold=0.05)
    assert not update.observe_force_limit(58.0)
    assert update.observe_force_limit(50.0) and update.process.force_max_n == 50.0
    assert update.solved_process.force_max_n == 60.0
    update.mark_solved()
    assert update.solved_process.force_max_n == 50.0 and not update.needs_solve
    assert not update.observe(10.2)  # K1 alone has not moved enough
    update.observe_force_limit(90.0)
    assert update.process.force_max_n == 60.0  # F_max is the machine's
    update.observe_force_limit(1.0)
    zero_cut = update.process.zero_cut_force_n()
    assert update.process.force_max_n == pytest.approx(zero_cut + 0.5 * (60.0 - zero_cut))
    restored = PassModelUpdate(GrindingProcess(force_max_n=60.0), threshold=0.05)
    restored.restore(10.4, 10.0, 48.0, 50.0)
    assert restored.solved_process.force_max_n == 50.0 and restored.process.force_max_n == 48.0
    assert restored.process.specific_energy_j_mm3 == 10.4 and not restored.needs_solve


def test_a_plan_is_read_against_the_machines_f_max_not_the_policys_limit():
    """After a guarded plan lowered the policy's limit to about 47 N, a plan at that force
    peaking at the machine's 60 N says the same 47 N, not 47 * 47/60 (a bug seen on the
    seeded jobs: the limit fell pass by pass to its floor)."""
    update = PassModelUpdate(GrindingProcess(force_max_n=60.0))
    process = update.process
    update.observe_plan(60.0, 0.5, 0.38, 60.0)
    limit = update.process.force_max_n
    assert limit == pytest.approx(achievable_mean_force_n(process, 60.0, 0.5, 0.38, 60.0)) and limit < 50.0
    update.observe_plan(limit, 0.2, 0.2, 60.0)
    assert update.process.force_max_n == pytest.approx(limit)
