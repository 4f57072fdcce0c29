"""The main job: start the whole hierarchy, grind one weld bead, report (DESIGN.md section 4).

``run_job`` starts every node as its own process (:mod:`hex_control.ros.app.graph`), waits
for the plant's scanner to publish the bead, sends the GrindBead goal with that profile to
the sequence planner, and records over ROS 2 what the tiers hand each other: pass commands,
force trajectories, measured forces, strut lengths, pass results and contours. It prints a
pass-by-pass table as the job goes and writes the report (:mod:`hex_control.grinding.job_report`).

Exit code 0 only if the job ended as the policy intended (done, or Quit Now); a node that
dies or a loop that stands ends the run with one line and exit code 3 (:class:`GraphFailure`,
``hexctl demo``). Each run's options are stored in its directory (``run_files.RUN_FILE``) when it
starts: ``--resume`` takes them up (its seed), and refuses one given that differs.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections import Counter
from pathlib import Path

import numpy as np
import rclpy
import yaml
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.node import Node

from hex_control.config import config_file
from hex_control.grinding.job import read_goal, read_log, unfinished_logs
from hex_control.grinding.job_report import PASS_TABLE_HEADER, JobRecord, job_line, pass_row
from hex_control.grinding.run_files import (
    WORKPIECE_FILE,
    fresh_job_dir,
    fresh_recording_dir,
    resumable_job_dir,
    store_run_options,
)
from hex_control.recording.bag import BagWriter
from hex_control.ros.app.graph import MACHINE_SIDE, NodeGraph, graph_nodes, missing_stream_edges
from hex_control.ros.infra.action_probe import ResponseProbe
from hex_control.ros.infra.interfaces import RESULTS, STREAM, TELEMETRY, contour_from_message, stamp_s
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.messages import to_primitive
from hex_control.ros.infra.runtime import make_executor
from hex_control.ros.tools.recorder import BATCHED_IN_TELEMETRY, Recorder
from hex_control_msgs.action import GrindBead
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceTrajectory, LoadPrediction, PassCommand, PassResult, PlantTelemetry

#: PassResult.status by value (FAULTED: ran, but not as planned), GrindBead.Result.reason by value
PASS_STATUSES = ("completed", "aborted", "rejected", "faulted")
REASONS = ("done", "quit", "cancelled", "aborted", "rejected")


def name_of(names: tuple[str, ...], value: int) -> str:
    """``names[value]``; a value the observer does not know yet (a newer message) as 'status <value>'."""
    return names[value] if 0 <= value < len(names) else f"status {value}"


#: topics a job's recording leaves out (relative to the cell)
RECORD_EXCLUDED = BATCHED_IN_TELEMETRY
KEPT_WHILE_UNNAMED = 200  # messages per publisher held until discovery names it: a late joiner's kept history


class _Tally:
    """The counters info_subscription keeps, for a node without diagnostics of its own."""

    def __init__(self, counter: Counter):
        self.counts = counter

    def count(self, name: str, increment: int = 1) -> None:
        self.counts[name] += increment

    def fault(self, *_args, **_kwargs) -> None:
        pass


class JobObserver(Node):
    def __init__(self, record: JobRecord, **kwargs):
        super().__init__("grind_job", **kwargs)
        self.record = record
        self.client = ActionClient(self, GrindBead, "sequence_planner/grind_bead")
        # the latched topics keep their last message for late joiners; this reader keeps ten,
        # so that two arriving while its executor is busy (the recorder shares it) are both seen
        # the record is what the cell's own nodes published: another process's messages on the
        # same topics (an attack, issue 37) are counted in ``refused``, not recorded
        self.refused = Counter()
        for msg_type, topic, callback, qos, owner in (
                (ContourMsg, "grinding/contour", self._on_contour, RESULTS, "plant"),
                (PassCommand, "grinding/pass_command", self._on_command, RESULTS, "sequence_planner"),
                # the planner's feedback carries every command too, kept for late joiners: a command
                # topic holds only its last, which a restarted planner may have replaced before it matched
                (GrindBead.Feedback, "sequence_planner/job_feedback", self._on_feedback, RESULTS, "sequence_planner"),
                (PassResult, "grinding/pass_result", self._on_result, RESULTS, ("plant", "pass_planner")),
                (ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, RESULTS, "pass_planner"),
                (PlantTelemetry, "plant/telemetry", self._on_telemetry, TELEMETRY, "plant"),
                (GrindBead.Result, "sequence_planner/job_result", self._on_job_result, RESULTS, "sequence_planner"),
                (LoadPrediction, "load_predictor/pass/prediction", self._on_k1, STREAM, "load_predictor/pass")):
            info_subscription(self, msg_type, topic, callback, qos, diagnostics=_Tally(self.refused), name=topic,
                              owner_node=owner, wait_depth=KEPT_WHILE_UNNAMED)
        self.job_id = None  # the job whose messages are recorded
        self.job_result = None
        self.foreign_messages = 0
        self.telemetry_arrivals = None  # a list to get (wall s, sim s of the last sample) per batch (hexctl bench)

    def destroy_node(self) -> None:
        # rclpy's destroy_node leaves waitables: the action client would keep the node and its
        # DDS participant until the garbage collector finalized it, at a moment that can
        # deadlock Fast DDS against the process's other participants
        self.client.destroy()
        super().destroy_node()

    def _mine(self, job_id: str) -> bool:
        mine = self.job_id is not None and job_id == self.job_id
        if job_id and self.job_id is not None and not mine:
            self.foreign_messages += 1  # another job's: an earlier one's latched, or another cell's
        return mine

    def _on_contour(self, msg: ContourMsg) -> None:
        if msg.pass_index == 0 and not msg.job_id or self._mine(msg.job_id):
            try:
                contour = contour_from_message(msg)
            except ValueError:
                return  # not a profile (someone else's garbage on the topic)
            self.record.contours.setdefault(int(msg.pass_index), (contour, msg.bead_width_mm))

    def _on_command(self, msg: PassCommand) -> None:
        if self._mine(msg.job_id) and not msg.stop:  # a stop ends the pass it names: no new command
            if int(msg.pass_index) not in self.record.commands:
                self.record.events.append(("command", int(msg.pass_index)))
            self.record.commands[int(msg.pass_index)] = {
                **self.record.commands.get(int(msg.pass_index), {}),  # the feedback's outlook, if heard
                "force_n": msg.normal_force_n, "feed_mm_s": msg.feed_speed_mm_s, "cut_depth_mm": msg.cut_depth_mm,
                "specific_energy_j_mm3": msg.specific_energy_j_mm3, "material_mm": msg.material_remaining_mm,
                "time_remaining_s": msg.time_remaining_s,
                "expected_penalty": msg.expected_penalty, "duration_s": msg.pass_duration_s}

    def _on_feedback(self, msg) -> None:
        """GrindBead feedback: its command, and the planner's outlook for the job (issue 42)."""
        self._on_command(msg.command)
        k = int(msg.command.pass_index)
        if self._mine(msg.command.job_id) and k in self.record.commands:
            self.record.commands[k].update(deadline_reachable=bool(msg.deadline_reachable),
                                           expected_final_material_mm=float(msg.expected_final_material_mm),
                                           planner_note=msg.note)

    def _on_result(self, msg: PassResult) -> None:
        if (self._mine(msg.job_id) and msg.pass_index >= self.record.first_pass
                and int(msg.pass_index) not in self.record.results):  # a restarted plant reports its last again
            self.record.events.append(("result", int(msg.pass_index)))
            self.record.results[int(msg.pass_index)] = {
                "status": name_of(PASS_STATUSES, msg.status), "reason": msg.reason,
                "measured_cut_depth_mm": msg.measured_cut_depth_mm, "duration_s": msg.duration_s,
                "mean_normal_force_n": msg.mean_normal_force_n, "peak_normal_force_n": msg.peak_normal_force_n,
                "feed_speed_mm_s": msg.feed_speed_mm_s, "specific_energy_j_mm3": msg.specific_energy_j_mm3,
                "burn": msg.burn_detected, "stall": msg.stall_detected, "stamp_s": stamp_s(msg.header.stamp),
                "part_quality": to_primitive(msg.part_quality)}

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        if self._mine(msg.job_id):
            self.record.events.append(("trajectory", int(msg.pass_index)))
            start = stamp_s(msg.header.stamp)
            self.record.trajectories[int(msg.pass_index)] = (start, list(msg.time_from_start_s),
                                                             list(msg.normal_force_n))
            self.record.planned_cut_mm[int(msg.pass_index)] = msg.planned_cut_depth_mm

    def _on_k1(self, msg: LoadPrediction) -> None:
        self.record.k1_predictions.append((stamp_s(msg.header.stamp), msg.prediction, msg.drift_probability))

    def _on_job_result(self, msg) -> None:
        if self.job_id is not None:
            self.job_result = msg

    def _on_telemetry(self, msg: PlantTelemetry) -> None:
        record, n = self.record, len(msg.strut_names)
        if self.telemetry_arrivals is not None and len(msg.time_s):
            self.telemetry_arrivals.append((time.monotonic(), msg.time_s[-1]))
        if record.force and len(msg.time_s) >= 2 and msg.time_s[0] - record.force[-1][0] > 1.5 * (
                msg.time_s[1] - msg.time_s[0]):
            record.telemetry_gaps.append((record.force[-1][0], msg.time_s[0]))  # batches lost on the way
        record.force.extend(zip(msg.time_s, msg.measured_force_n))
        if not n or len(msg.strut_lengths_m) != n * len(msg.time_s):
            return  # no strut command yet
        record.strut_names = record.strut_names or list(msg.strut_names)
        for k, stamp in enumerate(msg.time_s):
            if not record.struts or stamp - record.struts[-1][0] >= 0.05 - 1e-9:
                record.struts.append((stamp, *msg.strut_lengths_m[k * n:(k + 1) * n]))


