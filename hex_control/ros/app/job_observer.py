"""The job's observer: the node through which a job session sends the goal and records what
the cell's tiers hand each other (:class:`hex_control.grinding.job_report.JobRecord`).

It records only what the cell's own nodes published: another process's messages on the same
topics (an attack, issue 37) are counted in ``refused``, not recorded.
"""

from __future__ import annotations

import time
from collections import Counter

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.qos import QoSProfile

from hex_control.grinding.job_report import JobRecord
from hex_control.ros.infra.interfaces import RESULTS, STREAM, TELEMETRY, contour_from_message, stamp_s
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.messages import to_primitive
from hex_control_msgs.action import GrindBead
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceTrajectory, LoadPrediction, PassCommand, PassResult, PlantTelemetry

#: the plant's telemetry as its nodes take it, but 1000 batches deep (100 s of sim time, 14 s of
#: wall time at 7x), so that batches wait while this process's executor waits for a core. At 100
#: a loaded suite once lost 2.9 s of a pass (test_determinism, four workers on two cores); that
#: this reader overflowed is likely, not shown (its count of ``lost_plant/telemetry`` was not kept).
OBSERVED_TELEMETRY = QoSProfile(depth=1000, reliability=TELEMETRY.reliability, durability=TELEMETRY.durability)

#: PassResult.status by value (FAULTED: ran, but not as planned), GrindBead.Result.reason by value
PASS_STATUSES = ("completed", "aborted", "rejected", "faulted")
REASONS = ("done", "quit", "cancelled", "aborted", "rejected")


def name_of(names: tuple[str, ...], value: int) -> str:
    """``names[value]``; a value the observer does not know yet (a newer message) as 'status <value>'."""
    return names[value] if 0 <= value < len(names) else f"status {value}"


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
                (PlantTelemetry, "plant/telemetry", self._on_telemetry, OBSERVED_TELEMETRY, "plant"),
                (GrindBead.Result, "sequence_planner/job_result", self._on_job_result, RESULTS, "sequence_planner"),
                (LoadPrediction, "load_predictor/pass/prediction", self._on_k1, STREAM, "load_predictor/pass")):
            info_subscription(self, msg_type, topic, callback, qos, diagnostics=_Tally(self.refused), name=topic,
                              owner_node=owner, wait_depth=KEPT_WHILE_UNNAMED)
        # the planner's own health report (every node's shares /diagnostics: theirs are not refusals)
        info_subscription(self, DiagnosticArray, "/diagnostics", self._on_planner_health, 10,
                          diagnostics=_Tally(Counter()), name="diagnostics", owner_node="sequence_planner")
        self.job_id = None  # the job whose messages are recorded
        self.job_result = None
        self.foreign_messages = 0
        self.telemetry_arrivals = None  # a list to get (wall s, sim s of the last sample) per batch (hexctl bench)
        self.planner_hears_predictor = False  # the sequence planner's own word (its k1_predictor)

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

    def _on_planner_health(self, msg: DiagnosticArray) -> None:
        values = [kv.value for status in msg.status for kv in status.values if kv.key == "k1_predictor"]
        if values:
            self.planner_hears_predictor = values[-1] == "heard"

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
