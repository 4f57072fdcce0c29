"""The platform case of ``config/mobile_platform/platform.yaml``: model, plant, path and the
two controllers, built from one file."""

from __future__ import annotations

from dataclasses import dataclass, replace

import yaml

from hex_control.config import config_path
from hex_control.seeds.mobile_platform.control import EnergyIndexController, TwoPidController
from hex_control.seeds.mobile_platform.model import PlatformParameters
from hex_control.seeds.mobile_platform.path import DesiredMotion, PathSpec, desired_motion
from hex_control.seeds.mobile_platform.simulation import simulate_platform


@dataclass(frozen=True)
class PlatformCase:
    model: PlatformParameters
    plant: PlatformParameters
    path: PathSpec
    test_path: PathSpec
    period_s: float
    encoder_counts_per_rev: int
    hold_s: float
    energy_index: dict
    two_pid: dict
    initial: dict

    @classmethod
    def from_yaml(cls, source="platform.yaml") -> PlatformCase:
        """A path, or a file name under config/mobile_platform."""
        path = config_path(source, "mobile_platform")
        data = yaml.safe_load(path.read_text())
        model = PlatformParameters(**{k: float(v) for k, v in data["model"].items()})
        plant = replace(model, **{k: float(v) for k, v in data["plant"].items()})
        return cls(model, plant, PathSpec.from_dict(data["path"]), PathSpec.from_dict(data["test_path"]),
                   float(data["sampling_period_s"]), int(data["encoder_counts_per_wheel_rev"]), float(data["hold_s"]),
                   data["energy_index"], data["two_pid"],
                   data["initial"])

    def desired(self, test_path: bool = False) -> DesiredMotion:
        """H's motion along Fig. 7's path, or Fig. 10's test path."""
        return desired_motion(self.test_path if test_path else self.path, self.model.point_h_ahead_m, self.period_s,
                              self.hold_s)

    @property
    def tuning_plants(self) -> tuple[PlatformParameters, PlatformParameters]:
        """The two ends of the platform the controllers must serve: as modelled, and loaded
        with the payload and the gear friction."""
        return self.model, self.plant

    def run(self, plant: PlatformParameters, controller, desired: DesiredMotion, with_friction: bool = True):
        """The controller on ``plant`` along ``desired``, seeing the case's encoders."""
        return simulate_platform(plant, controller, desired, self.period_s, with_friction=with_friction,
                                 encoder_counts_per_rev=self.encoder_counts_per_rev)

    def energy_controller(self, gain=None, k=None) -> EnergyIndexController:
        return EnergyIndexController(self.model, float(gain or self.energy_index["gain"]),
                                     float(k or self.energy_index["k"]), self.period_s)

    def pid_controller(self, speed=None, turn=None, k=None) -> TwoPidController:
        return TwoPidController(self.model, speed or self.two_pid["speed"], turn or self.two_pid["turn"],
                                float(k or self.two_pid["k"]), period_s=self.period_s)
