"""Both platform controllers tuned the same way: the ITAE of the position error of H,
sum |H - H_bar| t dt along Fig. 7's path, summed over the platform as modelled and as
loaded (case.tuning_plants: gains tuned on one plant alone sat at its stability margin and
oscillated on the other), minimized by the project's one tuner
(hex_control.control.itae.minimize_itae). The seed tuned its PIDs by trial and error."""

from __future__ import annotations

from hex_control.control.itae import minimize_itae
from hex_control.seeds.mobile_platform.case import PlatformCase
from hex_control.seeds.mobile_platform.simulation import tracking_figures


def controller_itae(case: PlatformCase, make_controller, desired=None) -> float:
    """The tuning cost: ITAE summed over the tuning plants, a fresh controller on each."""
    desired = desired or case.desired()
    return sum(tracking_figures(case.run(plant, make_controller(), desired, with_friction=False), desired).itae_m_s2
               for plant in case.tuning_plants)


def tune_energy_index(case: PlatformCase, iterations_per_gain: int = 40, progress=None) -> tuple[dict, float]:
    desired, start = case.desired(), case.initial["energy_index"]

    def itae_of(gains):
        if progress:
            progress()
        return controller_itae(case, lambda: case.energy_controller(*gains), desired)

    (gain, k), value = minimize_itae(itae_of, (start["gain"], start["k"]), iterations_per_gain)
    return {"gain": gain, "k": k}, value


def tune_two_pid(case: PlatformCase, iterations_per_gain: int = 40, progress=None) -> tuple[dict, float]:
    desired, start = case.desired(), case.initial["two_pid"]

    def itae_of(gains):
        if progress:
            progress()
        return controller_itae(case, lambda: case.pid_controller(gains[0:3], gains[3:6], gains[6]), desired)

    gains, value = minimize_itae(itae_of, (*start["speed"], *start["turn"], start["k"]), iterations_per_gain)
    return {"speed": list(gains[0:3]), "turn": list(gains[3:6]), "k": gains[6]}, value
