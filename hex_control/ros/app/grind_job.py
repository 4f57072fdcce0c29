"""The main job: start the whole hierarchy, grind one weld bead, report (DESIGN.md section 4).

``run_job`` starts every node as its own process (:mod:`hex_control.ros.app.graph`), waits
for the plant's scanner to publish the bead, sends the GrindBead goal with that profile to
the sequence planner, and records over ROS 2 what the tiers hand each other: pass commands,
force trajectories, measured forces, strut lengths, pass results and contours. It prints a
pass-by-pass table as the job goes and writes the report (:mod:`hex_control.grinding.job_report`).

Exit code 0 only if the job ended as the policy intended (done, or Quit Now); a node that
dies or a loop that stands ends the run with one line and exit code 3 (:class:`GraphFailure`,
``hexctl demo``: :mod:`hex_control.ros.app.demo`). The observer that records is
:class:`hex_control.ros.app.job_observer.JobObserver`.
"""

from __future__ import annotations

import math
import signal
import time
from pathlib import Path

import numpy as np
import rclpy
import yaml
from rclpy.context import Context

from hex_control.grinding.job import read_goal, read_log, unfinished_logs
from hex_control.grinding.job_report import PASS_TABLE_HEADER, JobRecord, pass_row
from hex_control.grinding.run_files import WORKPIECE_FILE, fresh_job_dir, fresh_recording_dir, resumable_job_dir
from hex_control.recording.bag import BagWriter
from hex_control.ros.app.graph import NodeGraph, graph_nodes, missing_stream_edges
from hex_control.ros.app.job_observer import REASONS, JobObserver, name_of
from hex_control.ros.infra.action_probe import ResponseProbe
from hex_control.ros.infra.runtime import make_executor
from hex_control.ros.tools.recorder import BATCHED_IN_TELEMETRY, Recorder
from hex_control_msgs.action import GrindBead

#: topics a job's recording leaves out (relative to the cell)
RECORD_EXCLUDED = BATCHED_IN_TELEMETRY


#: wall seconds the plant's clock may stand still during a pass before the job is given up:
#: the plant runs on even without a controller, so a clock that stands while a pass has been
#: announced is a loop nobody answers (between passes it stands while the planners plan)
STALL_S = 60.0


#: wall seconds for a fresh graph's lock-step loop to close once its streams have matched
#: (the plant's first state answered: at most one re-send, 1 s, after both sides matched)
LOOP_START_S = 30.0
#: the latched topics a pass is handed over on (depth 1): the observer must know their
#: publishers before the job starts, else a late discovery left it only the latest pass's (a
#: two-cell test's observer once missed pass 0's trajectory)
HANDOVER_TOPICS = ("grinding/force_trajectory", "motion/tool_path_raw", "plant/strut_trajectory")


class GraphFailure(RuntimeError):
    """The graph stopped doing its job (a node died, the loop stands): not the job's outcome.
    ``one_line`` says it for ``hexctl demo``; ``resume_dir``, once set, the directory whose
    unfinished job ``--resume`` takes up."""

    def __init__(self, text: str, detail: str = ""):
        super().__init__(text + (f":\n{detail}" if detail else ""))
        self.text, self.resume_dir = text, None

    @property
    def one_line(self) -> str:
        resume = f"; hexctl demo --resume {self.resume_dir} takes up its job" if self.resume_dir else ""
        return self.text + resume


class NodeDied(GraphFailure):
    """A node of the graph exited on its own (``code``: its exit code, -N for signal N)."""

    def __init__(self, name: str, code: int, log_path: Path, tail: str = ""):
        how = f"was killed by {signal_name(-code)} (exit code {code})" if code < 0 else f"exited with code {code}"
        super().__init__(f"node {name} {how}; its log: {log_path}", tail)
        self.name, self.code, self.log_path = name, code, Path(log_path)


