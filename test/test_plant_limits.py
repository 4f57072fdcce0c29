"""Limits the plant enforces below every controller (hex_control.plant.limits, issue 21):
strokes refused, strut speed and acceleration limited, the table's travel clamped, an
overload tripped and reset."""

import math

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.grinding.config import load_pass_planner_config
from hex_control.kinematics import load_machine
from hex_control.plant.limits import ForceAxisLimits, StrutRateLimiter
from hex_control.plant.reset_time import pass_strut_lengths_m
from hex_control.shaping.shapers import design

PERIOD_S = 0.005


def test_a_strut_outside_its_stroke_is_refused_and_named():
    nist, _ = load_machine(config_file("machines/nist_ingersoll.yaml"))  # strokes 2050 .. 3350 mm
    nist.check_joint_positions_mm([2050.0, 3350.0, 2500.0, 2500.0, 2500.0, 2500.0])  # the ends are inside
    with pytest.raises(ValueError, match="strut 2 at 50000.0 mm"):
        nist.check_joint_positions_mm([2500.0, 2500.0, 50000.0, 2500.0, 2500.0, 2500.0])
    with pytest.raises(ValueError, match="strut 0"):
        nist.check_joint_positions_mm([math.nan] + [2500.0] * 5)
    with pytest.raises(ValueError, match="need 6 strut lengths"):
        nist.check_joint_positions_mm([2500.0] * 3)


def test_the_force_axis_is_clamped_to_the_tables_travel():
    limits = ForceAxisLimits((-5.0, 2.0), 150.0)
    assert limits.command_mm(1000.0, 0.0) == 2.0 and limits.command_mm(-80.0, 0.0) == -5.0
    assert limits.command_mm(0.7, 58.0) == 0.7
    assert limits.clamped == 2 and limits.trips == 0


def test_an_overload_retracts_until_the_command_asks_for_no_force():
    limits = ForceAxisLimits((-5.0, 2.0), 150.0, contact_mm=0.0)
    assert limits.command_mm(1.9, 151.0) == -5.0 and limits.tripped and limits.trips == 1
    assert limits.command_mm(1.9, 0.0) == -5.0  # the controller still pushes: held retracted
    assert limits.command_mm(1.0, 0.0) == -5.0
    assert limits.command_mm(-0.5, 0.0) == -0.5 and not limits.tripped  # it backed off: reset
    assert limits.command_mm(0.5, 40.0) == 0.5 and limits.trips == 1


@pytest.mark.parametrize("bad", [dict(travel_mm=(1.0, 2.0)), dict(travel_mm=(-5.0, math.inf)),
                                 dict(overload_n=0.0), dict(overload_n=math.nan)])
def test_nonsense_limits_are_refused(bad):
    with pytest.raises(ValueError):
        ForceAxisLimits(**bad)


def _run(limiter, targets_m):
    return np.array([limiter.command(t, PERIOD_S) for t in targets_m])


def test_a_jump_becomes_a_move_within_the_servos_speed_and_acceleration():
    """Issue 21: a strut command 100 mm away (a hostile or broken controller) reaches the
    servos as a move at <= 0.5 m/s and <= 5 m/s^2 that lands on the target without
    overshoot, all struts in step (one scale factor: the platform keeps its direction)."""
    limiter = StrutRateLimiter(0.5, 5.0)
    limiter.reset(np.full(6, 2.5))
    target = np.array([2.6, 2.45, 2.5, 2.5, 2.5, 2.5])
    out = _run(limiter, [target] * 400)
    speed = np.diff(np.vstack([np.full(6, 2.5), out]), axis=0) / PERIOD_S
    acceleration = np.diff(np.vstack([np.zeros(6), speed]), axis=0) / PERIOD_S
    assert np.max(np.abs(speed)) == pytest.approx(0.5, rel=1e-9)
    assert np.max(np.abs(acceleration)) <= 5.0 * (1 + 1e-9)
    np.testing.assert_allclose(out[-1], target, atol=1e-12)
    assert out[:, 0].max() <= 2.6 + 1e-12 and out[:, 1].min() >= 2.45 - 1e-12  # no overshoot
    moved = out - 2.5
    np.testing.assert_allclose(moved[:, 1], -0.5 * moved[:, 0], atol=1e-12)  # in step
    assert limiter.limited > 10


def test_a_path_within_the_limits_passes_unchanged():
    limiter = StrutRateLimiter(0.5, 5.0)
    t = np.arange(0.0, 2.0, PERIOD_S)
    path = 2.5 + 0.02 * (1 - np.cos(5 * t))[:, None] * np.linspace(-1, 1, 6)  # starts at rest
    limiter.reset(path[0])
    np.testing.assert_allclose(_run(limiter, path[1:]), path[1:], atol=1e-12)
    assert limiter.limited == 0


