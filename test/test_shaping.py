"""Input shaping (seed 003): closed-form shapers, residual vibration, optimized sequences,
the online filter."""

import math

import numpy as np
import pytest

from hex_control.shaping.filter import ShaperFilter
from hex_control.shaping.optimize import DesignProblem, criterion, optimize
from hex_control.shaping.shapers import SHAPERS, Shaper, convolve, design, zv, zvd
from hex_control.shaping.vibration import insensitivity, mode_response, residual_vibration

SEED_TABLE = Shaper(np.array([0.1503, 0.1736, 0.1975, 0.3399, 0.1388]),
                    np.array([0.0, 2.4776, 3.0949, 5.4923, 8.2632]) / (2 * math.pi))  # omega_0 = 1 Hz * 2 pi


def test_zv_and_zvd_residual_vibration_formulas():
    """Undamped: ZV leaves |cos(pi r/2)|, ZVD cos^2(pi r/2) (0.1564 at r = 0.9, 0.3090 at 0.8)."""
    r = np.array([0.8, 0.9, 1.0, 1.2])
    np.testing.assert_allclose(residual_vibration(zv(1.0), r), np.abs(np.cos(np.pi * r / 2)), atol=1e-12)
    np.testing.assert_allclose(residual_vibration(zvd(1.0), r), np.cos(np.pi * r / 2) ** 2, atol=1e-12)
    assert residual_vibration(zv(1.0), 0.9) == pytest.approx(0.1564, abs=1e-4)
    assert residual_vibration(zv(1.0), 0.8) == pytest.approx(0.3090, abs=1e-4)


@pytest.mark.parametrize("kind", sorted(SHAPERS))
@pytest.mark.parametrize("damping", [0.0, 0.05])
def test_each_shaper_cancels_its_mode_in_simulation(kind, damping):
    """Simulate the mode driven by the shaped step: after the shaper ends, its oscillation
    relative to that of an unshaped step applied at the shaper's end (the reference of the
    standard V, hence e^(-zeta w t_N)) equals V -- 0 for ZV/ZVD/ZVDD/MZV/2-hump EI, at most
    V_tol for EI and 3-hump EI (whose design frequency sits on a hump; with damping the
    K-factor approximation leaves them a little below V_tol). Checked by response, not only
    by the formula."""
    f, dt = 2.0, 1e-4
    shaper = design(kind, f, damping)
    t = np.arange(0, 6.0, dt)
    step = np.where(t >= shaper.delay_s, 1.0, 0.0)
    shaped = ShaperFilter(shaper, dt, interpolate=True).filter(np.where(t > 0.0, 1.0, 0.0)[:, None])[:, 0]
    shaped[0] = 0.0
    after = t > shaper.delay_s + 0.01

    def amplitude(command):
        y = mode_response(t, command, f, damping)[after] - 1.0
        decay = np.exp(damping * 2 * np.pi * f * (t[after] - t[after][0]))
        return np.max(np.abs(y * decay))
    expected = residual_vibration(shaper, f, damping)
    assert amplitude(shaped) / amplitude(step) == pytest.approx(expected, abs=3e-3)
    if kind in ("ei", "3hump_ei"):
        assert expected <= 0.05 + 1e-9 and (damping > 0 or expected == pytest.approx(0.05))
    else:
        assert expected < 1e-9


@pytest.mark.parametrize("kind, published, tolerance, delay_periods", [
    ("zv", 0.064, 0.0005, 0.5), ("zvd", 0.287, 0.0005, 1.0), ("ei", 0.40, 0.001, 1.0),
    ("2hump_ei", 0.73, 0.01, 1.5), ("3hump_ei", 0.97, 0.01, 2.0)])
def test_insensitivity_at_5_percent(kind, published, tolerance, delay_periods):
    """Published 5 % insensitivities and durations (in periods T), undamped. ZV, ZVD and EI
    agree to 3 digits; the closed-form 2- and 3-hump EI give 0.7245 and 0.9638 (their humps
    sit exactly at 5 %, so the band is not cut short), 0.006 below the published 0.73/0.97."""
    shaper = design(kind, 1.0)
    assert insensitivity(shaper, 1.0) == pytest.approx(published, abs=tolerance)
    assert shaper.delay_s == pytest.approx(delay_periods)  # design at 1 Hz: T = 1 s


