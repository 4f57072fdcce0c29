"""StampGuard: the stamps of a lock-step measurement stream, a restarted plant, a stray stamp."""

import pytest

from hex_control.control.stamp_guard import Stamp, StampGuard

MS = 1_000_000  # ns


def checks(guard, stamps_ms):
    return [guard.check(s * MS) for s in stamps_ms]


def test_a_stream_in_order_with_repeats():
    guard = StampGuard(1000 * MS)
    assert checks(guard, [100, 105, 105, 110, 1110]) == [Stamp.NEXT, Stamp.NEXT, Stamp.REPEAT, Stamp.NEXT, Stamp.NEXT]


def test_a_restarted_plant_is_followed_after_one_re_send():
    guard = StampGuard(1000 * MS)
    checks(guard, range(0, 50_001, 5))  # 50 s of a plant ...
    assert checks(guard, [0, 0, 5]) == [Stamp.REFUSED, Stamp.JUMPED, Stamp.NEXT]  # ... restarted: 0, re-sent
    assert guard.jump_ns == -50_000 * MS
    assert checks(StampGuard(50 * MS), [600, 605, 0, 5, 10]) == [Stamp.NEXT, Stamp.NEXT, Stamp.REFUSED,
                                                                 Stamp.JUMPED, Stamp.NEXT]  # realtime: no re-send


@pytest.mark.parametrize("stray_ms", [2**31 * 1000 - 1, -5_000, 0, 3_000])
def test_one_stray_stamp_is_refused_and_changes_nothing(stray_ms):
    guard = StampGuard(1000 * MS)
    checks(guard, [1000, 1005])
    assert checks(guard, [stray_ms, 1010, 1015]) == [Stamp.REFUSED, Stamp.NEXT, Stamp.NEXT]
    assert guard.last_ns == 1015 * MS and guard.held_ns is None


def test_a_gap_beyond_the_step_is_taken_once_confirmed():
    guard = StampGuard(1000 * MS)
    checks(guard, [0, 5])
    assert checks(guard, [2005, 2010]) == [Stamp.REFUSED, Stamp.JUMPED]
    assert guard.jump_ns == 2005 * MS
    with pytest.raises(ValueError):
        StampGuard(0)


def test_one_stamp_ahead_within_the_window_leaves_the_streams_own_states_answered():
    """Issue 37: one wrench stamped +0.3 s inside a 1 s window was taken as the next state;
    the plant's own states, now behind it, were held, confirmed by the re-send and taken as a
    jump back (the trajectory dropped). The plant's states after a stray ahead are late, and
    answered; with the shipped 50 ms window the +0.3 s stray is refused outright."""
    guard = StampGuard(1000 * MS)
    checks(guard, [1000, 1005])
    assert checks(guard, [1305, 1010, 1010, 1015]) == [Stamp.NEXT, Stamp.LATE, Stamp.REPEAT, Stamp.NEXT]
    guard = StampGuard(50 * MS)
    checks(guard, [1000, 1005])
    assert checks(guard, [1305, 1010, 1015]) == [Stamp.REFUSED, Stamp.NEXT, Stamp.NEXT]
    assert checks(guard, [1040, 1020, 1025]) == [Stamp.NEXT, Stamp.LATE, Stamp.NEXT]
    assert checks(guard, [950]) == [Stamp.REFUSED]  # 75 ms back: a jump only once confirmed
