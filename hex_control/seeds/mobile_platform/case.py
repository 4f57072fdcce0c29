"""The platform case of ``config/mobile_platform/platform.yaml``: model, plant, path and the
two controllers, built from one file."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from hex_control.seeds.case_files import integer, load_case, number, numbers, section
from hex_control.seeds.mobile_platform.control import EnergyIndexController, TwoPidController
from hex_control.seeds.mobile_platform.model import PlatformParameters
from hex_control.seeds.mobile_platform.path import DesiredMotion, PathSpec, desired_motion
from hex_control.seeds.mobile_platform.simulation import simulate_platform

SECTIONS = ("model", "plant", "path", "test_path", "sampling_period_s", "encoder_counts_per_wheel_rev", "hold_s",
            "energy_index", "two_pid", "initial")
PATH_KEYS = ("start_straight_m", "curves", "speed_m_s", "ramp_s")


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
        """A path, or a file name under config/mobile_platform. Checked as it is read: what
        is wrong comes out as one ValueError line naming the file."""
        path, data = load_case(source, "mobile_platform", SECTIONS)
        model_data = section(path, data, "model", [f.name for f in fields(PlatformParameters)])
        plant_data = section(path, data, "plant")
        try:
            model = PlatformParameters(**{k: number(path, f"model.{k}", v) for k, v in model_data.items()})
            plant = replace(model, **{k: number(path, f"plant.{k}", v) for k, v in plant_data.items()})
            paths = [PathSpec.from_dict(section(path, data, name, PATH_KEYS)) for name in ("path", "test_path")]
            energy = section(path, data, "energy_index", ("gain", "k"))
            pid = section(path, data, "two_pid", ("speed", "turn", "k"))
            initial = section(path, data, "initial", ("energy_index", "two_pid"))
            period = number(path, "sampling_period_s", data["sampling_period_s"], positive=True)
            case = cls(model, plant, *paths, period,
                       integer(path, "encoder_counts_per_wheel_rev", data["encoder_counts_per_wheel_rev"]),
                       number(path, "hold_s", data["hold_s"], minimum=0.0),
                       {k: number(path, f"energy_index.{k}", energy[k], positive=True) for k in ("gain", "k")},
                       {"speed": numbers(path, "two_pid.speed", pid["speed"], 3, minimum=0.0),
                        "turn": numbers(path, "two_pid.turn", pid["turn"], 3, minimum=0.0),
                        "k": number(path, "two_pid.k", pid["k"], positive=True)},
                       initial)
            case.energy_controller(), case.pid_controller()  # the controllers' own checks
        except TypeError as exc:  # an unknown key in model/plant/curves, or a section of the wrong kind
            raise ValueError(f"{path}: {exc}") from None
        except (KeyError, AttributeError) as exc:
            raise ValueError(f"{path}: a path section is missing or malformed ({exc})") from None
        except ValueError as exc:
            message = str(exc)
            raise ValueError(message if message.startswith(str(path)) else f"{path}: {message}") from None
        return case

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
