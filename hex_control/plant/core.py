"""The plant node's behaviour without ROS (issue 38 item 1): the simulated hardware
(:class:`~hex_control.plant.simulator.PlantSimulator`), its limits, the pass monitor and the
command inputs, stepped by the lock-step gate (:mod:`hex_control.plant.lockstep`) or on the
wall clock (:mod:`hex_control.plant.pacing`).

Inputs are plain values (the node converts its messages): a force-axis command (mm, the
stamp of the state it answers, ns), strut commands (lengths m, stamped), strut trajectories
(:class:`StrutTrajectory`), pass announcements (:class:`ScheduledPass`) and the force
controller's status (the pass whose force trajectory it holds). Outputs go to a
:class:`PlantOutputs` (a period's measurement, as soon as the force table has stepped,
then the rest of its state; standing still; a pass begun or ended);
counters, faults and log lines to :class:`Events`. Wall time comes from ``clock``.

What the plant does with them:
- Force commands older than ``command_timeout_s`` (sim time) drive the table to its retract
  stop (the amplifier's own watchdog: a dead controller cannot keep pushing).
- Limits below every controller (:mod:`hex_control.plant.limits`): strut commands and
  trajectories outside the machine's strokes are refused and counted; force commands are
  clamped to the table's travel; an overload trips the table back until the command asks
  for no force.
- Strut commands stamped ahead of sim time are applied when sim time reaches their stamps
  (in order, at most ``MAX_QUEUED_STRUT_COMMANDS``); a strut trajectory replaces what the
  held ones would do from its start on, is sampled every period once sim time reaches its
  stamp, and is refused if it arrives after its start (the tool never jumps into a move).
- With ``end_time_s`` > 0 the plant stops advancing there (a run of fixed length).

Units: s (sim time; wall time on ``clock``), mm and N on the force axis, m for struts.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Protocol

from hex_control.plant.limits import ForceAxisLimits
from hex_control.plant.lockstep import LockstepGate, pass_covered
from hex_control.plant.pacing import RealTimePacer
from hex_control.plant.pass_monitor import PassMonitor, PassReport, ScheduledPass
from hex_control.plant.simulator import PlantSimulator, PlantSnapshot
from hex_control.plant.strut_trajectory import StrutTrajectory

HELD_TRAJECTORIES = 4  # strut trajectories held at once (the running one and those queued after it)
MAX_QUEUED_STRUT_COMMANDS = 10_000  # strut commands stamped ahead: beyond this a flood
MISSED_WARN = 0.1  # real time: a fraction of a second's cycles missed beyond which the plant warns
LAG_WARN_S = 0.5  # real time: lag behind the wall clock beyond which the plant warns


class PlantOutputs(Protocol):
    def measurement(self, time_s: float, measured_force_n: float) -> None:
        """Publish one period's force measurement, the input the controller answers; it goes
        out before the rest of the period is simulated, so the two overlap."""

    def state(self, snapshot: PlantSnapshot) -> None:
        """Publish the rest of one period's state (after its measurement)."""

    def hold(self, snapshot: PlantSnapshot) -> None:
        """The plant stands still (lock-step between passes): say where, once."""

    def pass_started(self, scheduled: ScheduledPass) -> None:
        """A pass's path has begun."""

    def pass_ended(self, report: PassReport) -> None:
        """A pass is over and scanned: report it (before the next state goes out)."""


class Events(Protocol):
    def count(self, name: str, increment: int = 1) -> None: ...

    def fault(self, name: str, message: str) -> None: ...

    def clear(self, name: str) -> None: ...

    def log(self, level: str, text: str) -> None:
        """``level``: info, warning or error."""


class EventLog:
    """Events kept in plain containers (for tests, or a core run without a node)."""

    def __init__(self):
        self.counts: dict[str, int] = {}
        self.faults: dict[str, str] = {}
        self.lines: list[tuple[str, str]] = []

    def count(self, name: str, increment: int = 1) -> None:
        self.counts[name] = self.counts.get(name, 0) + increment

    def fault(self, name: str, message: str) -> None:
        self.faults[name] = message

    def clear(self, name: str) -> None:
        self.faults.pop(name, None)

    def log(self, level: str, text: str) -> None:
        self.lines.append((level, text))


