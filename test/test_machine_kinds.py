"""What every machine kind answers, whatever it is (issue 22 item 1): its joint names and
limits, inverse kinematics of tool poses to joint positions, and a warm-started forward
kinematics of the tool point. The nodes, the tool locator and the reset-time measurement
ask these and never the machine's type."""

import ast
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.kinematics import KIND_ALIASES, MACHINE_TYPES, load_machine
from hex_control.kinematics.machine_kind import CONSTRAINT_SETS, ConstraintCheck

ROOT = Path(__file__).resolve().parent.parent

MACHINES = ["nist_ingersoll", "generic_6_6", "pru3", "pru3_feed"]


def _poses(machine_file: str) -> np.ndarray:
    """A few reachable tool poses (x, y, z mm, roll, pitch, yaw rad) and one far away."""
    if machine_file.startswith("pru3"):
        x = [-50.0, 0.0, 120.0] if machine_file == "pru3_feed" else [0.0, 0.0, 0.0]
        good = [[x[0], 0.0, 200.0, 0.0, 0.0, 0.0], [x[1], 0.0, 215.0, 0.08, -0.05, 0.0],
                [x[2], 0.0, 190.0, -0.1, 0.1, 0.0]]
    else:
        machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
        home = machine.home_pose
        good = [home, home + [20.0, -10.0, 30.0, 0.02, 0.0, 0.01], home + [-30.0, 25.0, -20.0, 0.0, -0.03, 0.0]]
    return np.vstack([good, [[0.0, 0.0, 1e5, 0.0, 0.0, 0.0]]])


@pytest.mark.parametrize("machine_file", MACHINES)
def test_joint_positions_and_the_tool_tracker_agree(machine_file):
    machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
    poses = _poses(machine_file)
    positions, reachable = machine.joint_positions_mm(poses)
    joints = len(machine.joint_names)
    assert positions.shape == (len(poses), joints) and reachable.tolist() == [True, True, True, False]
    assert machine.joint_speed_max_mm_s.shape == machine.joint_acceleration_max_mm_s2.shape == (joints,)
    assert len(set(machine.joint_names)) == joints
    # the coordinates the machine holds: all three on a hexapod; z on the 3-PRU head, whose x
    # and y are its parasitic motion, and x too on its feed stage, which takes that up
    held = {"pru3": [2], "pru3_feed": [0, 2]}.get(machine_file, [0, 1, 2])
    tracker = machine.tool_tracker()
    for pose, joint_mm in zip(poses[:3], positions[:3]):  # a moving machine: each solve starts at the last
        np.testing.assert_allclose(tracker.tool_position_mm(joint_mm)[held], pose[held], atol=1e-6)


