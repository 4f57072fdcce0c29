"""What hexctl view makes of the cell's messages (hex_control.ros.app.foxglove_view), read back
from an MCAP sink of its Foxglove context with the independent ``mcap`` reader: the pass table
joins decision and result per pass, forces keep the sim-time stamps and turn NaN into null,
the bead scene draws the contour on its parent."""

import json
import math

import foxglove
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader

from hex_control.ros.app.foxglove_view import FoxgloveView
from hex_control_msgs.msg import Contour, PassCommand, PassResult, PlantTelemetry


def _decoder(schema):
    descriptors = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    pool = descriptor_pool.DescriptorPool()
    for file in descriptors.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))


def test_the_views_channels_carry_the_pass_table_forces_and_bead(ros, tmp_path):
    context = foxglove.Context()
    path = tmp_path / "view.mcap"
    writer = foxglove.open_mcap(path, context=context)
    view = ros.add(FoxgloveView(context, "/cell4", context=ros.context))
    assert view.get_namespace() == "/cell4"
    view._on_telemetry(PlantTelemetry(strut_names=["strut_0"], time_s=[1.0, 1.005], measured_force_n=[20.5, math.nan],
                                      true_force_n=[20.0, 21.0], strut_lengths_m=[2.5, 2.5]))
    view._on_telemetry(PlantTelemetry(time_s=[1.01], measured_force_n=[40.0], true_force_n=[40.0]))
    contour = Contour(job_id="j", pass_index=0, x_mm=[0.0, 30.0, 60.0], z_mm=[0.0, 1.0, 0.0],
                      parent_mm=[0.5, 0.5, 0.5])
    view._on_contour(contour)
    view._on_command(PassCommand(job_id="j", pass_index=0, cut_depth_mm=0.3, specific_energy_j_mm3=10.0,
                                 normal_force_n=60.0, feed_speed_mm_s=11.3, material_remaining_mm=0.868,
                                 time_remaining_s=30.0, expected_penalty=0.0327))
    view._on_command(PassCommand(job_id="j", pass_index=1, stop=True))  # a stop is no pass of its own
    view._on_result(PassResult(job_id="j", pass_index=0, status=PassResult.COMPLETED, measured_cut_depth_mm=0.32,
                               specific_energy_j_mm3=math.nan))
    view._on_contour(Contour(job_id="j", pass_index=1, x_mm=[0.0, 30.0, 60.0], z_mm=[0.0, 0.7, 0.0]))
    writer.close()

    messages = {}
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            messages.setdefault(channel.topic, []).append((schema, message))
    forces = [json.loads(m.data) for _, m in messages["/plant/wrench"]]
    assert [f["wrench"]["force"]["z"] for f in forces] == [20.5, None, 40.0]  # NaN is no JSON number
    assert [f["header"]["stamp"] for f in forces[:2]] == [{"sec": 1, "nanosec": 0}, {"sec": 1, "nanosec": 5_000_000}]
    assert [m.log_time for _, m in messages["/plant/wrench"]] == [1_000_000_000, 1_005_000_000, 1_010_000_000]
    assert [json.loads(m.data)["wrench"]["force"]["z"] for _, m in messages["/plant/true_wrench"]] == [20.0, 21.0, 40.0]
    # the force arrow of each batch's last sample: none for NaN, 40 mm (1 mm/N) along the tool's z for 40 N
    schema = messages["/scene/force"][0][0]
    scenes = [_decoder(schema).FromString(m.data) for _, m in messages["/scene/force"]]
    assert [len(s.entities[0].arrows) for s in scenes] == [0, 1]
    arrow, entity = scenes[1].entities[0].arrows[0], scenes[1].entities[0]
    assert entity.frame_id == "tool" and arrow.shaft_length + arrow.head_length == pytest.approx(0.040)
    q = arrow.pose.orientation  # the arrow's x axis turned onto z
    assert (1 - 2 * (q.y ** 2 + q.z ** 2), 2 * (q.x * q.z - q.w * q.y)) == (pytest.approx(0.0, abs=1e-12),
                                                                            pytest.approx(1.0))

    [row] = json.loads(messages["/pass_table"][-1][1].data)["rows"]
    assert row == {"job": "j", "pass": 0, "X_mm": 0.868, "t_left_s": 30.0, "K1_J_mm3": 10.0, "cut_planned_mm": 0.3,
                   "F_N": 60.0, "V_f_mm_s": 11.3, "J": 0.0327, "status": "completed", "cut_measured_mm": 0.32,
                   "duration_s": 0.0, "mean_force_n": 0.0, "K1_measured_J_mm3": None, "burn": False, "stall": False}

    schema, message = messages["/scene/bead"][-1]
    [entity] = _decoder(schema).FromString(message.data).entities
    contour_line, parent_line, first_line = entity.lines
    assert entity.frame_id == "bead"
    assert [(p.x, p.z) for p in contour_line.points] == [(0.0, 0.0), (0.03, pytest.approx(0.0007)), (0.06, 0.0)]
    assert [p.z for p in parent_line.points] == [0.0, 0.0, 0.0]  # no parent given: flat
    assert [p.z for p in first_line.points] == pytest.approx([0.0005, 0.0015, 0.0005])  # first scan, on its parent
    assert json.loads(messages["/grinding/contour"][-1][1].data)["z_mm"] == [0.0, 0.7, 0.0]


