"""The force controller's touch-down (hex_control.control.touch_down): the table reaches the
work's standoff before a pass starts, and the force loop then closes on the first samples.
The cause it fixes (issue 20): from the retracted stop the PI took 0.15-0.3 s to find the
work, leaving 2-5 mm of the bead's start unground and winding up its integrator."""

import math

import pytest

from hex_control.control.force_law import PIForceLaw
from hex_control.control.pi import TustinPI
from hex_control.control.touch_down import TouchDown
from hex_control.plant.force_table import ForceTable, ForceTableParameters

PERIOD_S = 0.005
RETRACTED_MM = -2.0


def test_the_move_starts_just_in_time_and_arrives_before_the_start():
    touch = TouchDown(contact_mm=0.0, standoff_mm=0.1, speed_mm_s=10.0, settle_s=0.1)
    command, time_to_start, trace = RETRACTED_MM, 1.0, []
    while time_to_start > 0:
        command = touch.command_mm(command, time_to_start, 0.0, PERIOD_S)
        trace.append((time_to_start, command))
        time_to_start -= PERIOD_S
    moving = [t for t, c in trace if c > RETRACTED_MM]
    # 1.9 mm at 10 mm/s is 0.19 s, to end 0.1 s before the start: the move begins 0.29 s before it
    assert max(moving) == pytest.approx(0.29, abs=2 * PERIOD_S)
    arrived = [t for t, c in trace if c == touch.target_mm]
    assert max(arrived) == pytest.approx(0.1, abs=2 * PERIOD_S)
    steps = [b - a for (_, a), (_, b) in zip(trace, trace[1:])]
    assert max(steps) <= 10.0 * PERIOD_S + 1e-12 and min(steps) >= 0.0


def test_felt_force_stops_the_move_towards_the_work():
    touch = TouchDown()
    assert touch.command_mm(-0.5, 0.05, 5.0, PERIOD_S) == -0.5
    assert touch.command_mm(-0.5, 0.05, 0.0, PERIOD_S) == pytest.approx(-0.45)
    # beyond the target (a command left pressing) it still backs off to the standoff
    assert touch.command_mm(0.5, 0.05, 30.0, PERIOD_S) == pytest.approx(0.45)


@pytest.mark.parametrize("bad", [dict(speed_mm_s=0.0), dict(standoff_mm=-0.1), dict(felt_n=math.nan),
                                 dict(settle_s=math.inf), dict(contact_mm="0")])
def test_bad_figures_are_refused(bad):
    with pytest.raises(ValueError):
        TouchDown(**bad)


def _time_to_force(start_mm: float, desired_n: float = 60.0) -> float:
    """Sim time (s) until the table's true force first reaches 90 % of a force step, from
    a table held at ``start_mm``, under the shipped PI (config/force_controller.yaml)."""
    table = ForceTable(ForceTableParameters(), step_s=0.001)
    table.reset(start_mm)
    law = PIForceLaw(TustinPI(0.01238, 0.3095, PERIOD_S, RETRACTED_MM, 2.0))
    law.reset(start_mm)
    for k in range(400):
        command = law.command(desired_n, table.measured_n)
        for _ in range(5):
            table.step(command)
        if table.force_n >= 0.9 * desired_n:
            return (k + 1) * PERIOD_S
    return math.inf


def test_a_loop_started_at_the_standoff_finds_the_force_several_times_sooner():
    from_retracted, from_standoff = _time_to_force(RETRACTED_MM), _time_to_force(TouchDown().target_mm)
    # the old behaviour: 0.225 s of the pass short of its force (3.6 mm of bead at 15.8 mm/s);
    # from the standoff 0.045 s, mostly the table's own 9 Hz pole
    assert from_retracted > 0.2
    assert from_standoff < 0.06 and from_standoff < from_retracted / 4
