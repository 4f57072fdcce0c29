"""The dynamic grinding model (seed 002 6.4-6.5) and the pass planner (6.6, 8.3 item 3)."""

import dataclasses
import math

import numpy as np
import pytest

from hex_control.grinding.contour import final_contour, weld_bead
from hex_control.grinding.dynamic import DiskModel, ForceSchedule, HeightControl, simulate_pass
from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.pass_plan import (
    Compliance,
    PlanningError,
    SearchStart,
    execute_plan,
    force_for_power,
    plan_pass,
    plan_pass_static,
    typical_search_start,
)
from hex_control.grinding.variation import ProcessVariation

MODEL = DiskModel()
BEAD = weld_bead(length_mm=80.0, height_mm=3.0, ripple_mm=0.15, seed=3)
FLAT = weld_bead(length_mm=80.0, height_mm=3.0, ripple_mm=0.0)


def _with_energy(model, factor):
    process = model.process
    return dataclasses.replace(model, process=dataclasses.replace(
        process, specific_energy_j_mm3=process.specific_energy_j_mm3 * factor))


def _middle(history, low=30.0, high=55.0):
    return (history["tip_x_mm"] > low) & (history["tip_x_mm"] < high)


@pytest.fixture(scope="module")
def plan():
    return plan_pass(BEAD, MODEL, 0.3, 7.5)  # a level top within F_max (56 N at most)


@pytest.mark.parametrize("beta", [0.0, 0.02])
def test_steady_state_cut_matches_the_static_model(beta):
    """A constant force on a flat bead: the dynamic model's steady cut depth is eq. 4.5's
    (the two tiers of the hierarchy agree); with the air motor (beta > 0) as well."""
    model = dataclasses.replace(MODEL, process=dataclasses.replace(MODEL.process, motor_beta_rad_s_per_n_mm=beta))
    force, feed = 50.0, 10.0
    start_angle = model.relaxed_angle_rad
    height = FLAT.z_mm.max() - 0.3 + model.radius_mm * math.sin(start_angle)
    centre = np.array([0.0, 500.0])
    drive = ForceSchedule(model, centre, np.full(2, height), np.full(2, force), start_angle)
    sim = simulate_pass(FLAT, model, drive, feed)
    x = np.linspace(35.0, 60.0, 200)
    cut = float(np.mean(FLAT.height_at(x) - sim.final.height_at(x)))
    static = float(model.process.cut_depth_mm(force, feed))
    assert cut == pytest.approx(static, rel=0.02)
    assert np.ptp(sim.history["angle_rad"][_middle(sim.history, 35, 60)]) < 1e-4  # settled


def test_halving_the_step_changes_the_final_contour_by_less_than_10_um():
    grid = np.linspace(0.0, 80.0, 1601)
    finals = []
    for step in (0.1, 0.05):
        target = final_contour(BEAD, 0.4, MODEL.process.bead_width_mm)
        drive = HeightControl(MODEL, BEAD.x_mm, target.tip_mm, BEAD.x_mm[0])
        finals.append(simulate_pass(BEAD, MODEL, drive, 10.0, step_mm=step).final.height_at(grid))
    assert np.max(np.abs(finals[0] - finals[1])) < 0.01


def test_truncating_inside_the_runge_kutta_stages_chatters():
    """6.5: truncating at the stages' trial positions starves the next stage of contact and
    the disk hunts; truncating between steps gives a steady force on a flat bead."""
    target = final_contour(FLAT, 0.4, MODEL.process.bead_width_mm)
    forces = {}
    for inside in (False, True):
        drive = HeightControl(MODEL, FLAT.x_mm, target.tip_mm, FLAT.x_mm[0])
        sim = simulate_pass(FLAT, MODEL, drive, 10.0, step_mm=0.1, truncate_in_stages=inside)
        forces[inside] = sim.history["force_n"][_middle(sim.history)]
    assert np.std(forces[False]) < 0.01
    steady = np.mean(forces[False])
    assert np.std(forces[True]) > 1.0 or abs(np.mean(forces[True]) - steady) > 0.2 * steady