@pytest.mark.parametrize("arguments, message", [
    (["--port", "70000"], "--port must be 0..65535"),
    (["--host", "nonsense.invalid"], "cannot serve on nonsense.invalid:8765"),
    (["--namespace", "not a name"], "namespace"),
    (["--duration", "nan"], "--duration must be a finite"),  # NaN compared false with 0: it served for ever
    (["--duration", "inf"], "--duration must be a finite"),
    (["--duration", "-1"], "--duration must be a finite"),
    (["--host", " "], "--host must name an address"),
])
def test_bad_view_options_are_one_line_and_exit_2(capsys, arguments, message):
    from hex_control.cli import main

    assert main(["view", *arguments]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_an_enormous_contour_or_batch_is_refused_and_a_long_contour_drawn_bounded(ros, tmp_path):
    """Threat model (docs/graph.md): the view's work per message stays bounded. A contour
    beyond the pass planner's limit, one with mismatched arrays, a batch beyond the plant's
    limit and batches whose stamps are no ROS stamps are refused (counted, WARN); 50,000
    points are drawn and sent (every second), and 5,000 wrenches of a batch logged, as
    MAX_OUTLINE_POINTS, the ends kept."""
    from hex_control.grinding.bead_outline import MAX_CONTOUR_POINTS, MAX_OUTLINE_POINTS
    from hex_control.kinematics.robot_telemetry import MAX_BATCH_SAMPLES

    context = foxglove.Context()
    path = tmp_path / "view.mcap"
    writer = foxglove.open_mcap(path, context=context)
    view = ros.add(FoxgloveView(context, context=ros.context))
    huge = [0.0] * (MAX_CONTOUR_POINTS + 1)
    view._on_contour(Contour(x_mm=huge, z_mm=huge))
    view._on_contour(Contour(x_mm=[0.0, 1.0], z_mm=[0.0, 1.0], parent_mm=[0.0]))
    view._on_telemetry(PlantTelemetry(time_s=[0.0] * (MAX_BATCH_SAMPLES + 1)))
    view._on_telemetry(PlantTelemetry(time_s=[1.0, math.nan], measured_force_n=[1.0, 2.0]))  # it ended the view
    view._on_telemetry(PlantTelemetry(time_s=[math.inf], measured_force_n=[1.0]))
    assert view.diagnostics.counters["rejected_contour"] == 2 and view.diagnostics.counters["rejected_telemetry"] == 3
    assert view.state.last_contour is None and view.diagnostics.summary()[1].count("refused") == 2
    x = [60.0 * i / 49_999 for i in range(50_000)]
    view._on_contour(Contour(x_mm=x, z_mm=[0.5] * len(x)))
    view._on_telemetry(PlantTelemetry(time_s=[0.001 * k for k in range(5000)], measured_force_n=[1.0] * 5000))
    view.republish()
    writer.close()
    scenes, contours, wrench_ns = [], [], []
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            if channel.topic == "/scene/bead":
                scenes.append(_decoder(schema).FromString(message.data))
            contours += [json.loads(message.data)] if channel.topic == "/grinding/contour" else []
            wrench_ns += [message.log_time] if channel.topic == "/plant/wrench" else []
    assert len(wrench_ns) == MAX_OUTLINE_POINTS and (wrench_ns[0], wrench_ns[-1]) == (0, 4_999_000_000)
    assert len(scenes) == 2 and len(contours) == 2 and len(contours[-1]["x_mm"]) == MAX_OUTLINE_POINTS
    assert contours[-1]["x_mm"][-1] == 60.0 and contours[-1]["parent_mm"] == []
    for line in scenes[-1].entities[0].lines:
        assert len(line.points) == MAX_OUTLINE_POINTS and (line.points[0].x, line.points[-1].x) == (0.0, 0.06)
