"""The machine's robot description and frames (hex_control.kinematics.robot_model, issue 40
item 1): the URDF is a well-formed tree whose joints are the ones the frames move, the struts
and rockers meet the platform's joints, and the disk frame is where the plant grinds."""

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.grinding.config import load_pass_planner_config
from hex_control.kinematics import load_machine
from hex_control.kinematics.robot_model import MM, frame_pose, robot_model
from hex_control.kinematics.rotation import rotation_matrix
from hex_control.plant.tool_locator import ToolLocator

MACHINES = ["nist_ingersoll.yaml", "generic_6_6.yaml", "pru3.yaml", "pru3_feed.yaml"]
FRAMES = {"base", "machine", "bead", "platform", "spindle", "disk", "tool"}


def _machine(name):
    machine, document = load_machine(config_file(f"machines/{name}"))
    frame = load_pass_planner_config("pass_planner.yaml", document).frame
    return machine, frame


def _path(machine, frame, samples=25):
    """Joint positions (n, joints) mm along 20 mm of the bead, 0.5 mm above its datum; for a
    machine whose file places no bead within its reach, 2 mm down from its home pose."""
    x = np.linspace(0.0, 20.0, samples)
    poses = np.zeros((samples, 6))
    poses[:, :3] = frame.positions_mm(x, np.full(samples, 0.5))
    poses[:, 3:] = np.radians(frame.orientation_rpy_deg)
    positions, reachable = machine.joint_positions_mm(poses)
    if not reachable.all():
        poses = np.repeat(machine.home_pose[None], samples, axis=0)
        poses[:, 2] -= x / 10
        positions, reachable = machine.joint_positions_mm(poses)
    assert reachable.all()
    return positions


def _joint_motion(joint, position) -> np.ndarray:
    """The child's pose in the parent (4, 4, m) that a URDF joint at ``position`` gives."""
    origin = joint.find("origin")
    xyz = [float(v) for v in origin.get("xyz").split()]
    roll, pitch, yaw = (float(v) for v in origin.get("rpy").split())
    out = np.eye(4)
    out[:3, :3] = rotation_matrix(roll, pitch, yaw)
    out[:3, 3] = xyz
    axis = np.array([float(v) for v in joint.find("axis").get("xyz").split()])
    motion = np.eye(4)
    if joint.get("type") == "prismatic":
        motion[:3, 3] = axis * position
    else:  # revolute about a unit axis (Rodrigues)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        motion[:3, :3] = np.eye(3) + math.sin(position) * k + (1 - math.cos(position)) * k @ k
    return out @ motion


@pytest.mark.parametrize("name", MACHINES)
def test_the_urdf_is_a_tree_of_the_frames_and_the_joints_the_state_moves(name):
    machine, frame = _machine(name)
    model = robot_model(machine, frame)
    root = ET.fromstring(model.urdf())
    links = {link.get("name") for link in root.iter("link")}
    joints = {joint.get("name"): joint for joint in root.iter("joint")}
    assert root.tag == "robot" and root.get("name") == machine.name
    assert FRAMES <= links
    parents = {}
    for joint in joints.values():
        parent, child = joint.find("parent").get("link"), joint.find("child").get("link")
        assert parent in links and child in links, joint.get("name")
        assert child not in parents, f"{child} has two parents"
        parents[child] = parent
        if joint.get("type") in ("revolute", "prismatic"):
            limit = joint.find("limit")
            assert float(limit.get("lower")) < float(limit.get("upper"))
    assert links - set(parents) == {"base"}  # one root; every other link hangs from one joint
    for link in links:  # and no cycles: every link reaches the root
        seen = set()
        while link != "base":
            assert link not in seen
            seen.add(link)
            link = parents[link]
    materials = {m.get("name") for m in root.findall("material")}
    assert all(m.get("name") in materials for m in root.iter("material"))

    state = model.state(_path(machine, frame)[0], 0.01)
    # the plant's joints (its joint states' names) are the URDF's, with the same meaning (m)
    assert set(machine.joint_names) <= set(state.joint_names) <= set(joints)
    moving = {n for n, j in joints.items() if j.get("type") != "fixed"}
    published = {(t.parent, t.child) for t in state.transforms}
    fixed = {(t.parent, t.child) for t in model.static_transforms()}
    for joint_name, joint in joints.items():
        pair = (joint.find("parent").get("link"), joint.find("child").get("link"))
        assert pair in (published if joint_name in moving else fixed), joint_name
    # each moving joint's transform is what the URDF joint at its published position gives
    # (what robot_state_publisher would compute from /joint_states)
    by_child = {t.child: t for t in state.transforms}
    for joint_name, position in zip(state.joint_names, state.joint_positions):
        joint = joints[joint_name]
        child = joint.find("child").get("link")
        if joint.get("type") == "prismatic":
            limit = joint.find("limit")
            assert float(limit.get("lower")) - 1e-12 <= position <= float(limit.get("upper")) + 1e-12
        np.testing.assert_allclose(by_child[child].matrix(), _joint_motion(joint, position), atol=1e-12)