def test_plan_reaches_the_desired_contour_and_volume(plan):
    assert plan.planned_depth_mm == 0.3 and plan.reason == "" and plan.simulations == 1
    assert plan.simulation.removed_mm3 == pytest.approx(plan.target.removed_mm3, rel=0.01)
    grid = np.linspace(0.0, 80.0, 1601)
    gap = plan.simulation.final.height_at(grid) - plan.target.contour.height_at(grid)
    assert np.max(np.abs(gap)) < 0.03  # mm
    h = plan.simulation.history
    assert np.all(np.diff(h["time_s"]) > 0) and np.all(h["force_n"] >= 0)
    assert h["force_n"][0] == 0.0 and np.max(h["force_n"]) <= MODEL.process.force_max_n


def test_plan_then_execute_removes_the_volume_and_k1_errors_grow_to_the_thesis_order(plan):
    """Executing the force trajectory with the plan's coefficients removes Delta V within
    3 %; with K1 10-20 % off the error is of the 10 % order the thesis reports (6.5)."""
    wanted = plan.target.removed_mm3
    same = execute_plan(BEAD, MODEL, plan)
    assert same.removed_mm3 == pytest.approx(wanted, rel=0.03)
    grid = np.linspace(0.0, 80.0, 1601)
    assert np.max(np.abs(same.final.height_at(grid) - plan.target.contour.height_at(grid))) < 0.05  # mm
    errors = {}
    for factor in (1.1, 1.2):
        errors[factor] = execute_plan(BEAD, _with_energy(MODEL, factor), plan).removed_mm3 / wanted - 1
    print(f"\nplan-then-execute volume error: same K1 {same.removed_mm3 / wanted - 1:+.2%}, "
          f"K1 +10 % {errors[1.1]:+.1%}, K1 +20 % {errors[1.2]:+.1%}")
    assert -0.15 < errors[1.1] < -0.05
    assert -0.25 < errors[1.2] < -0.10


BEADS = {"ripple": weld_bead(60.0, 1.0, 12.0, ripple_mm=0.15, seed=4),
         "steep ends": weld_bead(60.0, 1.0, 3.0, ripple_mm=0.05, seed=5),
         "rounded ends": weld_bead(60.0, 1.0, 25.0, ripple_mm=0.05, seed=6)}


@pytest.mark.parametrize("bead, feed", [(b, v) for b in BEADS for v in (5.0, 39.5)]
                         + [(b, 75.0) for b in BEADS])
def test_an_executed_plan_removes_its_planned_volume_within_3_percent(bead, feed):
    """Issue 20 acceptance, for 40 % of each bead at the slowest, a middle and the fastest
    feed: executing the plan's force trajectory under force control removes what the plan's
    simulation removed. With the out-of-contact approach at an ad-hoc 5 mm/s it removed 20-40 %
    less at 40-75 mm/s (the disk lost in the troughs). With the spring's rest angle
    following the table at its own time constant (eq. 7.3) it agrees within 1.1 %; with the
    rest angle always wound for the wanted force it removed 16 % less on the ripple at
    75 mm/s. Nothing goes below the parent."""
    contour = BEADS[bead]
    plan = plan_pass(contour, MODEL, 0.4 * contour.area_above(contour.parent_mm) / contour.length_mm, feed)
    executed = execute_plan(contour, MODEL, plan)
    assert executed.removed_mm3 == pytest.approx(plan.simulation.removed_mm3, rel=0.03)
    assert np.min(executed.final.z_mm - executed.final.parent_mm) >= 0.0


