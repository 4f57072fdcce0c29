"""Write config/foxglove/hex_control.json, the Foxglove layout of the cell (hexctl view live, or a
demo's recording): the 3-D scene (TF, the URDF from /robot_description, the bead's scene), the
normal force, the bead's profile, the pass table and the last pass result. Built with the
foxglove-sdk's layout types; test_foxglove_layout checks that the shipped file is this script's.

Run: .venv/bin/python scripts/foxglove_layout.py [output]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import foxglove.layouts as fl

LAYOUT_FILE = Path(__file__).resolve().parent.parent / "config/foxglove/hex_control.json"
#: the topics the layout shows: hexctl view's channels, and the recording's topics of the same names
TOPICS = ("/tf", "/tf_static", "/robot_description", "/scene/machine", "/scene/bead", "/plant/wrench",
          "/grinding/contour", "/pass_table", "/grinding/pass_result", "/grinding/bead_outline")


def layout() -> fl.Layout:
    scene = fl.ThreeDeePanel(title="cell (base frame, m)", config=fl.ThreeDeeConfig(
        follow_tf="base", fixed_frame="base",
        layers={"urdf": fl.BaseRendererUrdfLayerSettings(layer_id="foxglove.Urdf", instance_id="urdf",
                                                         label="machine (robot_description)", source_type="topic",
                                                         topic="/robot_description")},
        topics={"/scene/bead": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/grinding/bead_outline": fl.BaseRendererRosPolygonTopicSettings(visible=True),
                "/scene/force": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/scene/machine": fl.BaseRendererSceneUpdateTopicSettings(visible=True)}))
    force = fl.PlotPanel(title="normal force (N) over sim time", config=fl.PlotConfig(
        paths=[fl.PlotSeries(value="/plant/wrench.wrench.force.z", label="measured", timestamp_method="headerStamp")],
        x_axis_val="timestamp", y_axis_label="N"))
    profile = fl.PlotPanel(title="bead profile: height (mm) along the bead (mm)", config=fl.PlotConfig(
        paths=[fl.PlotSeries(value="/grinding/contour.z_mm[:]", label="contour")],
        x_axis_val="currentCustom", x_axis_path=fl.PlotXAxisPath(value="/grinding/contour.x_mm[:]")))
    table = fl.TablePanel(title="pass table: decision (X, K1, cut, F_N, V_f, J) and result",
                          config=fl.TableConfig(topic_path="/pass_table.rows"))
    result = fl.RawMessagesPanel(title="last pass result", config=fl.RawMessagesConfig(
        topic_path="/grinding/pass_result"))
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=3, content=scene),
        fl.SplitItem(proportion=2, content=fl.SplitContainer(direction="column", items=[
            fl.SplitItem(content=force), fl.SplitItem(content=profile),
            fl.SplitItem(content=fl.TabContainer(tabs=[fl.TabItem(title="passes", content=table),
                                                       fl.TabItem(title="result", content=result)]))]))]))


def layout_text() -> str:
    return json.dumps(json.loads(layout().to_json()), indent=2, sort_keys=True) + "\n"


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else LAYOUT_FILE
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(layout_text())
    print(f"wrote {target}")
