"""The machine as a robot description (URDF) and a tree of frames (TF), generated from the
machine's own geometry so that the model always matches the kinematics (issue 40 item 1).
ROS-free: the ``robot_state`` node (:mod:`hex_control.ros.nodes.robot_state`) publishes what
this computes.

Frames (REP 103: right-handed, z up; on the wire metres and radians). The tree's root is
``base``, the fixed frame of a machine tool (REP 105's map/odom do not apply):

  base      the machine's fixed base; the kinematics' frame
  machine   the frame of tool poses and tool paths: identical to base (a fixed joint)
  bead      the workpiece: origin at the bead's x = 0, z = 0, x along it, z its normal
  platform  the moving platform (its joints' frame); its pose comes from forward kinematics
  spindle   the tool point on the platform (platform + tool offset): the tool pose's frame
  disk      the disk centre: the spindle moved by the structural mode's deflection along the
            bead normal (where the plant grinds: its tool-centre telemetry)
  tool      the force sensor's frame, fixed at the disk (a wrench's normal force on its z)

Closed chains do not fit a URDF tree: the platform and the disk hang from floating joints
whose transforms this module computes; the struts (hexapod: a universal joint at the base,
the prismatic strut, a spherical joint at the platform; 3-PRU: carriage, rocker) are chains
of their own whose ends meet the platform's joints.

Units: joint positions in mm (the machine's), deflection in mm; URDF and transforms in m, rad.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from hex_control.kinematics import pru3
from hex_control.kinematics.machine_kind import MachineKind
from hex_control.kinematics.pru3 import Pru3Geometry
from hex_control.kinematics.rotation import (
    matrix_from_quaternion,
    quaternion_from_rpy,
    rotation_matrix,
    rpy_from_matrix,
)
from hex_control.kinematics.stewart import StewartGeometry, TrackingForwardKinematics

MM = 1e-3  # m per mm
FK_TOLERANCE_MM = 1e-10  # forward kinematics to well below the 1e-6 mm the frames promise


@dataclass(frozen=True)
class FrameTransform:
    """``child``'s pose in ``parent``: translation (m) and unit quaternion (x, y, z, w)."""

    parent: str
    child: str
    translation_m: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]

    def matrix(self) -> np.ndarray:
        """The homogeneous transform (4, 4), m."""
        out = np.eye(4)
        out[:3, :3] = matrix_from_quaternion(*self.rotation_xyzw)
        out[:3, 3] = self.translation_m
        return out


@dataclass(frozen=True)
class RobotState:
    """The machine at one instant: its URDF joints' positions (m for prismatic, rad for
    revolute joints), the moving frames' transforms and the disk centre in ``base`` (mm)."""

    joint_names: list[str]
    joint_positions: list[float]
    transforms: list[FrameTransform]
    disk_mm: np.ndarray  # (3,)


def _quaternion(r: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method, scalar code: a
    node converts some twenty of them per sample)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = r.tolist()
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
    norm = math.sqrt(sum(v * v for v in q))
    return tuple(v / norm for v in q)


def _axis_rotation(axis: int, angle: float) -> np.ndarray:
    """The rotation by ``angle`` (rad) about x (0), y (1) or z (2)."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == 0:
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    if axis == 1:
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _transform(parent: str, child: str, translation_mm, rotation: np.ndarray | None = None) -> FrameTransform:
    quaternion = (0.0, 0.0, 0.0, 1.0) if rotation is None else _quaternion(rotation)
    return FrameTransform(parent, child, tuple(float(v) * MM for v in translation_mm), quaternion)


def frame_pose(transforms: list[FrameTransform], frame: str, root: str = "base") -> np.ndarray:
    """The pose (4, 4) of ``frame`` in ``root`` from a tree's transforms between neighbours
    (as a TF listener composes them); KeyError if the tree does not join them."""
    by_child = {t.child: t for t in transforms}
    out = np.eye(4)
    while frame != root:
        step = by_child[frame]
        out = step.matrix() @ out
        frame = step.parent
    return out


def bead_rotation(frame) -> np.ndarray:
    """The bead frame's axes in the machine frame (columns x = along, y = up x along, z = up)."""
    along, up = np.asarray(frame.along, float), np.asarray(frame.up, float)
    return np.column_stack([along, np.cross(up, along), up])


