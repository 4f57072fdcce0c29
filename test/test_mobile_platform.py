"""Seed 004 section 4: the two-wheeled mobile platform, its dynamics (Appell-Gibbs, shown
equal to Lagrange with multipliers), the path of Fig. 7 and 10, the correcting velocities
of eq. 19, the energy-index command of eq. 20-21 against two PIDs (Fig. 8, 10-11)."""

import math

import numpy as np
import pytest

from hex_control.seeds.mobile_platform.case import PlatformCase
from hex_control.seeds.mobile_platform.control import PlatformState, commanded_motion
from hex_control.seeds.mobile_platform.model import appell_gibbs_accelerations, lagrange_accelerations
from hex_control.seeds.mobile_platform.path import curvature, path_length
from hex_control.seeds.mobile_platform.simulation import _rk4_step, simulate_platform, tracking_figures

CASE = PlatformCase.from_yaml()
MODEL = CASE.model


def test_appell_gibbs_equations_equal_lagrange_with_multipliers():
    rng = np.random.default_rng(4)
    for _ in range(20):
        beta, v, w = rng.uniform(-math.pi, math.pi), rng.uniform(-0.5, 0.5), rng.uniform(-2, 2)
        torques = rng.uniform(-1, 1, 2)
        rates = MODEL.wheel_rates(v, w)
        q_dot = [v * math.cos(beta), v * math.sin(beta), w, *rates]
        q_ddot, _ = lagrange_accelerations(MODEL, beta, q_dot, torques)
        # v' is the acceleration of A along the heading (its normal part is v w)
        v_dot = q_ddot[0] * math.cos(beta) + q_ddot[1] * math.sin(beta)
        normal = -q_ddot[0] * math.sin(beta) + q_ddot[1] * math.cos(beta)
        assert (v_dot, q_ddot[2]) == pytest.approx(appell_gibbs_accelerations(MODEL, v, w, torques), rel=1e-9, abs=1e-9)
        assert normal == pytest.approx(v * w, abs=1e-9)
        # and the wheels roll: theta'' follows (v', w')
        assert q_ddot[3:] == pytest.approx(MODEL.wheel_rates(v_dot, q_ddot[2]), abs=1e-9)


def test_constraint_forces_are_the_floors_forces_on_the_wheels():
    """Straight from rest: each wheel's floor force is (tau - I_w theta'') / r; turning at
    speed: the axle's lateral force is C's mass times its centripetal acceleration."""
    q_ddot, forces = lagrange_accelerations(MODEL, 0.0, [0, 0, 0, 0, 0], [0.5, 0.5])
    assert forces[1] == pytest.approx((0.5 - MODEL.wheel_inertia_kg_m2 * q_ddot[3]) / MODEL.wheel_radius_m)
    assert forces[0] == pytest.approx(0.0, abs=1e-12)
    v, w = 0.2, 1.0
    q_ddot, forces = lagrange_accelerations(MODEL, 0.0, [v, 0, w, *MODEL.wheel_rates(v, w)], [0.0, 0.0])
    assert forces[0] == pytest.approx(MODEL.mass_kg * (v * w + MODEL.mass_ahead_m * q_ddot[2]))


def test_paths_of_fig_7_and_10_are_smooth_and_the_motion_stops_at_their_ends():
    for test_path in (False, True):
        spec = CASE.test_path if test_path else CASE.path
        s = np.linspace(0, path_length(spec), 200001)
        kappa = curvature(spec, s)
        assert np.max(np.abs(np.diff(kappa))) < 1e-3  # clothoids: no curvature jump
        assert np.trapezoid(kappa, s) == pytest.approx(sum(c.turn_rad for c in spec.curves), abs=1e-3)
        desired = CASE.desired(test_path)
        assert np.max(np.linalg.norm(desired.velocity_m_s, axis=1)) == pytest.approx(spec.speed_m_s, rel=1e-3)
        assert np.linalg.norm(desired.velocity_m_s[-1]) == pytest.approx(0.0, abs=1e-9)
        assert np.linalg.norm(desired.position_m[-1] - desired.path_m[-1]) < 1e-9
        # the heading H's exact motion asks for settles on the last straight's direction as
        # exp(-s / d): within 1 mrad after Fig. 7's 1 m, still settling on Fig. 10's 0.3 m (3 d),
        # the seed's reason to shorten it: "to capture orientation errors after the final curve"
        settled = abs(desired.heading_rad[-1] - sum(c.turn_rad for c in spec.curves))
        assert settled < 1e-3 if not test_path else 1e-3 < settled < 0.1


