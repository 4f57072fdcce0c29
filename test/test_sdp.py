"""Sequence planner by stochastic dynamic programming (seed 002 chapter 5)."""

import itertools
import math

import numpy as np
import pytest

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.penalties import DeadlineCharge, InPathCharges, LatenessCharge, SideCharge
from hex_control.grinding.sdp import (
    GRIND,
    QUIT,
    ROUNDING,
    WAIT,
    Charges,
    CutCorrelation,
    PlannerGrid,
    Policy,
    build_controls,
    feed_values,
    solve,
)
from hex_control.grinding.sdp_reference import solve_reference
from hex_control.grinding.stochastic import CutDepthModel

PROCESS = GrindingProcess()  # L = 300 mm, t_R = 2 s, V_max = 75 mm/s: shortest pass 6 s
SHORTEST_S = 6.0
POLICY = solve(PROCESS)
X = POLICY.material_mm


def stage(t):
    return POLICY.stage_index(t)


def column(x):
    return int(np.argmin(np.abs(X - x)))


def test_zero_material_costs_nothing_at_every_time():
    """Section 5.4: J(t, 0 mm) = 0 for all t (wait for the deadline inside the tolerance)."""
    assert np.all(POLICY.penalty[:, column(0.0)] == 0.0)


def test_no_grinding_when_overground():
    """Section 5.4, 'Already Overground': grinding cannot help; J(t, X<0) = C(X) at all t."""
    over = X < 0
    assert np.all(POLICY.action[:, over] == WAIT)
    np.testing.assert_array_equal(POLICY.penalty[:, over], np.broadcast_to(Charges().deadline(X[over]),
                                                                           POLICY.penalty[:, over].shape))


def test_no_grind_band_before_the_deadline():
    """Section 5.4 / Fig. 5-21: no pass starts within one shortest pass of the deadline."""
    for k in range(stage(SHORTEST_S)):
        assert np.all(POLICY.action[k] == WAIT)
        np.testing.assert_allclose(POLICY.penalty[k], Charges().deadline(X))
    assert POLICY.action[stage(SHORTEST_S), column(0.5)] == GRIND


def test_time_bands_one_shortest_pass_wide():
    """Fig. 5-21/5-24: below the max-force threshold J is constant in time within a band of
    width equal to the shortest pass, and drops from one band to the next."""
    x = column(0.08)
    bands = [POLICY.penalty[stage(t), x] for t in (6, 8, 10, 12, 14, 16)]
    assert bands[0] == bands[1] == bands[2]
    assert bands[3] == bands[4] == bands[5]
    assert bands[3] < bands[0]


def test_near_constant_cut_fraction_with_the_fastest_feed_below_the_threshold():
    """Section 5.4 rules 1-3: below the max-force threshold the optimal cut is a near-constant
    fraction of the material, taken with the fastest feed, smaller with more time remaining
    (the thesis: 57 % in the band nearest the deadline, perhaps 49 % in the next; here 60 %
    and 54 % with these charges and 15 % variation of C1). From 2.5 tolerances above the
    target: nearer, the second-order effects of Fig. 5-19 lower the fraction."""
    below = (X > 0.045) & (X < 0.105)
    fractions = []
    for t in (6.0, 12.0, 18.0):
        row = stage(t)
        assert np.all(POLICY.feed_mm_s[row, below] == PROCESS.feed_max_mm_s)
        fraction = POLICY.cut_fraction[row, below]
        assert np.std(fraction) < 0.05
        fractions.append(np.mean(fraction))
    assert 0.5 < fractions[0] < 0.65 and 0.45 < fractions[1] < 0.6
    assert fractions[0] >= fractions[1] >= fractions[2]