def test_plan_on_a_curved_parent_surface_keeps_the_final_contour_parallel_to_it():
    bead = weld_bead(length_mm=80.0, height_mm=3.0, ripple_mm=0.15, parent_curvature_per_mm=2e-3, seed=5)
    plan = plan_pass(bead, MODEL, 0.5, 5.0)
    assert plan.reason == ""  # a level top, within F_max
    assert plan.simulation.removed_mm3 == pytest.approx(plan.target.removed_mm3, rel=0.01)
    grid = np.linspace(0.0, 80.0, 1601)
    assert np.max(np.abs(plan.simulation.final.height_at(grid) - plan.target.contour.height_at(grid))) < 0.03
    middle = (grid > 20) & (grid < 60)
    above_parent = plan.simulation.final.height_at(grid) - np.interp(grid, bead.x_mm, bead.parent_mm)
    assert np.ptp(above_parent[middle]) < 0.03  # a flat top over the curved parent, 1.6 mm of sag


def test_relaxed_angle_variant_is_as_good_as_height_control(plan):
    variant = plan_pass(BEAD, MODEL, 0.3, 7.5, control="relaxed_angle")
    assert variant.simulation.removed_mm3 == pytest.approx(plan.target.removed_mm3, rel=0.01)
    grid = np.linspace(0.0, 80.0, 1601)
    assert np.max(np.abs(variant.simulation.final.height_at(grid) - variant.target.contour.height_at(grid))) < 0.05
    assert np.ptp(variant.simulation.history["height_mm"]) == 0.0  # the height stays put
    assert np.ptp(variant.simulation.history["relaxed_angle_rad"]) > 0.0


@pytest.mark.parametrize("bead, feed", [(b, v) for b in BEADS for v in (5.0, 20.0, 39.5, 75.0)])
def test_force_guard_keeps_the_planned_force_within_f_max(bead, feed):
    """Issue 20 item 3: the deepest pass the sequence planner can command at a feed (F_max
    by eq. 4.6) planned as a level top (eq. 6.2) needs up to 2.5 F_max on the crests and
    at the ends; planned, its force stays within F_max everywhere, it removes at least
    half of it (more than lowering the level top would: only the crests are cut
    shallower), and a depth cut says which limit and why."""
    contour, process = BEADS[bead], MODEL.process
    depth = float(process.cut_depth_mm(process.force_max_n, feed))
    plan = plan_pass(contour, MODEL, depth, feed)
    assert np.max(plan.force_n) <= process.force_max_n
    assert plan.planned_depth_mm >= 0.5 * depth or (bead == "ripple" and feed >= 39.5
                                                    and plan.planned_depth_mm >= 0.3 * depth)
    assert plan.simulation.removed_mm3 == pytest.approx(plan.target.removed_mm3, rel=0.03 if feed < 75 else 0.12)
    if plan.planned_depth_mm < depth:
        assert plan.reason.startswith("force guard: the requested pass needs") and "depth reduced" in plan.reason
    assert plan.simulations <= 8


STEEP_RIPPLED = {"steep ends, ripple 0.15": weld_bead(60.0, 1.0, 2.0, ripple_mm=0.15, seed=7),
                 "steep ends, ripple 0.10": weld_bead(60.0, 1.0, 3.0, ripple_mm=0.1, seed=5)}


@pytest.mark.parametrize("bead, feed", [(b, v) for b in STEEP_RIPPLED for v in (5.0, 20.0, 39.5, 75.0)])
def test_a_plan_states_the_depth_its_own_simulation_removes(bead, feed):
    """Issue 37 item 5: on beads with rounded, steep ends and ripple, at feeds across
    [5, 75] mm/s, the deepest pass at the feed: the depth the plan states is what its own
    simulation removes, within the search's 2 %. (The target's depth was stated before: at
    75 mm/s the simulation removed 6-7 % less; test below.)"""
    contour, process = STEEP_RIPPLED[bead], MODEL.process
    plan = plan_pass(contour, MODEL, float(process.cut_depth_mm(process.force_max_n, feed)), feed)
    area = process.bead_width_mm * contour.length_mm
    simulated = plan.simulation.removed_mm3 / area
    assert simulated == pytest.approx(plan.planned_depth_mm, rel=0.02)
    if abs(simulated / (plan.target.removed_mm3 / area) - 1) > 0.02:
        assert f"its simulation removes {simulated:.4f} mm" in plan.reason
    assert np.max(plan.force_n) <= process.force_max_n


