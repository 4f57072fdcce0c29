"""The chatter case of ``config/milling/chatter.yaml``: the tool, the cut and the seed's
spindle programmes, as one object the report, the CLI and the tests share."""

from __future__ import annotations

from dataclasses import dataclass

import yaml

from hex_control.config import config_path
from hex_control.seeds.milling.cutting import Cut
from hex_control.seeds.milling.optimal_speed import OptimalLinearSpeed
from hex_control.seeds.milling.programmes import seed_programmes
from hex_control.seeds.milling.tool_beam import BeamTool, ToolModes


@dataclass(frozen=True)
class ChatterCase:
    tool: BeamTool
    modes: ToolModes
    cut: Cut
    step_s: float
    duration_s: float
    settle_s: float
    chatter_band_hz: tuple[float, float]
    low_rpm: float
    high_rpm: float
    optimal: dict

    @classmethod
    def from_yaml(cls, source="chatter.yaml") -> ChatterCase:
        """A path, or a file name under config/milling."""
        path = config_path(source, "milling")
        data = yaml.safe_load(path.read_text())
        tool_data = dict(data["tool"])
        modes = int(tool_data.pop("modes"))
        tool = BeamTool(**{k: (int(v) if k == "elements" else float(v)) for k, v in tool_data.items()})
        cut = Cut(**{k: (int(v) if k == "teeth" else float(v)) for k, v in data["cut"].items()})
        sim, speeds = data["simulation"], data["programmes"]
        return cls(tool, tool.modes(modes), cut, float(sim["step_s"]), float(sim["duration_s"]),
                   float(sim["settle_s"]), tuple(float(f) for f in sim["chatter_band_hz"]),
                   float(speeds["low_rpm"]), float(speeds["high_rpm"]),
                   {k: float(v) for k, v in data["optimal_linear"].items()})

    def programmes(self) -> dict:
        """The seed's four programmes and the optimal-linear one (a fresh controller)."""
        o = self.optimal
        return {**seed_programmes(self.low_rpm, self.high_rpm),
                "optimal-linear": OptimalLinearSpeed(self.modes, self.cut, self.low_rpm, o["max_rpm"],
                                                     fall_s=o["fall_s"], acceleration_rpm_s=o["acceleration_rpm_s"],
                                                     q1=o["q1"], q2=o["q2"], r=o["r"],
                                                     control_period_s=o["control_period_s"])}
