"""Message introspection used by the topic tools and the configurable node inputs."""

import pytest
from geometry_msgs.msg import WrenchStamped

from hex_control.ros.infra.messages import (
    check_numeric_field,
    fill_message,
    get_field,
    message_class,
    to_primitive,
    type_name_of,
)
from hex_control_msgs.msg import Contour
from hex_control_msgs.srv import TestPose as PoseTestService


def test_message_class_resolution():
    assert message_class("geometry_msgs/msg/WrenchStamped") is WrenchStamped
    assert message_class("hex_control_msgs/Contour") is Contour
    assert type_name_of(Contour) == "hex_control_msgs/msg/Contour"
    for bad in ("nonsense", "geometry_msgs/msg/Nope", "no_such_pkg/msg/X"):
        with pytest.raises(ValueError):
            message_class(bad)


def test_fill_and_dump_round_trip_with_nested_sequences():
    data = {"error_code": {"val": -2}, "first_unreachable_index": 1,
            "reports": [{"reachable": True, "strut_lengths_mm": [1.0, 2.0]},
                        {"reachable": False, "strut_distance_margin_mm": -3}]}
    response = fill_message(PoseTestService.Response(), data)
    assert response.reports[1].strut_distance_margin_mm == -3.0
    dumped = to_primitive(response)
    assert dumped["reports"][0]["strut_lengths_mm"] == [1.0, 2.0]
    assert dumped["error_code"]["val"] == -2
    assert fill_message(PoseTestService.Response(), dumped) == response


def test_fill_refuses_unknown_fields_and_bad_types():
    with pytest.raises(ValueError, match="no field 'forse'"):
        fill_message(WrenchStamped(), {"wrench": {"forse": {"z": 1.0}}})
    with pytest.raises(ValueError, match="needs a number"):
        fill_message(WrenchStamped(), {"wrench": {"force": {"z": "ten"}}})
    with pytest.raises(ValueError, match="must be in"):
        fill_message(Contour(), {"pass_index": -1})
    with pytest.raises(ValueError, match="needs a list"):
        fill_message(Contour(), {"x_mm": 3.0})
    assert fill_message(Contour(), {"x_mm": [0, 1.5]}).x_mm.tolist() == [0.0, 1.5]


def test_field_paths():
    msg = fill_message(WrenchStamped(), {"wrench": {"force": {"z": 12.5}}})
    assert get_field(msg, "wrench.force.z") == 12.5
    with pytest.raises(ValueError, match="no field 'q'"):
        get_field(msg, "wrench.force.q")
    check_numeric_field(WrenchStamped, "wrench.force.z")
    with pytest.raises(ValueError, match="not a number"):
        check_numeric_field(WrenchStamped, "header.frame_id")


def test_a_contour_message_is_refused_beyond_its_limits_of_points_length_and_height():
    """The planners plan on what arrives: a contour of too many points, too long, or standing
    absurdly far from the bead frame (1e300 mm looped the pass planner's search for ever, a
    helper's attack of 2026-12-07) is refused at the message, with the limit named."""
    from hex_control.ros.infra.interfaces import (
        MAX_CONTOUR_HEIGHT_MM,
        MAX_CONTOUR_LENGTH_MM,
        contour_from_message,
    )
    from hex_control_msgs.msg import Contour as ContourMsg

    x = [0.0, 10.0, 20.0]
    good = contour_from_message(ContourMsg(x_mm=x, z_mm=[0.5, 1.0, 0.5], parent_mm=[0.0, 0.0, -999.0]))
    assert good.parent_mm.tolist() == [0.0, 0.0, -999.0]
    for fields, words in (({"z_mm": [0.5, 1e300, 0.5]}, r"z_mm beyond \+-1000 mm of the bead frame"),
                          ({"z_mm": [0.5, 1.0, 0.5], "parent_mm": [0.0, -1e300, 0.0]}, r"parent_mm beyond \+-1000 mm"),
                          ({"z_mm": [0.5, float("nan"), 0.5]}, "z_mm beyond"),
                          ({"z_mm": [0.5, 1.0, 0.5], "x_mm": [0.0, 10.0, 3000.0]}, "exceeds the limit of 2000 mm"),
                          ({"x_mm": [0.01 * k for k in range(100_001)], "z_mm": [0.5] * 100_001},
                           "100001 points exceed the limit of 100000")):
        with pytest.raises(ValueError, match=words):
            contour_from_message(ContourMsg(**{"x_mm": x, **fields}))
    assert MAX_CONTOUR_HEIGHT_MM == 1000.0 and MAX_CONTOUR_LENGTH_MM == 2000.0