class _Urdf:
    """A URDF document built link by link and joint by joint (xml.etree)."""

    COLOURS = {"frame": (0.55, 0.57, 0.6, 1.0), "strut": (0.85, 0.55, 0.15, 1.0), "rod": (0.8, 0.8, 0.82, 1.0),
               "joint": (0.2, 0.3, 0.8, 1.0), "platform": (0.3, 0.6, 0.35, 1.0), "disk": (0.75, 0.2, 0.2, 0.9)}

    def __init__(self, name: str):
        self.root = ET.Element("robot", name=name)
        for colour, rgba in self.COLOURS.items():
            ET.SubElement(ET.SubElement(self.root, "material", name=colour), "color",
                          rgba=" ".join(f"{v:g}" for v in rgba))

    @staticmethod
    def _origin(parent, xyz_mm=(0, 0, 0), rpy=(0, 0, 0)) -> None:
        ET.SubElement(parent, "origin", xyz=" ".join(f"{v * MM:.9g}" for v in xyz_mm),
                      rpy=" ".join(f"{v:.12g}" for v in rpy))

    def link(self, name: str, visuals=()) -> None:
        """``visuals``: (shape, dimensions mm, origin xyz mm, rpy rad, colour); shapes box
        (x, y, z), cylinder (radius, length along z), sphere (radius,)."""
        link = ET.SubElement(self.root, "link", name=name)
        for shape, size, xyz, rpy, colour in visuals:
            visual = ET.SubElement(link, "visual")
            self._origin(visual, xyz, rpy)
            geometry = ET.SubElement(visual, "geometry")
            if shape == "box":
                ET.SubElement(geometry, "box", size=" ".join(f"{v * MM:.6g}" for v in size))
            elif shape == "cylinder":
                ET.SubElement(geometry, "cylinder", radius=f"{size[0] * MM:.6g}", length=f"{size[1] * MM:.6g}")
            else:
                ET.SubElement(geometry, "sphere", radius=f"{size[0] * MM:.6g}")
            ET.SubElement(visual, "material", name=colour)

    def joint(self, name: str, kind: str, parent: str, child: str, *, xyz_mm=(0, 0, 0), rpy=(0, 0, 0),
              axis=None, limits=None) -> None:
        """``limits``: (lower, upper) in m or rad."""
        joint = ET.SubElement(self.root, "joint", name=name, type=kind)
        self._origin(joint, xyz_mm, rpy)
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=child)
        if axis is not None:
            ET.SubElement(joint, "axis", xyz=" ".join(f"{v:g}" for v in axis))
        if limits is not None:
            ET.SubElement(joint, "limit", lower=f"{limits[0]:.9g}", upper=f"{limits[1]:.9g}", effort="0",
                          velocity="0")

    def text(self) -> str:
        ET.indent(self.root)
        return '<?xml version="1.0"?>\n' + ET.tostring(self.root, encoding="unicode") + "\n"


def _rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """URDF's fixed-axis roll, pitch, yaw of a rotation matrix (R = Rz Ry Rx)."""
    return tuple(float(v) for v in rpy_from_matrix(rotation))


def _z_towards(direction) -> np.ndarray:
    """A rotation whose z axis is ``direction`` (a unit vector), R = Rx(a) Ry(b)."""
    a, b = _cardan_angles(direction)
    return _axis_rotation(0, a) @ _axis_rotation(1, b)


