"""Seed 004 section 3: chatter in slender ball-end milling and its reduction by spindle-speed
variation (eq. 11-18, Fig. 2-3), with the stability-lobe check of the chosen case. The
seed's methods are checked by what they do, and the checks are shown to reject
deliberately wrong variants (test/seed_004_mutants.py)."""

import math
from dataclasses import replace

import numpy as np
import pytest
import seed_004_mutants as mutants

from hex_control.seeds.milling.case import ChatterCase
from hex_control.seeds.milling.checks import (
    _Probe,
    eq18_command,
    eq18_conformance,
    is_seed_triangle,
    transition_samples,
    triangle_timing,
)
from hex_control.seeds.milling.cutting import Cut, cutting_force
from hex_control.seeds.milling.lobes import chatter_frequency, depth_limit
from hex_control.seeds.milling.optimal_speed import OptimalLinearSpeed
from hex_control.seeds.milling.programmes import ConstantSpeed, TriangularSpeed
from hex_control.seeds.milling.report import compare_programmes, run_programme
from hex_control.seeds.milling.semi_discretization import critical_depth, directional_matrix, spectral_radius
from hex_control.seeds.milling.simulation import MillingSimulator
from hex_control.seeds.milling.study import zero_order_lobes
from hex_control.seeds.milling.tool_beam import BeamTool

SEED_CHATTER_HZ = 808.0  # Fig. 2a: constant 15 000 rev/min
FIG_2_3 = ("constant 15000", "Z04", "Z05", "optimal-linear", "optimal-linear, fast spindle")


@pytest.fixture(scope="module")
def case():
    return ChatterCase.from_yaml()


@pytest.fixture(scope="module")
def results(case):
    """Fig. 2-3's runs (1.6 s each); constant 16 500 is checked by the lobes and the bench."""
    return {r.name: r for r in compare_programmes(case, names=FIG_2_3)}


def test_case_parameters_follow_their_stated_rules(case):
    """config/milling/chatter.yaml: where the seed is silent a rule decides, not the seed's
    808 Hz. The overhang puts 15 000 rev/min (the seed's chatter reference) at the lowest
    point of its lobe; a_p is 1.10x the lobe limit there. The chatter frequency is then a
    prediction: 769 Hz, 4.8 % below the seed's 808 Hz (asserted as measured, 4-6 %)."""
    lobes = zero_order_lobes(case)
    speeds = np.linspace(14000, 16400, 2401)
    limits = depth_limit(lobes, speeds)
    assert speeds[np.nanargmin(limits)] == pytest.approx(case.low_rpm, abs=50)
    assert case.cut.depth_m == pytest.approx(1.10 * float(depth_limit(lobes, case.low_rpm)[0]), rel=1e-3)
    assert case.cut.depth_m < 0.95 * float(depth_limit(lobes, case.high_rpm)[0])
    assert case.tool.diameter_m == 0.016 and case.tool.overhang_m < 0.160  # Fette 16 x 160
    miss = 1 - chatter_frequency(lobes, case.low_rpm) / SEED_CHATTER_HZ
    assert 0.04 < miss < 0.06


def test_beam_elements_give_the_cantilevers_frequency_and_tip_stiffness():
    tool = BeamTool(0.016, 0.136, 600e9, 14500, 0.02, elements=8)
    modes = tool.modes(3)
    ei, rho_a = tool.young_pa * tool.second_moment_m4, tool.density_kg_m3 * tool.area_m2
    for omega, beta_l in zip(modes.omega_rad_s, (1.8751, 4.6941, 7.8548)):  # clamped-free roots
        assert omega == pytest.approx(beta_l ** 2 * math.sqrt(ei / (rho_a * tool.overhang_m ** 4)), rel=2e-3)
    assert modes.tip_stiffness_n_m == pytest.approx(3 * ei / tool.overhang_m ** 3, rel=5e-3)
    assert abs(modes.tip_frf(0.0)) == pytest.approx(1 / modes.tip_stiffness_n_m)


