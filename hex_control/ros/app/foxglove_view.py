"""``hexctl view``: the running cell served over the Foxglove WebSocket protocol with the
official ``foxglove-sdk`` (issue 40 item 2), for Foxglove (app.foxglove.dev or the desktop
app: Open connection -> Foxglove WebSocket -> ws://localhost:8765) when RViz is not there.

A ROS node in the cell's namespace listens to the cell and logs to Foxglove channels, each
stamped with the cell's sim time (the timeline is the header stamps', not receive time); what
it keeps and how much of a message it sends is :mod:`hex_control.recording.live_view` (no
ROS), the messages it logs are built in :mod:`hex_control.ros.app.foxglove_scenes`, and
:mod:`hex_control.ros.app.foxglove_server` serves it:

  /tf, /tf_static           foxglove.FrameTransforms from the robot_state node's TF tree
  /robot_description        the URDF (schema std_msgs/msg/String, JSON): the 3-D panel's URDF layer
  /scene/machine            foxglove.SceneUpdate: the URDF's visuals as primitives in their link frames
  /scene/bead               foxglove.SceneUpdate in frame ``bead``: the bead's contour, the parent
                            surface under it and the bead as first scanned (lines, m)
  /scene/force              foxglove.SceneUpdate in frame ``tool``: the measured normal force as an
                            arrow along the tool's z, 1 mm per N (each telemetry batch's last sample)
  /plant/wrench             JSON shaped like geometry_msgs/WrenchStamped: the measured normal force
  /plant/true_wrench        the same for the true force (both from the plant's telemetry samples)
  /grinding/contour         JSON shaped like hex_control_msgs/Contour (plot z_mm against x_mm; a
                            long one at MAX_OUTLINE_POINTS evenly spaced points)
  /pass_table               JSON {rows: [...]}: per pass the decision (X, K1, cut, F_N, V_f, J) and
                            the measured result (Table panel)

Every input is obeyed from its source alone (docs/graph.md, threat model): the frames and
the URDF from robot_state, telemetry and contours from the plant, pass commands from the
sequence planner, results from the plant and the pass planner; the others are counted
(``foreign_*`` on ``/diagnostics``, node ``foxglove_view``) and named in a WARN. A contour
beyond the pass planner's point limit, a telemetry batch beyond the plant's or with stamps
that are no ROS stamps is refused (``rejected_*``), and a scene line, the contour channel
and a batch's wrenches have at most ``MAX_OUTLINE_POINTS`` points: the work per message and
per second's republish stays bounded. A client that stops reading loses its own messages (the SDK's per-client queue),
not anyone else's.

The names and shapes match the demo's recording (MCAP, ROS 2 messages), so that
``config/foxglove/hex_control.json`` (the shipped layout) shows both. Static content (the
static frames, the URDF and its scene, the bead, the pass table) is logged again every
second: a client that connects late has it at once.
"""

from __future__ import annotations

import foxglove
from foxglove import Channel
from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel
from rclpy.node import Node
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from hex_control.kinematics.robot_telemetry import TelemetryRefused, checked_stamps
from hex_control.recording.live_view import LiveView, contour_points, contour_refusal, force_samples, seconds_to_ns
from hex_control.ros.app.foxglove_scenes import (
    CONTOUR_SCHEMA,
    STRING_SCHEMA,
    TABLE_SCHEMA,
    WRENCH_SCHEMA,
    bead_scene,
    force_scene,
    frame_transforms,
    machine_scene,
    ns_timestamp,
    wrench_json,
)
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, RESULTS, TELEMETRY
from hex_control.ros.infra.message_info import FOREIGN_WARN_S, info_subscription
from hex_control.ros.nodes.robot_state import TF_STATIC
from hex_control_msgs.msg import Contour, PassCommand, PassResult, PlantTelemetry

#: every channel the view logs to (config/foxglove/hex_control.json shows them)
CHANNEL_TOPICS = ("/tf", "/tf_static", "/robot_description", "/scene/machine", "/scene/bead", "/scene/force",
                  "/plant/wrench", "/plant/true_wrench", "/grinding/contour", "/pass_table")
#: the node(s) each input is obeyed from, relative to the cell's namespace (as the cell's nodes obey them)
OWNERS = {"tf": "robot_state", "tf_static": "robot_state", "robot_description": "robot_state",
          "plant/telemetry": "plant", "grinding/contour": "plant", "grinding/pass_command": "sequence_planner",
          "grinding/pass_result": ("plant", "pass_planner")}
STATUS = {PassResult.COMPLETED: "completed", PassResult.ABORTED: "aborted", PassResult.REJECTED: "rejected",
          PassResult.FAULTED: "faulted"}