def test_convolution_cancels_both_modes():
    both = convolve(zv(1.0), zv(3.0))
    assert np.all(residual_vibration(both, [1.0, 3.0]) < 1e-12) and both.amplitudes.sum() == pytest.approx(1.0)


def test_seed_5_impulse_table_scores_its_printed_criterion():
    """Seed Table (section 3): criterion 0.0250 for 0.85, 1, 1.5 omega_0 -- eq. 12 summed over
    the frequencies with normalized amplitudes gives 0.0249."""
    problem = DesignProblem(frequencies_hz=(0.85, 1.0, 1.5), impulses=5)
    value = criterion(problem, SEED_TABLE.amplitudes[None], SEED_TABLE.times_s[None])[0]
    assert value == pytest.approx(0.0250, abs=2e-4)


def test_optimized_5_impulse_design_matches_or_beats_the_seed_and_zvd():
    """Our evolution reaches the seed's criterion (<= 0.025), keeps V low over 0.7-1.6 omega_0
    like the seed's (its zeros at 0.85, 1 and 1.5), at a delay comparable to ZVD (<= 1.5 T;
    the seed's 1.32 T), and beats ZVD on +-30 % frequency error (seed Fig. 11-12)."""
    design_ = optimize(DesignProblem(frequencies_hz=(0.85, 1.0, 1.5), impulses=5, max_delay_s=1.5), seed=1)
    assert design_.criterion <= 0.025
    assert design_.shaper.delay_s <= 1.5
    band = np.linspace(0.7, 1.3, 121)
    ours, seed, classic = (residual_vibration(s, band).max() for s in (design_.shaper, SEED_TABLE, zvd(1.0)))
    assert ours < 0.5 * classic and seed < classic
    wide = np.linspace(0.75, 1.55, 161)
    assert residual_vibration(design_.shaper, wide).max() < 0.15


def test_band_design_minimizes_the_worst_vibration():
    problem = DesignProblem(band_hz=(0.8, 1.2), impulses=4, max_delay_s=1.5)
    design_ = optimize(problem, seed=2, generations=300)
    band = np.linspace(0.8, 1.2, 81)
    assert residual_vibration(design_.shaper, band).max() < residual_vibration(zvd(1.0), band).max()


def test_online_filter_equals_offline_convolution_and_is_multichannel():
    dt = 0.001
    shaper = Shaper(np.array([0.3, 0.5, 0.2]), np.array([0.0, 0.012, 0.031]))  # on the grid
    x = np.random.default_rng(0).normal(size=(500, 6)).cumsum(axis=0)
    online = ShaperFilter(shaper, dt, channels=6)
    streamed = np.array([online.step(row) for row in x])
    offline = ShaperFilter(shaper, dt, channels=6).filter(x)
    np.testing.assert_allclose(streamed, offline, atol=1e-12)
    reference = sum(a * np.concatenate([np.repeat(x[:1], k, axis=0), x])[: len(x)]
                    for a, k in zip(shaper.amplitudes, (0, 12, 31)))
    np.testing.assert_allclose(offline, reference, atol=1e-12)


def test_a_step_becomes_the_staircase_and_a_shaper_change_causes_no_jump():
    dt = 0.001
    filt = ShaperFilter(zvd(10.0), dt)
    out = [filt.step([0.0])[0] for _ in range(5)] + [filt.step([1.0])[0] for _ in range(120)]
    assert sorted(set(np.round(out, 12))) == [0.0, 0.25, 0.75, 1.0]
    filt.reset(0.0)
    outputs = [filt.step([min(k * 0.01, 1.0)])[0] for k in range(60)]
    filt.set_shaper(zv(7.0))
    outputs += [filt.step([min((k + 60) * 0.01, 1.0)])[0] for k in range(200)]
    assert np.max(np.abs(np.diff(outputs))) < 0.011  # no jump beyond the ramp's own step
    assert outputs[-1] == pytest.approx(1.0)


def test_rounding_vs_interpolating_the_impulse_times():
    """What placing a ZV's impulses on a 10 ms grid costs at a 7.3 Hz mode (half period
    68.5 ms): rounding moves the second impulse to 70 ms, interpolation splits it."""
    shaper = zv(7.3)
    rounded = residual_vibration(ShaperFilter(shaper, 0.01).effective_shaper, 7.3)
    interpolated = residual_vibration(ShaperFilter(shaper, 0.01, interpolate=True).effective_shaper, 7.3)
    assert rounded == pytest.approx(abs(math.sin(math.pi * 7.3 * 0.0015)), abs=1e-3)  # 1.5 ms timing error
    assert interpolated < rounded