def test_cutting_force_law_of_eq_11_to_13():
    cut = Cut(teeth=1, depth_m=1e-3, feed_per_tooth_m=1e-4, cutting_pressure_pa=800e6, force_ratio=0.3)
    phi = math.pi / 3
    fx, fy = cutting_force(cut, [phi], (0.0, 0.0), (0.0, 0.0))
    tangential = 800e6 * 1e-3 * 1e-4 * math.sin(phi)  # eq. 11: k_d a_p h
    assert math.hypot(fx, fy) == pytest.approx(tangential * math.hypot(1, 0.3))  # eq. 12: F_y2 = mu F_y1
    # the tangential part opposes the tooth's motion, the radial part pushes the tool out of the cut
    assert (fx * math.cos(phi) - fy * math.sin(phi)) == pytest.approx(-tangential)
    radial_out = (math.sin(phi), math.cos(phi))
    assert (fx * radial_out[0] + fy * radial_out[1]) == pytest.approx(-0.3 * tangential)
    # deflected away from the material by more than the chip: the tooth leaves the cut (eq. 11-12, h <= 0)
    away = -2e-4
    assert cutting_force(cut, [phi], (away * radial_out[0], away * radial_out[1]), (0.0, 0.0)) == (0.0, 0.0)
    # the previous tooth pushed away left material behind: a thicker chip now (delayed feedback)
    thicker = cutting_force(cut, [phi], (0.0, 0.0), (away * radial_out[0], away * radial_out[1]))
    assert math.hypot(*thicker) == pytest.approx(math.hypot(fx, fy) * (1e-4 * math.sin(phi) + 2e-4)
                                                / (1e-4 * math.sin(phi)))
    assert cutting_force(cut, [1.5 * math.pi], (0.0, 0.0), (0.0, 0.0)) == (0.0, 0.0)  # outside the immersion


def test_lobes_by_two_methods_agree_and_place_the_seeds_reference_speeds(case):
    """The chosen depth is above the lobe at 15 000 rev/min and below it at 16 500, by the
    zero-order lobes and by semi-discretization alike."""
    lobes = zero_order_lobes(case)
    for speed, unstable in ((case.low_rpm, True), (case.high_rpm, False)):
        zero_order = float(depth_limit(lobes, speed)[0])
        semi = critical_depth(case.modes, case.cut, speed, 0.5 * zero_order, 2 * zero_order, tolerance_m=2e-7)
        assert semi == pytest.approx(zero_order, rel=0.03)
        assert (spectral_radius(case.modes, case.cut, speed) > 1) is unstable
        assert (case.cut.depth_m > zero_order) is unstable


def test_time_domain_model_turns_unstable_where_the_lobes_say(case):
    """Eq. 14 with 11-13 at constant 15 000 rev/min: below the semi-discretization limit the
    free vibration dies out, above it it grows (compared one spindle revolution apart, which
    removes the forced tooth-passing response)."""
    limit = critical_depth(case.modes, case.cut, case.low_rpm, 0.5e-4, 2e-4, tolerance_m=1e-6)

    def growth(depth_m):
        record = MillingSimulator(case.modes, replace(case.cut, depth_m=depth_m), case.step_s).run(
            ConstantSpeed(case.low_rpm), 0.3)
        revolution = int(round(60 / case.low_rpm / case.step_s))
        free = np.abs(np.diff(record.deflection_m[::revolution, 1]))
        return free[-3:].max() / free[3:6].max()

    assert growth(0.85 * limit) < 0.3
    assert growth(1.15 * limit) > 3.0


def test_delay_follows_the_instantaneous_spindle_speed_eq_16(case):
    """tau solves int_{t-tau}^t n(s) ds = 60/z: on a speed ramp it lies between the tooth
    periods of the speeds now and one period ago, at the mean speed over the period."""
    programme = TriangularSpeed(15000.0, 16500.0, 0.004, 0.004)  # a fast ramp, to make the difference show
    delays = []

    class Probe:
        initial_rpm = programme.initial_rpm

        def speed_rpm(self, time_s, simulator):
            delays.append((time_s, simulator.delay_s))
            return programme.speed_rpm(time_s)

    MillingSimulator(case.modes, case.cut, case.step_s).run(Probe(), 0.02)
    for time_s, delay_s in delays[200::97]:
        grid = np.linspace(time_s - delay_s, time_s, 400)
        turned_rev = np.trapezoid([programme.speed_rpm(t) for t in grid], grid) / 60
        assert turned_rev == pytest.approx(1 / case.cut.teeth, rel=2e-3)