@dataclass(frozen=True)
class CartesianStage:
    """A toy third machine kind: three orthogonal linear axes carrying the tool, which keeps
    its orientation (any other is unreachable). Only what every kind answers, nothing more."""

    strokes_mm: tuple = ((-300.0, 300.0), (-300.0, 300.0), (0.0, 500.0))
    name: str = "cartesian_stage"
    plant_drive = "strut_servos"
    maps_workspace = False
    constraint_sets = CONSTRAINT_SETS

    @property
    def home_pose(self) -> np.ndarray:
        return np.array([0.0, 0.0, 250.0, 0.0, 0.0, 0.0])

    @classmethod
    def from_dict(cls, data: dict) -> "CartesianStage":
        return cls(tuple(tuple(float(v) for v in axis) for axis in data["strokes_mm"]), str(data["name"]))

    @property
    def joint_names(self) -> list[str]:
        return ["axis_x", "axis_y", "axis_z"]

    @property
    def joint_speed_max_mm_s(self) -> np.ndarray:
        return np.full(3, 250.0)

    @property
    def joint_acceleration_max_mm_s2(self) -> np.ndarray:
        return np.full(3, 2500.0)

    def constraint_check(self, poses) -> ConstraintCheck:
        rows = np.asarray(poses, float).reshape(-1, 6)
        low, high = np.array(self.strokes_mm).T
        stroke = np.minimum(rows[:, :3] - low, high - rows[:, :3]).min(axis=1)
        level = -np.abs(rows[:, 3:]).max(axis=1)  # the tool cannot turn
        margins = np.column_stack([stroke, level, np.full(len(rows), np.inf), np.full(len(rows), np.inf)])
        satisfied = np.column_stack([stroke >= 0, level >= 0, np.ones((len(rows), 2), bool)])
        return ConstraintCheck(rows[:, :3].copy(), satisfied, margins)

    def joint_positions_mm(self, poses):
        check = self.constraint_check(poses)
        return check.positions_mm, check.reachable

    def check_joint_positions_mm(self, positions_mm) -> None:
        positions = np.asarray(positions_mm, float).reshape(-1)
        if positions.shape != (3,) or not self.constraint_check(np.r_[positions, 0, 0, 0]).reachable[0]:
            raise ValueError(f"axes outside their strokes {self.strokes_mm} mm: {positions}")

    def forward_pose(self, positions_mm, guess, tolerance_mm=1e-9, max_iterations=50):
        return np.r_[np.asarray(positions_mm, float), 0.0, 0.0, 0.0], 0, 0.0

    def tool_tracker(self):
        return self

    def tool_position_mm(self, positions_mm) -> np.ndarray:
        return np.asarray(positions_mm, float)[:3].copy()


STAGE_YAML = """machine:
  type: cartesian_stage
  name: toy_stage
  strokes_mm: [[-300, 300], [-300, 300], [0, 500]]
bead_frame:
  origin_mm: [-100.0, 0.0, 150.0]
  along: [1.0, 0.0, 0.0]
  up: [0.0, 0.0, 1.0]
  orientation_rpy_deg: [0.0, 0.0, 0.0]
"""


@pytest.fixture
def stage_file(tmp_path, monkeypatch):
    monkeypatch.setitem(MACHINE_TYPES, "cartesian_stage", CartesianStage)
    path = tmp_path / "stage.yaml"
    path.write_text(STAGE_YAML)
    return path