def _cardan_angles(direction) -> tuple[float, float]:
    """(a, b) rad with Rx(a) Ry(b) e_z = ``direction`` (a unit vector): a universal joint's two angles."""
    x, y, z = direction
    return math.atan2(-y, z), math.asin(max(-1.0, min(1.0, x)))


class RobotModel:
    """A machine's URDF (:meth:`urdf`), its fixed frames (:meth:`static_transforms`) and its
    state from joint positions (:meth:`state`). This base class knows only what every kind
    answers: the platform from ``forward_pose``; the kinds' subclasses add their joints."""

    def __init__(self, machine: MachineKind, bead_frame, *, disk_radius_mm: float = 100.0):
        if not disk_radius_mm > 0:
            raise ValueError(f"disk_radius_mm must be > 0, got {disk_radius_mm!r}")
        self.machine, self.bead_frame, self.disk_radius_mm = machine, bead_frame, float(disk_radius_mm)
        self._up = np.asarray(bead_frame.up, float)
        self._pose = np.asarray(machine.home_pose, float)  # warm start of the forward kinematics

    # -- what subclasses provide -------------------------------------------------------------
    size_mm = 100.0  # scale of the visuals (platform radius)

    def tool_offset_mm(self) -> np.ndarray:
        """The tool point in the platform frame."""
        return np.zeros(3)

    def _platform_parent(self) -> str:
        return "base"

    def _machine_joints(self, urdf: _Urdf) -> None:
        """The kind's own links and joints (struts, carriages)."""

    def _solve(self, positions_mm: np.ndarray) -> tuple[np.ndarray, list, list, list]:
        """(tool pose (6,) mm, rad in base; joint names, joint positions, moving transforms
        other than the platform's and the disk's; the platform's transform)."""
        pose, _, _ = self.machine.forward_pose(positions_mm, self._pose, FK_TOLERANCE_MM, 50)
        rotation = rotation_matrix(*pose[3:])
        platform = _transform("base", "platform", pose[:3] - rotation @ self.tool_offset_mm(), rotation)
        return pose, [], [], [platform]

    # -- the model -------------------------------------------------------------------------
    def urdf(self) -> str:
        urdf = _Urdf(self.machine.name)
        urdf.link("base")
        urdf.link("machine")
        urdf.link("bead")
        urdf.joint("machine_frame", "fixed", "base", "machine")
        urdf.joint("bead_frame", "fixed", "machine", "bead", xyz_mm=self.bead_frame.origin_mm,
                   rpy=_rpy(bead_rotation(self.bead_frame)))
        self._machine_joints(urdf)
        radius = self.size_mm
        urdf.link("platform", [("cylinder", (radius * 1.1, radius * 0.12), self._platform_visual_mm(), (0, 0, 0),
                                "platform")])
        urdf.joint("platform_pose", "floating", self._platform_parent(), "platform")
        offset = self.tool_offset_mm()
        urdf.link("spindle", [("cylinder", (radius * 0.15, radius * 0.5), (0, 0, radius * 0.25), (0, 0, 0),
                               "frame")])
        urdf.joint("spindle_mount", "fixed", "platform", "spindle", xyz_mm=offset)
        # the disk turns in the bead's x-z plane (the process model's section): axis along y
        urdf.link("disk", [("cylinder", (self.disk_radius_mm, 6.0), (0, 0, 0), (math.pi / 2, 0, 0), "disk")])
        urdf.joint("structure_deflection", "floating", "spindle", "disk")
        urdf.link("tool")
        urdf.joint("force_sensor", "fixed", "disk", "tool")
        return urdf.text()

    def _platform_visual_mm(self) -> tuple[float, float, float]:
        return (0.0, 0.0, 0.0)

    def static_transforms(self) -> list[FrameTransform]:
        """The fixed joints' transforms (for /tf_static)."""
        return [_transform("base", "machine", (0, 0, 0)),
                _transform("machine", "bead", self.bead_frame.origin_mm, bead_rotation(self.bead_frame)),
                _transform("platform", "spindle", self.tool_offset_mm()),
                _transform("disk", "tool", (0, 0, 0))] + self._static_joints()

    def _static_joints(self) -> list[FrameTransform]:
        return []

    def state(self, positions_mm, deflection_mm: float = 0.0) -> RobotState:
        """The machine with its joints at ``positions_mm`` (the machine's joint order) and the
        structure deflected by ``deflection_mm`` along the bead normal; forward kinematics
        warm-started from the last call's pose."""
        positions_mm = np.asarray(positions_mm, float).reshape(-1)
        if positions_mm.shape != (len(self.machine.joint_names),) or not np.all(np.isfinite(positions_mm)):
            raise ValueError(f"need {len(self.machine.joint_names)} finite joint positions (mm)")
        if not math.isfinite(deflection_mm):
            raise ValueError("deflection_mm must be finite")
        pose, names, values, transforms = self._solve(positions_mm)
        self._pose = pose
        rotation = rotation_matrix(*pose[3:])
        deflection = self._up * deflection_mm  # in base; the disk's transform is in the spindle frame
        disk = _transform("spindle", "disk", rotation.T @ deflection)
        return RobotState(names, values, transforms + [disk], pose[:3] + deflection)