def test_bad_input_is_refused():
    with pytest.raises(ValueError):
        ShaperFilter(zv(1.0), 0.001).step([math.nan])
    with pytest.raises(ValueError):
        design("posicast", 1.0)
    with pytest.raises(ValueError):
        zv(-1.0)


@pytest.mark.parametrize("kind", ["zvd", "ei"])
def test_a_reset_move_settles_sooner_when_shaped(kind):
    """A 100 mm reset step through a lightly damped 5 Hz structural mode (zeta = 0.02), the
    shaper designed for 5.5 Hz (10 % off): the 2 % settle time drops more than 3x (measured:
    unshaped 6.21 s, ZVD 0.17 s, EI 0.69 s; a plain ZV only halves it, 3.16 s -- too narrow
    for a 10 % error). On the library's mode model; the plant node wires it in issue 6."""
    from hex_control.shaping.vibration import settle_time

    dt = 1e-3
    t = np.arange(0.0, 12.0, dt)
    raw = np.where(t >= 0.1, 100.0, 0.0)
    shaped = ShaperFilter(design(kind, 5.5), dt, interpolate=True).filter(raw[:, None])[:, 0]
    unshaped_settle = settle_time(t, mode_response(t, raw, 5.0, 0.02), 100.0, 0.0) - 0.1
    shaped_settle = settle_time(t, mode_response(t, shaped, 5.0, 0.02), 100.0, 0.0) - 0.1
    assert unshaped_settle > 3 * shaped_settle and unshaped_settle > 5.0


def test_a_whole_path_is_shaped_as_the_stream_would_be_until_it_rests():
    """The input shaper's per-pass path (shape_whole) equals the online filter fed the same
    samples one by one and then the last sample until the shaper's delay has passed."""
    from hex_control.shaping.filter import shape_whole

    rng = np.random.default_rng(3)
    path = np.cumsum(rng.normal(size=(300, 6)), axis=0)
    shaper = design("zvd", 5.0, 0.02)
    for interpolate in (False, True):
        whole, _ = shape_whole(shaper, 0.005, path, interpolate)
        online = ShaperFilter(shaper, 0.005, 6, interpolate)
        extra = len(whole) - len(path)
        streamed = np.array([online.step(row) for row in np.concatenate([path, np.repeat(path[-1:], extra, 0)])])
        assert extra == round(online.delay_s / 0.005)
        np.testing.assert_allclose(whole, streamed, rtol=0, atol=1e-9)
        np.testing.assert_allclose(whole[-1], path[-1], atol=1e-9)  # it ends at rest on the last sample
    with pytest.raises(ValueError):
        shape_whole(shaper, 0.005, [[0.0, math.nan]])


def test_a_whole_path_started_its_lag_early_is_on_time_at_constant_feed():
    """The bead-end gouge of issue 20: the force trajectory is timed against the planned
    path; the shaped path, started when the planned one starts, trails it by the ZVD's lag
    (half its duration, 0.1 s at 5 Hz): 5.2 mm at 51.8 mm/s, where the demo's end-of-pass
    force peak landed on finished parent (gouge 0.44 mm at x = 293 of 300 mm). Started the
    lag early, it is on the planned path wherever the feed is constant."""
    from hex_control.shaping.filter import shape_whole

    dt, feed = 0.005, 51.8
    t = np.arange(0.0, 4.0, dt)
    x = np.clip(feed * (t - 1.0), 0.0, feed * 2.0)  # rest, 2 s at the feed, rest
    shaper = design("zvd", 5.0, 0.0)
    for interpolate in (False, True):
        shaped, lag_s = shape_whole(shaper, dt, x[:, None], interpolate)
        assert lag_s == pytest.approx(0.1, abs=dt / 2 if not interpolate else 1e-9)
        steady = (t > 1.3) & (t < 2.9)
        late = np.interp(t[steady], np.arange(len(shaped)) * dt, shaped[:, 0])  # started with the plan
        on_time = np.interp(t[steady], np.arange(len(shaped)) * dt - lag_s, shaped[:, 0])  # started lag early
        np.testing.assert_allclose(x[steady] - late, feed * lag_s, atol=1e-6)
        np.testing.assert_allclose(on_time, x[steady], atol=1e-6)