def test_variable_speed_programmes_lower_the_chatter_fig_2_3_by_four_measures(results):
    """Fig. 2-3 against constant 15 000 rev/min, which chatters at the lobe's frequency (the
    time-domain peak within 1 % of the zero-order lobes' 769 Hz). The seed: the chatter peak of
    the spectrum falls by up to 68 %, the RMS falls too. Here, as measured: Z04's peak falls
    by 75 %, Z05's by 71 %, the optimal-linear programme's by 57 % (the fast spindle's 78 %);
    RMS to 35-45 %, the energy over the window to 12-20 %. The largest time-domain amplitude
    falls far less than the spectral peak (Z04 66 %, Z05 79 %, fast spindle 67 % of the
    reference): the chatter is intermittent, growing while the speed is unstable and dying
    while it is stable, and the spectrum averages it over the window. The optimal-linear
    programme at the spindle's limit has the smallest largest amplitude (46 %): it leaves
    the unstable speed and stays near 15 900 rev/min."""
    reference = results["constant 15000"]
    assert reference.chatter_hz == pytest.approx(768.6, rel=0.01)
    for name, peak, amplitude in (("Z04", 0.35, (0.5, 0.8)), ("Z05", 0.35, (0.65, 0.9)),
                                  ("optimal-linear", 0.55, (0.3, 0.6)),
                                  ("optimal-linear, fast spindle", 0.35, (0.5, 0.8))):
        result = results[name]
        assert result.chatter_peak_m < peak * reference.chatter_peak_m, name
        assert result.rms_m < 0.5 * reference.rms_m, name
        assert result.energy_m2_s < 0.25 * reference.energy_m2_s, name
        assert amplitude[0] < result.max_amplitude_m / reference.max_amplitude_m < amplitude[1], name
        # the peak falls further than the largest amplitude: the spectrum averages intermittent chatter
        assert result.chatter_peak_m / reference.chatter_peak_m < result.max_amplitude_m / reference.max_amplitude_m


def test_eq_18_check_accepts_the_programme_and_rejects_wrong_variants(case):
    """Eq. 18 (with eq. 15-16's B_u and eq. 10's limit) recomputed independently from the
    simulator's state at every control instant: the optimal-linear programme conforms; a
    plain ramp, 'always the maximum acceleration' and eq. 18 with its sign turned do not."""
    acceleration = case.optimal["acceleration_rpm_s"]
    check = eq18_conformance(case, case.optimal_linear(), 0.1, acceleration_rpm_s=acceleration)
    assert check.conforms and check.commands == 100
    assert check.worst_rpm < 0.01 * acceleration * case.optimal["control_period_s"]
    o = case.optimal
    made = {"max_rpm": o["max_rpm"], "fall_s": o["fall_s"], "acceleration_rpm_s": acceleration, "q1": o["q1"],
            "q2": o["q2"], "r": o["r"], "control_period_s": o["control_period_s"]}
    wrong = {"plain ramp": mutants.plain_ramp(case.low_rpm, case.high_rpm, acceleration),
             "maximum acceleration": mutants.MaximumAcceleration(case.modes, case.cut, case.low_rpm, **made),
             "reversed": mutants.ReversedEq18(case.modes, case.cut, case.low_rpm, **made)}
    for name, programme in wrong.items():
        assert not eq18_conformance(case, programme, 0.1, acceleration_rpm_s=acceleration).conforms, name


def test_optimal_linear_programme_reaches_n_max_only_with_the_seeds_simulated_spindle(results):
    """Section 3: applied directly eq. 18 drives the speed up; at n_max it falls linearly to n0
    ("triangle-like segments"). With the spindle's real acceleration (1500 rev/min in 0.4 s,
    the seed's "shorter than 0.4 s is too short") eq. 18's command sits at eq. 10's limit in
    both directions and the speed's climb slows as the chatter it feeds on dies: in 1.6 s it
    stays below n_max (about 15 900 rev/min). With the 10x faster spindle of the seed's
    simulations it rises to n_max within 0.1 s and falls over 0.4 s: the triangle-like
    segments, a sawtooth of period about 0.45 s."""
    slow, fast = results["optimal-linear"], results["optimal-linear, fast spindle"]
    assert 15500 < slow.speed_range_rpm[1] < 16400
    assert fast.speed_range_rpm[1] == pytest.approx(16500.0)
    speed, dt = fast.record.speed_rpm, fast.record.step_s
    tops = np.flatnonzero((speed[1:] >= 16500.0 - 1e-6) & (speed[:-1] < 16500.0 - 1e-6)) + 1
    assert tops[0] * dt < 0.1 and 3 <= tops.size <= 4
    assert np.diff(tops) * dt == pytest.approx(np.full(tops.size - 1, 0.45), abs=0.05)


def test_optimal_linear_programme_rises_by_eq_18_and_falls_linearly(case):
    """At n_max the speed ramps down linearly to n0 in fall_s and the eq. 18 command resumes:
    the whole record conforms to the rule, fall included (n_max lowered to 15 600 so that the
    spindle's limited acceleration reaches it within 0.3 s)."""
    o = case.optimal
    programme = OptimalLinearSpeed(case.modes, case.cut, case.low_rpm, 15600.0, fall_s=0.2,
                                   acceleration_rpm_s=o["acceleration_rpm_s"],
                                   q1=o["q1"], q2=o["q2"], r=o["r"], control_period_s=o["control_period_s"])
    record = run_programme(case, "optimal-linear", programme).record
    speed, dt = record.speed_rpm, record.step_s
    assert speed.min() >= case.low_rpm and speed.max() == pytest.approx(15600.0)
    commands = np.array(programme.commands)[:, 1]
    assert np.all(np.abs(commands) <= o["acceleration_rpm_s"] * o["control_period_s"] + 1e-9)  # eq. 10
    assert commands.mean() > 0
    peaks = np.flatnonzero(speed >= 15600.0 - 1e-6)
    assert peaks.size and peaks[0] < speed.size - int(0.2 / dt)
    fall = speed[peaks[0]:peaks[0] + int(0.19 / dt)]
    assert np.allclose(np.diff(fall), -(15600.0 - case.low_rpm) / 0.2 * dt, rtol=1e-6)