def test_a_third_machine_kind_needs_only_its_module_and_yaml(stage_file):
    """Through inverse and forward kinematics (the kinematics node's requests), the tool
    locator and the plant's drive, limits and reset-time measurement, with no code that
    knows the kind."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.kinematics.service import KinematicsCore
    from hex_control.plant.drives import make_drive
    from hex_control.plant.limits import StrutRateLimiter
    from hex_control.plant.reset_time import measure_reset_time
    from hex_control.plant.simulator import PlantSimulator
    from hex_control.plant.tool_locator import ToolLocator

    stage, document = load_machine(stage_file)
    assert isinstance(stage, CartesianStage) and stage.name == "toy_stage"
    core = KinematicsCore(stage, document)
    poses = np.array([[10.0, -20.0, 200.0, 0, 0, 0], [10.0, -20.0, 900.0, 0, 0, 0], [0.0, 0.0, 200.0, 0.1, 0, 0]])
    check = core.inverse(poses).check
    assert check.reachable.tolist() == [True, False, False]
    assert check.margins[1, 0] == pytest.approx(-400.0) and not check.satisfied[2, 1]
    assert check.positions_mm[0].tolist() == [10.0, -20.0, 200.0]
    pose, _, residual = stage.forward_pose([10.0, -20.0, 200.0], np.zeros(6))
    np.testing.assert_allclose(pose, poses[0])
    assert residual == 0.0

    frame = load_pass_planner_config("pass_planner.yaml", document).frame
    drive = make_drive(stage, step_s=1e-3)
    limiter = StrutRateLimiter(stage.joint_speed_max_mm_s / 1000.0, stage.joint_acceleration_max_mm_s2 / 1000.0)
    plant = PlantSimulator(machine=drive, strut_limiter=limiter)
    start, target = np.array([0.0, 0.0, 0.2]), np.array([0.05, 0.0, 0.25])  # m
    plant.command_struts(start)
    plant.command_struts(target)  # a 50 mm jump of two axes: a limited move onto it
    for _ in range(200):
        plant.advance(0.005, -1.0)
    np.testing.assert_allclose(drive.lengths_m, target, atol=1e-5)
    assert limiter.limited > 0
    x_mm, h_mm = ToolLocator(stage, frame).centre_mm(drive.lengths_m)
    assert (x_mm, h_mm) == pytest.approx((150.0, 100.0), abs=0.01)  # the tool point in the bead frame
    with pytest.raises(ValueError):
        stage.check_joint_positions_mm([0.0, 0.0, 900.0])
    reset = measure_reset_time(stage, frame, 100.0, 20.0, 20.0)
    assert 0.0 < reset.reset_time_s < 20.0 and reset.path_s > 100.0 / 20.0


def test_the_plant_node_runs_a_third_machine_kind(ros, stage_file):
    """The plant node, in this process (where the toy kind is registered), takes the
    stage's joint commands by its joint names and publishes its joint states."""
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState

    from hex_control.ros.nodes.plant import PlantNode
    from ros_harness import wait_until

    ros.add(PlantNode(context=ros.context, parameter_overrides=[
        Parameter("machine_file", value=str(stage_file)), Parameter("mode", value="realtime"),
        Parameter("grinding", value=False), Parameter("strut_command_owner", value="stage_operator")]))
    states = ros.collect(JointState, "/plant/strut_states", 1000)
    commands = ros.node("stage_operator").create_publisher(JointState, "/plant/strut_command", 10)
    wait_until(lambda: commands.get_subscription_count() >= 1, 15.0, what="the plant")

    def arrived():
        commands.publish(JointState(name=["axis_z", "axis_x", "axis_y"], position=[0.25, 0.05, 0.0]))
        return states and np.allclose(states[-1].position, [0.05, 0.0, 0.25], atol=1e-5)
    wait_until(arrived, 15.0, interval_s=0.2, what="the stage at its command")
    assert list(states[-1].name) == ["axis_x", "axis_y", "axis_z"]


@pytest.mark.parametrize("machine_file", ["pru3", "pru3_feed"])
def test_the_heads_constraint_sets_agree_with_its_inverse_kinematics(machine_file):
    """Reachable exactly where the head's own inverse kinematics says, over a sweep of
    heights and tilts reaching past every limit."""
    from hex_control.kinematics.pru3 import joint_check

    machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
    z, tilt = np.meshgrid(np.linspace(100.0, 320.0, 23), np.linspace(-0.7, 0.7, 15))
    poses = np.column_stack([np.full(z.size, 50.0), np.zeros(z.size), z.ravel(), tilt.ravel(), -0.5 * tilt.ravel(),
                             np.zeros(z.size)])
    check = machine.constraint_check(poses)
    reachable = joint_check(machine, poses).reachable
    assert 0 < reachable.sum() < len(poses)
    np.testing.assert_array_equal(check.reachable, reachable)
    too_tilted = np.abs(poses[:, 3]) > machine.tilt_max_rad  # refused by the tilt set, not the strokes'
    assert too_tilted.any() and not check.satisfied[too_tilted, 1].any()


@pytest.mark.parametrize("machine_file", MACHINES)
def test_every_kind_answers_its_home_pose_and_constraint_sets(machine_file):
    """What the kinematics node asks of any machine: its start is a reachable tool pose
    and its constraint sets name ConstraintCheck's four columns."""
    machine, _ = load_machine(config_file(f"machines/{machine_file}.yaml"))
    home = np.asarray(machine.home_pose, float)
    assert home.shape == (6,) and machine.joint_positions_mm(home[None])[1].tolist() == [True]
    assert tuple(machine.constraint_sets) == CONSTRAINT_SETS
    assert machine.constraint_check(home[None]).satisfied.shape == (1, len(machine.constraint_sets))