def test_each_joint_keeps_its_own_limits_and_all_move_in_step():
    """The 3-PRU head on its feed stage: sliders at 0.2 m/s and 2 m/s^2, the stage at
    0.5 m/s and 30 m/s^2 (config/machines/pru3_feed.yaml). A jump of every joint reaches the
    servos within each joint's own limits, the tightest joint setting the pace of all."""
    speed, acceleration = np.array([0.2, 0.2, 0.2, 0.5]), np.array([2.0, 2.0, 2.0, 30.0])
    limiter = StrutRateLimiter(speed, acceleration)
    start = np.array([0.05, 0.05, 0.05, 0.0])
    limiter.reset(start)
    target = start + np.array([0.01, -0.02, 0.0, 0.3])  # the stage's 300 mm are the longest move
    out = _run(limiter, [target] * 600)
    v = np.diff(np.vstack([start, out]), axis=0) / PERIOD_S
    a = np.diff(np.vstack([np.zeros(4), v]), axis=0) / PERIOD_S
    assert np.all(np.abs(v).max(axis=0) <= speed * (1 + 1e-9))
    assert np.all(np.abs(a).max(axis=0) <= acceleration * (1 + 1e-9))
    assert np.abs(v[:, 3]).max() == pytest.approx(0.5, rel=1e-9)  # the stage's own speed limit binds
    np.testing.assert_allclose(out[-1], target, atol=1e-12)
    moved = out - start
    np.testing.assert_allclose(moved[:, :3], np.outer(moved[:, 3] / 0.3, [0.01, -0.02, 0.0]), atol=1e-12)
    # with one slider's acceleration limit the pace of a slider's move, the stage waits for it
    limiter = StrutRateLimiter(speed, np.array([0.1, 2.0, 2.0, 30.0]))
    limiter.reset(start)
    out = _run(limiter, [start + np.array([0.01, 0.0, 0.0, 0.01])] * 600)
    a = np.diff(np.diff(np.vstack([start, start, out]), axis=0), axis=0) / PERIOD_S**2
    assert np.abs(a[:, 0]).max() <= 0.1 * (1 + 1e-9) and np.abs(a[:, 3]).max() <= 0.1 * (1 + 1e-9)


@pytest.mark.parametrize("bad", [(0.0, 5.0), (0.5, -1.0), (math.inf, 5.0), (0.5, math.nan),
                                 (np.array([0.5, 0.0]), 5.0), (0.5, np.array([5.0, math.inf])), (np.array([]), 5.0)])
def test_nonsense_strut_limits_are_refused(bad):
    with pytest.raises(ValueError):
        StrutRateLimiter(*bad)


@pytest.mark.parametrize("shaped", [False, True])
@pytest.mark.parametrize("feed_mm_s", [5.0, 75.0])
@pytest.mark.parametrize("bead_mm", [150.0, 300.0])
@pytest.mark.parametrize("machine_file", ["nist_ingersoll", "pru3_feed"])
def test_the_planned_paths_stay_well_inside_the_machine_files_joint_limits(machine_file, bead_mm, feed_mm_s, shaped):
    """The limits (not published) are chosen above what a pass's path asks: on the NIST
    hexapod (500 mm/s, 20 m/s^2) the reset move of a 300 mm bead peaks near 180 mm/s, the
    feed's start at 75 mm/s near 10.6 m/s^2 unshaped; on the 3-PRU head's feed stage (500
    mm/s, 30 m/s^2) the reset move peaks near 265 mm/s and the unshaped start of a 75 mm/s
    feed (a step of speed in one 5 ms sample) at 15 m/s^2, its sliders (200 mm/s, 2 m/s^2)
    near 31 mm/s and 0.1 m/s^2. The limiter leaves such paths untouched."""
    machine, document = load_machine(config_file(f"machines/{machine_file}.yaml"))
    config = load_pass_planner_config("pass_planner.yaml", document)
    height_mm = config.model.radius_mm * math.sin(config.model.relaxed_angle_rad) + 1.0
    lengths = pass_strut_lengths_m(machine, config.frame, bead_mm, feed_mm_s, height_mm, timing=config.path,
                                   shaper=design("zvd", 5.0, 0.02) if shaped else None)
    period_s = config.path.sample_period_s
    speed = np.diff(lengths, axis=0) / period_s * 1000.0
    acceleration = np.diff(speed, axis=0) / period_s
    assert np.all(np.max(np.abs(speed), axis=0) < 0.6 * machine.joint_speed_max_mm_s)
    assert np.all(np.max(np.abs(acceleration), axis=0) < 0.6 * machine.joint_acceleration_max_mm_s2)
    limiter = StrutRateLimiter(machine.joint_speed_max_mm_s / 1000.0, machine.joint_acceleration_max_mm_s2 / 1000.0)
    limiter.reset(lengths[0])
    np.testing.assert_allclose([limiter.command(row, period_s) for row in lengths[1:]], lengths[1:], atol=1e-12)
    assert limiter.limited == 0


def _array_limiter_command(state, target, period_s, speed_max, acceleration_max):
    """The limiter's law on arrays, as it was written before it moved to plain floats."""
    def least(limit, value):
        magnitude = np.abs(value)
        moving = magnitude > 0
        return float(np.min(np.broadcast_to(limit, magnitude.shape)[moving] / magnitude[moving])) if moving.any() \
            else math.inf
    command, old_target, speed = state
    behind = old_target - command
    pace = min(1.0 / period_s, least(acceleration_max, behind) ** 0.5) if np.any(behind) else 0.0
    change = (target - old_target) / period_s + behind * pace - speed
    speed = speed + min(1.0, least(acceleration_max * period_s, change)) * change
    speed = min(1.0, least(speed_max, speed)) * speed
    return command + speed * period_s, target, speed


def test_the_limiter_in_plain_floats_gives_the_array_laws_bits():
    """Issue 39: the per-period limiter runs in plain floats; every command is bit for bit
    what the array version gave, through jumps (limited) and small moves (passed)."""
    speed_max, acceleration_max = np.array([0.05, 0.04, 0.05, 0.06, 0.05, 0.05]), 0.5
    limiter = StrutRateLimiter(speed_max, acceleration_max)
    start = np.full(6, 2.5)
    limiter.reset(start)
    state = (start.copy(), start.copy(), np.zeros(6))
    rng = np.random.default_rng(1)
    target = start.copy()
    for period in range(600):
        target = target + (0.02 * rng.normal(size=6) if period % 100 == 0 else 1e-5 * rng.normal(size=6))
        state = _array_limiter_command(state, target, 0.005, speed_max, acceleration_max)
        assert np.array_equal(limiter.command(target, 0.005), state[0])
    assert limiter.limited > 0