class HexapodModel(RobotModel):
    """Stewart-Gough 6-6: per strut a universal joint at the base (``strut_<i>_base_x``, then
    ``_y``, about axes whose zero is the strut's direction at the home pose), the prismatic
    strut ``strut_<i>`` (its length, as the plant's joint states give it) from the universal
    joint's centre to the platform joint, and a spherical joint there (a ball, visual only)."""

    machine: StewartGeometry

    def __init__(self, machine: StewartGeometry, bead_frame, **kwargs):
        super().__init__(machine, bead_frame, **kwargs)
        self.size_mm = float(np.linalg.norm(machine.platform_joints_mm[:, :2], axis=1).max())
        self._tracker = TrackingForwardKinematics(machine, tolerance_mm=FK_TOLERANCE_MM, max_iterations=6)
        home = machine.home_pose
        struts = home[:3] + (rotation_matrix(*home[3:]) @ machine.joints_from_tool_mm.T).T - machine.base_joints_mm
        self._nominal = [_z_towards(s / np.linalg.norm(s)) for s in struts]

    def tool_offset_mm(self) -> np.ndarray:
        return self.machine.tool_offset_mm

    def _platform_visual_mm(self):
        return tuple(self.machine.platform_joints_mm.mean(axis=0))

    def _machine_joints(self, urdf: _Urdf) -> None:
        m, r = self.machine, self.size_mm * 0.08
        # tube and rod each as long as they can be without poking out of the other's end
        piece = min(m.strut_length_max_mm / 2, m.strut_length_min_mm)
        cone = float(max(m.base_joint_max_rad))
        for i, base_joint in enumerate(m.base_joints_mm):
            urdf.link(f"strut_{i}_cardan", [("box", (2.5 * r, 2.5 * r, 1.5 * r), (0, 0, 0), (0, 0, 0), "joint")])
            urdf.joint(f"strut_{i}_base_x", "revolute", "base", f"strut_{i}_cardan", xyz_mm=base_joint,
                       rpy=_rpy(self._nominal[i]), axis=(1, 0, 0), limits=(-cone, cone))
            urdf.link(f"strut_{i}_tube", [("cylinder", (r, piece), (0, 0, piece / 2), (0, 0, 0), "strut")])
            urdf.joint(f"strut_{i}_base_y", "revolute", f"strut_{i}_cardan", f"strut_{i}_tube", axis=(0, 1, 0),
                       limits=(-cone, cone))
            urdf.link(f"strut_{i}_rod", [("cylinder", (0.6 * r, piece), (0, 0, -piece / 2), (0, 0, 0), "rod"),
                                         ("sphere", (1.3 * r,), (0, 0, 0), (0, 0, 0), "joint")])
            urdf.joint(f"strut_{i}", "prismatic", f"strut_{i}_tube", f"strut_{i}_rod", axis=(0, 0, 1),
                       limits=(m.strut_length_min_mm * MM, m.strut_length_max_mm * MM))

    def _solve(self, positions_mm):
        m = self.machine
        pose = self._tracker.solve(positions_mm)  # Newton from the last pose; raises ForwardKinematicsError
        rotation = rotation_matrix(*pose[3:])
        platform_origin = pose[:3] - rotation @ m.tool_offset_mm
        tops = platform_origin + (rotation @ m.platform_joints_mm.T).T
        names, values, transforms = [], [], []
        for i, (base_joint, top) in enumerate(zip(m.base_joints_mm, tops)):
            strut = top - base_joint
            length = float(np.linalg.norm(strut))
            local = self._nominal[i].T @ (strut / length)
            a, b = _cardan_angles(local)
            names += [f"strut_{i}_base_x", f"strut_{i}_base_y", f"strut_{i}"]
            values += [a, b, length * MM]
            transforms += [_transform("base", f"strut_{i}_cardan", base_joint,
                                      self._nominal[i] @ _axis_rotation(0, a)),
                           _transform(f"strut_{i}_cardan", f"strut_{i}_tube", (0, 0, 0), _axis_rotation(1, b)),
                           _transform(f"strut_{i}_tube", f"strut_{i}_rod", (0, 0, length))]
        transforms.append(_transform("base", "platform", platform_origin, rotation))
        return pose, names, values, transforms