def test_eq_19_correcting_velocity_moves_h_towards_its_target():
    state = PlatformState(0.0, 0.0, 0.3, 0.0, 0.0)
    target = state.point_h(MODEL.point_h_ahead_m) + np.array([0.01, -0.02])
    desired = (target, np.zeros(2), 0.0, 0.0, 0.0, np.zeros(2))
    v, w = commanded_motion(MODEL, state, desired, k=2.0, period_s=0.01)
    # H's velocity of that (v, w): v e + d w n
    e, n = np.array([math.cos(0.3), math.sin(0.3)]), np.array([-math.sin(0.3), math.cos(0.3)])
    h_dot = v * e + MODEL.point_h_ahead_m * w * n
    assert h_dot == pytest.approx((target - state.point_h(MODEL.point_h_ahead_m)) / (2.0 * 0.01))


def test_eq_21_command_lowers_the_index_of_eq_20_over_one_period():
    """From a wheel-rate error, the command of eq. 21 (about the desired motion's voltage)
    leaves a smaller kinetic-energy error after one sampling period than no correction."""
    controller = CASE.energy_controller()
    state = PlatformState(-MODEL.point_h_ahead_m, 0.0, 0.0, 0.05, 0.2)  # should stand still
    desired = (np.zeros(2), np.zeros(2), 0.0, 0.0, 0.0, np.zeros(2))

    def index_after(voltages):
        end = (state.x_m, state.y_m, state.beta_rad, state.v_m_s, state.w_rad_s, 0.0, 0.0)
        for _ in range(10):
            end = _rk4_step(MODEL, end, voltages, CASE.period_s / 10)
        rates = np.array(MODEL.wheel_rates(end[3], end[4]))
        return 0.5 * rates @ controller.mass @ rates

    u = controller.voltages(0.0, state, desired)
    assert index_after(u) < 0.9 * index_after(controller.desired_voltage(0.0, 0.0, (0.0, 0.0)))


def eq_21_feedback(model, q1: float, r: float, period_s: float) -> np.ndarray:
    """Eq. 21's feedback matrix written out with R = r I and Q1 = q1 I: u = -F (q' - q_bar' -
    q_hat'), F = (R + R^T)^-1 int_0^Delta B^T Phi^T ds (M*^T Q1^T + Q1 M*), for the drives'
    linear model M* q'' = -L* q' + B_u U in the wheel rates; Phi by Simpson's rule."""
    from scipy.linalg import expm

    from hex_control.seeds.mobile_platform.control import wheel_rate_matrix

    j = wheel_rate_matrix(model)
    mass = j.T @ np.diag(model.quasi_mass) @ j
    drive = model.gear_ratio * model.torque_constant_n_m_a / model.armature_resistance_ohm
    a = -np.linalg.solve(mass, drive * model.gear_ratio * model.torque_constant_n_m_a * np.eye(2))
    b = np.linalg.solve(mass, drive * np.eye(2))
    nodes = np.linspace(0.0, period_s, 201)
    weights = np.full(nodes.size, 2.0)
    weights[1:-1:2], weights[0], weights[-1] = 4.0, 1.0, 1.0
    g = np.einsum("k,kij->ij", weights * period_s / (3 * (nodes.size - 1)), [expm(a * t) @ b for t in nodes])
    big_r, big_q1 = r * np.eye(2), q1 * np.eye(2)
    return np.linalg.solve(big_r + big_r.T, g.T @ (mass.T @ big_q1.T + big_q1 @ mass))


def test_eq_21_gain_is_q1_over_r_with_the_seeds_half():
    """Eq. 21: (R + R^T)^-1 = (2 r)^-1 halves the symmetrized (M*^T Q1^T + Q1 M*) = 2 q1 M*,
    so the feedback is (q1 / r) G^T M*: the controller's gain is q1 / r and only the ratio
    matters. The variant that drops the 1/2 (the project's law before issue 41) is rejected."""
    import seed_004_mutants as mutants

    from hex_control.seeds.mobile_platform.control import EnergyIndexController

    gain = CASE.energy_index["gain"]
    for q1, r in ((gain, 1.0), (2 * gain, 2.0), (gain * 1e-3, 1e-3)):
        expected = eq_21_feedback(MODEL, q1, r, CASE.period_s)
        assert CASE.energy_controller().feedback == pytest.approx(expected, rel=1e-6)
    wrong = mutants.EnergyIndexWithoutHalf(MODEL, gain, CASE.energy_index["k"], CASE.period_s)
    assert not np.allclose(wrong.feedback, eq_21_feedback(MODEL, gain, 1.0, CASE.period_s), rtol=0.1)
    assert isinstance(wrong, EnergyIndexController)


def test_odometry_follows_the_true_pose_to_the_encoders_resolution():
    desired = CASE.desired()
    true = simulate_platform(CASE.plant, CASE.pid_controller(), desired, CASE.period_s, with_friction=False)
    from hex_control.seeds.mobile_platform.odometry import EncoderOdometry

    counts = 60000
    odometry = EncoderOdometry(CASE.plant, counts, CASE.period_s, PlatformState(*true.states[0]))
    angles = np.cumsum([[0.0, 0.0]] + [CASE.plant.wheel_rates(v, w) for v, w in true.states[:-1, 3:]], axis=0)
    angles *= CASE.period_s  # rectangle rule: good to the resolution checked below
    seen = [odometry.measure(a) for a in angles]
    position_error = max(math.hypot(s.x_m - x, s.y_m - y) for s, (x, y) in zip(seen, true.states[:, :2]))
    assert position_error < 2e-3
    speed_quantum = 2 * math.pi / counts * CASE.plant.wheel_radius_m / CASE.period_s
    assert max(abs(s.v_m_s - v) for s, v in zip(seen[1:], true.states[1:, 3])) < 3 * speed_quantum