def test_z04_z05_timing_is_the_seeds_and_changed_timings_are_rejected(case):
    """Section 3: Z04 rises and falls in 0.4 s, Z05 in 0.5 s, between 15 000 and 16 500 rev/min,
    measured on the speed each programme gives at the simulation's steps; Z04 with a 0.25 s
    rise, and Z05 built with Z04's times, are rejected."""
    time_s = np.arange(int(round(1.6 / case.step_s))) * case.step_s

    def timing(programme):
        return triangle_timing(time_s, [programme.speed_rpm(t) for t in time_s])

    programmes = case.programmes()
    for name in ("Z04", "Z05"):
        assert is_seed_triangle(name, timing(programmes[name]), case.low_rpm, case.high_rpm), name
    assert not is_seed_triangle("Z04", timing(mutants.z04_fast_rise(case.low_rpm, case.high_rpm)), case.low_rpm,
                                case.high_rpm)
    assert not is_seed_triangle("Z05", timing(mutants.z05_as_z04(case.low_rpm, case.high_rpm)), case.low_rpm,
                                case.high_rpm)


def test_eq_18_with_eq_14s_cutting_stiffness_and_its_size(case):
    """Eq. 18's K* is eq. 14's: the tool's K plus the cut's proportional feedback. At the
    case's depth that term is small against the tool's; with it eq. 18's command
    differs by a few % of its size and keeps its sign in nearly every control period. The
    programme carries it (the check above recomputes eq. 18 with it). Eq. 14's a_p k_d is
    4.5 % of the tip stiffness; with the teeth's directional factor, up to 9-12 %."""
    ratio = case.cut.depth_m * case.cut.cutting_pressure_pa / case.modes.tip_stiffness_n_m
    assert 0.03 < ratio < 0.06
    directional = np.linalg.norm(directional_matrix(case.cut, np.linspace(0, math.pi, 90)), ord=2, axis=(1, 2))
    assert ratio * directional.max() < 0.12  # at its largest over the revolution
    probe = _Probe(ConstantSpeed(case.low_rpm))
    MillingSimulator(case.modes, case.cut, case.step_s).run(probe, 0.1)
    o = case.optimal
    transitions = transition_samples(case.modes, o["control_period_s"])
    pairs = np.array([[eq18_command(case.modes, case.cut, state, case.low_rpm, q1=o["q1"], q2=o["q2"], r=o["r"],
                                    period_s=o["control_period_s"], cutting_stiffness=with_term,
                                    transitions=transitions) for with_term in (True, False)]
                      for _, _, state in probe.samples[2500::50]])
    assert np.mean(np.sign(pairs[:, 0]) == np.sign(pairs[:, 1])) > 0.9
    relative = np.abs(pairs[:, 0] - pairs[:, 1]) / np.abs(pairs).max(axis=1)
    assert 0.001 < np.median(relative) < 0.1


def test_a_material_enters_only_through_k_d_a_p_and_mu_figs_4_5(case):
    """Figs. 4-5 (steel C45, bronze CC331G) give no values in the seed's text, nor the
    cutting coefficients, depths or speeds of those cuts. In eq. 11-12 a material is
    (k_d, mu) and k_d enters only as k_d a_p: a depth set by the same rule (1.10x the lobe
    limit) gives the same cut for any k_d, so only mu (K_r/K_t) could tell the materials
    apart. Shown on the force law and the lobes."""
    cut = case.cut
    scaled = replace(cut, cutting_pressure_pa=2.5 * cut.cutting_pressure_pa, depth_m=cut.depth_m / 2.5)
    angles, now, before = [0.3, 0.3 + math.pi], (2e-6, -1e-6), (-3e-6, 4e-6)
    assert cutting_force(scaled, angles, now, before) == pytest.approx(cutting_force(cut, angles, now, before))
    lobes = zero_order_lobes(case)
    steel = zero_order_lobes(replace(case, cut=scaled))
    assert float(depth_limit(steel, case.low_rpm)[0]) == pytest.approx(float(depth_limit(lobes, case.low_rpm)[0]) / 2.5,
                                                                       rel=1e-6)