def signal_name(number: int) -> str:
    """SIGKILL for 9; 'signal N' for a number that names none."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class JobSession:
    """A fresh graph, an observer in its own rclpy context, and one job on it. Use as a
    context manager; ``start_job`` sends the goal, ``wait_for_outcome`` spins to the end
    (the fault tests kill and restart nodes in between, through ``graph``).

    The plant keeps the part in the job directory (``WORKPIECE_FILE``), so a restarted plant
    grinds on where it was. With ``resume`` the session takes up the unfinished job that a
    run cut off left in ``output``: ``resume_job`` instead of ``start_job``."""

    def __init__(self, output: Path, seed: int = 0, *, mode: str = "lockstep", real_time_factor: float = 1.0,
                 plant_overrides: dict | None = None, placement: dict | None = None, machine_file: str | None = None,
                 namespace: str = "", record: bool = True, resume: bool = False):
        self.output = Path(output)
        jobs = resumable_job_dir(self.output) if resume else fresh_job_dir(self.output)
        self.resumed_log = unfinished_logs(jobs)[-1] if resume else None
        workpiece = jobs / WORKPIECE_FILE
        if not resume:
            workpiece.unlink(missing_ok=True)  # a finished job's part: this run grinds a fresh bead
        plant_overrides = {**(plant_overrides or {}), "workpiece_file": str(workpiece)}
        self.graph = NodeGraph(graph_nodes(jobs, seed, mode=mode, plant_overrides=plant_overrides,
                                           machine_file=machine_file, real_time_factor=real_time_factor,
                                           namespace=namespace), self.output / "logs", placement=placement)
        self.seed, self.mode = seed, mode
        self.record = JobRecord()
        self.context = Context()
        # no rclpy signal handlers: they shut the context down from a thread of their own, racing
        # the SystemExit that `hexctl demo` raises on SIGTERM to stop the graph (a CI run exited 1, not 143)
        rclpy.init(context=self.context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
        # the graph's executor (events unless HEX_EXECUTOR=single): a SingleThreadedExecutor
        # rebuilding its wait set for every message took 0.18-0.25 CPU s per simulated s here
        self.executor = make_executor(context=self.context)
        self.observer = JobObserver(self.record, context=self.context, namespace=namespace or "/")
        self.executor.add_node(self.observer)
        self.recorder = None
        if record:  # every topic of the cell, into output/recording (rosbag2's MCAP layout), but the
            # per-period streams that plant/telemetry batches: written from the batches (a reader of each
            # would cost the lock-step loop a send per period)
            self.recorder = Recorder(self.observer, BagWriter(fresh_recording_dir(self.output)), all_topics=True,
                                     under=namespace, exclude=RECORD_EXCLUDED, unbatch=True)
        self.goal_handle = self.result_future = None

    def __enter__(self) -> JobSession:
        for name in self.graph.specs:
            # resuming, the sequence planner comes last (resume_job): it sends the resumed pass's
            # command at once, and the pass planner refuses a command whose contour has not come
            # within contour_wait_s (5 s wall) -- a plant taking up the part may start slower
            if not (self.resumed_log is not None and name == "sequence_planner"):
                self.graph.start(name)
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.recorder is not None:
                self.recorder.close()
            # every node on the session's executor (the observer, and any a caller added: a test's
            # impostors), destroyed before the context: a node left to the garbage collector keeps
            # its DDS participant, and its latched messages reach the next graph in the domain
            for node in self.executor.get_nodes():
                self.executor.remove_node(node)
                node.destroy_node()
            self.executor.shutdown()
            self.context.try_shutdown()
        finally:  # the nodes run in sessions of their own: nothing else would stop them
            self.graph.stop()

    def spin_until(self, condition, timeout_s: float, what: str):
        end = time.monotonic() + timeout_s
        while not (value := condition()):
            if time.monotonic() > end:
                raise TimeoutError(f"timed out after {timeout_s:g} s waiting for {what}")
            if self.graph.dead():
                name, code = next(iter(self.graph.dead().items()))
                raise NodeDied(name, code, self.graph.log_path(name), self.graph.log_tail(name))
            self.executor.spin_once(timeout_sec=0.05)
        return value

    def wait_until_ready(self) -> None:
        """Spin until the graph can take a goal: the plant's first scan, the control streams
        matched, the sequence planner hearing the K1 predictor (a planner that has not found it
        yet decides the first pass without its prediction: the job would depend on discovery),
        the publishers of the HANDOVER_TOPICS discovered,
        the action server answering, the force loop's first state answered. TimeoutError
        naming what it waited for."""
        record, observer = self.record, self.observer
        self.spin_until(lambda: record.contours, 60.0, "the plant's first scan")
        try:
            self.spin_until(lambda: not missing_stream_edges(observer), 60.0,
                            "the control streams to match (pass planner -> shaper -> kinematics -> plant, force loop)")
        except TimeoutError as exc:
            raise TimeoutError(f"{exc}; not seen: {', '.join(missing_stream_edges(observer))}") from None
        self.spin_until(lambda: observer.planner_hears_predictor, 60.0, "the sequence planner to hear the K1 predictor")
        self.spin_until(lambda: all(observer.count_publishers(topic) for topic in HANDOVER_TOPICS), 60.0,
                        f"the publishers of {', '.join(HANDOVER_TOPICS)} to be discovered")
        probe = ResponseProbe(observer.client)
        try:
            self.spin_until(probe, 60.0, "the sequence planner's action server to answer")
        except TimeoutError as exc:
            raise TimeoutError(f"{exc}: {probe}") from None
        self.spin_until(lambda: record.force, LOOP_START_S, "the plant's first state to be answered (the force loop)")

    def _ready(self) -> None:
        try:
            self.wait_until_ready()
        except TimeoutError as exc:
            silent = self.graph.dump_tracebacks()  # where each node waits, into logs/<node>.log
            raise TimeoutError(f"the graph did not start ({exc}); its nodes' tracebacks are in {self.graph.log_dir}"
                               f"{' (none from ' + ', '.join(silent) + ')' if silent else ''}") from None

    def start_job(self, deadline_s: float, reset_time_s: float | None = None, job_id: str | None = None) -> str:
        record, observer = self.record, self.observer
        self._ready()
        bead, width = record.contours[0]
        goal = GrindBead.Goal(job_id=job_id or f"job-{self.seed}-{int(time.time())}", deadline_s=float(deadline_s),
                              bead_width_mm=float(width))
        goal.bead.x_mm, goal.bead.z_mm, goal.bead.parent_mm = bead.x_mm.tolist(), bead.z_mm.tolist(), \
            bead.parent_mm.tolist()
        if reset_time_s is not None:
            goal.process_yaml = yaml.safe_dump({"reset_time_s": float(reset_time_s)})
        observer.job_id = goal.job_id
        record.goal = {"job_id": goal.job_id, "deadline_s": deadline_s, "bead_width_mm": width,
                       "bead_length_mm": bead.length_mm, "seed": self.seed, "reset_time_s": reset_time_s,
                       "mode": self.mode,
                       "material_mm": float(np.trapezoid(bead.z_mm - bead.parent_mm, bead.x_mm) / bead.length_mm)}
        sent = observer.client.send_goal_async(goal)
        self.spin_until(sent.done, 60.0, "the goal's acceptance")
        self.goal_handle = sent.result()
        self.result_future = self.goal_handle.get_result_async()
        return goal.job_id

    def cancel_job(self) -> None:
        """Cancel the job's goal (as Ctrl-C on ``hexctl action send_goal`` does); its result
        then comes through ``wait_for_outcome``."""
        if self.goal_handle is None:
            raise ValueError("no goal of this session to cancel")
        cancelled = self.goal_handle.cancel_goal_async()
        self.spin_until(cancelled.done, 30.0, "the cancel's answer")

    def resume_job(self) -> str:
        """Take up the unfinished job (``resume``): the plant the part as last scanned, then
        (once it has published that scan) the sequence planner the job from its log; no goal
        is sent. The record holds the passes from here on."""
        if self.resumed_log is None:
            raise ValueError("this session was not opened to resume a job")
        goal, log = read_goal(self.resumed_log), read_log(self.resumed_log)
        self.observer.job_id = goal.job_id
        self.record.first_pass = sum(r["type"] == "result" for r in log)
        self.spin_until(lambda: self.record.contours, 60.0, "the plant's scan of the part it took up")
        self.graph.start("sequence_planner")
        self._ready()
        first = next((r for r in log if r["type"] == "decision"), None)
        self.record.goal = {"job_id": goal.job_id, "deadline_s": goal.deadline_s, "bead_width_mm": goal.bead_width_mm,
                            "bead_length_mm": goal.bead_length_mm, "seed": self.seed,
                            "reset_time_s": goal.config_overrides.get("process", {}).get("reset_time_s"),
                            "mode": self.mode, "material_mm": goal.material_mm,
                            "resumed_at_pass": self.record.first_pass,
                            "expected_penalty_at_start": first["expected_penalty"] if first else math.nan}
        return goal.job_id

    def wait_for_outcome(self, timeout_s: float, on_pass=None) -> dict:
        """Spin until the job's result (the action's, or the planner's latched job_result
        after a restart); ``on_pass(index, command, result)`` for each pass as it ends."""
        record, seen = self.record, set()
        clock = {"sim_s": None, "since": time.monotonic()}

        def finished():
            sim_s = record.force[-1][0] if record.force else None
            in_pass = bool(set(record.trajectories) - set(record.results))
            if sim_s != clock["sim_s"] or not in_pass:
                clock.update(sim_s=sim_s, since=time.monotonic())
            elif time.monotonic() - clock["since"] > STALL_S:
                raise GraphFailure(f"the plant's clock has stood at {sim_s} s for {STALL_S:g} s: nothing answers "
                                   f"its lock-step loop (see {self.graph.log_path('plant')} and "
                                   f"{self.graph.log_path('force_controller')})")
            for index in sorted(set(record.results) - seen):
                if index in record.commands:
                    seen.add(index)
                    if on_pass:
                        on_pass(index, record.commands[index], record.results[index])
            if self.result_future is not None and self.result_future.done():
                return self.result_future.result().result
            return self.observer.job_result  # the planner's latched result: after a restart, or a resumed job's

        result = self.spin_until(finished, timeout_s, "the job's result")
        job_result = self.observer.resolve_topic_name("sequence_planner/job_result")

        def straggling():  # the last pass's result and contour, the recording's copy of the job's result, and
            # each pass's command (a restarted planner's wait in the observer until discovery names its endpoints)
            return (len(record.results) < result.passes or max(record.contours) < len(record.results)
                    or set(record.results) - set(record.commands)
                    or self.recorder is not None and not self.recorder.counts.get(job_result))

        end = time.monotonic() + 10.0  # they may come after the job's result; a bounded wait for them
        while time.monotonic() < end and straggling():
            self.executor.spin_once(timeout_sec=0.05)
        finished()
        record.outcome = {"reason": name_of(REASONS, result.reason), "message": result.message, "passes": result.passes,
                          "material_remaining_mm": result.material_remaining_mm,
                          "time_remaining_s": result.time_remaining_s, "lateness_s": result.lateness_s,
                          "total_charge": result.total_charge}
        return record.outcome



def run_job(output: Path, deadline_s: float = 60.0, seed: int = 0, mode: str = "lockstep",
            real_time_factor: float = 1.0, *, reset_time_s: float | None = None, plant_overrides: dict | None = None,
            timeout_s: float = 1800.0, quiet: bool = False, placement: dict | None = None,
            machine_file: str | None = None, restart_planner_after: int | None = None,
            namespace: str = "", record: bool = True, resume: bool = False) -> JobRecord:
    """Run one job on a fresh graph; returns what was recorded (the graph is stopped).
    ``restart_planner_after`` k: kill the sequence planner (SIGKILL) once pass k has ended
    and start it again -- it resumes from its job log. ``resume``: take up the unfinished
    job in ``output`` instead of starting one (``deadline_s`` and ``reset_time_s`` are the
    job's own then)."""
    with JobSession(output, seed, mode=mode, real_time_factor=real_time_factor, plant_overrides=plant_overrides,
                    placement=placement, machine_file=machine_file, namespace=namespace, record=record,
                    resume=resume) as session:
        if resume:
            session.resume_job()
        else:
            session.start_job(deadline_s, reset_time_s)
        if not quiet:
            goal = session.record.goal
            resumed = f", resumed after {session.record.first_pass} passes" if resume else ""
            print(f"job {goal['job_id']}: bead {goal['bead_length_mm']:.0f} mm x {goal['bead_width_mm']:g} mm, mean "
                  f"height {goal['material_mm']:.3f} mm, deadline {goal['deadline_s']:g} s{resumed}")
            print(PASS_TABLE_HEADER)

        def on_pass(index, command, result):
            if not quiet:
                print(pass_row(index, command, result, session.record.guard_cut_mm(index)), flush=True)
                if index == session.record.first_pass and command.get("planner_note"):
                    print(f"   planner: {command['planner_note']}", flush=True)
            if index == restart_planner_after:
                session.graph.kill("sequence_planner")
                session.graph.start("sequence_planner")
                session.record.events.append(("planner_restart", index))
                if not quiet:
                    print("     sequence planner killed and restarted", flush=True)
        session.wait_for_outcome(timeout_s, on_pass)
        if not quiet and any(session.record.guard_cut_mm(k) is not None for k in session.record.results):
            print("   * depth cut by the pass planner's force or stall guard (the pass would need more than F_max "
                  "or 80 % of the grinder's power somewhere)")
    return session.record
