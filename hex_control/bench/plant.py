"""Benchmark of the force-table plant (issue target: >= 100,000 internal steps/s)."""

from __future__ import annotations

import numpy as np
from scipy.signal import cont2discrete, dlsim, tf2ss

from hex_control.bench import benchmark, best_time
from hex_control.plant.force_table import ForceTable, ForceTableParameters, position_loop


@benchmark("plant")
def plant_speed(quick: bool) -> list[str]:
    n = 20_000 if quick else 200_000
    parameters = ForceTableParameters(runout_mm=0.02, sensor_noise_n=0.5)
    table = ForceTable(parameters, step_s=1e-3)

    def stepped():
        table.reset(0.0)
        for _ in range(n):
            table.step(0.3)
    stepped_s = best_time(stepped, repeat=3)
    linear = cont2discrete(tf2ss(*position_loop("two_pole")), 1e-3, method="zoh")
    bulk_s = best_time(lambda: dlsim(linear, np.full(n, 0.3)), repeat=3)
    return [f"force table at 1 kHz (stiction, contact, runout, sensor, noise), {n} steps",
            f"step by step : {n / stepped_s:12,.0f} steps/s (target >= 100,000), "
            f"real-time factor {n * 1e-3 / stepped_s:.0f}x",
            f"bulk dlsim of the linear table alone: {n / bulk_s:12,.0f} steps/s (baseline)",
            f"ratio step-by-step / bulk: {bulk_s / stepped_s:.2f}"]


@benchmark("pru3-machine")
def pru3_machine_speed(quick: bool) -> list[str]:
    """The 3-PRU head's dynamics (held per 5 ms period) against the generic strut servos."""
    from hex_control.kinematics.pru3 import Pru3Geometry, inverse_kinematics
    from hex_control.plant.machine import Machine, MachineParameters
    from hex_control.plant.pru3_machine import Pru3Machine

    steps = 500 if quick else 5000
    target = inverse_kinematics(Pru3Geometry(), np.array([215.0, 0.08, -0.05])).lengths_mm[0] / 1000.0
    machines = {"generic servos": Machine(MachineParameters(struts=3, participation=1 / 3)),
                "3-PRU, lspd drive": Pru3Machine(drive="lspd"), "3-PRU, ctc drive": Pru3Machine(drive="ctc")}
    start = machines["3-PRU, lspd drive"].lengths_m

    def run(machine):
        machine.reset(start)
        for _ in range(steps):
            machine.step(target)
    seconds = {name: best_time(lambda m=machine: run(m), repeat=3) for name, machine in machines.items()}
    baseline = seconds["generic servos"]
    lines = [f"machine models at 1 kHz, a tilt move, {steps} steps ({steps * 1e-3:g} s simulated)"]
    for name, elapsed in seconds.items():
        lines.append(f"{name:18s}: real-time factor {steps * 1e-3 / elapsed:7.1f}x, "
                     f"{elapsed / baseline:6.1f}x the generic servos' time")
    return lines