def test_at_75_mm_s_the_height_control_lags_behind_steep_ends_and_ripple():
    """Why the target's depth was not the plan's: the height PI (eq. 6.17) closes its tip
    error at G2 / (1 + G1) = 9.5 /s, 8 mm of feed at 75 mm/s: after the steep start the tip
    rides above its trajectory for the bead's first 15 mm and removes 7 % less in all."""
    contour, process = STEEP_RIPPLED["steep ends, ripple 0.15"], MODEL.process
    plan = plan_pass(contour, MODEL, float(process.cut_depth_mm(process.force_max_n, 75.0)), 75.0)
    area = process.bead_width_mm * contour.length_mm
    target = plan.target.removed_mm3 / area
    assert plan.simulation.removed_mm3 / area < 0.95 * target  # the word it used to give
    assert plan.planned_depth_mm == pytest.approx(plan.simulation.removed_mm3 / area)
    grid = np.linspace(0.0, 15.0, 301)
    lag = plan.simulation.final.height_at(grid) - plan.target.contour.height_at(grid)
    assert np.mean(lag) > 0.005  # mm left above the target after the start


def test_a_level_top_on_a_rippled_bead_needs_far_more_than_f_max_at_speed():
    """The behaviour the force guard replaces: the unguarded plan (issue 20: about 144 N at
    39.5 mm/s against F_max 60 N) comes from cutting the crests three times the mean."""
    contour = BEADS["ripple"]
    depth = float(MODEL.process.cut_depth_mm(MODEL.process.force_max_n, 39.5))
    target = final_contour(contour, depth, MODEL.process.bead_width_mm)
    drive = HeightControl(MODEL, contour.x_mm, target.tip_mm, contour.x_mm[0])
    level_top = simulate_pass(contour, MODEL, drive, 39.5)
    assert np.max(level_top.history["force_n"]) > 2 * MODEL.process.force_max_n
    assert np.max(contour.z_mm - target.tip_mm) > 2.5 * depth


def test_stall_guard_reduces_the_depth_and_says_why():
    process = dataclasses.replace(MODEL.process, max_power_w=900.0)  # 80 %: 720 W
    model = dataclasses.replace(MODEL, process=process)
    plan = plan_pass(BEAD, model, 0.6, 10.0)
    assert plan.planned_depth_mm < 0.6 and "stall guard" in plan.reason and "720 W" in plan.reason
    # the deepest pass under the limit, to 2 % of the limit in power
    assert 0.98 * 720.0 <= plan.simulation.peak_power_w <= 720.0
    assert plan.simulations <= 6  # the secant on a nearly affine power: not a 13-step bisection
    assert plan.summary()["simulations"] == plan.simulations


@pytest.mark.parametrize("depth, feed, control", [(math.nan, 10.0, "height"), (-0.1, 10.0, "height"),
                                                  (0.4, 1000.0, "height"), (0.4, 10.0, "sideways")])
def test_unplannable_commands_raise_with_a_reason(depth, feed, control):
    with pytest.raises(PlanningError):
        plan_pass(BEAD, MODEL, depth, feed, control=control)


def test_static_planner_force_is_the_power_law_on_a_flat_bead():
    compliance = Compliance(np.array([0.0, 0.01, 0.05]), np.array([0.0, 3000.0, 30000.0]))  # stiffening
    plan = plan_pass_static(FLAT, MODEL.process, compliance, 0.4, 10.0)
    middle = (plan.x_mm > 30) & (plan.x_mm < 50)
    depth = np.mean(FLAT.height_at(plan.x_mm[middle]) - plan.target.contour.z_mm[middle])
    np.testing.assert_allclose(MODEL.process.cut_depth_mm(plan.force_n[middle], 10.0), depth, rtol=1e-9)
    np.testing.assert_allclose(plan.time_s, (plan.x_mm - plan.x_mm[0]) / 10.0)
    torque = plan.force_n * MODEL.process.disk_radius_mm
    np.testing.assert_allclose(np.interp(plan.deflection_rad, compliance.deflection_rad, compliance.torque_n_mm),
                               torque, rtol=1e-9)
    assert np.all(plan.force_n[plan.removal_rate_mm3_s == 0] == 0)


