"""The chatter case of ``config/milling/chatter.yaml``: the tool, the cut and the seed's
spindle programmes, as one object the report, the CLI and the tests share. The file is
checked as it is read (hex_control.seeds.case_files): what is wrong comes out as one line."""

from __future__ import annotations

from dataclasses import dataclass

from hex_control.seeds.case_files import integer, load_case, number, numbers, section
from hex_control.seeds.milling.cutting import Cut
from hex_control.seeds.milling.optimal_speed import OptimalLinearSpeed
from hex_control.seeds.milling.programmes import seed_programmes
from hex_control.seeds.milling.tool_beam import BeamTool, ToolModes

TOOL_KEYS = ("diameter_m", "overhang_m", "young_pa", "density_kg_m3", "damping_ratio", "elements", "modes")
CUT_KEYS = ("teeth", "depth_m", "feed_per_tooth_m", "cutting_pressure_pa", "force_ratio", "start_rad", "exit_rad")
SIMULATION_KEYS = ("step_s", "duration_s", "settle_s", "chatter_band_hz")
OPTIMAL_KEYS = ("max_rpm", "fall_s", "acceleration_rpm_s", "fast_acceleration_rpm_s", "q1", "q2", "r",
                "control_period_s")


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
        path, data = load_case(source, "milling", ("tool", "cut", "simulation", "programmes", "optimal_linear"))
        tool_data = section(path, data, "tool", TOOL_KEYS)
        cut_data = section(path, data, "cut", CUT_KEYS)
        sim = section(path, data, "simulation", SIMULATION_KEYS)
        speeds = section(path, data, "programmes", ("low_rpm", "high_rpm"))
        optimal_data = section(path, data, "optimal_linear", OPTIMAL_KEYS)
        try:
            tool = BeamTool(**{k: number(path, f"tool.{k}", tool_data[k], positive=True)
                               for k in TOOL_KEYS if k not in ("elements", "modes")},
                            elements=integer(path, "tool.elements", tool_data["elements"]))
            modes = tool.modes(integer(path, "tool.modes", tool_data["modes"]))
            cut = Cut(teeth=integer(path, "cut.teeth", cut_data["teeth"]),
                      **{k: number(path, f"cut.{k}", cut_data[k], minimum=0.0) for k in CUT_KEYS if k != "teeth"})
            band = numbers(path, "simulation.chatter_band_hz", sim["chatter_band_hz"], 2, minimum=0.0)
            if not band[0] < band[1]:
                raise ValueError("simulation.chatter_band_hz must be (low, high) with low < high")
            optimal = {k: number(path, f"optimal_linear.{k}", optimal_data[k], positive=True) for k in OPTIMAL_KEYS}
            optimal["cutting_stiffness"] = bool(optimal_data.get("cutting_stiffness", True))
            case = cls(tool, modes, cut, *(number(path, f"simulation.{k}", sim[k], positive=True)
                                           for k in ("step_s", "duration_s")),
                       number(path, "simulation.settle_s", sim["settle_s"], minimum=0.0), (band[0], band[1]),
                       *(number(path, f"programmes.{k}", speeds[k], positive=True) for k in ("low_rpm", "high_rpm")),
                       optimal)
            if not case.settle_s < case.duration_s:
                raise ValueError("simulation.settle_s must be shorter than duration_s")
            case.programmes()  # the programmes' own checks (speeds, times)
        except ValueError as exc:
            message = str(exc)
            raise ValueError(message if message.startswith(str(path)) else f"{path}: {message}") from None
        return case

    def optimal_linear(self, acceleration_rpm_s: float | None = None, **changes) -> OptimalLinearSpeed:
        """A fresh eq. 18 controller, at the spindle's acceleration or the one given."""
        o = {**self.optimal, **changes}
        return OptimalLinearSpeed(self.modes, self.cut, self.low_rpm, o["max_rpm"], fall_s=o["fall_s"],
                                  acceleration_rpm_s=acceleration_rpm_s or o["acceleration_rpm_s"],
                                  q1=o["q1"], q2=o["q2"], r=o["r"], control_period_s=o["control_period_s"],
                                  cutting_stiffness=o["cutting_stiffness"])

    def programmes(self) -> dict:
        """The seed's four programmes and the optimal-linear one, at the spindle's limit and
        with the 10x faster spindle of the seed's simulations (fresh controllers)."""
        return {**seed_programmes(self.low_rpm, self.high_rpm),
                "optimal-linear": self.optimal_linear(),
                "optimal-linear, fast spindle": self.optimal_linear(self.optimal["fast_acceleration_rpm_s"])}