@dataclass(frozen=True)
class CoreSettings:
    """The core's settings (the node's parameters of the same names; no defaults here:
    the node's parameter table holds them)."""

    mode: str  # lockstep | realtime
    period_s: float  # control period
    real_time_factor: float  # sim s per wall s (realtime mode, and a free-running lock-step)
    command_timeout_s: float  # sim age of the last force command after which the table retracts
    retract_mm: float  # the table's retract stop
    table_start_mm: float
    end_time_s: float  # 0 = never
    wait_for_controller: bool  # lock-step: a pass starts only once the controller holds it
    plan_ahead_s: float = 0.0  # lock-step: sim time run on after a scan while the next pass is planned

    def __post_init__(self):
        if self.mode not in ("lockstep", "realtime"):
            raise ValueError(f"mode must be lockstep or realtime, got {self.mode!r}")
        if not (self.period_s > 0 and self.real_time_factor > 0 and self.command_timeout_s > 0):
            raise ValueError("period_s, real_time_factor and command_timeout_s must be > 0")
        if not (math.isfinite(self.plan_ahead_s) and self.plan_ahead_s >= 0):
            raise ValueError(f"plan_ahead_s must be finite and >= 0, got {self.plan_ahead_s!r}")


class PlantCore:
    def __init__(self, settings: CoreSettings, sim: PlantSimulator, *, axis_limits: ForceAxisLimits,
                 outputs: PlantOutputs, events: Events, strut_names: list[str], monitor: PassMonitor | None = None,
                 check_struts: Callable[[list[float]], None] | None = None,
                 check_trajectory: Callable[[object], None] | None = None,
                 clock: Callable[[], float] = time.monotonic):
        """``check_struts(lengths_m)`` raises ValueError for lengths outside the machine's
        strokes, ``check_trajectory(rows_m)`` for any row of a trajectory (n, struts) outside
        them (None: ``check_struts`` row by row); ``clock()`` is the wall time (s)."""
        self.settings, self.sim, self.axis_limits = settings, sim, axis_limits
        self.outputs, self.events, self.clock = outputs, events, clock
        self._last_watchdog_s: float | None = None  # wall s of the watchdog's last tick
        self.strut_names, self.monitor = list(strut_names), monitor
        self.check_struts = check_struts or (lambda lengths_m: None)
        self.check_trajectory = check_trajectory or self._check_rows
        self.lockstep = settings.mode == "lockstep"
        self.command_mm = settings.table_start_mm
        self.last_command_s = 0.0  # sim time of the latest force command
        self.strut_queue: deque = deque()  # (stamp s, lengths m) of commands stamped ahead of sim time
        self.trajectories: list[StrutTrajectory] = []  # by start
        self.controller_holds: deque = deque(maxlen=HELD_TRAJECTORIES)  # (job_id, pass_index) the controller has
        self.gate = LockstepGate()
        self.plan_ahead_until_s = -math.inf  # lock-step: sim time may run on to here after a scan (lockstep.py)
        self.pacer = RealTimePacer(settings.period_s, settings.real_time_factor)
        self.loop_end_s: float | None = None  # wall time the run reached end_time_s
        self._paced = (0, 0)  # cycles, missed at the last pace judgement

    # -- outputs ---------------------------------------------------------------------------
    def publish_state(self) -> None:
        """Send the present state (at start-up, and again while nobody has answered)."""
        snapshot = self.sim.snapshot()
        self._measured(snapshot.time_s, snapshot.measured_force_n)
        self.outputs.state(snapshot)
        self.gate.period_simulated(self.clock())

    def _measured(self, time_s: float, measured_force_n: float) -> None:
        self.outputs.measurement(time_s, measured_force_n)
        self.gate.sent(self.clock())

    def _check_rows(self, rows_m) -> None:
        for row in rows_m:
            self.check_struts(row)

    def refuse(self, counter: str, text: str) -> None:
        """An input the node could not even convert: count it and say why."""
        self.events.count(counter)
        self.events.log("warning", text)

    # -- inputs ----------------------------------------------------------------------------
    def on_force_command(self, position_mm: float, stamp_ns: int | None) -> None:
        """A force-axis command (table position, mm) stamped with the state it answers
        (ns; None for a stamp that is not one)."""
        if not math.isfinite(position_mm):
            self.events.count("rejected_force_command")
            return
        gate = self.gate
        if self.lockstep and not gate.free_running and not gate.answers(stamp_ns, self.sim.time_s):
            self.events.count("stale_force_commands")  # it answers another state than the one waiting
            return
        self.command_mm = position_mm
        self.last_command_s, gate.free_running = self.sim.time_s, False
        self.events.clear("free_running")
        answered = gate.answer(self.clock())
        if self.lockstep:
            if answered:
                gate.answer_ready = True
                self._lockstep_step()
            else:
                self.events.count("unsolicited_commands")

    def on_strut_command(self, names, positions, stamp_s: float) -> None:
        """Jogging: strut lengths (m) by joint name (no names: in the machine's order),
        applied when sim time reaches ``stamp_s``."""
        try:
            by_name = dict(zip(names, positions)) if len(names) else dict(zip(self.strut_names, positions))
            lengths = [float(by_name[name]) for name in self.strut_names]
            if not all(math.isfinite(v) for v in lengths):
                raise ValueError(f"strut lengths must be finite, got {lengths}")
            self.check_struts(lengths)
        except (KeyError, ValueError) as error:
            self.refuse("rejected_strut_command", f"strut command rejected: {error}")
            return
        if stamp_s <= self.sim.time_s:
            self.sim.command_struts(lengths)
        elif (self.strut_queue and stamp_s < self.strut_queue[-1][0]
              or len(self.strut_queue) >= MAX_QUEUED_STRUT_COMMANDS):
            self.events.count("rejected_strut_command")  # out of order, or a flood
        else:  # a path streamed ahead: apply it when its time comes (deterministic in lock-step)
            self.strut_queue.append((stamp_s, lengths))

    def on_strut_trajectory(self, trajectory: StrutTrajectory) -> None:
        try:
            self.check_trajectory(trajectory.lengths_m)
        except ValueError as error:
            self.refuse("rejected_strut_trajectory", f"strut trajectory rejected: {error}")
            return
        if trajectory.start_s < self.sim.time_s - 1e-9:  # never jump into a move part-way
            self.events.count("late_strut_trajectory")
            self.events.log("warning", f"strut trajectory from {trajectory.start_s:.3f} s refused: it arrived at "
                                       f"{self.sim.time_s:.3f} s")
            return
        # a trajectory replaces whatever the held ones would do from its start on
        kept = [t for t in self.trajectories if t.start_s < trajectory.start_s - 1e-9]
        self.trajectories = (kept + [trajectory])[-HELD_TRAJECTORIES:]
        self.events.count("strut_trajectories")
        self._lockstep_step()

    def on_pass_announced(self, scheduled: ScheduledPass) -> None:
        """A force trajectory announced a pass (with a workpiece only)."""
        try:
            if self.monitor.schedule(scheduled):
                self.events.count("passes_announced")
        except ValueError as error:
            self.refuse("rejected_trajectory", f"force trajectory rejected: {error}")
        self._lockstep_step()

    def on_controller_status(self, message: str, values: dict) -> None:
        """The force controller's latched status: ``trajectory`` with the pass it holds."""
        index = str(values.get("pass_index", ""))
        if message != "trajectory" or not (index.isascii() and index.isdigit() and len(index) <= 10):
            self.events.count("ignored_controller_status")  # (a unicode digit or 5000 of them: no int)
            return
        self.controller_holds.append((str(values.get("job_id", "")), int(index)))
        self._lockstep_step()

    # -- timers ----------------------------------------------------------------------------
    @staticmethod
    def watchdog_period_s(timeout_s: float) -> float:
        """The lock-step watchdog's tick (wall s): a quarter of ``lockstep_timeout_s``."""
        return timeout_s / 4

    def watchdog_tick(self, timeout_s: float) -> bool:
        """The node's watchdog timer, every :meth:`watchdog_period_s` of wall time:
        :meth:`lockstep_watchdog`, less the time this plant itself stood. A tick more than a
        tick late means the plant did not run for about that long (stopped, swapped out): the
        controller's answer may have been sent meanwhile, and Fast DDS hands what was sent to a
        process stopped for over 1-2 s on only at the writer's next heartbeat (docs/
        known_problems.md), so that time is not counted as the controller's silence
        (``plant_stalls``). A silent controller still times out: each tick counts one tick."""
        now, tick = self.clock(), self.watchdog_period_s(timeout_s)
        if self._last_watchdog_s is not None and now - self._last_watchdog_s > 2 * tick:
            self.gate.stalled(self._last_watchdog_s + tick, now)
            self.events.count("plant_stalls")
        self._last_watchdog_s = now
        return self.lockstep_watchdog(timeout_s)

    def lockstep_watchdog(self, timeout_s: float) -> bool:
        """Every fraction of ``timeout_s`` (wall time): re-send an unanswered first state;
        after the first answer, say the waiting measurement once more when a quarter of the
        timeout has passed (it or its answer was lost on the way: a flood on the topic
        overflows its queue; the controller answers a repeat with the same command), and run
        free once the controller has been silent the whole timeout. True while running free
        (the node then calls :meth:`free_run` every control period, until it says False)."""
        self._watch(timeout_s)
        return self.gate.free_running

    def _watch(self, timeout_s: float) -> None:
        gate, now = self.gate, self.clock()
        if gate.started and not gate.resent and gate.timed_out(now, self.watchdog_period_s(timeout_s)):
            gate.resent = True
            snapshot = self.sim.snapshot()
            self.outputs.measurement(snapshot.time_s, snapshot.measured_force_n)
            self.events.count("measurements_resent")
        if not gate.timed_out(now, timeout_s):
            return
        if not gate.started:
            self.publish_state()  # nobody answered yet: say it again
            return
        self.events.count("lockstep_timeouts")
        self.gate.free_running = True
        self.events.fault("free_running", "lock-step: the controller stopped answering, running on the wall "
                                          "clock with the held command")
        if self._covered():
            self._advance()

    def free_run(self) -> bool:
        """Every control period of wall time (over real_time_factor) while running free: a
        lock-step whose controller fell silent runs on. False when no step is due (the
        controller answers again, the next pass is not covered, the run is over): the node's
        timer then stops until the watchdog finds the plant running free again."""
        if not (self.gate.free_running and self._covered()):
            return False
        self._advance()
        return not self._run_over()

    def realtime_tick(self) -> None:
        for _ in range(self.pacer.due(self.clock())):
            self._advance()

    # -- stepping --------------------------------------------------------------------------
    def _covered(self) -> bool:
        """May sim time advance? Always, but in lock-step with a workpiece: only while a pass
        runs, or is announced with its motion and force trajectory in hand (lockstep.py)."""
        if not self.lockstep or self.monitor is None or self.monitor.running is not None:
            return True
        if self.sim.time_s + self.settings.period_s <= self.plan_ahead_until_s + 1e-9:
            return True  # the machine holds its pose while the next pass is planned
        return pass_covered(self.monitor.scheduled, self.trajectories, self.controller_holds,
                            self.settings.wait_for_controller)

    def _lockstep_step(self) -> None:
        gate = self.gate
        if not self.lockstep or not gate.answer_ready:
            return
        if self._covered():
            gate.answer_ready = False
            self._advance()
        elif not gate.holding:  # standing still: say where, to whoever subscribes later too
            gate.holding = True
            self.outputs.hold(self.sim.snapshot())

    def _apply_strut_commands(self) -> None:
        now = self.sim.time_s + 1e-9
        while self.strut_queue and self.strut_queue[0][0] <= now:
            self.sim.command_struts(self.strut_queue.popleft()[1])
        self.trajectories = [t for t in self.trajectories if t.end_s > now - self.settings.period_s]
        active = [t for t in self.trajectories if t.start_s <= now]
        if active:
            self.sim.command_struts(active[-1].at(self.sim.time_s))

    def _run_over(self) -> bool:
        return 0 < self.settings.end_time_s <= self.sim.time_s + 1e-9

    def _advance(self) -> None:
        s = self.settings
        if self._run_over():
            self.loop_end_s = self.loop_end_s or self.clock()
            return  # hold still
        self.gate.holding = False
        self.gate.timing.cycle()
        command_age_s = self.sim.time_s - self.last_command_s
        if command_age_s > s.command_timeout_s:
            self.command_mm = s.retract_mm  # amplifier watchdog
        self._apply_strut_commands()
        try:
            self._simulate_period(self._limited_command(), command_age_s)
        finally:  # the watchdog times the controller from here, not from the measurement
            self.gate.period_simulated(self.clock())

    def _simulate_period(self, command_mm: float, command_age_s: float) -> None:
        limiter = self.sim.strut_limiter
        limited = limiter.limited if limiter is not None else 0
        try:  # the measurement goes out mid-period: the controller answers while the rest is simulated
            state = self.sim.advance(self.settings.period_s, command_mm, self._measured)
        except ValueError as error:  # the tool left the machine's forward kinematics
            self.events.count("simulation_errors")
            self.events.log("error", f"plant step failed: {error}")
            if self.monitor is not None:
                self.monitor.period_unsimulated()
            return
        if limiter is not None and limiter.limited > limited:
            self.events.count("limited_strut_commands")  # a strut command beyond the servos' speed or acceleration
        if self.monitor is not None:
            self._monitor_pass(state, command_age_s)
        self.outputs.state(state)

    def _limited_command(self) -> float:
        """The force command within the table's travel, or the retract stop while tripped."""
        limits = self.axis_limits
        clamped, trips, tripped = limits.clamped, limits.trips, limits.tripped
        command_mm = limits.command_mm(self.command_mm, self.sim.table.force_n)
        if tripped and not limits.tripped:
            self.events.count("overload_resets")
            self.events.clear("overload")
        if limits.clamped > clamped:
            self.events.count("clamped_force_commands")
        if limits.trips > trips:
            self.events.count("overload_trips")
            self.events.fault("overload", f"overload: {self.sim.table.force_n:.0f} N > {limits.overload_n:g} N, "
                                          "table retracted until the command asks for no force")
            self.events.log("error", f"overload trip at {self.sim.table.force_n:.0f} N: table retracted")
        return command_mm

    def _monitor_pass(self, state: PlantSnapshot, command_age_s: float) -> None:
        monitor = self.monitor
        before = monitor.running
        centre_x_mm = state.centre_mm[0] if state.centre_mm is not None else math.nan
        report = monitor.on_period(state.time_s, state.deflection_mm, state.strut_speeds_m_s, command_age_s,
                                   force_n=state.force_n, centre_x_mm=centre_x_mm)
        if monitor.running is not None and monitor.running is not before:
            self.outputs.pass_started(monitor.running)
        if report is None:
            return
        m = report.measurement
        self.plan_ahead_until_s = state.time_s + self.settings.plan_ahead_s
        self.outputs.pass_ended(report)
        self.events.count(f"passes_{report.status}")
        if m.burn_detected or m.stall_detected:  # until a pass without
            what = "burn" if m.burn_detected else "stall"
            self.events.fault("last_pass", f"pass {m.pass_index}: {what} detected")
        elif report.faulted and not report.aborted:
            self.events.fault("last_pass", f"pass {m.pass_index} faulted: {report.reason}")
        else:
            self.events.clear("last_pass")
        verdict = "" if report.status == "completed" else f", {report.status.upper()}: {report.reason}"
        self.events.log("info", f"pass {m.pass_index} of {m.job_id}: cut {m.measured_cut_depth_mm:.4f} mm, "
                                f"{report.duration_s:.2f} s{verdict}")

    # -- reporting -------------------------------------------------------------------------
    def loop_report(self) -> dict:
        """The loop's timing since the first answer (wall time) and, in real time, its pace;
        judges the pace (a WARN ``pace`` fault) on the way."""
        gate, now = self.gate, self.clock()
        start = gate.loop_start_s
        wall = (self.loop_end_s or now) - start if start is not None else math.nan
        p50, p99 = gate.timing.latency_percentiles_ms()
        report = {"sim_time_s": self.sim.time_s, "cycles": gate.timing.cycles,
                  "loop_rate_hz": gate.timing.cycles / wall if wall > 0 else math.nan,
                  "missed_fraction": gate.timing.missed_fraction, "latency_p50_ms": p50, "latency_p99_ms": p99}
        if not self.lockstep:
            report.update(late_ticks=self.pacer.late_ticks, dropped_periods=self.pacer.dropped,
                          real_time_lag_ms=self.pacer.lag_s(now) * 1e3)
            self._judge_pace(report["real_time_lag_ms"] * 1e-3)
        return report

    def _judge_pace(self, lag_s: float) -> None:
        """Real time: WARN while the last second missed over MISSED_WARN of its cycles or
        the plant lags the wall clock by over LAG_WARN_S; it clears when both recover."""
        cycles, missed = self.gate.timing.cycles, self.gate.timing.missed
        if cycles < self._paced[0]:  # the count restarted with the first answer
            self._paced = (0, 0)
        recent_cycles, recent_missed = cycles - self._paced[0], missed - self._paced[1]
        self._paced = (cycles, missed)
        missed_fraction = recent_missed / recent_cycles if recent_cycles else 0.0
        if missed_fraction > MISSED_WARN or lag_s > LAG_WARN_S:
            self.events.fault("pace", f"behind real time: {missed_fraction:.0%} of the last second's cycles "
                                      f"missed, {lag_s * 1e3:.0f} ms late")
        else:
            self.events.clear("pace")
