"""Which stamps of a measurement stream to answer, and when its clock has jumped.

A lock-step plant stamps its states in sim time, one control period apart, and sends a state
again (the same stamp) until it is answered. Its clock starts again from zero when it
restarts; a stray publisher can send any stamp at all. The rule, for stamps in integer ns:

- a stamp in (last, last + max_step]: the next one, taken;
- the last stamp again: a repeat of what is answered, ignored;
- a stamp in [last - max_step, last): late, taken -- the stream's own state after a stray
  one a little ahead of it was taken (a lock-step plant waits for its answer: refusing it
  would stall the loop, and a confirmation would then count as a jump backwards);
- any other stamp (further back, or a leap ahead): held as the possible start of a new
  timeline and refused, until the next stamp confirms it -- the same stamp again (the plant
  re-sending an unanswered state) or one in (held, held + max_step]. A confirmed jump is
  taken, and the caller restarts what it derived from the old timeline; a stamp that fits
  the old timeline instead drops the held one (one stray message changes nothing).

So a restarted plant is followed after one re-send, and a single hostile stamp is refused
(or, within max_step, answered as one more state) without disturbing the loop. max_step
is a few control periods (issue 37: at 1 s, one wrench stamped +0.3 s was taken as the
next state, the plant's own then as a jump backwards, and the pass's trajectory dropped).
"""

from __future__ import annotations

import enum


class Stamp(enum.Enum):
    NEXT = "next"  # the stream's next stamp: answer it
    REPEAT = "repeat"  # the last answered stamp again: ignore it
    REFUSED = "refused"  # off the timeline, not (yet) confirmed: count it, do not answer
    JUMPED = "jumped"  # the first of a confirmed new timeline: restart, then answer it
    LATE = "late"  # behind the last by at most max_step: the stream's own after a stray ahead; answer it


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
        if self.last_ns - self.max_step_ns <= stamp_ns < self.last_ns:
            self.last_ns, self.held_ns = stamp_ns, None
            return Stamp.LATE
        if self.held_ns is not None and self.held_ns <= stamp_ns <= self.held_ns + self.max_step_ns:
            self.jump_ns = stamp_ns - self.last_ns
            self.last_ns, self.held_ns = stamp_ns, None
            return Stamp.JUMPED
        self.held_ns = stamp_ns
        return Stamp.REFUSED
