"""Node input_shaper over real topics: staircase, run-time change without a jump, NaN, the
path's owner (the behaviour itself: test_motion_shaper.py)."""

import math

import numpy as np
import pytest
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from hex_control.ros.nodes.input_shaper import InputShaperNode
from ros_harness import wait_until


@pytest.fixture
def shaper_node(ros):
    def start(**parameters):
        overrides = [Parameter(k, value=v) for k, v in {
            "input_type": "joint_state", "input_topic": "/t/raw", "output_topic": "/t/shaped",
            "sample_period_s": 0.01, "shaper": "zvd", "frequency_hz": 10.0, "damping": 0.0, **parameters}.items()]
        node = ros.add(InputShaperNode(context=ros.context, parameter_overrides=overrides))
        source = ros.node("raw_source")
        publisher = source.create_publisher(JointState, "/t/raw", 100)
        shaped = ros.collect(JointState, "/t/shaped", 100, publishers=1)
        ros.wait_for_match(source, "/t/raw", subscribers=1)
        return node, publisher, shaped
    return start


def send(publisher, values):
    for value in values:
        publisher.publish(JointState(name=["strut_0", "strut_1"], position=[value, 2 * value]))


def test_a_step_becomes_the_zvd_staircase(shaper_node):
    _, publisher, shaped = shaper_node()
    send(publisher, [0.0] * 5 + [1.0] * 20)
    wait_until(lambda: len(shaped) >= 25, 10.0, what="25 shaped samples")
    first = [m.position[0] for m in shaped]
    assert sorted(set(np.round(first, 12))) == [0.0, 0.25, 0.75, 1.0]  # ZVD at 10 Hz: 0, 50, 100 ms
    assert first.index(0.25) == 5 and first.index(0.75) == 10 and first.index(1.0) == 15
    np.testing.assert_allclose([m.position[1] for m in shaped], 2 * np.array(first))


def test_run_time_change_without_a_jump_and_nan_rejected(ros, shaper_node):
    node, publisher, shaped = shaper_node()
    ramp = np.minimum(np.arange(200) * 0.01, 1.0)
    send(publisher, ramp[:80])
    wait_until(lambda: len(shaped) >= 80, 10.0, what="80 samples")
    assert node.set_parameters([Parameter("shaper", value="ei"), Parameter("frequency_hz", value=7.0)])[0].successful
    assert not node.set_parameters([Parameter("frequency_hz", value=-1.0)])[0].successful
    publisher.publish(JointState(name=["strut_0", "strut_1"], position=[math.nan, 0.0]))
    for start in range(80, 200, 40):  # chunks well inside the 100-sample queues
        send(publisher, ramp[start:start + 40])
        wait_until(lambda: len(shaped) >= start + 40, 10.0, what=f"{start + 40} samples")
    output = np.array([m.position[0] for m in shaped])
    assert np.max(np.abs(np.diff(output))) <= 0.0101
    assert output[-1] == pytest.approx(1.0)
    wait_until(lambda: node.diagnostics.counters["rejected_nonfinite"] == 1, 2.0, what="the NaN counted")


def test_switch_to_an_optimized_shaper(shaper_node):
    node, publisher, shaped = shaper_node()
    node.set_parameters([Parameter("optimized_frequencies_hz", value=[8.5, 10.0, 15.0]),
                         Parameter("shaper", value="optimized")])
    wait_until(lambda: node._pending is not None and node._pending.done(), 30.0, what="the design")
    send(publisher, [0.0, 1.0])
    wait_until(lambda: len(shaped) >= 2, 5.0, what="samples")
    assert node.diagnostics.values["shaper"].startswith("optimized (criterion")
    assert len(node.core.shaper.amplitudes) == 5 and node.core.shaper.delay_s <= 1.5 / 8.5  # the optimized design


def test_a_whole_tool_path_is_shaped_as_the_stream_would_be(ros, shaper_node):
    """A pass's path arrives whole (latched) and leaves whole: the ZVD staircase on every
    channel, its identity kept, longer by the shaper's delay so it ends at rest, and
    stamped the shaper's lag (half the ZVD: 0.05 s) early, so that it is on time where it
    moves at constant velocity. Only the pass planner's paths are shaped."""
    from hex_control.ros.infra.interfaces import LATCHED, PATH_FIELDS
    from hex_control_msgs.msg import ToolPath

    shaper, _, _ = shaper_node()
    node = ros.node("pass_planner")
    publisher = node.create_publisher(ToolPath, "/motion/tool_path_raw", LATCHED)
    rogue = ros.node("path_source").create_publisher(ToolPath, "/motion/tool_path_raw", LATCHED)
    shaped = ros.collect(ToolPath, "/motion/tool_path", LATCHED, publishers=1)
    step = [0.0] * 5 + [1.0] * 20
    path = ToolPath(job_id="job-s", pass_index=3, sample_period_s=0.01)
    path.header.stamp.sec = 12
    for k, name in enumerate(PATH_FIELDS):
        setattr(path, name, [(k + 1) * v for v in step])
    ros.wait_for_match(node, "/motion/tool_path_raw", subscribers=1)
    wait_until(lambda: rogue.get_subscription_count() >= 1, 10.0, what="the rogue matched")
    rogue.publish(path)  # well formed, but not the pass planner's: refused, counted
    bad = ToolPath(job_id="job-s", pass_index=4, sample_period_s=0.01, x_mm=[0.0, math.nan])
    publisher.publish(bad)  # malformed (columns of unequal length, a NaN): refused, nothing out
    publisher.publish(path)  # in order after it: when this one is out, the bad one was handled
    out = wait_until(lambda: shaped[0] if shaped else None, 10.0, what="the shaped path")
    assert (out.job_id, out.pass_index) == ("job-s", 3)
    assert (out.header.stamp.sec, out.header.stamp.nanosec) == (11, 950_000_000)
    assert len(out.x_mm) == len(step) + 10  # ZVD at 10 Hz lasts 0.1 s: ten more samples, at rest
    x = np.array(out.x_mm)
    assert x[5] == pytest.approx(0.25) and x[10] == pytest.approx(0.75) and x[15:] == pytest.approx(1.0)
    np.testing.assert_allclose(out.yaw_rad, 6 * x)
    wait_until(lambda: shaper.diagnostics.counters["foreign_tool_path_raw"] == 1, 5.0, what="the rogue counted")
    assert len(shaped) == 1