@pytest.mark.parametrize("name", MACHINES)
def test_the_struts_meet_the_platform_joints_and_the_disk_is_where_the_plant_grinds(name):
    machine, frame = _machine(name)
    model = robot_model(machine, frame)
    locator = ToolLocator(machine, frame)
    along, up = np.asarray(frame.along), np.asarray(frame.up)
    worst = 0.0
    for k, positions in enumerate(_path(machine, frame)):
        deflection_mm = 0.05 * math.sin(k)
        state = model.state(positions, deflection_mm)
        tree = model.static_transforms() + state.transforms
        ends = ([frame_pose(tree, f"strut_{i}_rod")[:3, 3] for i in range(6)] if len(machine.joint_names) == 6
                else [(frame_pose(tree, f"rocker_{i}") @ [0, 0, machine.rocker_length_mm * MM, 1])[:3]
                      for i in range(3)])
        np.testing.assert_allclose(np.array(ends), _platform_joints_in_base(tree, machine), atol=1e-12)
        disk_m = frame_pose(tree, "disk")[:3, 3]
        np.testing.assert_allclose(disk_m / MM, state.disk_mm, atol=1e-9)
        np.testing.assert_allclose(frame_pose(tree, "tool"), frame_pose(tree, "disk"), atol=0)
        # the plant's tool centre (x along the bead, height above it) from the same lengths (m)
        centre = locator.centre_mm(positions / 1000.0, deflection_mm)
        in_bead = np.linalg.inv(frame_pose(tree, "bead")) @ np.append(disk_m, 1.0)
        worst = max(worst, abs(in_bead[0] / MM - centre[0]), abs(in_bead[2] / MM - centre[1]))
        offset = state.disk_mm - np.asarray(frame.origin_mm)
        assert abs(offset @ along - centre[0]) < 1e-6 and abs(offset @ up - centre[1]) < 1e-6
    assert worst <= 1e-6, worst


def _platform_joints_in_base(tree, machine) -> np.ndarray:
    """The platform's joints (m) in base, through the published platform frame."""
    platform = frame_pose(tree, "platform")
    return ((platform[:3, :3] @ machine.platform_joints_mm.T).T * MM + platform[:3, 3])


def test_bad_joint_positions_are_refused():
    machine, frame = _machine("nist_ingersoll.yaml")
    model = robot_model(machine, frame)
    with pytest.raises(ValueError, match="6 finite"):
        model.state([2500.0] * 5)
    with pytest.raises(ValueError, match="6 finite"):
        model.state([2500.0] * 5 + [math.nan])
    with pytest.raises(ValueError, match="deflection"):
        model.state(_path(machine, frame)[0], math.inf)
    with pytest.raises(ValueError, match="disk_radius_mm"):
        robot_model(machine, frame, disk_radius_mm=0.0)


def test_the_bead_outline_runs_along_the_contour_and_back_along_its_parent():
    from hex_control.grinding.bead_outline import bead_outline_m

    points = bead_outline_m([0.0, 10.0, 20.0], [0.0, 1.0, 0.0], [0.5, 0.5, 0.4])
    np.testing.assert_allclose(points / MM, [[0, 0, 0.5], [10, 0, 1.5], [20, 0, 0.4],
                                             [20, 0, 0.4], [10, 0, 0.5], [0, 0, 0.5]], atol=1e-12)
    flat = bead_outline_m([0.0, 5.0], [0.2, 0.3])
    np.testing.assert_allclose(flat[:, 2] / MM, [0.2, 0.3, 0.0, 0.0], atol=1e-12)
    for bad in (([0.0], [1.0], []), ([0.0, 1.0], [1.0], []), ([0.0, 1.0], [1.0, math.nan], []),
                ([0.0, 1.0], [1.0, 1.0], [0.0])):
        with pytest.raises(ValueError):
            bead_outline_m(*bad)


def _batch(positions_mm, names, start_s=0.0, period_s=0.001, **changes):
    """A telemetry batch as the plant sends it (lengths m, row-major), fields replaced by ``changes``."""
    n = len(positions_mm)
    batch = {"time_s": list(start_s + period_s * np.arange(n)), "strut_names": list(names),
             "strut_lengths_m": (np.asarray(positions_mm) * MM).ravel().tolist(), "deflection_mm": [0.0] * n}
    return batch | changes