class Pru3Model(RobotModel):
    """3-PRU head (seed 001), on its feed stage if it has one (prismatic ``feed_x`` carrying
    the ``head`` frame along x; else ``head`` is fixed to the base): per rail a carriage on
    the prismatic ``strut_<i>`` (the slider position), a rocker on the revolute ``rocker_<i>``
    (axis tangent to the rail circle, zero = vertical) reaching the platform joint."""

    machine: Pru3Geometry

    def __init__(self, machine: Pru3Geometry, bead_frame, **kwargs):
        super().__init__(machine, bead_frame, **kwargs)
        self.size_mm = machine.platform_radius_mm
        self._q = np.array(pru3.HOME_Q, float)

    def _platform_parent(self) -> str:
        return "head"

    def _machine_joints(self, urdf: _Urdf) -> None:
        m = self.machine
        low, high = m.stroke_mm
        rails = [("cylinder", (10.0, high - low + 60.0), (*rail[:2], (low + high) / 2), (0, 0, 0), "frame")
                 for rail in m.rails_mm]
        urdf.link("head", rails)
        if m.feed_stroke_mm is not None:
            urdf.joint("feed_x", "prismatic", "base", "head", axis=(1, 0, 0),
                       limits=tuple(v * MM for v in m.feed_stroke_mm))
        else:
            urdf.joint("head_mount", "fixed", "base", "head")
        length = m.rocker_length_mm
        for i, (rail, angle) in enumerate(zip(m.rails_mm, m.rail_angles_rad)):
            urdf.link(f"carriage_{i}", [("box", (30.0, 50.0, 30.0), (0, 0, 0), (0, 0, 0), "strut")])
            urdf.joint(f"strut_{i}", "prismatic", "head", f"carriage_{i}", xyz_mm=rail, rpy=(0, 0, angle),
                       axis=(0, 0, 1), limits=(low * MM, high * MM))
            urdf.link(f"rocker_{i}", [("cylinder", (6.0, length), (0, 0, length / 2), (0, 0, 0), "rod"),
                                      ("sphere", (10.0,), (0, 0, length), (0, 0, 0), "joint")])
            urdf.joint(f"rocker_{i}", "revolute", f"carriage_{i}", f"rocker_{i}", axis=(0, 1, 0),
                       limits=(-math.pi / 2, math.pi / 2))

    def _static_joints(self) -> list[FrameTransform]:
        return [] if self.machine.feed_stroke_mm is not None else [_transform("base", "head", (0, 0, 0))]

    def _solve(self, positions_mm):
        m = self.machine
        self._q, _ = pru3.forward_kinematics(m, positions_mm[:3], self._q, tolerance_mm=FK_TOLERANCE_MM)
        solved = pru3.inverse_kinematics(m, self._q)
        full, tops = solved.full[0], solved.joints_mm[0]
        feed = float(positions_mm[3]) if len(positions_mm) > 3 else 0.0
        names, values, transforms = [], [], []
        if m.feed_stroke_mm is not None:
            names.append("feed_x")
            values.append(feed * MM)
            transforms.append(_transform("base", "head", (feed, 0.0, 0.0)))
        for i, (rail, angle, top) in enumerate(zip(m.rails_mm, m.rail_angles_rad, tops)):
            slider = float(positions_mm[i])
            reach = _axis_rotation(2, -angle) @ (top - rail - (0.0, 0.0, slider))  # in the carriage frame
            tilt = math.atan2(reach[0], reach[2])
            names += [f"strut_{i}", f"rocker_{i}"]
            values += [slider * MM, tilt]
            transforms += [_transform("head", f"carriage_{i}", rail + (0.0, 0.0, slider), _axis_rotation(2, angle)),
                           _transform(f"carriage_{i}", f"rocker_{i}", (0, 0, 0), _axis_rotation(1, tilt))]
        rotation = rotation_matrix(*full[3:])
        transforms.append(_transform("head", "platform", full[:3], rotation))
        pose = full.copy()
        pose[0] += feed
        return pose, names, values, transforms