def test_force_for_power_inverts_the_air_motor():
    process = GrindingProcess(motor_beta_rad_s_per_n_mm=0.02)
    force = np.array([10.0, 40.0, 80.0])
    np.testing.assert_allclose(force_for_power(process, process.power_w(force)), force, rtol=1e-9)
    with pytest.raises(PlanningError):
        force_for_power(process, 1e6)


def test_process_variation_is_seeded_and_has_the_stated_spread():
    variation = ProcessVariation(specific_energy_cv=0.15, friction_cv=0.1)
    draws = [variation.draw(MODEL, 0, np.random.default_rng(seed)) for seed in range(4000)]
    energy = np.array([d.process.specific_energy_j_mm3 for d in draws]) / MODEL.process.specific_energy_j_mm3
    friction = np.array([d.process.friction_coefficient for d in draws]) / MODEL.process.friction_coefficient
    assert np.mean(energy) == pytest.approx(1.0, abs=0.01) and np.std(energy) == pytest.approx(0.15, abs=0.01)
    assert np.mean(friction) == pytest.approx(1.0, abs=0.01) and np.std(friction) == pytest.approx(0.10, abs=0.01)
    again = variation.draw(MODEL, 0, np.random.default_rng(7))
    assert again == variation.draw(MODEL, 0, np.random.default_rng(7))
    variation = ProcessVariation(0.0, 0.0, dulling_per_pass=0.1, wear_mm_per_pass=0.5)
    dull = variation.draw(MODEL, 3, np.random.default_rng(0))
    assert dull.process.specific_energy_j_mm3 == pytest.approx(MODEL.process.specific_energy_j_mm3 * 1.1**3)
    assert dull.process.disk_radius_mm == pytest.approx(MODEL.process.disk_radius_mm - 1.5)


# -- planning made cheap (issue 39 item 1) ---------------------------------------------------------

def test_the_incremental_kernel_simulates_the_pass_the_old_one_did():
    """The incremental kernel (contact.LiveContour: the face searched only below the
    contour's top, cuts written in a gap, collinear points dropped) against the old one
    kept in contact_reference, on a rippled bead: the same force, angle and patch at every
    step to 1e-6, the same volume to 1e-4, in fewer points. The final contours differ by a
    few um at most: where the old truncation misplaced a crossing next to a cutter vertex
    above the contour (test_contact), the new one is exact."""
    from hex_control.grinding.contact_reference import contact_patch_reference

    target = final_contour(BEAD, 0.3, MODEL.process.bead_width_mm)
    new, old = (simulate_pass(BEAD, MODEL, HeightControl(MODEL, BEAD.x_mm, target.tip_mm, BEAD.x_mm[0]), 7.5,
                              contact_search=search) for search in (None, contact_patch_reference))
    for name in ("force_n", "angle_rad", "patch_area_mm2", "height_mm", "tip_z_mm"):
        np.testing.assert_allclose(new.history[name], old.history[name], rtol=1e-6, atol=1e-9)
    assert new.removed_mm3 == pytest.approx(old.removed_mm3, rel=1e-4)
    grid = np.linspace(0.0, 80.0, 16001)
    assert np.max(np.abs(new.final.height_at(grid) - old.final.height_at(grid))) < 0.01
    assert new.final.x_mm.size < 0.6 * old.final.x_mm.size


