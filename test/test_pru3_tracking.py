"""Contour tracking on the 3-PRU head (seed 001 sections 3, 4.3): the four strategies on
the seed's test motion, their IAE tables (Tables 1-4) and ITAE gain optimization."""

import math

import numpy as np
import pytest

from hex_control.control.pru3_tracking import (
    DEFAULT_GAINS,
    STRATEGIES,
    Gains,
    _itae_or_inf,
    contour_error,
    iae_table,
    optimize_gains,
    track,
    track_batch,
)


@pytest.fixture(scope="module")
def runs():
    return dict(zip(STRATEGIES, track_batch(STRATEGIES, [DEFAULT_GAINS[s] for s in STRATEGIES], duration_s=0.5)))


def test_contour_error_is_the_part_normal_to_the_path():
    e = np.array([0.0, 0.3, 0.4])
    np.testing.assert_allclose(contour_error(e, [0.0, 1.0, 0.0]), [0.0, 0.0, 0.4])
    np.testing.assert_allclose(contour_error(e, [0.0, 0.0, 0.0]), e)


def test_iae_tables_reproduce_the_seeds_orderings(runs):
    print()
    for strategy, run in runs.items():
        print(iae_table(strategy, run))
    task = {s: runs[s].iae("task") for s in ("ctc", "ctc_cc")}
    link = {s: runs[s].iae("link") for s in ("lspd", "lspd_cc")}
    # Tables 1-2: CC lowers CTC's contour error in alpha and beta (0.0057/0.0055 -> 0.0037/0.0034)
    assert np.all(task["ctc_cc"]["contour"][1:] < 0.85 * task["ctc"]["contour"][1:])
    # Tables 3-4: CC lowers LSPD's link-space contour error on every slider (~0.62 -> ~0.40)
    assert np.all(link["lspd_cc"]["contour"] < 0.85 * link["lspd"]["contour"])
    # the seed's layout: LSPD's link-space errors (mm s) an order above CTC's task-space ones
    assert np.min(link["lspd"]["tracking"]) > 10 * np.max(task["ctc"]["tracking"][1:])
    # magnitudes: CTC's contour IAE within a factor 3 of the seed's 0.0055-0.0057 rad s
    assert np.all((0.0019 < task["ctc"]["contour"][1:]) & (task["ctc"]["contour"][1:] < 0.017))


def test_lspd_leaves_gravity_to_the_pd_and_sags(runs):
    """LSPD feeds forward only A(q_d) q_d'': the sliders' PD carries the weight, so z sits
    low by about weight / (3 K_p); CTC models gravity and does not."""
    sag = runs["lspd"].desired[-50:, 0] - runs["lspd"].q[-50:, 0]
    weight_share = 75.53 / 3  # N per slider at rest
    assert np.mean(sag) == pytest.approx(weight_share / DEFAULT_GAINS["lspd"].proportional, rel=0.3)
    assert np.max(np.abs(runs["ctc"].desired[:, 0] - runs["ctc"].q[:, 0])) < 0.01


def test_itae_optimization_improves_on_the_start_and_repeats_with_a_seed():
    first = optimize_gains("ctc", duration_s=0.2, generations=2, population=6, seed=1)
    best, itae, start = first
    assert itae < 0.5 * start and isinstance(best, Gains)
    # the same seed, the same gains: on a shorter run (a generation's mutation and crossover
    # drawn from the seed all the same), since each optimization simulates every candidate
    short = optimize_gains("ctc", duration_s=0.1, generations=1, population=4, seed=2)
    assert optimize_gains("ctc", duration_s=0.1, generations=1, population=4, seed=2) == short


def test_a_diverging_candidate_raises_and_scores_infinite():
    """Gains the 2 ms loop cannot hold (derivative gain beyond the sampling's limit) drive a
    Runge-Kutta stage out of the workspace: a FloatingPointError, ITAE inf to the optimizer."""
    unstable = Gains(proportional=600.0, derivative=15.0, contour=0.0)
    with pytest.raises(FloatingPointError):
        track("lspd", unstable, duration_s=0.2, control_period_s=2e-3)
    assert _itae_or_inf("lspd", unstable, 0.2, 2e-3) == math.inf


