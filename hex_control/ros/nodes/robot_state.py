"""Node ``robot_state``: the machine's robot description and frames, as robot_state_publisher
gives them in a ROS 2 install (issue 40 item 1), from the plant's telemetry. The model is
:mod:`hex_control.kinematics.robot_model` (ROS-free, generated from the machine file, so it
always matches the kinematics); this node converts.

Out: ``robot_description`` (std_msgs/String, URDF, latched), ``tf_static`` (latched: base ->
machine -> bead, platform -> spindle, disk -> tool), and per telemetry batch of the plant (the
last sample, or with ``every_sample`` each) ``joint_states`` (every URDF joint that moves: m,
rad) and ``tf`` (base -> platform, spindle -> disk, the struts' links), stamped with the
plant's sim time of that sample; per scan ``grinding/bead_outline`` (geometry_msgs/
PolygonStamped in frame ``bead``, latched: the bead's cross-section along its length, so that
a recording shows the workpiece in 3-D). Names are relative: under a cell's namespace they
are the cell's. In: ``plant/telemetry``, ``grinding/contour``, each obeyed from its owner
(the plant) alone; the batches checked by :mod:`hex_control.kinematics.robot_telemetry`, the
contours by :mod:`hex_control.grinding.bead_outline` (docs/graph.md, threat model). Frames and
units: the model module's docstring (REP 103). ``/diagnostics``: ``states`` published,
``no_frames`` samples it could not place, ``rejected_telemetry`` (malformed batches),
``stale_telemetry`` (off the timeline), ``rejected_contours``, ``foreign_*`` and ``lost_*``.
"""

from __future__ import annotations

from geometry_msgs.msg import Point32, PolygonStamped, TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from hex_control.config import DEFAULT_MACHINE_FILE, config_file
from hex_control.grinding.bead_outline import bead_outline_m
from hex_control.grinding.config import load_pass_planner_config
from hex_control.kinematics import load_machine
from hex_control.kinematics.robot_model import FrameTransform, robot_model
from hex_control.kinematics.robot_telemetry import RobotTelemetry, TelemetryRefused
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, TELEMETRY, time_msg
from hex_control.ros.infra.message_info import FOREIGN_WARN_S, info_subscription
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import run_node
from hex_control_msgs.msg import Contour, PlantTelemetry

PARAMETERS = {
    "machine_file": Spec(str(config_file(DEFAULT_MACHINE_FILE)), "machine YAML (config/machines/); the plant's"),
    "pass_planner_config": Spec("pass_planner.yaml", "bead frame and disk of the workpiece (the plant's)"),
    "every_sample": Spec(False, "frames for every control period of a telemetry batch, not only its last"),
    "telemetry_owner": Spec("plant", "node whose telemetry places the machine; '' = the first heard (hand use)"),
    "contour_owner": Spec("plant", "node whose contours are drawn; '' = the first heard (hand use)"),
}
#: tf2's own profile for /tf_static: every late joiner gets the whole static tree
TF_STATIC = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def transform_message(transform: FrameTransform, stamp) -> TransformStamped:
    msg = TransformStamped()
    msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, transform.parent, transform.child
    t, q = msg.transform.translation, msg.transform.rotation
    t.x, t.y, t.z = transform.translation_m
    q.x, q.y, q.z, q.w = transform.rotation_xyzw
    return msg


class RobotStateNode(Node):
    READY_PARAMETERS = ("machine_file",)

    def __init__(self, **kwargs):
        super().__init__("robot_state", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        machine, document = load_machine(p("machine_file"))
        config = load_pass_planner_config(p("pass_planner_config"), document)
        self.model = robot_model(machine, config.frame, disk_radius_mm=config.model.process.disk_radius_mm)
        self.core = RobotTelemetry(self.model, every_sample=p("every_sample"))
        self.diagnostics = Diagnostics(self)
        self.description = self.create_publisher(String, "robot_description", LATCHED)
        self.static = self.create_publisher(TFMessage, "tf_static", TF_STATIC)
        self.tf = self.create_publisher(TFMessage, "tf", 100)
        self.joints = self.create_publisher(JointState, "joint_states", 10)
        self.description.publish(String(data=self.model.urdf()))
        self.static.publish(TFMessage(transforms=[transform_message(t, time_msg(0.0))
                                                  for t in self.model.static_transforms()]))
        self.outline = self.create_publisher(PolygonStamped, "grinding/bead_outline", LATCHED)
        for msg_type, topic, callback, name, qos in (
                (PlantTelemetry, "plant/telemetry", self._on_telemetry, "telemetry", TELEMETRY),
                (Contour, "grinding/contour", self._on_contour, "contour", LATCHED)):
            info_subscription(self, msg_type, topic, callback, qos, diagnostics=self.diagnostics, name=name,
                              owner_node=p(f"{name}_owner"))

    def _refused(self, counter: str, message: str) -> None:
        self.diagnostics.count(counter)
        self.diagnostics.fault(counter, message, hold_s=FOREIGN_WARN_S)
        self.get_logger().warning(message, throttle_duration_sec=5.0)

    def _on_contour(self, msg: Contour) -> None:
        """The scanned bead as a closed outline in the bead frame: a recording shows it in 3-D."""
        try:
            points = bead_outline_m(msg.x_mm, msg.z_mm, msg.parent_mm)
        except ValueError as error:
            self._refused("rejected_contours", f"contour refused: {error}")
            return
        outline = PolygonStamped()
        outline.header.stamp, outline.header.frame_id = msg.header.stamp, "bead"
        outline.polygon.points = [Point32(x=x, y=y, z=z) for x, y, z in points.tolist()]
        self.outline.publish(outline)

    def _on_telemetry(self, msg: PlantTelemetry) -> None:
        try:
            placed = self.core.place(time_s=msg.time_s, strut_names=msg.strut_names,
                                     strut_lengths_m=msg.strut_lengths_m, deflection_mm=msg.deflection_mm)
        except TelemetryRefused as error:
            self._refused(error.counter, f"telemetry refused: {error}")
            return
        for time_s, error in placed.failures:
            self.diagnostics.count("no_frames")
            self.get_logger().warning(f"no frames for t = {time_s:.3f} s: {error}", throttle_duration_sec=5.0)
        for time_s, state in placed.states:
            self.diagnostics.count("states")
            stamp = time_msg(time_s)
            joint_state = JointState(name=state.joint_names, position=state.joint_positions)
            joint_state.header.stamp = stamp
            self.joints.publish(joint_state)
            self.tf.publish(TFMessage(transforms=[transform_message(t, stamp) for t in state.transforms]))


def main(args=None) -> int:
    return run_node(RobotStateNode, args)


if __name__ == "__main__":
    main()