def test_a_typical_search_start_is_the_median_end_of_the_commonest_family():
    ends = [SearchStart("capped", 0.80, 0.10), SearchStart("capped", 0.85, 0.30), SearchStart("level", 0.5, 0.0),
            SearchStart("capped", 0.84, 0.18)]
    assert typical_search_start(ends) == SearchStart("capped", 0.84, 0.18)
    with pytest.raises(ValueError, match="no search ends"):
        typical_search_start([])
    for bad in ({"family": "deeper"}, {"guess_scale": 0.0}, {"guess_scale": math.nan}, {"intercept_load": 1.0}):
        with pytest.raises(ValueError, match="search start"):
            SearchStart(**{"family": "capped", "guess_scale": 0.8, **bad})
    from hex_control.grinding.config import parse_pass_planner_config

    for section, words in (({"family": "capped", "guess": 0.8}, "unknown search_start fields"),
                           ([0.8], "unknown search_start fields"), ({"family": "capped", "guess_scale": -1}, "> 0")):
        with pytest.raises(ValueError, match=words):
            parse_pass_planner_config({"search_start": section})
    assert parse_pass_planner_config({"search_start": None}).search_start is None


def test_the_shipped_search_start_saves_first_passes_simulations_on_beads_it_was_not_taken_from():
    """Issue 39 (the clock stands while a job's first pass is planned): the pass planner's
    ``search_start`` (config/pass_planner.yaml, the typical end of 24 cold first searches:
    ``hexctl bench search-start``, which checks it on 12 other first passes: 45 simulations
    cold, 30 from it). Here two of those: fewer simulations each, and the plan's promises
    kept -- force within F_max and no less than 98 % of it, the depth its simulation
    removes, within 2 % of the cold search's depth."""
    from hex_control.bench.grinding import first_searches
    from hex_control.grinding.config import load_pass_planner_config

    shipped = load_pass_planner_config("pass_planner.yaml").search_start
    assert shipped is not None and shipped.family == "capped"
    beads, feeds = ((0.9, 5), (1.2, 6)), (12.0,)
    process = load_pass_planner_config("pass_planner.yaml").model.process
    for cold, warm in zip(first_searches(beads, feeds), first_searches(beads, feeds, shipped)):
        assert warm.simulations < cold.simulations, (warm.simulations, cold.simulations)
        assert 0.98 * process.force_max_n <= np.max(warm.force_n) <= process.force_max_n
        assert warm.planned_depth_mm == pytest.approx(cold.planned_depth_mm, rel=0.02)
        area = process.bead_width_mm * 60.0
        assert warm.simulation.removed_mm3 / area == pytest.approx(warm.planned_depth_mm, rel=0.02)


def test_a_warm_started_search_keeps_the_plans_word_in_fewer_simulations():
    """A guarded pass planned again from where its search ended (PassSession hands each
    search the last one's end): its first guess lands within the search's 2 % of F_max, so
    it takes two simulations (the level top and that guess) instead of four, and it keeps
    the plan's promises: force within F_max, the stated depth what its simulation removes
    within 2 %, no less removed than the cold search's plan (within 2 %)."""
    contour, process = BEADS["ripple"], MODEL.process
    depth = float(process.cut_depth_mm(process.force_max_n, 39.5))
    cold = plan_pass(contour, MODEL, depth, 39.5)
    assert cold.simulations >= 3 and cold.warm_start.family == "capped"
    warm = plan_pass(contour, MODEL, depth, 39.5, warm_start=cold.warm_start)
    assert warm.simulations == 2
    assert 0.98 * process.force_max_n <= np.max(warm.force_n) <= process.force_max_n
    area = process.bead_width_mm * contour.length_mm
    assert warm.simulation.removed_mm3 / area == pytest.approx(warm.planned_depth_mm, rel=0.02)
    assert warm.planned_depth_mm == pytest.approx(cold.planned_depth_mm, rel=0.02)
    # a start from another family is not taken
    other = plan_pass(contour, MODEL, depth, 39.5, warm_start=dataclasses.replace(cold.warm_start, family="level"))
    assert other.simulations == cold.simulations and other.planned_depth_mm == cold.planned_depth_mm