def test_unknown_strategy_is_refused():
    with pytest.raises(ValueError):
        track("pid")


def test_tracking_rows_of_tables_1_2_and_why_they_differ_from_the_seeds():
    """Tables 1-2's tracking rows against the seed's own CTC law with an exact model, for which
    e'' + K_v e' + K_p e = 0 on every axis (Z = 0, as the seed prints). The seed prints
    IAE 0.0208 / 0.0226 (alpha / beta), contour 0.0057 / 0.0055, and does not state where
    the motion starts. Computed on the linear error dynamics (exact_ctc_error_iae):
    - started at rest at the path's first point, alpha's error is identically 0 for every
      gain pair (41 x 31 grid, K_p 1-10^4, K_v 0.3-300): the printed 0.0208 cannot come;
      beta's is 0.15 w / K_p = 0.0189 at the default gains (0.0181 of it within 0.5 s);
    - started moving along the path, every error is 0;
    - started level (alpha = beta = 0) at rest, the best gains miss one of the four numbers
      by 2.1x or more;
    - only from an unstated start off the path (alpha 0.10, beta 0.15 rad, at rest) with soft
      gains (K_p 21.5, K_v 10) do all four come within 30 %.
    The machine's full simulation agrees with the error dynamics (beta within 10 %); the
    long runs (0.5 s, a 4x finer period, CC) are in `hexctl bench pru3_tracking`."""
    from hex_control.control.pru3_tracking import CircularTilt, exact_ctc_error_iae

    seed = np.array([0.0208, 0.0226, 0.0057, 0.0055])  # Table 1: tracking alpha, beta; contour alpha, beta
    omega = CircularTilt().frequency_rad_s
    kp, kv = np.meshgrid(np.logspace(0, 4, 41), np.logspace(-0.5, 2.5, 31), indexing="ij")
    on_path = exact_ctc_error_iae(kp, kv, duration_s=0.5, step_s=5e-4)
    assert np.all(on_path["tracking"][..., 1] == 0.0) and np.all(on_path["tracking"][..., 0] == 0.0)
    default = DEFAULT_GAINS["ctc"]
    at_default = exact_ctc_error_iae(default.proportional, default.derivative, duration_s=0.5, step_s=1e-4)
    natural = math.sqrt(default.proportional)  # K_v = 2 sqrt(K_p): critically damped, e = e0' t exp(-w_n t)
    assert default.derivative == pytest.approx(2 * natural)
    decayed = 1 - math.exp(-natural * 0.5) * (1 + natural * 0.5)  # the part of the transient within 0.5 s
    assert at_default["tracking"][2] == pytest.approx(0.15 * omega / default.proportional * decayed, rel=1e-3)
    level = exact_ctc_error_iae(kp, kv, start=(0.0, 0.0, 0.0), duration_s=0.5, step_s=5e-4)
    values = np.stack([level["tracking"][..., 1], level["tracking"][..., 2], level["contour"][..., 1],
                       level["contour"][..., 2]], axis=-1)
    assert np.min(np.max(np.abs(np.log(values / seed)), axis=-1)) > math.log(2.0)
    off = exact_ctc_error_iae(21.5, 10.0, start=(0.0, 0.10, 0.15), duration_s=0.5, step_s=1e-4)
    fitted = np.array([off["tracking"][1], off["tracking"][2], off["contour"][1], off["contour"][2]])
    assert np.all(np.abs(fitted / seed - 1) < 0.30)
    machine = track("ctc", duration_s=0.2, control_period_s=2e-3).iae("task")["tracking"]
    model = exact_ctc_error_iae(default.proportional, default.derivative, duration_s=0.2, step_s=1e-4)["tracking"]
    assert machine[2] == pytest.approx(model[2], rel=0.1)
    assert machine[1] < 0.05 * machine[2]
