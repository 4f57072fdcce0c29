"""Limits the plant enforces below every controller (hex_control.plant.limits, issue 21):
strokes refused, the table's travel clamped, an overload tripped and reset."""

import math

import pytest

from hex_control.plant.limits import ForceAxisLimits, check_strokes


def test_a_strut_outside_its_stroke_is_refused_and_named():
    check_strokes([2.05, 3.35, 2.5, 2.5, 2.5, 2.5], 2050.0, 3350.0)  # the ends are inside
    with pytest.raises(ValueError, match="strut 2 at 50000.0 mm"):
        check_strokes([2.5, 2.5, 50.0, 2.5, 2.5, 2.5], 2050.0, 3350.0)
    with pytest.raises(ValueError, match="strut 0"):
        check_strokes([math.nan] + [2.5] * 5, 2050.0, 3350.0)


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
