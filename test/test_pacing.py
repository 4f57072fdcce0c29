"""The real-time pacer: sim time keeps pace with the wall clock through late timer ticks."""

import pytest

from hex_control.plant.pacing import RealTimePacer


def test_on_time_ticks_step_one_period_each():
    pacer = RealTimePacer(0.005)
    assert [pacer.due(10.0 + 0.005 * k) for k in range(100)] == [1] * 100
    assert (pacer.late_ticks, pacer.dropped) == (0, 0)


def test_a_late_tick_steps_the_periods_it_missed():
    """A timer that skips ticks (rcl does) loses no sim time: 20 ms late owes 4 more periods."""
    pacer = RealTimePacer(0.005)
    assert pacer.due(0.0) == 1
    assert pacer.due(0.025) == 5
    assert pacer.due(0.027) == 0  # early: the next period is not yet due
    assert pacer.due(0.030) == 1
    assert pacer.stepped * 0.005 == pytest.approx(0.035)  # sim time = wall time since start + one period
    assert pacer.late_ticks == 1 and pacer.lag_s(0.030) == pytest.approx(0.0, abs=1e-12)


def test_the_real_time_factor_scales_the_wall_period():
    pacer = RealTimePacer(0.005, real_time_factor=0.5)  # half speed: a period every 10 ms of wall time
    assert sum(pacer.due(0.001 * k) for k in range(1001)) == 101


def test_a_simulation_far_behind_gives_up_the_excess_and_counts_it():
    pacer = RealTimePacer(0.005, max_lag_periods=20)
    pacer.due(0.0)
    assert pacer.due(1.0) == 20  # 200 periods owed: step 20, give up 180
    assert pacer.dropped == 180
    assert pacer.due(1.005) == 1  # then on time again from there
    assert pacer.lag_s(1.005) == pytest.approx(0.9, abs=1e-9)


def test_bad_settings_are_refused():
    for args in ((0.0,), (0.005, 0.0), (0.005, 1.0, 0)):
        with pytest.raises(ValueError):
            RealTimePacer(*args)