class FoxgloveView(Node):
    """Subscribes to the cell (its names relative to the node's namespace) and logs to the
    Foxglove channels of ``context``; :meth:`republish` logs the static content again."""

    def __init__(self, foxglove_context: foxglove.Context, namespace: str = "", **kwargs):
        super().__init__("foxglove_view", namespace=namespace or "/", **kwargs)
        self.tf = FrameTransformsChannel("/tf", context=foxglove_context)
        self.tf_static = FrameTransformsChannel("/tf_static", context=foxglove_context)
        self.description = Channel("/robot_description", schema=STRING_SCHEMA, message_encoding="json",
                                   context=foxglove_context)
        self.machine = SceneUpdateChannel("/scene/machine", context=foxglove_context)
        self.bead = SceneUpdateChannel("/scene/bead", context=foxglove_context)
        self.force = SceneUpdateChannel("/scene/force", context=foxglove_context)
        self.wrench = Channel("/plant/wrench", schema=WRENCH_SCHEMA, context=foxglove_context)
        self.true_wrench = Channel("/plant/true_wrench", schema=WRENCH_SCHEMA, context=foxglove_context)
        self.contour = Channel("/grinding/contour", schema=CONTOUR_SCHEMA, context=foxglove_context)
        self.table = Channel("/pass_table", schema=TABLE_SCHEMA, context=foxglove_context)
        self.static_msg = self.urdf = None
        self.state = LiveView()  # the sim time heard, the pass table, the contours
        self.diagnostics = Diagnostics(self)
        for msg_type, topic, callback, qos in (
                (TFMessage, "tf", self._on_tf, 100), (TFMessage, "tf_static", self._on_tf_static, TF_STATIC),
                (String, "robot_description", self._on_description, LATCHED),
                (PlantTelemetry, "plant/telemetry", self._on_telemetry, TELEMETRY),
                (Contour, "grinding/contour", self._on_contour, LATCHED),
                (PassCommand, "grinding/pass_command", self._on_command, LATCHED),
                (PassResult, "grinding/pass_result", self._on_result, RESULTS)):
            info_subscription(self, msg_type, topic, callback, qos, diagnostics=self.diagnostics,
                              name=topic.rsplit("/", 1)[-1], owner_node=OWNERS[topic])

    def _refused(self, name: str, message: str) -> None:
        self.diagnostics.count(f"rejected_{name}")
        self.diagnostics.fault(f"rejected_{name}", message, hold_s=FOREIGN_WARN_S)
        self.get_logger().warning(message, throttle_duration_sec=10.0)

    def _on_tf(self, msg: TFMessage) -> None:
        if msg.transforms:
            stamp = msg.transforms[0].header.stamp
            self.state.heard(stamp.sec * 1_000_000_000 + stamp.nanosec)
        self.tf.log(frame_transforms(msg), log_time=self.state.time_ns)

    def _on_tf_static(self, msg: TFMessage) -> None:
        self.static_msg = msg
        self.tf_static.log(frame_transforms(msg), log_time=self.state.time_ns)

    def _on_description(self, msg: String) -> None:
        self.urdf = msg.data
        self._log_description()

    def _log_description(self) -> None:
        self.description.log({"data": self.urdf}, log_time=self.state.time_ns)
        try:
            self.machine.log(machine_scene(self.urdf), log_time=self.state.time_ns)
        except ValueError as error:
            self.get_logger().warning(f"robot_description: {error}", throttle_duration_sec=10.0)

    def _on_telemetry(self, msg: PlantTelemetry) -> None:
        try:  # a NaN stamp ended the view (no integer nanoseconds): refused with the batch, as robot_state does
            checked_stamps(msg.time_s)
        except TelemetryRefused as error:
            self._refused("telemetry", f"telemetry refused: {error}")
            return
        for channel, forces in ((self.wrench, msg.measured_force_n), (self.true_wrench, msg.true_force_n)):
            for ns, force_n in force_samples(msg.time_s, forces):  # a plot's worth a batch
                channel.log(wrench_json(ns, force_n), log_time=ns)
        ns = seconds_to_ns(msg.time_s[-1])  # the batch's latest: its stamps are in order (checked)
        self.state.heard(ns)
        if msg.measured_force_n:
            self.force.log(force_scene(msg.measured_force_n[-1], ns_timestamp(ns)), log_time=ns)

    def _on_contour(self, msg: Contour) -> None:
        refusal = contour_refusal(len(msg.x_mm), len(msg.z_mm), len(msg.parent_mm))
        if refusal:
            return self._refused("contour", refusal)
        self.state.contour(msg)
        self._log_contour()

    def _log_contour(self) -> None:
        msg, now_ns = self.state.last_contour, self.state.time_ns
        self.bead.log(bead_scene(msg, self.state.first_contour, ns_timestamp(now_ns)), log_time=now_ns)
        self.contour.log({"job_id": msg.job_id, "pass_index": msg.pass_index,
                          **contour_points(msg.x_mm, msg.z_mm, msg.parent_mm)}, log_time=now_ns)

    def _on_command(self, msg: PassCommand) -> None:
        if msg.stop:
            return
        self.state.row(msg.job_id, msg.pass_index, {
            "X_mm": msg.material_remaining_mm, "t_left_s": msg.time_remaining_s, "K1_J_mm3": msg.specific_energy_j_mm3,
            "cut_planned_mm": msg.cut_depth_mm, "F_N": msg.normal_force_n, "V_f_mm_s": msg.feed_speed_mm_s,
            "J": msg.expected_penalty})
        self._log_table()

    def _on_result(self, msg: PassResult) -> None:
        self.state.row(msg.job_id, msg.pass_index, {
            "status": STATUS.get(msg.status, str(msg.status)), "cut_measured_mm": msg.measured_cut_depth_mm,
            "duration_s": msg.duration_s, "mean_force_n": msg.mean_normal_force_n,
            "K1_measured_J_mm3": msg.specific_energy_j_mm3, "burn": bool(msg.burn_detected),
            "stall": bool(msg.stall_detected)})
        self._log_table()

    def _log_table(self) -> None:
        self.table.log(self.state.table(), log_time=self.state.time_ns)

    def republish(self) -> None:
        """The static content again, for clients that connected since."""
        if self.static_msg is not None:
            self.tf_static.log(frame_transforms(self.static_msg), log_time=self.state.time_ns)
        if self.urdf is not None:
            self._log_description()
        if self.state.last_contour is not None:
            self._log_contour()
        if self.state.rows:
            self._log_table()