def test_the_whole_run_is_the_same_on_either_form_of_the_dynamics():
    desired = CASE.desired()
    runs = [simulate_platform(CASE.plant, CASE.pid_controller(), desired, CASE.period_s, with_friction=False,
                              lagrange=lagrange) for lagrange in (False, True)]
    assert np.max(np.abs(runs[0].states - runs[1].states)) < 1e-9


@pytest.fixture(scope="module")
def comparison():
    """Fig. 7's path, both plants, both controllers with the case's gains (tuned alike by
    fair.py); Fig. 10's path and the seed's other conditions are in `hexctl bench
    mobile_platform_fair` (docs/results/platform_fair_comparison.txt)."""
    desired = CASE.desired()
    runs = {}
    for plant_name, plant in zip(("as modelled", "loaded"), CASE.tuning_plants):
        for name, make in (("energy index", CASE.energy_controller), ("two PID", CASE.pid_controller)):
            runs[(plant_name, name)] = tracking_figures(CASE.run(plant, make(), desired), desired)
    return runs


def test_fig_8_heading_error_small_and_vanishing_by_the_end(comparison):
    """Fig. 8 (the energy-index law): the heading error is small and near zero by the end.
    The PIDs' is small too; its end value is a count or two of heading (0.017 mrad)."""
    for key, f in comparison.items():
        assert f.max_heading_error_rad < 1e-3, key
        if key[1] == "energy index":
            assert f.final_heading_error_rad < 0.3 * f.max_heading_error_rad, key


def test_fig_10_11_energy_index_against_two_pids_tuned_alike(comparison):
    """Fig. 10-11, compared fairly: both controllers tuned by one optimizer on one criterion
    (RMS path error over both plants) with one budget, seeing 5.2 um encoder counts. As
    measured (statements of the ordering, each able to fail either way):
    - as modelled the two tie at the encoders' resolution: RMS path error 2.2 vs 2.6 um,
      within 35 % of each other and both under half a count;
    - loaded (payload, gear friction the law's model lacks) the PIDs keep H nearer the path
      on RMS (3.1 vs 3.8 um: 0.65-0.95x the law's) and the heading 2-3x better; the law keeps
      the largest path error lower (11 vs 25 um: under 0.6x the PIDs');
    - these are fractions of a count: the gains rounded to 5 digits move them by up to
      0.3 um and 0.02 mrad, so the bands are wider than the differences' noise, no tighter;
    - neither asks the floor for much friction (mu < 0.1), final positions within 10 um.
    The seed's "much better" shows only where the tuning did not look: at twice v_A the law's
    RMS path error is 4x lower (bench); with twice the friction the PIDs' is 2.5x lower."""
    count_m = 2 * math.pi * MODEL.wheel_radius_m / CASE.encoder_counts_per_rev
    assert count_m == pytest.approx(5.24e-6, rel=1e-2)
    modelled = comparison[("as modelled", "energy index")], comparison[("as modelled", "two PID")]
    loaded = comparison[("loaded", "energy index")], comparison[("loaded", "two PID")]
    assert 0.8 < modelled[1].rms_path_error_m / modelled[0].rms_path_error_m < 1.35
    assert max(f.rms_path_error_m for f in modelled) < 0.6 * count_m
    assert 0.65 < loaded[1].rms_path_error_m / loaded[0].rms_path_error_m < 0.95
    assert loaded[0].max_path_error_m < 0.6 * loaded[1].max_path_error_m
    assert loaded[1].max_heading_error_rad < 0.7 * loaded[0].max_heading_error_rad
    for f in comparison.values():
        assert f.max_required_friction < 0.1 and f.final_position_error_m < 1e-5


def test_energy_index_law_sweep_has_an_instability_near_its_tuned_gain():
    """The law's gain q1/r and eq. 19's k swept (bench): at q1/r = 1000, 2.7x the tuned gain,
    k <= 1 gives millimetre errors; the tuned point (364, 0.57) keeps H within micrometres.
    Checked here at the two ends, on the platform as modelled."""
    desired = CASE.desired()

    def rms(gain, k):
        return tracking_figures(CASE.run(MODEL, CASE.energy_controller(gain, k), desired, with_friction=False),
                                desired).rms_path_error_m

    assert rms(1000.0, 0.74) > 1e-4
    assert rms(CASE.energy_index["gain"], CASE.energy_index["k"]) < 5e-6