def test_maximum_force_above_the_threshold_and_passes_timed_to_the_deadline():
    """Rules 4-5: where the target cannot be reached, grind with the maximum force; where a
    single pass can end at the deadline, time it to end there."""
    durations = sorted(set(POLICY.pass_duration_s[~np.isnan(POLICY.pass_duration_s)]))
    for t in durations[:-1]:
        for x in (1.5, 1.9):
            k, i = stage(t), column(x)
            assert POLICY.action[k, i] == GRIND
            assert POLICY.force_n[k, i] == PROCESS.force_max_n
            assert POLICY.pass_duration_s[k, i] == t  # the pass ends exactly at the deadline


def test_convexity_of_time_slices_and_where_the_model_breaks_it():
    """Section 5.4 claims every time slice of J is convex for a convex deadline charge. That
    holds when the cut-depth noise scales with the cut ('independence of dimension', the
    thesis's footnote): then the only violations come from the discrete force grid and
    shrink as it is refined. With eq. 4.9a the noise is proportional to the force, so the
    smallest pass keeps a noise floor that waiting does not have, and J is concave just
    above X = 0 whatever the grid (checked in the simple formulation, one pass per stage;
    the left edge, where X - delta is clamped to the grid, excluded)."""
    charges = Charges(deadline=DeadlineCharge(SideCharge("linear", 10.0), SideCharge("linear", 2.0), 0.0))
    process = GrindingProcess(feed_min_mm_s=75.0)

    def worst(source, forces):
        grid = PlannerGrid(time_step_s=6.0, horizon_s=60.0, forces=forces, feeds=1)
        policy = solve(process, charges, grid, CutDepthModel(source=source, pdf="normal"))
        inner = policy.material_mm > -0.5
        second = np.diff(policy.penalty[:, inner], 2, axis=1)
        return second.min(), policy.material_mm[inner][1:-1][np.any(second < -1e-9, axis=0)]

    coarse, _ = worst("cut", 64)
    fine, _ = worst("cut", 256)
    assert fine > -5e-5 and fine > coarse / 5
    floor, where = worst("c1", 256)
    assert floor < -2e-3 and where.max() < 0.25


def test_quit_after_the_deadline_and_one_late_pass_under_expensive_time():
    """Section 5.5 with $1/mm and $1/s (expensive time): after the deadline the underground
    region quits at once (Fig. 5-28); just before it, with much material, one pass at maximum
    force and feed finishes a little late (Fig. 5-29)."""
    # $1/mm of material, $0.03/s of lateness: iso-charge slope 33 s/mm, below the 56 s/mm of
    # the maximum-force boundary (eq. 5.7 here), so time is expensive; the slightly-late band
    # is where (6 s - t) * 0.03 < 0.07 mm * 1, i.e. t > 3.7 s
    charges = Charges(deadline=DeadlineCharge(SideCharge("linear", 5.0), SideCharge("linear", 1.0), 0.02),
                      lateness=LatenessCharge(SideCharge("linear", 0.03)))
    policy = solve(PROCESS, charges, PlannerGrid(late_horizon_s=30.0))
    x = policy.material_mm
    for t in (-2.0, -10.0, -20.0):
        assert np.all(policy.action[policy.stage_index(t), x > 0.02] == QUIT)
    assert np.all(policy.action[policy.stage_index(2.0), x > 0.02] == QUIT)
    k = policy.stage_index(4.0)
    heavy = x > 1.0
    assert np.all(policy.action[k, heavy] == GRIND)
    assert np.all(policy.force_n[k, heavy] == PROCESS.force_max_n)
    assert np.all(policy.feed_mm_s[k, heavy] == PROCESS.feed_max_mm_s)