#: wall seconds the plant's clock may stand still during a pass before the job is given up:
#: the plant runs on even without a controller, so a clock that stands while a pass has been
#: announced is a loop nobody answers (between passes it stands while the planners plan)
STALL_S = 60.0


#: wall seconds for a fresh graph's lock-step loop to close once its streams have matched
#: (the plant's first state answered: at most one re-send, 1 s, after both sides matched)
LOOP_START_S = 30.0


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
            self.executor.remove_node(self.observer)
            self.observer.destroy_node()
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
        matched, the action server answering, the force loop's first state answered.
        TimeoutError naming what it waited for."""
        record, observer = self.record, self.observer
        self.spin_until(lambda: record.contours, 60.0, "the plant's first scan")
        self.spin_until(lambda: not missing_stream_edges(observer), 60.0,
                        "the control streams to match (pass planner -> shaper -> kinematics -> plant, force loop)")
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

        def straggling():  # the last pass's result and contour, and the recording's copy of the job's result
            return (len(record.results) < result.passes or max(record.contours) < len(record.results)
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


def start_policy(record: JobRecord):
    """The policy the sequence planner solved for this goal at the start (same config, and
    its cut model of a pass planned on the estimated K1; not its force limit from the scan)."""
    import dataclasses

    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.sdp import solve
    from hex_control.grinding.sequencer import SequencerSettings, policy_cut_model

    process, charges, grid, cut_model = load_planner_config(config_file("sequence_planner.yaml"))
    changes = {"bead_width_mm": record.goal["bead_width_mm"], "bead_length_mm": record.goal["bead_length_mm"]}
    if record.goal.get("reset_time_s") is not None:
        changes["reset_time_s"] = record.goal["reset_time_s"]
    model, factor = policy_cut_model(cut_model, SequencerSettings(Path()).k1_estimate_cv)
    process = dataclasses.replace(process, **changes, specific_energy_j_mm3=process.specific_energy_j_mm3 / factor)
    grid = grid.covering(record.goal["deadline_s"], record.goal["material_mm"])
    return solve(process, charges, grid, model), charges


def calibrate_reset_time(bead_length_mm: float, feed_mm_s: float = 20.0,
                         machine_file: str = "machines/nist_ingersoll.yaml") -> dict:
    """t_R measured on the plant's machine model, with the input shaper's default (ZVD at
    the structural mode) and without: what the sequence planner plans with."""
    from hex_control.config import load_cell_configuration
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.kinematics import load_machine
    from hex_control.plant.machine import MachineParameters
    from hex_control.plant.reset_time import measure_reset_time
    from hex_control.shaping.shapers import design

    parameters = MachineParameters(**load_cell_configuration(machine=config_file(machine_file)).structure)
    machine, document = load_machine(config_file(machine_file))
    config = load_pass_planner_config("pass_planner.yaml", document)
    height = config.model.radius_mm * np.sin(config.model.relaxed_angle_rad) + 1.0
    shaper = design("zvd", parameters.mode_frequency_hz, parameters.mode_damping)
    return {name: measure_reset_time(machine, config.frame, bead_length_mm, feed_mm_s, height, timing=config.path,
                                     parameters=parameters, shaper=s)
            for name, s in (("unshaped", None), ("zvd", shaper))}


def _calibrated_reset_time(bead_length_mm: float, deadline_s: float, machine_file: str) -> float:
    """t_R with the input shaper (s), printed beside the unshaped one."""
    reset = calibrate_reset_time(bead_length_mm, machine_file=machine_file)
    for name, r in reset.items():
        print(f"reset time t_R ({name}): {r.reset_time_s:.2f} s (settle {r.settle_s:.2f} s after the path, "
              f"peak deflection {r.peak_deflection_mm:.3f} mm)")
    shortest = bead_length_mm / 75.0
    print(f"shaping buys {reset['unshaped'].reset_time_s - reset['zvd'].reset_time_s:.2f} s a pass: "
          f"{int(deadline_s // (shortest + reset['unshaped'].reset_time_s))} -> "
          f"{int(deadline_s // (shortest + reset['zvd'].reset_time_s))} fastest passes fit in {deadline_s:g} s")
    return reset["zvd"].reset_time_s


def use_private_domain(environment) -> bool:
    """Set ``ROS_DOMAIN_ID`` in ``environment`` to a domain for this run unless it is set:
    1..101 (the ids whose ports never clash with the ephemeral range), from the process id,
    so two demos started side by side differ. True if it chose one."""
    if environment.get("ROS_DOMAIN_ID", "").strip():
        return False
    environment["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 101)
    return True


def run_seeded_job(directory: Path, options: dict, *, reset_time_s: float | None, machine_file: str,
                   quiet: bool = False, placement: dict | None = None, restart_planner_after: int | None = None,
                   record: bool = True, resume: bool = False, timeout_s: float = 1800.0) -> tuple[dict, object]:
    """One job of ``hexctl demo`` or of a campaign's cell, on a fresh graph: the run's
    ``options`` (:func:`run_options`, its seed included) stored in ``directory`` (unless
    resumed), the job run, its report written (``job.json`` with ``wall_s`` and
    ``simulated_pass_time_s``). The summary and the start policy's charges. A graph that
    fails raises GraphFailure (``resume_dir`` set where an unfinished job is left)."""
    import json

    from hex_control.grinding.job_report import write_report

    directory, seed = Path(directory), options["seed"]
    if not resume:
        store_run_options(directory, options)
    overrides = {"bead_length_mm": float(options["bead_length"]), "bead_height_mm": float(options["bead_height"]),
                 "dulling_per_pass": float(options["dulling"])}
    start = time.monotonic()
    try:
        job = run_job(directory, options["deadline"], seed, "realtime" if options["realtime"] else "lockstep",
                      options["real_time_factor"], reset_time_s=reset_time_s, plant_overrides=overrides,
                      timeout_s=timeout_s, quiet=quiet,
                      placement=placement, machine_file=str(config_file(machine_file)),
                      restart_planner_after=restart_planner_after, namespace=options["namespace"], record=record,
                      resume=resume)
    except GraphFailure as exc:
        jobs_dir = directory / "jobs"
        exc.resume_dir = directory if jobs_dir.is_dir() and unfinished_logs(jobs_dir) else None
        raise
    wall = time.monotonic() - start
    policy, charges = start_policy(job)
    summary = write_report(job, directory, policy)
    summary["wall_s"] = wall
    summary["simulated_pass_time_s"] = sum(r["duration_s"] for r in job.results.values())
    (directory / "job.json").write_text(json.dumps(summary, indent=2, default=float))
    return summary, charges


def run_demo(output: str, options: dict, *, machine_file: str = "machines/nist_ingersoll.yaml", jobs: int = 1,
             machine_host: list[str] | None = None,
             machine_peers: str = "", restart_planner_after: int | None = None, record: bool = True,
             resume: bool = False) -> int:
    """``hexctl demo``: calibrate t_R, run ``jobs`` seeded jobs, report each and, for several,
    the statistics. ``options``: :func:`run_options` (seed, deadline, bead, machine,
    namespace ...), stored into each job's directory as it starts; ``machine_file``: the
    machine option's file (config/machines/). 0 only if every job ended
    as its policy intended, without burn. The graph runs in a ROS domain of its own unless
    ROS_DOMAIN_ID is set, and under the ``namespace`` option if given; each job's messages
    are recorded into its ``recording/``. ``resume``: take up the unfinished job of an earlier
    run cut off in ``output`` (its deadline and t_R come from its log, the rest of its options
    from its RUN_FILE, through ``options``) instead. A node that dies or a loop that stands
    raises GraphFailure (``resume_dir`` set where an unfinished job is left)."""
    import json

    from hex_control.grinding.job_report import job_statistics

    seed = options["seed"]
    if use_private_domain(os.environ):
        print(f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}: a domain of the demo's own (export ROS_DOMAIN_ID "
              "to run it in yours)")
    out = Path(output)
    if resume:
        jobs, reset_time_s = 1, None
        print(f"resuming the unfinished job of {resumable_job_dir(out)} (seed {seed})")
    else:
        reset_time_s = _calibrated_reset_time(options["bead_length"], options["deadline"], machine_file)
    placement = None
    if machine_host:  # the machine-side nodes on another host (network namespace) with its DDS peers
        placement = {name: (machine_host, {"ROS_STATIC_PEERS": machine_peers} if machine_peers else {})
                     for name in MACHINE_SIDE}
        print(f"machine-side nodes {', '.join(MACHINE_SIDE)} run under: {' '.join(machine_host)}")
    summaries, charges = [], None
    for k in range(jobs):
        directory = out / f"job_{seed + k:03d}" if jobs > 1 else out
        summary, charges = run_seeded_job(directory, {**options, "seed": seed + k}, reset_time_s=reset_time_s,
                                          machine_file=machine_file, quiet=jobs > 1, placement=placement,
                                          restart_planner_after=restart_planner_after, record=record, resume=resume)
        summaries.append(summary)
        print(job_line(seed + k, summary), flush=True)
    if jobs > 1:
        stats = job_statistics(summaries, charges.deadline.tolerance_mm)
        (out / "statistics.json").write_text(json.dumps(stats, indent=2))
        print(json.dumps(stats, indent=2))
    print(f"report: {out}")
    ok = all(s["ended_as_intended"] and not s["burn"] for s in summaries)
    return 0 if ok else 1
