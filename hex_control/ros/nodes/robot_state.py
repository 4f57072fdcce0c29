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
are the cell's. In: ``plant/telemetry``, ``grinding/contour``. Frames and units: the model
module's docstring (REP 103). ``/diagnostics``: ``states`` published, ``no_frames`` samples it
could not place, ``rejected_contours``.
"""

from __future__ import annotations

import numpy as np
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
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, TELEMETRY, time_msg
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import run_node
from hex_control_msgs.msg import Contour, PlantTelemetry

PARAMETERS = {
    "machine_file": Spec(str(config_file(DEFAULT_MACHINE_FILE)), "machine YAML (config/machines/); the plant's"),
    "pass_planner_config": Spec("pass_planner.yaml", "bead frame and disk of the workpiece (the plant's)"),
    "every_sample": Spec(False, "frames for every control period of a telemetry batch, not only its last"),
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
        self.every_sample = p("every_sample")
        self.diagnostics = Diagnostics(self)  # counts samples it could not place (no_frames), and states published
        self.description = self.create_publisher(String, "robot_description", LATCHED)
        self.static = self.create_publisher(TFMessage, "tf_static", TF_STATIC)
        self.tf = self.create_publisher(TFMessage, "tf", 100)
        self.joints = self.create_publisher(JointState, "joint_states", 10)
        self.description.publish(String(data=self.model.urdf()))
        self.static.publish(TFMessage(transforms=[transform_message(t, time_msg(0.0))
                                                  for t in self.model.static_transforms()]))
        self.outline = self.create_publisher(PolygonStamped, "grinding/bead_outline", LATCHED)
        self.create_subscription(PlantTelemetry, "plant/telemetry", self._on_telemetry, TELEMETRY)
        self.create_subscription(Contour, "grinding/contour", self._on_contour, LATCHED)

    def _on_contour(self, msg: Contour) -> None:
        """The scanned bead as a closed outline in the bead frame: a recording shows it in 3-D."""
        try:
            points = bead_outline_m(msg.x_mm, msg.z_mm, msg.parent_mm)
        except ValueError as error:
            self.diagnostics.count("rejected_contours")
            self.get_logger().warning(f"no bead outline: {error}", throttle_duration_sec=5.0)
            return
        outline = PolygonStamped()
        outline.header.stamp, outline.header.frame_id = msg.header.stamp, "bead"
        outline.polygon.points = [Point32(x=x, y=y, z=z) for x, y, z in points.tolist()]
        self.outline.publish(outline)

    def _on_telemetry(self, msg: PlantTelemetry) -> None:
        samples, joints = len(msg.time_s), len(msg.strut_names)
        if not samples or not joints or len(msg.strut_lengths_m) != samples * joints \
                or len(msg.deflection_mm) != samples:
            return  # before the first strut command the plant has no joint positions
        lengths_m = np.asarray(msg.strut_lengths_m, float).reshape(samples, joints)
        for k in range(samples) if self.every_sample else (samples - 1,):
            try:  # the plant's arrays are in the machine's joint order; its positions in m
                state = self.model.state(lengths_m[k] * 1000.0, msg.deflection_mm[k])
            except ValueError as error:  # forward kinematics found no pose (or a malformed sample)
                self.diagnostics.count("no_frames")
                self.get_logger().warning(f"no frames for t = {msg.time_s[k]:.3f} s: {error}",
                                          throttle_duration_sec=5.0)
                continue
            self.diagnostics.count("states")
            stamp = time_msg(msg.time_s[k])
            joint_state = JointState(name=state.joint_names, position=state.joint_positions)
            joint_state.header.stamp = stamp
            self.joints.publish(joint_state)
            self.tf.publish(TFMessage(transforms=[transform_message(t, stamp) for t in state.transforms]))


def main(args=None) -> int:
    return run_node(RobotStateNode, args)


if __name__ == "__main__":
    main()