def test_burn_constraint_lowers_the_maximum_cut_and_binds():
    """Section 5.6: with F_N <= C_B sqrt(V_f) the deepest cut is smaller, and where the policy
    grinds at a feed below (F_max / C_B)^2 its force sits on the burn curve (within one step
    of the force grid)."""
    burn = GrindingProcess(burn_coefficient=9.0)
    with_burn = solve(burn)
    assert np.nanmax(with_burn.cut_mm) < 0.2 * np.nanmax(POLICY.cut_mm)
    slow = with_burn.feed_mm_s < (burn.force_max_n / 9.0) ** 2
    assert slow.sum() > 100
    limit = 9.0 * np.sqrt(with_burn.feed_mm_s[slow])
    force = with_burn.force_n[slow]
    step = (burn.force_max_n - burn.zero_cut_force_n()) / 32
    assert np.all(force <= limit + 1e-9)
    heavy = slow & (X[None, :] > 1.0)
    assert np.all(with_burn.force_n[heavy] > 9.0 * np.sqrt(with_burn.feed_mm_s[heavy]) - step - 1e-9)


@pytest.mark.parametrize("late_horizon_s, per_pass, finish", [(0.0, 0.0, 0.0), (20.0, 0.01, 0.0), (0.0, 0.0, 3.0)])
def test_agrees_with_brute_force_backward_induction(late_horizon_s, per_pass, finish):
    """Independent plain-loop induction (same grid, controls, transition weights): 1e-9."""
    grid = PlannerGrid(material_min_mm=-0.5, material_max_mm=1.5, material_states=41, horizon_s=40.0,
                       late_horizon_s=late_horizon_s, forces=6, feeds=4)
    charges = Charges(in_path=InPathCharges(per_pass=per_pass, surface_finish_per_mm_s=finish))
    policy = solve(PROCESS, charges, grid)
    penalty, action = solve_reference(PROCESS, charges, grid, CutDepthModel())
    np.testing.assert_allclose(policy.penalty, penalty, atol=1e-9)
    np.testing.assert_array_equal(policy.action, action)


def test_the_fft_correlation_is_the_direct_sum_to_rounding():
    """The expectation over the cut (eq. 5.3) by FFT against the same sums taken directly
    (J held at its end values beyond the grid), on the benchmark grid's controls (kernels up
    to 282 nodes wide on 300 states) and rows spanning 1e-6 to 1e3: within ROUNDING."""
    grid = PlannerGrid(material_states=300, horizon_s=598.0, forces=32, feeds=8)
    n_x = len(grid.material_mm)
    correlation = CutCorrelation.of(build_controls(PROCESS, grid, CutDepthModel()), CutDepthModel(),
                                    grid.material_step_mm, n_x)
    rows = np.sort(10.0 ** np.random.default_rng(1).uniform(-6, 3, (4, n_x)), axis=1)
    spectra = correlation.spectra(rows)
    for v, (low, kernel) in enumerate(correlation.kernels):
        after = np.clip(np.arange(n_x)[:, None] - (low + np.arange(kernel.shape[1]))[None, :], 0, n_x - 1)
        direct = np.einsum("rik,fk->rfi", rows[:, after], kernel)
        np.testing.assert_allclose(correlation(spectra[v], v), direct, rtol=0, atol=0.1 * ROUNDING * rows.max())


