"""What ``hexctl view`` logs to Foxglove, built from the cell's messages: frame transforms,
the machine's URDF as scene primitives, the bead's contours, the force arrow, and the JSON
schemas of the channels that mirror ROS messages (:mod:`hex_control.ros.app.foxglove_view`).

Units: the scenes in m (the contours' mm scaled by ``MM``), times in ns of the cell's sim time.
"""

from __future__ import annotations

import json
import math

from foxglove import Schema
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    LinePrimitive,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    Timestamp,
    Vector3,
)
from tf2_msgs.msg import TFMessage

from hex_control.grinding.bead_outline import MAX_OUTLINE_POINTS, spaced_indices
from hex_control.kinematics.robot_model import MM, urdf_visuals
from hex_control_msgs.msg import Contour

STRING_SCHEMA = Schema(name="std_msgs/msg/String", encoding="jsonschema", data=json.dumps(
    {"type": "object", "properties": {"data": {"type": "string"}}}).encode())
WRENCH_SCHEMA = {"type": "object", "title": "geometry_msgs/msg/WrenchStamped", "properties": {
    "header": {"type": "object"}, "wrench": {"type": "object"}}}
CONTOUR_SCHEMA = {"type": "object", "title": "hex_control_msgs/msg/Contour", "properties": {
    "pass_index": {"type": "integer"}, "x_mm": {"type": "array"}, "z_mm": {"type": "array"},
    "parent_mm": {"type": "array"}}}
TABLE_SCHEMA = {"type": "object", "title": "hex_control/PassTable", "properties": {"rows": {"type": "array"}}}
FORCE_SCALE_M_PER_N = 1e-3  # the force arrow: 1 mm per N (60 N, F_max, is 60 mm)


def ns_timestamp(ns: int) -> Timestamp:
    """A sim time in ns as Foxglove's stamp."""
    return Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def timestamp(stamp) -> Timestamp:
    """A ROS stamp (builtin_interfaces/Time) as Foxglove's."""
    return Timestamp(sec=int(stamp.sec), nsec=int(stamp.nanosec))


def frame_transforms(msg: TFMessage) -> FrameTransforms:
    return FrameTransforms(transforms=[FrameTransform(
        timestamp=timestamp(t.header.stamp), parent_frame_id=t.header.frame_id, child_frame_id=t.child_frame_id,
        translation=Vector3(x=t.transform.translation.x, y=t.transform.translation.y, z=t.transform.translation.z),
        rotation=Quaternion(x=t.transform.rotation.x, y=t.transform.rotation.y, z=t.transform.rotation.z,
                            w=t.transform.rotation.w)) for t in msg.transforms])


def machine_scene(urdf: str) -> SceneUpdate:
    """The URDF's visuals as scene entities, one per link, locked to the link's frame."""
    by_link = {}
    for v in urdf_visuals(urdf):
        pose = Pose(position=Vector3(x=v.translation_m[0], y=v.translation_m[1], z=v.translation_m[2]),
                    orientation=Quaternion(x=v.rotation_xyzw[0], y=v.rotation_xyzw[1], z=v.rotation_xyzw[2],
                                           w=v.rotation_xyzw[3]))
        size, color = Vector3(x=v.size_m[0], y=v.size_m[1], z=v.size_m[2]), Color(r=v.rgba[0], g=v.rgba[1],
                                                                                  b=v.rgba[2], a=v.rgba[3])
        shapes = by_link.setdefault(v.link, {"cubes": [], "cylinders": [], "spheres": []})
        if v.shape == "box":
            shapes["cubes"].append(CubePrimitive(pose=pose, size=size, color=color))
        elif v.shape == "cylinder":
            shapes["cylinders"].append(CylinderPrimitive(pose=pose, size=size, bottom_scale=1.0, top_scale=1.0,
                                                         color=color))
        else:
            shapes["spheres"].append(SpherePrimitive(pose=pose, size=size, color=color))
    return SceneUpdate(entities=[SceneEntity(frame_id=link, id=f"machine/{link}", frame_locked=True, **shapes)
                                 for link, shapes in by_link.items()])


def force_scene(force_n: float, stamp: Timestamp) -> SceneUpdate:
    """The normal force the work puts on the disk: an arrow from the tool frame's origin along
    its z (the bead normal), FORCE_SCALE_M_PER_N long per N (none below 0.5 N)."""
    length = max(force_n, 0.0) * FORCE_SCALE_M_PER_N if math.isfinite(force_n) else 0.0
    arrows = [ArrowPrimitive(pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.0),
                                       orientation=Quaternion(x=0.0, y=-math.sqrt(0.5), z=0.0, w=math.sqrt(0.5))),
                             shaft_length=length * 0.8, shaft_diameter=0.004, head_length=length * 0.2,
                             head_diameter=0.01, color=Color(r=0.2, g=0.8, b=1.0, a=1.0))] if length >= 5e-4 else []
    return SceneUpdate(entities=[SceneEntity(timestamp=stamp, frame_id="tool", id="force", frame_locked=True,
                                             arrows=arrows)])


def bead_scene(contour: Contour, first: Contour | None, stamp: Timestamp) -> SceneUpdate:
    """The contour (orange), the parent surface (grey) and the bead as first scanned (faint),
    in the bead frame (x along, z up; m)."""
    def line(x_mm, z_mm, rgba, thickness):  # at most MAX_OUTLINE_POINTS vertices, the ends kept
        keep = spaced_indices(len(x_mm), MAX_OUTLINE_POINTS)
        return LinePrimitive(thickness=thickness, scale_invariant=True, color=Color(r=rgba[0], g=rgba[1], b=rgba[2],
                                                                                    a=rgba[3]),
                             points=[Point3(x=x_mm[i] * MM, y=0.0, z=z_mm[i] * MM) for i in keep])
    parent = list(contour.parent_mm) or [0.0] * len(contour.x_mm)
    # heights are above the parent surface's datum: the contour drawn on top of the parent
    lines = [line(contour.x_mm, [z + p for z, p in zip(contour.z_mm, parent)], (1.0, 0.55, 0.1, 1.0), 3.0),
             line(contour.x_mm, parent, (0.6, 0.6, 0.6, 1.0), 2.0)]
    if first is not None:
        first_parent = list(first.parent_mm) or [0.0] * len(first.x_mm)
        lines.append(line(first.x_mm, [z + p for z, p in zip(first.z_mm, first_parent)], (1.0, 1.0, 1.0, 0.35), 1.0))
    return SceneUpdate(entities=[SceneEntity(timestamp=stamp, frame_id="bead", id="bead", frame_locked=True,
                                             lines=lines)])


def wrench_json(ns: int, force_n: float | None) -> dict:
    """A normal force (N, along the tool's z) as a geometry_msgs/WrenchStamped-shaped JSON message."""
    return {"header": {"stamp": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}, "frame_id": "tool"},
            "wrench": {"force": {"x": 0.0, "y": 0.0, "z": force_n}, "torque": {"x": 0.0, "y": 0.0, "z": 0.0}}}
