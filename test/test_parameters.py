"""Every node's parameters: one descriptor each with a description and, for a number, a
range; values out of range or off the choices refused at start-up with one line (issue 21)."""

import subprocess
import sys
from pathlib import Path

import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter

from hex_control.ros.infra.parameters import ParameterError, ParameterSpec, declare_parameters
from hex_control.ros.nodes.force_controller import ForceControllerNode
from hex_control.ros.nodes.input_shaper import InputShaperNode
from hex_control.ros.nodes.kinematics import KinematicsNode
from hex_control.ros.nodes.load_predictor import LoadPredictorNode
from hex_control.ros.nodes.pass_planner import PassPlannerNode
from hex_control.ros.nodes.plant import PlantNode
from hex_control.ros.nodes.robot_state import RobotStateNode
from hex_control.ros.nodes.sequence_planner import SequencePlannerNode
from hex_control.ros.nodes.synthetic_load import SyntheticLoadNode

NODES = (ForceControllerNode, InputShaperNode, KinematicsNode, LoadPredictorNode, PassPlannerNode, PlantNode,
         RobotStateNode, SequencePlannerNode, SyntheticLoadNode)
NUMBERS = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER)


def test_a_spec_gives_its_own_descriptor_with_range_and_choices():
    rate = ParameterSpec(200.0, "control rate", 1.0, 10_000.0).descriptor()
    assert rate.description == "control rate" and rate.read_only
    assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (1.0, 10_000.0)
    assert not rate.integer_range
    count = ParameterSpec(5, "samples", 0, None, read_only=False).descriptor()
    assert (count.integer_range[0].from_value, count.integer_range[0].to_value) == (0, 2**63 - 1)
    assert not count.read_only and not count.floating_point_range
    assert ParameterSpec("pi", "law", choices=("pi", "energy_optimal")).descriptor().additional_constraints \
        == "one of: pi, energy_optimal"
    with pytest.raises(TypeError):
        ParameterSpec("pi", "law", 0.0, 1.0).descriptor()


@pytest.mark.parametrize("node_class", NODES, ids=lambda c: c.__name__)
def test_every_parameter_is_described_and_every_number_has_a_range(ros, tmp_path, node_class):
    overrides = [Parameter("job_dir", value=str(tmp_path))] if node_class is SequencePlannerNode else []
    node = ros.add(node_class(context=ros.context, parameter_overrides=overrides))
    names = [name for name in node._parameters if name != "use_sim_time"]  # rclpy's own
    descriptors = dict(zip(names, node.describe_parameters(names)))
    assert len(names) >= 2
    for name, descriptor in descriptors.items():
        assert descriptor.name == name  # its own descriptor, not one shared and overwritten
        assert len(descriptor.description) > 5, name
        if descriptor.type in NUMBERS:
            assert descriptor.floating_point_range or descriptor.integer_range, name


def test_a_value_out_of_range_or_off_the_choices_is_refused_at_declaration(ros):
    node = ros.node("declaring")
    with pytest.raises(InvalidParameterValueException, match="rate_hz"):
        ForceControllerNode(context=ros.context, parameter_overrides=[Parameter("rate_hz", value=0.0)])
    with pytest.raises(ParameterError, match="trigger must be one of timer, measurement; got 'sometimes'"):
        ForceControllerNode(context=ros.context, parameter_overrides=[Parameter("trigger", value="sometimes")])
    declare_parameters(node, {"gain": ParameterSpec(1.0, "a live gain", 0.0, 2.0, read_only=False)})
    assert not node.set_parameters([Parameter("gain", value=3.0)])[0].successful  # the range holds live too
    assert node.set_parameters([Parameter("gain", value=1.5)])[0].successful


@pytest.mark.parametrize("command", [
    ["hex-force-controller", "-p", "rate_hz:=0.0"],
    ["hex-force-controller", "-p", "ramp_down_s:=0.0"],
    ["hex-plant", "-p", "control_period_s:=-0.005"],
    ["hex-plant", "-p", "mode:=fast"],
    ["hex-kinematics", "-p", "machine_file:=/nonexistent.yaml"],
], ids=lambda c: f"{c[0]} {c[2]}")
def test_a_bad_parameter_stops_the_node_with_one_line(ros_env, command):
    exe = Path(sys.executable).parent / command[0]
    run = subprocess.run([str(exe), "--ros-args", *command[1:]], env=ros_env, capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 2, run.stdout + run.stderr
    assert "Traceback" not in run.stderr and len(run.stderr.strip().splitlines()) == 1, run.stderr
    name, value = command[2].split(":=")
    assert name in run.stderr or value in run.stderr  # says what is wrong