def test_the_policy_does_not_change_when_every_charge_is_scaled():
    """Scaling every charge scales J and leaves the argmin alone. Controls that tie exactly
    -- the same passes in another order, under the linear charge -- are told apart only by
    rounding; the tie rule (lowest force, fastest feed within ROUNDING) keeps that noise out
    of the policy. Before it, 270 feed choices of the shipped policy flipped at scale 3."""
    import copy

    import yaml

    from hex_control.config import config_file
    from hex_control.grinding.config import parse_planner_config

    config = yaml.safe_load(config_file("sequence_planner.yaml").read_text())
    policies = []
    for scale in (1.0, 3.0):
        scaled = copy.deepcopy(config)
        charges = scaled["charges"]
        for side in ("over", "under"):
            charges["deadline"][side]["coefficient"] *= scale
        charges["lateness"]["coefficient"] *= scale
        process, charges, grid, cut_model = parse_planner_config(scaled)
        policies.append(solve(process, charges, grid, cut_model))
    one, three = policies
    np.testing.assert_allclose(three.penalty, 3 * one.penalty, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(three.action, one.action)
    np.testing.assert_array_equal(three.force_n, one.force_n)
    np.testing.assert_array_equal(three.feed_mm_s, one.feed_mm_s)
    assert np.count_nonzero(one.action == GRIND) > 1000


def test_surface_finish_charge_slows_the_last_pass():
    """The in-path charge the thesis proposed (section 5.4): a finishing pass is charged in
    proportion to its feed, so the last passes slow down."""
    finishing = solve(PROCESS, Charges(in_path=InPathCharges(surface_finish_per_mm_s=0.002)))
    k, i = stage(14.0), column(0.06)
    assert finishing.feed_mm_s[k, i] < POLICY.feed_mm_s[k, i]


def test_lookup_and_save_load(tmp_path):
    decision = POLICY.lookup(13.3, 0.5)
    assert decision["stage_time_s"] == 12.0 and decision["action"] == "grind"
    between = POLICY.lookup(12.0, 0.075)
    lo, hi = POLICY.force_n[stage(12.0), column(0.07)], POLICY.force_n[stage(12.0), column(0.08)]
    assert min(lo, hi) <= between["force_n"] <= max(lo, hi)
    path = tmp_path / "policy.npz"
    POLICY.save(path)
    loaded = Policy.load(path)
    np.testing.assert_array_equal(loaded.penalty, POLICY.penalty)
    assert loaded.metadata["process"]["bead_length_mm"] == 300.0
    with pytest.raises(ValueError):
        POLICY.lookup(math.nan, 0.1)


def test_a_grid_grows_at_its_own_steps_to_hold_the_start_state():
    grid = PlannerGrid(material_min_mm=-1.0, material_max_mm=2.0, material_states=301, horizon_s=120.0)
    assert grid.covering(60.0, 1.5) is grid
    grown = grid.covering(243.0, 3.456)
    assert grown.horizon_s == 244.0 and grown.time_step_s == grid.time_step_s
    assert grown.material_step_mm == pytest.approx(grid.material_step_mm, rel=1e-12)
    assert grown.material_max_mm == pytest.approx(3.47) and grown.material_states == 448
    np.testing.assert_allclose(grown.material_mm[:301], grid.material_mm, atol=1e-12)  # same nodes, more of them


def test_bad_configurations_are_refused():
    with pytest.raises(ValueError):
        PlannerGrid(material_min_mm=0.5)
    with pytest.raises(ValueError):
        CutDepthModel(pdf="uniform")
    with pytest.raises(ValueError):
        SideCharge("cubic", 1.0)


@pytest.mark.parametrize("t0, x0", [(40.0, 1.0), (60.0, 1.5), (20.0, 0.5)])
def test_monte_carlo_jobs_cost_what_the_policy_expects(t0, x0):
    """2000 simulated jobs driven by the table (feedback, Fig. 5-7) against the same process
    model: mean total charge = J(t0, X0) within 3 standard errors plus the interpolation
    error of the lookup between material nodes. That error was 0.02 on the 301-state grid
    (the MC mean moved by that much on a 4x finer grid); linear interpolation error scales
    with h^2, so on this 1201-state grid it is below 0.005."""
    from hex_control.grinding.rollout import run_job

    policy = solve(PROCESS, Charges(), PlannerGrid(material_states=1201))
    rng = np.random.default_rng(1)
    charges = np.array([run_job(policy, PROCESS, Charges(), CutDepthModel(), t0, material_mm=x0, rng=rng).total_charge
                        for _ in range(2000)])
    standard_error = charges.std() / math.sqrt(len(charges))
    assert abs(charges.mean() - policy.expected_penalty(t0, x0)) < 3 * standard_error + 0.005


def test_the_shipped_planner_expects_what_its_jobs_cost():
    """The shipped configuration at the demo's start state (150 mm bead, 60 s, 0.936 mm,
    t_R 4.2 s): 3000 jobs simulated on the planner's own model cost J(t0, X0) within
    3 standard errors plus the lookup's interpolation error (0.02 on a 301-state grid, as
    above; 10 000 jobs: J 0.0067, cost 0.018 +- 0.003; on 601 states 0.0080 against
    0.011 +- 0.002 at 5-10x the solve time). With a 32-node quadrature of the cut PDF
    J was 0.0005 and the jobs cost 0.21 +- 0.01."""
    import dataclasses

    from hex_control.config import config_file
    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.rollout import run_job

    process, charges, grid, cut_model = load_planner_config(config_file("sequence_planner.yaml"))
    process = dataclasses.replace(process, bead_length_mm=150.0, reset_time_s=4.2)
    t0, x0 = 60.0, 0.936
    policy = solve(process, charges, grid.covering(t0, x0), cut_model)
    rng = np.random.default_rng(1)
    costs = np.array([run_job(policy, process, charges, cut_model, t0, material_mm=x0,
                              rng=rng).total_charge for _ in range(3000)])
    standard_error = costs.std() / math.sqrt(len(costs))
    assert abs(costs.mean() - policy.expected_penalty(t0, x0)) < 3 * standard_error + 0.02


def test_rule_5_where_it_applies_and_the_seeds_indifference_where_it_does_not():
    """Section 5.4 rule 5 (far from the target: maximum force, slowest feed), checked at
    X = 1.9 mm. There the policy holds the maximum force at every stage, but its feed is
    10.7 / 15 / 5 / 8.3 mm/s at t = 60 / 80 / 100 / 118 s, the slowest only at 100 s. The
    reasons are the thesis's own words on Fig. 5-20:
    - t = 100 s: unreachable (the two longest passes that fit remove 1.70 mm), and no single
      pass ends at the deadline: rule 5, slowest feed.
    - t = 60 and 80 s: the sub-region where "the planner is almost indifferent to the choice
      of feedspeed". The feeds' expected penalties lie within 0.1 % of each other, and the
      tie rule takes the first of them.
    - t = 118 s: the 62 s and 54 s passes remove 1.99 mm > 1.9 mm, so the target is
      reachable. Rules 1-2 apply, not rule 5."""
    controls = build_controls(PROCESS, PlannerGrid(), CutDepthModel())
    slowest = len(controls.feeds_mm_s) - 1
    for t in (60.0, 80.0, 100.0, 118.0):
        assert POLICY.force_n[stage(t), column(1.9)] == PROCESS.force_max_n
    assert POLICY.feed_mm_s[stage(100.0), column(1.9)] == pytest.approx(controls.feeds_mm_s[slowest])
    for t in (60.0, 80.0):
        values = feed_values(POLICY, controls, CutDepthModel(), t, 1.9)
        assert np.nanmax(values) - np.nanmin(values) < 1e-3 * POLICY.penalty[stage(t), column(1.9)]
    values = feed_values(POLICY, controls, CutDepthModel(), 100.0, 1.9)  # not indifferent: slowest by far
    assert np.nanargmin(values) == slowest and np.nanmax(values) > 1.1 * np.nanmin(values)
    durations_s = controls.duration_stages * PlannerGrid().time_step_s
    depths_mm = PROCESS.cut_depth_mm(PROCESS.force_max_n, controls.feeds_mm_s)

    def most_removed_mm(t):  # the deepest mean removal of up to three passes that fit in t
        best = 0.0
        for passes in itertools.product(range(-1, len(durations_s)), repeat=3):
            chosen = [p for p in passes if p >= 0]
            if sum(durations_s[chosen]) <= t:
                best = max(best, float(sum(depths_mm[chosen])))
        return best

    assert most_removed_mm(100.0) == pytest.approx(1.70, abs=0.01)
    assert most_removed_mm(118.0) == pytest.approx(1.99, abs=0.01)
