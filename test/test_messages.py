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