def test_one_name_per_kind_and_the_former_spelling_still_read():
    from hex_control.cli import MACHINES

    assert set(MACHINES) <= set(MACHINE_TYPES)  # hexctl demo --machine names kinds as the machine files do
    data = {"machine": {"type": "pru3"}}
    assert type(load_machine(data)[0]) is MACHINE_TYPES["pru3"]
    hexapod_file = dict(load_machine(config_file("machines/nist_ingersoll.yaml"))[1])
    for kind in ("hexapod", *KIND_ALIASES):
        document = {**hexapod_file, "machine": {**hexapod_file["machine"], "type": kind}}
        with (pytest.warns(DeprecationWarning, match="now spelled 'hexapod'") if kind in KIND_ALIASES
              else _no_warning()):
            machine, _ = load_machine(document)
        assert type(machine) is MACHINE_TYPES["hexapod"]
    with pytest.raises(ValueError, match="unknown machine type 'delta'"):
        load_machine({"machine": {"type": "delta"}})


class _no_warning:
    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        return self._catch.__exit__(*exc)


#: where a machine kind may be named or tested: the kinematics package and the plant's drives
MACHINE_MODULES = ("hex_control/kinematics/", "hex_control/plant/drives.py", "hex_control/plant/pru3_machine.py")
KIND_CLASSES = {"StewartGeometry", "Pru3Geometry", "CartesianStage"}


def kind_switches(source: str, kind_names) -> list[str]:
    """Lines of ``source`` that switch on a machine's kind: isinstance / issubclass / type()
    against a kind's class, or a comparison (==, !=, in, is) with a kind's class or name."""
    def names_kind(node) -> bool:
        if isinstance(node, ast.Name) and node.id in KIND_CLASSES:
            return True
        if isinstance(node, ast.Attribute) and node.attr in KIND_CLASSES:
            return True
        if isinstance(node, ast.Constant) and node.value in kind_names:
            return True
        return isinstance(node, (ast.Tuple, ast.List, ast.Set)) and any(names_kind(e) for e in node.elts)

    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in (
                "isinstance", "issubclass") and len(node.args) == 2 and names_kind(node.args[1]):
            found.append(f"{node.lineno}: {node.func.id}")
        elif isinstance(node, ast.Compare) and any(names_kind(side) for side in (node.left, *node.comparators)):
            found.append(f"{node.lineno}: comparison")
        elif isinstance(node, ast.MatchClass) and names_kind(node.cls):
            found.append(f"{node.lineno}: match")
    return found


def test_no_code_switches_on_the_machine_kind_outside_the_machine_modules():
    """Issue 38 item 4: the code asks a machine what it answers (MachineKind), never which
    kind it is; a new kind is its module, its MACHINE_TYPES entry and its YAML."""
    kind_names = {*MACHINE_TYPES, *KIND_ALIASES, "cartesian_stage"}
    offenders = []
    for path in sorted((ROOT / "hex_control").rglob("*.py")):
        relative = path.relative_to(ROOT).as_posix()
        if not relative.startswith(MACHINE_MODULES):
            offenders += [f"{relative}:{line}" for line in kind_switches(path.read_text(), kind_names)]
    assert not offenders, offenders
    # and the scan finds a switch where there is one
    switches = ("if isinstance(geometry, StewartGeometry): pass\n"
                "if isinstance(m, (kinematics.Pru3Geometry, int)): pass\n"
                "ok = options['machine'] == 'hexapod'\n"
                "ok = kind in ('pru3', 'x')\n"
                "ok = type(m) is CartesianStage\n"
                "ok = isinstance(m, dict) and m.maps_workspace and name == 'nist'\n")
    assert [line.split(":")[0] for line in kind_switches(switches, kind_names)] == ["1", "2", "3", "4", "5"]
