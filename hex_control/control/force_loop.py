"""The force controller's supervisor (seed 002 ch. 7), without ROS: :class:`ForceLoop`.

Every control period the force law (:mod:`hex_control.control.force_law`) turns the desired
and measured normal force into a table position command; around it this class decides what
the law may do. The node ``force_controller`` only reads its parameters into a
:class:`ForceLoopSettings`, converts messages into the plain values of the ``on_*`` methods
and publishes the :class:`Command` they return. Times are integer ns on the loop's clock
(the node clock, or the plant's stamps under ``trigger`` ``measurement``), forces N,
positions mm.

- Desired force: a force trajectory (times from its start stamp, forces) or a direct
  setpoint. A trajectory is taken only if it is well formed, its peak is within
  ``max_force_n`` and, with ``require_pass_command``, it is the pass of the latest accepted
  pass command (job id and pass index; one that comes before its command waits for it).
  A direct setpoint is refused while a trajectory is held (pending or running): a jog must
  not drop a pass (issue 37: one 0 N setpoint made a pass cut 0.048 of 0.308 mm).
- Touch-down: while a trajectory waits for its start the table moves to ``touch_standoff_mm``
  short of ``contact_mm`` (:mod:`hex_control.control.touch_down`); the loop then starts
  bumplessly from there.
- Watchdog: a setpoint or measurement older than its timeout ramps the command to
  ``output_min_mm`` over ``ramp_down_s`` (a WARN); the loop restarts bumplessly when both
  are fresh again. Non-finite inputs are refused and counted. The desired force is limited
  to ``max_force_n`` (F_max, never above the cell's ``cell_force_max_n``) and the command
  to [output_min_mm, output_max_mm]; a command held at a limit ``saturation_warn_s`` while
  tracking is a WARN (no contact, or work out of reach).
- Overload: a measured force above ``overload_n`` (the plant's trip), or above
  ``overforce_ratio`` x ``max_force_n`` for ``overforce_s``, or contact lost within
  ``TRIP_WINDOW_S`` of a force above that (the trip seen in part), retracts the table to
  ``output_min_mm`` at once and holds it there until the next pass (a new accepted
  trajectory; in jog mode, a setpoint after the setpoints have paused a timeout): at or
  behind the contact the plant's trip resets, which a loop pushing on into a retracted
  table never allowed (issue 37).
- Stamps (trigger ``measurement``, :mod:`hex_control.control.stamp_guard`): a measurement
  stamped off the plant's timeline is refused and not answered (``rejected_stamp``) unless
  the next confirms a new timeline; the plant's state sent again is answered again with the
  same command, the loop not stepped. A confirmed jump backwards (a restarted plant), or a
  timer clock that goes back, drops the trajectory and retracts until the next pass.

Counters and faults go to a :class:`Report` (the node's Diagnostics; :class:`Tally` here).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import asdict, dataclass, replace
from typing import Callable, Protocol

import numpy as np

from hex_control.control.force_law import FORCE_LAWS, ROLL_OFFS, make_force_law
from hex_control.control.stamp_guard import Stamp, StampGuard
from hex_control.control.touch_down import TouchDown

CEILING_WARN_S = 5.0  # a desired force above max_force_n keeps its WARN this long (wall s) after the last
REFUSAL_WARN_S = 5.0  # so does a refused setpoint
TRIGGERS = ("timer", "measurement")
#: the force falling below touch_felt_n this soon (s) after an overforce is the plant's overload
#: trip (its table retracted): a 150 N spike under a 30 Hz sensor can read as ~117 N for 15 ms
TRIP_WINDOW_S = 0.2
#: the settings a running loop takes from a live parameter change
LIVE = ("setpoint_timeout_s", "measurement_timeout_s", "ramp_down_s", "feed_forward_mm_per_n", "max_force_n",
        "saturation_warn_s")


@dataclass(frozen=True, kw_only=True)
class ForceLoopSettings:
    """What the loop runs with. The physical values have no default here: the node takes
    them from the cell configuration (hex_control.config.CellConfiguration, config/cell.yaml:
    F_max, K_x = K_theta / R^2, the table's contact and overload trip)."""

    cell_force_max_n: float  # F_max of the cell: max_force_n can never exceed it
    max_force_n: float  # the desired force's ceiling (live)
    stiffness_n_per_mm: float  # contact stiffness K_x (energy-optimal law)
    contact_mm: float  # table position at which the disk touches the work
    overload_n: float  # a measured force above this backs the loop off until the next pass
    rate_hz: float = 200.0
    trigger: str = "timer"
    law: str = "pi"
    kp_mm_per_n: float = 0.002
    ki_mm_per_n_s: float = 0.05
    output_min_mm: float = -2.0
    output_max_mm: float = 2.0
    setpoint_timeout_s: float = 0.5
    measurement_timeout_s: float = 0.1
    ramp_down_s: float = 0.5
    feed_forward_mm_per_n: float = 0.0
    roll_off: str = "none"
    roll_off_hz: float = 8.0
    roll_off_quality: float = 0.5
    energy_q1: float = 1.0
    energy_q2: float = 1.0
    energy_r: float = 1e3
    energy_correction_limit_mm: float = 0.5
    touch_standoff_mm: float = 0.1
    touch_speed_mm_s: float = 10.0
    touch_settle_s: float = 0.1
    touch_felt_n: float = 2.0
    saturation_warn_s: float = 1.0
    max_stamp_step_s: float = 0.05
    require_pass_command: bool = False
    overforce_ratio: float = 1.5
    overforce_s: float = 0.05

    def __post_init__(self):
        if self.trigger not in TRIGGERS:
            raise ValueError(f"trigger must be one of {', '.join(TRIGGERS)}, got {self.trigger!r}")
        if self.law not in FORCE_LAWS or self.roll_off not in ROLL_OFFS:
            raise ValueError(f"law {self.law!r} or roll_off {self.roll_off!r} unknown")
        if not self.output_min_mm < self.output_max_mm:
            raise ValueError(f"output_min_mm {self.output_min_mm} must be below output_max_mm {self.output_max_mm}")
        numbers = {k: v for k, v in asdict(self).items() if isinstance(v, float)}
        bad = {k: v for k, v in numbers.items() if not math.isfinite(v)}
        if bad or not (self.rate_hz > 0 and self.overload_n > 0 and self.max_stamp_step_s > 0):
            raise ValueError(f"need finite values, rate_hz, overload_n, max_stamp_step_s > 0: {bad or numbers}")
        if not 0 <= self.max_force_n <= self.cell_force_max_n:
            raise ValueError(f"max_force_n {self.max_force_n:g} N must be in [0, the cell's F_max "
                             f"{self.cell_force_max_n:g} N]")
        if not (self.overforce_ratio >= 1 and self.overforce_s >= 0):
            raise ValueError("need overforce_ratio >= 1 and overforce_s >= 0")

    def ceiling_refusal(self, max_force_n: float) -> str:
        """Why ``max_force_n`` may not be set ('' if it may)."""
        if not (math.isfinite(max_force_n) and 0 <= max_force_n <= self.cell_force_max_n):
            return (f"max_force_n {max_force_n:g} N refused: the cell's F_max is {self.cell_force_max_n:g} N "
                    "(config/cell.yaml process.force_max_n)")
        return ""


@dataclass(frozen=True)
class Command:
    """A table position command (mm) answering the state stamped ``stamp_ns``."""

    stamp_ns: int
    position_mm: float


@dataclass(frozen=True)
class Verdict:
    accepted: bool
    reason: str = ""


@dataclass(frozen=True)
class Trajectory:
    """The desired force of one pass: ``forces_n`` at ``times_s`` after ``start_ns``."""

    start_ns: int
    times_s: np.ndarray
    forces_n: np.ndarray
    job_id: str = ""
    pass_index: int = 0

    @property
    def key(self) -> tuple[str, int]:
        return self.job_id, self.pass_index


class Report(Protocol):
    """Where the loop's counters and faults go (the node's Diagnostics)."""

    state: str

    def count(self, name: str, increment: int = 1) -> None: ...

    def fault(self, name: str, message: str, *, hold_s: float | None = None) -> None: ...

    def clear(self, name: str) -> None: ...


class Tally:
    """A :class:`Report` kept in memory: ``counters``, ``faults`` (name -> text), ``state``."""

    def __init__(self):
        self.counters: Counter[str] = Counter()
        self.faults: dict[str, str] = {}
        self.state = "ok"

    def count(self, name: str, increment: int = 1) -> None:
        self.counters[name] += increment

    def fault(self, name: str, message: str, *, hold_s: float | None = None) -> None:
        self.faults[name] = message

    def clear(self, name: str) -> None:
        self.faults.pop(name, None)


def _quiet(_text: str) -> None:
    pass


class ForceLoop:
    """The supervisor around the force law; see the module docstring. ``warn(text)`` gets
    the events (trips, jumps, overloads), ``notice(text)`` the refused inputs (the node
    throttles it)."""

    def __init__(self, settings: ForceLoopSettings, report: Report | None = None,
                 warn: Callable[[str], None] = _quiet, notice: Callable[[str], None] = _quiet):
        self.settings = settings
        self.report = report if report is not None else Tally()
        self.warn, self.notice = warn, notice
        self.period_s = 1.0 / settings.rate_hz
        self.limits = (settings.output_min_mm, settings.output_max_mm)
        self.law = make_force_law(settings.law, asdict(settings), self.period_s, self.limits)
        self.law.reset(self.limits[0])
        self.touch_down = TouchDown(settings.contact_mm, settings.touch_standoff_mm, settings.touch_speed_mm_s,
                                    settings.touch_settle_s, settings.touch_felt_n)
        self.measurement_triggered = settings.trigger == "measurement"
        self.stamps = StampGuard(round(settings.max_stamp_step_s * 1e9))
        self.command_mm = self.limits[0]
        self.trajectory: Trajectory | None = None
        self.direct_setpoint: float | None = None
        self.setpoint_ns: int | None = None
        self.measured_n: float | None = None
        self.measured_ns: int | None = None
        self.feed_forward_n = 0.0
        self.tripped = True  # start retracted; only a loss of inputs while tracking is a trip
        self.saturated_s = 0.0  # how long the command has been held at a limit while tracking
        self.answer: Command | None = None  # the last command sent
        self.pass_command: tuple[str, int] | None = None  # (job id, pass index) of the latest accepted
        self.waiting: Trajectory | None = None  # the planner's trajectory that came before its command
        self.backed_off: tuple[str, int] | None = None  # after an overload: the pass it happened in
        self.stopped: tuple[str, int] | None = None  # the latest pass a stop ended
        self.overforce_s = 0.0  # how long the measured force has been above overforce_ratio x max_force_n
        self.overforce_ns: int | None = None  # when it last was, and the peak then (N)
        self.overforce_peak_n = 0.0

    def update(self, **changes) -> None:
        """A live change of the ``LIVE`` settings; ValueError (nothing changed) if invalid."""
        unknown = set(changes) - set(LIVE)
        if unknown:
            raise ValueError(f"{sorted(unknown)} cannot change while the loop runs")
        self.settings = replace(self.settings, **changes)

    # -- inputs ----------------------------------------------------------------------------
    def _refuse(self, counter: str, fault: str, text: str, hold_s: float | None = None) -> Verdict:
        self.report.count(counter)
        self.report.fault(fault, text, hold_s=hold_s)
        self.notice(text)
        return Verdict(False, text)

    def _reject(self, what: str) -> Verdict:
        self.report.count(f"rejected_{what}")
        self.notice(f"malformed {what} rejected")
        return Verdict(False, f"malformed {what}")

    def on_pass_command(self, job_id: str, pass_index: int, stop: bool = False) -> Trajectory | None:
        """The latest accepted pass command; the trajectory it lets through, if one waited.
        ``stop`` (the job was cancelled or ended with this pass in flight): its trajectory is
        dropped, held or waiting, and the force ramps to zero as at a pass's end; a
        trajectory of that pass that comes later is refused."""
        key = (job_id, int(pass_index))
        if stop:
            if self.trajectory is not None and self.trajectory.key == key:
                self.trajectory, self.tripped, self.saturated_s = None, True, 0.0  # ramp down, no watchdog fault
                self.report.count("passes_stopped")
                self.notice(f"{job_id} pass {pass_index} stopped: retracting")
            if self.waiting is not None and self.waiting.key == key:
                self.waiting = None
            self.stopped = key
            return None
        self.pass_command = key
        if self.waiting is not None and self.waiting.key == self.pass_command:
            waiting, self.waiting = self.waiting, None
            return waiting if self._adopt(waiting).accepted else None
        return None

    def on_trajectory(self, start_ns: int, times_s, forces_n, job_id: str = "", pass_index: int = 0) -> Verdict:
        t, f = np.asarray(times_s, float), np.asarray(forces_n, float)
        if t.ndim != 1 or t.size == 0 or t.shape != f.shape or not (np.all(np.isfinite(t)) and np.all(np.isfinite(f))) \
                or np.any(np.diff(t) <= 0) or np.any(f < 0) or start_ns < 0:
            return self._reject("trajectory")
        trajectory = Trajectory(int(start_ns), t, f, job_id, int(pass_index))
        peak, ceiling = float(f.max()), self.settings.max_force_n
        if peak > ceiling:
            return self._refuse("refused_trajectory", "trajectory", f"force trajectory of {job_id} pass {pass_index} "
                                f"refused: peak {peak:.1f} N above max_force_n {ceiling:g} N")
        if self.settings.require_pass_command and trajectory.key != self.pass_command:
            self.waiting = trajectory  # the command may still come (a restart hears both latched, in any order)
            latest = "none" if self.pass_command is None else f"{self.pass_command[0]} pass {self.pass_command[1]}"
            return self._refuse("refused_trajectory", "trajectory", f"force trajectory of {job_id} pass {pass_index} "
                                f"refused: no accepted pass command for it (latest: {latest})")
        return self._adopt(trajectory)

    def _adopt(self, trajectory: Trajectory) -> Verdict:
        if trajectory.key == self.stopped:
            return self._refuse("refused_trajectory", "trajectory", f"force trajectory of {trajectory.job_id} pass "
                                f"{trajectory.pass_index} refused: that pass was stopped", REFUSAL_WARN_S)
        if self.backed_off is not None and trajectory.key == self.backed_off:
            return self._refuse("refused_trajectory", "trajectory", f"force trajectory of {trajectory.job_id} pass "
                                f"{trajectory.pass_index} refused: it overloaded; retracted until the next pass")
        if self.backed_off is not None:
            self._rearm()
        self.trajectory, self.direct_setpoint, self.waiting = trajectory, None, None
        self.report.clear("trajectory")
        return Verdict(True)

    def holds_trajectory(self, now_ns: int | None) -> bool:
        """A trajectory pending or running at ``now_ns`` (held, if the time is unknown)."""
        if self.trajectory is None:
            return False
        return now_ns is None or (now_ns - self.trajectory.start_ns) * 1e-9 <= self.trajectory.times_s[-1]

    def on_setpoint(self, force_n: float, clock_ns: int | None = None) -> Verdict:
        """A direct desired force (N); ``clock_ns`` the node clock (unused when measurements
        trigger the loop: then the latest measurement's stamp is the time)."""
        if not (math.isfinite(force_n) and force_n >= 0):
            return self._reject("setpoint")
        now = self._now(clock_ns)
        if self.holds_trajectory(now):
            t = self.trajectory
            return self._refuse("refused_setpoint", "setpoint", f"setpoint {force_n:g} N refused: the force "
                                f"trajectory of {t.job_id} pass {t.pass_index} is held", REFUSAL_WARN_S)
        if self.backed_off is not None:
            paused = self._stale(self.setpoint_ns, self.settings.setpoint_timeout_s, now)
            self.setpoint_ns = now
            if not paused:
                return self._refuse("refused_setpoint", "setpoint", f"setpoint {force_n:g} N refused: backed off "
                                    "after an overload (pause the setpoints to re-arm)", REFUSAL_WARN_S)
            self._rearm()
        self.direct_setpoint, self.trajectory, self.setpoint_ns = force_n, None, now
        return Verdict(True)

    def on_prediction(self, prediction: float, mean: float) -> None:
        if math.isfinite(prediction) and math.isfinite(mean):
            self.feed_forward_n = prediction - mean
        else:
            self._reject("prediction")

    def on_measurement(self, force_n: float, stamp_ns: int, clock_ns: int | None = None) -> Command | None:
        """A measured normal force (N) stamped ``stamp_ns``. Under trigger ``measurement`` the
        command that answers it (or None: refused, or a repeat nobody waits on); under
        ``timer`` it is stored at ``clock_ns`` and None returned."""
        if not math.isfinite(force_n) or stamp_ns < 0:
            self._reject("measurement")
            return None
        if not self.measurement_triggered:
            self.measured_n, self.measured_ns = force_n, clock_ns
            return None
        verdict = self.stamps.check(stamp_ns)
        if verdict is Stamp.REPEAT:  # sent again: the plant has not had the answer
            if self.answer is not None and self.answer.stamp_ns == stamp_ns:
                self.report.count("answers_repeated")
                return self.answer
            return None
        if verdict is Stamp.REFUSED:
            self._reject("stamp")
            return None
        if verdict is Stamp.JUMPED:
            self.clock_jumped(self.stamps.jump_ns * 1e-9)
        elif verdict is Stamp.LATE:
            self.report.count("late_stamps")
        self.measured_n, self.measured_ns = force_n, int(stamp_ns)
        return self.tick(int(stamp_ns))

    def clock_jumped(self, jump_s: float) -> None:
        """The loop's clock jumped: later, on the same timeline, the trajectory still holds;
        backwards (a restarted plant) the trajectory and the times held are of the old
        timeline, so they go and the loop retracts until the next pass."""
        self.report.count("clock_jumps")
        if jump_s > 0:
            self.warn(f"measurement stamps leapt {jump_s:+.3f} s")
            return
        self.trajectory = self.waiting = self.direct_setpoint = self.setpoint_ns = self.measured_ns = None
        if not self.tripped:
            self.tripped = True
            self.report.count("watchdog_trips")
        text = f"clock jumped {jump_s:+.3f} s: force trajectory dropped, retracting"
        self.report.fault("clock_jump", text)
        self.warn(text)

    # -- loop ------------------------------------------------------------------------------
    def _now(self, clock_ns: int | None) -> int | None:
        """The loop's time: the latest measurement's stamp when measurements trigger it (the
        plant's clock, whatever the node's says), else the node clock."""
        return self.measured_ns if self.measurement_triggered else clock_ns

    def _elapsed_s(self, now_ns: int) -> float | None:
        """Time into the held force trajectory (negative before its start), None without one."""
        if self.direct_setpoint is not None or self.trajectory is None:
            return None
        return (now_ns - self.trajectory.start_ns) * 1e-9

    def _desired(self, now_ns: int) -> float | None:
        if self.direct_setpoint is not None:
            return self.direct_setpoint
        elapsed = self._elapsed_s(now_ns)
        if elapsed is None or elapsed < 0 or elapsed > self.trajectory.times_s[-1]:
            return None  # no trajectory, not started, or over
        return float(np.interp(elapsed, self.trajectory.times_s, self.trajectory.forces_n))

    def _limited(self, desired_n: float | None) -> float | None:
        """The desired force no higher than ``max_force_n`` (F_max): above it the disk burns
        the work whatever the planner asked (counted, a WARN for a few seconds)."""
        ceiling = self.settings.max_force_n
        if desired_n is None or desired_n <= ceiling:
            return desired_n
        self.report.count("clamped_setpoints")
        self.report.fault("ceiling", f"desired {desired_n:.1f} N limited to max_force_n {ceiling:g} N",
                          hold_s=CEILING_WARN_S)
        return ceiling

    @staticmethod
    def _stale(stamp_ns: int | None, timeout_s: float, now_ns: int | None) -> bool:
        return stamp_ns is None or now_ns is None or not 0 <= (now_ns - stamp_ns) * 1e-9 <= timeout_s

    def _overloaded(self, now_ns: int) -> str:
        """Why the measured force calls for backing off ('' if it does not)."""
        s, force = self.settings, self.measured_n
        if force > s.overload_n:
            return f"measured {force:.0f} N above the overload {s.overload_n:g} N"
        if force > s.overforce_ratio * s.max_force_n:
            self.overforce_s += self.period_s
            self.overforce_ns, self.overforce_peak_n = now_ns, max(force, self.overforce_peak_n)
            if self.overforce_s >= s.overforce_s - 1e-9:
                return (f"measured {force:.0f} N above {s.overforce_ratio:g} x max_force_n for "
                        f"{self.overforce_s:.3f} s")
            return ""
        self.overforce_s = 0.0
        if self.overforce_ns is not None and 0 <= (now_ns - self.overforce_ns) * 1e-9 <= TRIP_WINDOW_S:
            if force < s.touch_felt_n:  # a spike the sensor saw only in part: the plant tripped
                return f"contact lost right after {self.overforce_peak_n:.0f} N (the plant's overload trip)"
        else:
            self.overforce_ns, self.overforce_peak_n = None, 0.0
        return ""

    def _back_off(self, why: str) -> None:
        self.backed_off = ("", -1) if self.trajectory is None else self.trajectory.key
        self.trajectory = self.waiting = self.direct_setpoint = None
        self.tripped, self.saturated_s = True, 0.0
        self.report.count("overloads")
        text = f"overload: {why}: retracted to {self.limits[0]:+.2f} mm until the next pass"
        self.report.fault("overload", text)
        self.warn(text)

    def _rearm(self) -> None:
        self.backed_off, self.overforce_s, self.overforce_ns, self.overforce_peak_n = None, 0.0, None, 0.0
        self.report.clear("overload")

    def tick(self, now_ns: int) -> Command:
        """One control period at ``now_ns``: the command to send."""
        s = self.settings
        fresh_measurement = not self._stale(self.measured_ns, s.measurement_timeout_s, now_ns)
        if fresh_measurement and self.backed_off is None:
            why = self._overloaded(now_ns)
            if why:
                self._back_off(why)
        if self.backed_off is not None:  # retracted at once and held so, the law following
            self.command_mm = self.limits[0]
            self.law.hold(self.command_mm)
            return self._send(now_ns)
        elapsed = self._elapsed_s(now_ns)
        if elapsed is not None and elapsed > self.trajectory.times_s[-1] and not self.tripped:
            # the pass is over: the force ramps to zero as after a watchdog trip, but this is
            # the plan's end, not a fault (the node stays OK between passes)
            self.tripped, self.saturated_s = True, 0.0
            self.report.state = "idle"
        if elapsed is not None and elapsed < 0 and fresh_measurement:
            # a pass is coming: touch down in time; the loop starts bumplessly from there
            self.tripped = True
            command = self.touch_down.command_mm(self.command_mm, -elapsed, self.measured_n, self.period_s)
            self.command_mm = min(max(command, self.limits[0]), self.limits[1])
            self.law.hold(self.command_mm)
            return self._send(now_ns)
        desired = self._limited(self._desired(now_ns))
        fresh_setpoint = desired is not None and (self.trajectory is not None or not self._stale(
            self.setpoint_ns, s.setpoint_timeout_s, now_ns))
        if fresh_setpoint and fresh_measurement:
            if self.tripped:
                self.tripped = False
                self.law.reset(self.command_mm)  # bumpless restart from where the ramp left it
                self.report.clear("watchdog")
                self.report.clear("clock_jump")
                self.report.state = "tracking"
            command = self.law.command(desired, self.measured_n, s.feed_forward_mm_per_n * self.feed_forward_n)
            self._watch_saturation(command, desired)
        else:
            if not self.tripped:  # was tracking: a real watchdog trip
                self.tripped = True
                self.report.count("watchdog_trips")
                reason = "setpoint" if not fresh_setpoint else "measurement"
                self.report.fault("watchdog", f"watchdog: stale {reason}, retracting")
                self.saturated_s = 0.0
                self.warn(f"watchdog: stale {reason}, ramping the force to zero")
            step = (self.limits[1] - self.limits[0]) * self.period_s / s.ramp_down_s
            command = max(self.command_mm - step, self.limits[0])
            self.law.hold(command)
        self.command_mm = min(max(command, self.limits[0]), self.limits[1])
        return self._send(now_ns)

    def _send(self, now_ns: int) -> Command:
        self.answer = Command(now_ns, self.command_mm)
        return self.answer

    def _watch_saturation(self, command_mm: float, desired_n: float) -> None:
        """A command held at a limit for ``saturation_warn_s`` while tracking is a fault (no
        contact, or the work out of reach), cleared as soon as the command comes off it."""
        if not self.limits[0] < command_mm < self.limits[1]:
            self.saturated_s += self.period_s
            if self.saturated_s >= self.settings.saturation_warn_s and not self._saturation_reported:
                self._saturation_reported = True
                self.report.count("saturations")
                text = (f"command saturated at {command_mm:+.2f} mm for {self.saturated_s:.2f} s: desired "
                        f"{desired_n:.1f} N, measured {self.measured_n:.1f} N")
                self.report.fault("saturated", text)
                self.warn(text)
        else:
            self.saturated_s = 0.0
            self._saturation_reported = False
            self.report.clear("saturated")

    _saturation_reported = False
