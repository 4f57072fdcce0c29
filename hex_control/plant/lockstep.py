"""The plant's lock-step gate (issue 19, DESIGN.md 4.1): when the simulated hardware may
advance one control period.

The handshake. After publishing its state at time t the plant waits for the force-axis
command that answers it (stamped t, the state it answers); only that answer steps the
loop. A command stamped otherwise (a late or repeated answer, a stranger's) is counted
and changes nothing: it can neither stop nor shift the loop. Until a first command has
answered, an unanswered state is sent again every ``lockstep_timeout_s`` of wall time;
after that the waiting measurement is sent once more a quarter of the timeout after its
period was simulated (it or its answer lost on the way), and a timeout means the
controller stopped answering: the plant runs free on the wall clock with the held command
until commands return.

The cover. With a workpiece, sim time also never outruns the trajectories: it advances
only while a pass runs, or is announced with the strut trajectory of its whole path held
(from the path's start, or earlier: a shaped path starts its shaper's lag early, to the
path's end) and, unless told not to wait, the force controller saying it holds the pass's
force trajectory. Between passes the clock stands still while the planners plan, so the
time a pass waits for is the pass planner's fixed ``start_delay_s``: one seed, one part,
at any machine load.

Planning ahead (issue 39). The next pass's path starts ``start_delay_s`` after the scan
that ends a pass, whatever the planners take, and until it starts the machine only holds
its reset pose: so after each scan the plant runs on ``plan_ahead_s`` (:data:`PLAN_AHEAD_S`)
of sim time while the planners plan, and stands only if they need longer. The periods
simulated are the same either way (the path's start does not depend on when the plan
came), as long as the plan still comes before its path: ``plan_ahead_s`` stays below
``start_delay_s`` less the input shaper's lag (0.1 s for the shipped machines' 5 Hz ZVD),
which the pass planner makes sure of.

Units: s (plant time; wall time on a monotonic clock).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable

from hex_control.plant.loop_timing import LoopTiming
from hex_control.plant.pass_monitor import ScheduledPass
from hex_control.plant.strut_trajectory import StrutTrajectory

#: sim time (s) a lock-step plant runs on after a scan while the next pass is planned: the
#: plant's and the pass planner's default (``plan_ahead_s``); below the pass planner's
#: ``start_delay_s`` (0.6 s) less the shaper's lag (a 5 Hz ZVD: 0.1 s), so every plan still
#: comes before its path (pass_session.SHAPER_LAG_MARGIN_S)
PLAN_AHEAD_S = 0.4
STAMP_TOLERANCE_S = 1e-6  # a trajectory starting this little after its pass's path still covers it


def time_ns(time_s: float) -> int:
    """Plant time on the nanosecond grid the plant stamps its states with."""
    return round(time_s * 1e9)


def pass_covered(scheduled: ScheduledPass | None, trajectories: Iterable[StrutTrajectory],
                 controller_holds: Collection[tuple[str, int]], wait_for_controller: bool) -> bool:
    """Is the announced pass ready to run: the motion of its whole path in hand and, when
    waited for, its force trajectory in the controller's hands?"""
    if scheduled is None:
        return False
    if not any(t.start_s <= scheduled.path_start_s + STAMP_TOLERANCE_S and t.end_s >= scheduled.path_end_s
               for t in trajectories):
        return False
    return not wait_for_controller or (scheduled.job_id, scheduled.pass_index) in controller_holds


class LockstepGate:
    """The handshake's state: ``sent`` when a state goes out, ``answer`` when a command
    stamped with the waiting state arrives; ``answer_ready`` until the step it allows is
    taken; ``holding`` while the plant stands still between passes; ``free_running``
    while the controller is silent. Times are wall times (s) on one monotonic clock."""

    def __init__(self):
        self.timing = LoopTiming()
        self.answer_ready = False  # the command answering the last state is in hand
        self.holding = False  # standing still until a pass is covered
        self.free_running = False  # the controller stopped answering: running on the wall clock
        self.started = False  # a first command has answered a state
        self.waiting_since_s: float | None = None  # the unanswered measurement's period ended here
        self.resent = False  # the unanswered measurement was said again
        self.loop_start_s: float | None = None  # wall time of the first answer

    @staticmethod
    def answers(stamp_ns: int | None, time_s: float) -> bool:
        """Is a command stamped ``stamp_ns`` (None: not a valid stamp) the answer to the
        state at plant time ``time_s``?"""
        return stamp_ns is not None and stamp_ns == time_ns(time_s)

    def sent(self, now_s: float) -> None:
        """A measurement went out (the command latency counts from here)."""
        self.timing.sent(now_s)
        self.waiting_since_s, self.resent = None, False

    def period_simulated(self, now_s: float) -> None:
        """The rest of the period whose measurement went out is simulated: from now on the
        wait for its answer is the controller's (the plant's own work is not its silence)."""
        if self.timing.pending_since_s is not None:
            self.waiting_since_s = now_s

    def answer(self, now_s: float) -> bool:
        """A command arrived; True if it answers the last state sent (then the first one
        also starts the loop's timing: start-up is not the loop)."""
        answered = self.timing.answered(now_s)
        if answered and not self.started:
            self.started, self.loop_start_s = True, now_s
            self.timing = LoopTiming()
        return answered

    def stalled(self, start_s: float, end_s: float) -> None:
        """The plant itself stood from about ``start_s`` to ``end_s`` (wall s; stopped,
        swapped out): a wait for the answer that began before is that much shorter. A
        wait that began within the span began after the plant went on (it sent the state):
        the controller's from its start."""
        if self.waiting_since_s is not None and self.waiting_since_s < start_s:
            self.waiting_since_s += end_s - start_s

    def timed_out(self, now_s: float, timeout_s: float) -> bool:
        """Has the last state waited ``timeout_s`` or more for its answer since its period
        was simulated?"""
        since = self.waiting_since_s if self.timing.pending_since_s is not None else None
        return since is not None and now_s - since >= timeout_s