def test_telemetry_batches_are_checked_before_any_work_and_the_timeline_goes_on():
    """Threat model (docs/graph.md): a malformed batch is refused whole (sizes, names, stamps);
    a jump back or ahead is taken only once the next batch confirms it (a restarted plant)."""
    from hex_control.kinematics.robot_telemetry import MAX_BATCH_SAMPLES, RobotTelemetry, TelemetryRefused

    machine, frame = _machine("nist_ingersoll.yaml")
    core = RobotTelemetry(robot_model(machine, frame))
    path, names = _path(machine, frame, samples=4), machine.joint_names
    placed = core.place(**_batch(path, names, start_s=1.0))
    assert [t for t, _ in placed.states] == [1.003] and not placed.failures  # the last sample only
    lengths = (path * MM).ravel().tolist()
    malformed = {"empty": {"time_s": [], "deflection_mm": [], "strut_lengths_m": []},
                 "one length short": {"strut_lengths_m": lengths[:-1]},
                 "deflections short": {"deflection_mm": [0.0] * 3},
                 "names not the machine's": {"strut_names": list(reversed(names))},
                 "NaN stamp": {"time_s": [1.1, math.nan, 1.2, 1.3]},
                 "inf stamp": {"time_s": [1.1, 1.2, 1.3, math.inf]},
                 "negative stamp": {"time_s": [-1.0, -0.9, -0.8, -0.7]},
                 "beyond a ROS stamp": {"time_s": [1.1, 1.2, 1.3, 1e12]},
                 "back inside the batch": {"time_s": [1.1, 1.3, 1.2, 1.4]},
                 "huge": {"time_s": [1.1] * (MAX_BATCH_SAMPLES + 1)}}
    for what, change in malformed.items():
        with pytest.raises(TelemetryRefused, match=r"samples|arrays|stamps") as refused:
            core.place(**_batch(path, names, start_s=1.1) | change)
        assert refused.value.counter == "rejected_telemetry", what
    # NaN lengths or deflection: that sample has no frames, the batch's others do
    core.every_sample = True
    placed = core.place(**_batch(path, names, start_s=1.1, deflection_mm=[0.0, math.nan, 0.0, 0.0]))
    assert len(placed.states) == 3 and [t for t, _ in placed.failures] == [1.101]
    # every sample of a long batch: at most max_placed of them, evenly spaced, the last kept
    core.max_placed = 3
    placed = core.place(**_batch(np.repeat(path, 5, axis=0), names, start_s=1.2))
    assert [t for t, _ in placed.states] == pytest.approx([1.2, 1.210, 1.219])
    core.every_sample = False
    # one forged batch in the past or the future moves nothing; the plant's next one is placed
    for forged_s in (0.5, 1e6):
        with pytest.raises(TelemetryRefused, match="does not go on") as refused:
            core.place(**_batch(path, names, start_s=forged_s))
        assert refused.value.counter == "stale_telemetry"
        assert core.timeline.last_s == pytest.approx(1.219)
    assert core.place(**_batch(path, names, start_s=1.3)).states
    # a restarted plant (time from 0 again): its first batch waits, its second confirms it
    with pytest.raises(TelemetryRefused):
        core.place(**_batch(path, names, start_s=0.0))
    assert [t for t, _ in core.place(**_batch(path, names, start_s=0.1)).states] == [pytest.approx(0.103)]
    # before the plant's first strut command there are no lengths: nothing to place, no refusal
    assert core.place(**_batch(path, names, start_s=0.2, strut_lengths_m=[])).states == []


def test_an_enormous_contour_is_refused_before_conversion_and_a_long_one_drawn_bounded():
    """10^6 points (a forged scan) are refused on their size alone; 50,000 are drawn with at
    most MAX_OUTLINE_POINTS vertices a side, the ends kept."""
    from hex_control.grinding.bead_outline import MAX_CONTOUR_POINTS, MAX_OUTLINE_POINTS, bead_outline_m

    class Huge:  # a sequence whose elements must never be read
        def __len__(self):
            return 10**6

        def __iter__(self):
            raise AssertionError("converted before the size check")

    with pytest.raises(ValueError, match=str(MAX_CONTOUR_POINTS)):
        bead_outline_m(Huge(), Huge(), Huge())
    x = np.linspace(0.0, 60.0, 50_000)
    points = bead_outline_m(x, 0.8 * np.sin(x), np.full_like(x, 0.1))
    assert len(points) == 2 * MAX_OUTLINE_POINTS
    np.testing.assert_allclose(points[[0, MAX_OUTLINE_POINTS - 1, -1], 0] / MM, [0.0, 60.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(points[0, 2] / MM, 0.1, atol=1e-12)
