"""``hexctl view``: the running cell served over the Foxglove WebSocket protocol with the
official ``foxglove-sdk`` (issue 40 item 2), for Foxglove (app.foxglove.dev or the desktop
app: Open connection -> Foxglove WebSocket -> ws://localhost:8765) when RViz is not there.

A ROS node in the cell's namespace listens to the cell and logs to Foxglove channels, each
stamped with the cell's sim time (the timeline is the header stamps', not receive time); the
messages it logs are built in :mod:`hex_control.ros.app.foxglove_scenes`:

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
and a batch's wrenches have at most ``MAX_OUTLINE_POINTS`` points: the work per message and per second's republish stays
bounded. A client that stops reading loses its own messages (the SDK's per-client queue),
not anyone else's.

The names and shapes match the demo's recording (MCAP, ROS 2 messages), so that
``config/foxglove/hex_control.json`` (the shipped layout) shows both. Static content (the
static frames, the URDF and its scene, the bead, the pass table) is logged again every
second: a client that connects late has it at once.
"""

from __future__ import annotations

import math
import time

import foxglove
import rclpy
from foxglove import Channel
from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel
from foxglove.messages import Timestamp
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from hex_control.grinding.bead_outline import MAX_CONTOUR_POINTS, MAX_OUTLINE_POINTS, spaced_indices
from hex_control.kinematics.robot_telemetry import TelemetryRefused, checked_stamps
from hex_control.ros.app.foxglove_scenes import (
    CONTOUR_SCHEMA,
    STRING_SCHEMA,
    TABLE_SCHEMA,
    WRENCH_SCHEMA,
    bead_scene,
    force_scene,
    frame_transforms,
    json_number,
    machine_scene,
    seconds_to_ns,
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
        self.static_msg = self.urdf = self.first_contour = self.last_contour = None
        self.time_ns = 0  # the cell's sim time, as far as heard
        self.rows: dict[tuple[str, int], dict] = {}
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
            self.time_ns = max(self.time_ns, stamp.sec * 1_000_000_000 + stamp.nanosec)
        self.tf.log(frame_transforms(msg), log_time=self.time_ns)

    def _on_tf_static(self, msg: TFMessage) -> None:
        self.static_msg = msg
        self.tf_static.log(frame_transforms(msg), log_time=self.time_ns)

    def _on_description(self, msg: String) -> None:
        self.urdf = msg.data
        self._log_description()

    def _log_description(self) -> None:
        self.description.log({"data": self.urdf}, log_time=self.time_ns)
        try:
            self.machine.log(machine_scene(self.urdf), log_time=self.time_ns)
        except ValueError as error:
            self.get_logger().warning(f"robot_description: {error}", throttle_duration_sec=10.0)

    def _on_telemetry(self, msg: PlantTelemetry) -> None:
        try:  # a NaN stamp ended the view (no integer nanoseconds): refused with the batch, as robot_state does
            checked_stamps(msg.time_s)
        except TelemetryRefused as error:
            self._refused("telemetry", f"telemetry refused: {error}")
            return
        for k in spaced_indices(len(msg.time_s), MAX_OUTLINE_POINTS).tolist():  # a plot's worth a batch
            time_s = msg.time_s[k]
            ns = seconds_to_ns(time_s)
            header = {"stamp": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}, "frame_id": "tool"}
            for channel, forces in ((self.wrench, msg.measured_force_n), (self.true_wrench, msg.true_force_n)):
                if k < len(forces):
                    wrench = {"force": {"x": 0.0, "y": 0.0, "z": json_number(forces[k])},
                              "torque": {"x": 0.0, "y": 0.0, "z": 0.0}}
                    channel.log({"header": header, "wrench": wrench}, log_time=ns)
            self.time_ns = max(self.time_ns, ns)
        if msg.time_s and msg.measured_force_n:
            ns = seconds_to_ns(msg.time_s[-1])
            self.force.log(force_scene(msg.measured_force_n[-1], Timestamp(sec=ns // 1_000_000_000,
                                                                          nsec=ns % 1_000_000_000)), log_time=ns)

    def _on_contour(self, msg: Contour) -> None:
        if not len(msg.x_mm) == len(msg.z_mm) <= MAX_CONTOUR_POINTS or len(msg.parent_mm) not in (0, len(msg.x_mm)):
            self._refused("contour", f"contour of {len(msg.x_mm)} points refused (at most {MAX_CONTOUR_POINTS}, "
                          "x, z and parent alike)")
            return
        if self.first_contour is None or msg.pass_index == 0:
            self.first_contour = msg
        self.last_contour = msg
        self._log_contour()

    def _log_contour(self) -> None:
        msg = self.last_contour
        stamp = Timestamp(sec=self.time_ns // 1_000_000_000, nsec=self.time_ns % 1_000_000_000)
        self.bead.log(bead_scene(msg, self.first_contour, stamp), log_time=self.time_ns)
        keep = spaced_indices(len(msg.x_mm), MAX_OUTLINE_POINTS).tolist()  # a plot's worth, sent every second
        self.contour.log({"job_id": msg.job_id, "pass_index": msg.pass_index, "x_mm": [msg.x_mm[i] for i in keep],
                          "z_mm": [msg.z_mm[i] for i in keep],
                          "parent_mm": [msg.parent_mm[i] for i in keep] if len(msg.parent_mm) else []},
                         log_time=self.time_ns)

    def _row(self, job_id: str, pass_index: int) -> dict:
        return self.rows.setdefault((job_id, pass_index), {"job": job_id, "pass": pass_index})

    def _on_command(self, msg: PassCommand) -> None:
        if msg.stop:
            return
        self._row(msg.job_id, msg.pass_index).update({
            "X_mm": json_number(msg.material_remaining_mm), "t_left_s": json_number(msg.time_remaining_s),
            "K1_J_mm3": json_number(msg.specific_energy_j_mm3), "cut_planned_mm": json_number(msg.cut_depth_mm),
            "F_N": json_number(msg.normal_force_n), "V_f_mm_s": json_number(msg.feed_speed_mm_s),
            "J": json_number(msg.expected_penalty)})
        self._log_table()

    def _on_result(self, msg: PassResult) -> None:
        self._row(msg.job_id, msg.pass_index).update({
            "status": STATUS.get(msg.status, str(msg.status)),
            "cut_measured_mm": json_number(msg.measured_cut_depth_mm),
            "duration_s": json_number(msg.duration_s), "mean_force_n": json_number(msg.mean_normal_force_n),
            "K1_measured_J_mm3": json_number(msg.specific_energy_j_mm3), "burn": bool(msg.burn_detected),
            "stall": bool(msg.stall_detected)})
        self._log_table()

    def _log_table(self) -> None:
        self.table.log({"rows": [self.rows[key] for key in sorted(self.rows)]}, log_time=self.time_ns)

    def republish(self) -> None:
        """The static content again, for clients that connected since."""
        if self.static_msg is not None:
            self.tf_static.log(frame_transforms(self.static_msg), log_time=self.time_ns)
        if self.urdf is not None:
            self._log_description()
        if self.last_contour is not None:
            self._log_contour()
        if self.rows:
            self._log_table()


def serve(host: str = "127.0.0.1", port: int = 8765, namespace: str = "", *, ready=None,
          duration_s: float = 0.0) -> int:
    """Serve the cell in this process's ROS domain until Ctrl-C (or for ``duration_s`` > 0 of
    wall time); ``ready(port)`` is called once the server listens (port 0: a free one)."""
    context = foxglove.Context()
    try:
        server = foxglove.start_server(name="hex_control", host=host, port=port, context=context)
    except RuntimeError as error:  # an address that does not resolve, a port in use: the user's input
        raise ValueError(f"cannot serve on {host}:{port}: {error}") from None
    rclpy_context = rclpy.Context()
    rclpy.init(context=rclpy_context)
    executor = SingleThreadedExecutor(context=rclpy_context)
    view = FoxgloveView(context, namespace, context=rclpy_context)
    executor.add_node(view)
    print(f"hexctl view: serving {namespace or 'the cell'} on ws://{host}:{server.port} (Foxglove: Open connection "
          f"-> Foxglove WebSocket); Ctrl-C ends it", flush=True)
    if ready is not None:
        ready(server.port)
    end = time.monotonic() + duration_s if duration_s > 0 else math.inf
    next_republish = 0.0
    try:
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
            if time.monotonic() >= next_republish:
                view.republish()
                next_republish = time.monotonic() + 1.0
    finally:
        executor.remove_node(view)
        view.destroy_node()
        executor.shutdown()
        rclpy_context.try_shutdown()
        server.stop()
    return 0
