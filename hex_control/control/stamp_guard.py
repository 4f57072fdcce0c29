"""Which stamps of a measurement stream to answer, and when its clock has jumped.

A lock-step plant stamps its states in sim time, one control period apart, and sends a state
again (the same stamp) until it is answered. Its clock starts again from zero when it
restarts; a stray publisher can send any stamp at all. The rule, for stamps in integer ns:

- a stamp in (last, last + max_step]: the next one, taken;
- the last stamp again: a repeat of what is answered, ignored;
- any other stamp (backwards, or a leap ahead): held as the possible start of a new
  timeline and refused, until the next stamp confirms it -- the same stamp again (the plant
  re-sending an unanswered state) or one in (held, held + max_step]. A confirmed jump is
  taken, and the caller restarts what it derived from the old timeline; a stamp that fits
  the old timeline instead drops the held one (one stray message changes nothing).

So a restarted plant is followed after one re-send, and a single hostile stamp is refused
without disturbing the loop.
"""

from __future__ import annotations

import enum


class Stamp(enum.Enum):
    NEXT = "next"  # the stream's next stamp: answer it
    REPEAT = "repeat"  # the last answered stamp again: ignore it
    REFUSED = "refused"  # off the timeline, not (yet) confirmed: count it, do not answer
    JUMPED = "jumped"  # the first of a confirmed new timeline: restart, then answer it


class StampGuard:
    """Classifies the stamps (ns) of one stream; see the module docstring."""

    def __init__(self, max_step_ns: int):
        if max_step_ns <= 0:
            raise ValueError(f"max_step_ns must be > 0, got {max_step_ns}")
        self.max_step_ns = int(max_step_ns)
        self.last_ns: int | None = None
        self.held_ns: int | None = None
        self.jump_ns = 0  # the last confirmed jump (new - old), ns

    def check(self, stamp_ns: int) -> Stamp:
        stamp_ns = int(stamp_ns)
        if self.last_ns is None:
            self.last_ns = stamp_ns
            return Stamp.NEXT
        if stamp_ns == self.last_ns:
            return Stamp.REPEAT
        if self.last_ns < stamp_ns <= self.last_ns + self.max_step_ns:
            self.last_ns, self.held_ns = stamp_ns, None
            return Stamp.NEXT
        if self.held_ns is not None and self.held_ns <= stamp_ns <= self.held_ns + self.max_step_ns:
            self.jump_ns = stamp_ns - self.last_ns
            self.last_ns, self.held_ns = stamp_ns, None
            return Stamp.JUMPED
        self.held_ns = stamp_ns
        return Stamp.REFUSED
