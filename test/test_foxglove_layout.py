"""The shipped Foxglove layout (config/foxglove/hex_control.json) is the one
scripts/foxglove_layout.py builds with the foxglove-sdk's layout types, and shows only
topics that hexctl view serves (the recording has the ROS topics of the same names)."""

import json
import re
from pathlib import Path

from conftest import load_script

from hex_control.ros.app.foxglove_view import CHANNEL_TOPICS

ROOT = Path(__file__).resolve().parent.parent


def test_the_shipped_layout_is_the_scripts_and_names_served_topics():
    script = load_script("foxglove_layout")
    shipped = (ROOT / "config/foxglove/hex_control.json").read_text()
    assert shipped == script.layout_text(), "run scripts/foxglove_layout.py"
    layout = json.loads(shipped)
    panels = re.findall(r'"panelType": "(\w+)"', shipped)
    assert sorted(panels) == ["Plot", "Plot", "RawMessages", "Table", "ThreeDee"]
    topics = {match.split(".")[0].split("[")[0] for match in re.findall(r'"(/[a-z_/]+[^"]*)"', shipped)}
    served = set(CHANNEL_TOPICS) | {"/grinding/pass_result", "/grinding/bead_outline"}  # the recording's
    assert topics <= served and {"/plant/wrench", "/robot_description", "/scene/bead"} <= topics, topics
    assert layout["content"]["items"][0]["content"]["config"]["followTf"] == "base"