_MODELS = {StewartGeometry: HexapodModel, Pru3Geometry: Pru3Model}


def robot_model(machine: MachineKind, bead_frame, *, disk_radius_mm: float = 100.0) -> RobotModel:
    """The machine's model: its kind's (struts, carriages) where there is one, else the
    platform alone. ``bead_frame``: origin_mm, along, up (e.g. a grinding BeadFrame)."""
    return _MODELS.get(type(machine), RobotModel)(machine, bead_frame, disk_radius_mm=disk_radius_mm)


@dataclass(frozen=True)
class Visual:
    """One visual of a URDF link, for a viewer that draws primitives: ``shape`` box, cylinder
    (along z) or sphere; ``size_m`` its extent along x, y, z (m); its pose in the link's frame."""

    link: str
    shape: str
    size_m: tuple[float, float, float]
    translation_m: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]


def urdf_visuals(text: str) -> list[Visual]:
    """The visuals of a URDF document (the shapes this module writes: box, cylinder, sphere;
    others are skipped); ValueError if it is not a URDF."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise ValueError(f"not a URDF document: {error}") from None
    if root.tag != "robot":
        raise ValueError(f"not a URDF document: root <{root.tag}>")
    colours = {m.get("name"): tuple(float(v) for v in m.find("color").get("rgba").split())
               for m in root.findall("material") if m.find("color") is not None}
    visuals = []
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            origin = visual.find("origin")
            xyz = tuple(float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split())
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            material = visual.find("material")
            rgba = colours.get(material.get("name") if material is not None else None, (0.7, 0.7, 0.7, 1.0))
            shape = next(iter(visual.find("geometry")), None)
            if shape is None:
                continue
            if shape.tag == "box":
                size = tuple(float(v) for v in shape.get("size").split())
            elif shape.tag == "cylinder":
                diameter = 2 * float(shape.get("radius"))
                size = (diameter, diameter, float(shape.get("length")))
            elif shape.tag == "sphere":
                size = (2 * float(shape.get("radius")),) * 3
            else:
                continue
            quaternion = tuple(float(v) for v in quaternion_from_rpy(*rpy))
            visuals.append(Visual(link.get("name"), shape.tag, size, xyz, quaternion, rgba))
    return visuals
