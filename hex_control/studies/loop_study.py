"""How much force-loop bandwidth disk runout allows, with and without a roll-off filter
(seed 002 section 7.3 and 8.3 item 2).

The thesis's trouble: the runout force (K_x x runout, at the disk rotation frequency, 50 Hz
falling to 20 Hz as the air motor slows) reaches the force sensor; a loop fast enough to
respond to it answers out of phase and amplifies it, so the thesis cut its bandwidth to
0.2 Hz. Here "usable" means: the closed loop is stable, amplifies runout anywhere in the
disk band by at most ``max_runout_gain`` (|S| over the band), keeps the peak sensitivity
below ``max_sensitivity`` (a 6 dB robustness margin) and the tracking peak below
``max_tracking_peak``. Among the gain scales g (K_p = g 0.002 mm/N, K_I = g 0.05 mm/(N s))
the usable one with the highest bandwidth is kept.

Linear figures come from python-control (table x sensor discretized by zero-order hold,
PI by Tustin, roll-off as designed); tracking RMS comes from simulating the nonlinear
table (stiction, contact loss, runout with motor droop, sensor noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hex_control.control.force_law import PIForceLaw, roll_off_filter
from hex_control.control.pi import TustinPI
from hex_control.plant.force_table import ForceTable, ForceTableParameters, position_loop, simulate_force_loop

BASE_GAINS = (0.002, 0.05)  # K_p mm/N, K_I mm/(N s) at gain scale 1


@dataclass(frozen=True)
class RollOff:
    kind: str = "none"  # none | lowpass | notch
    frequency_hz: float = 35.0
    quality: float = 0.5  # notch only


@dataclass(frozen=True)
class LoopFigures:
    gain_scale: float
    stable: bool
    bandwidth_hz: float  # -3 dB of desired -> true force
    runout_gain: float  # max |S| over the disk band
    peak_sensitivity: float
    peak_tracking: float


def _frequency_grid(rate_hz: float) -> np.ndarray:
    return np.logspace(-2, math.log10(0.49 * rate_hz), 3000)


def linear_figures(gain_scale: float, rate_hz: float, roll_off: RollOff = RollOff(),
                   parameters: ForceTableParameters = ForceTableParameters(),
                   band_hz: tuple[float, float] = (20.0, 50.0)) -> LoopFigures:
    """Frequency-domain figures of the sampled loop at one gain scale."""
    import control  # here alone: 1 s with the matplotlib it loads

    period = 1.0 / rate_hz
    num, den = position_loop(parameters.position_loop, parameters.pole1_hz, parameters.pole2_hz)
    w = 2 * math.pi * parameters.sensor_cutoff_hz
    table = control.tf(parameters.stiffness_n_per_mm * np.asarray(num), den)
    sensor = control.tf([w * w], [1, 2 * parameters.sensor_damping * w, w * w])
    loop_plant = control.sample_system(table * sensor, period, method="zoh")
    force_plant = control.sample_system(table, period, method="zoh")
    kp, ki = (gain_scale * g for g in BASE_GAINS)
    controller = control.sample_system(control.tf([kp, ki], [1, 0]), period, method="tustin")
    sos = roll_off_filter(roll_off.kind, roll_off.frequency_hz, period, roll_off.quality)
    if sos is not None:
        controller = controller * control.tf(sos.b, sos.a, period)
    stable = bool(np.all(np.abs(control.feedback(controller * loop_plant, 1).poles()) < 1))
    f = _frequency_grid(rate_hz)
    z = np.exp(2j * math.pi * f * period)
    loop = controller(z) * loop_plant(z)
    sensitivity = 1 / (1 + loop)
    tracking = controller(z) * force_plant(z) * sensitivity
    in_band = (f >= band_hz[0]) & (f <= min(band_hz[1], 0.49 * rate_hz))
    below = np.nonzero(np.abs(tracking) < 1 / math.sqrt(2))[0]
    return LoopFigures(gain_scale, stable, float(f[below[0]]) if below.size else float(f[-1]),
                       float(np.max(np.abs(sensitivity[in_band]))), float(np.max(np.abs(sensitivity))),
                       float(np.max(np.abs(tracking))))


def usable_bandwidth(rate_hz: float, roll_off: RollOff = RollOff(),
                     parameters: ForceTableParameters = ForceTableParameters(),
                     max_runout_gain: float = 1.1, max_sensitivity: float = 2.0, *, max_tracking_peak: float = 1.3,
                     gain_scales=np.logspace(-1, 1.5, 61)) -> LoopFigures | None:
    """The usable gain scale with the highest bandwidth, or None if none is usable."""
    best = None
    for g in gain_scales:
        fig = linear_figures(float(g), rate_hz, roll_off, parameters)
        usable = fig.stable and fig.runout_gain <= max_runout_gain and fig.peak_sensitivity <= max_sensitivity \
            and fig.peak_tracking <= max_tracking_peak
        if usable and (best is None or fig.bandwidth_hz > best.bandwidth_hz):
            best = fig
    return best


def thesis_step(t: float) -> float:
    """Desired force (N): 10 N, stepping to 25 N at 0.5 s (cf. Fig. 7-8, during grinding)."""
    return 25.0 if t >= 0.5 else 10.0


def thesis_ramp(t: float) -> float:
    """Desired force (N): 10 N, ramping to 30 N between 0.5 s and 3.5 s."""
    return 10.0 + 20.0 * min(max((t - 0.5) / 3.0, 0.0), 1.0)


def grinding_table(runout_mm: float = 0.05) -> ForceTableParameters:
    """The table while grinding: 4.8 N stiction, runout at 50 Hz idle slowing 1 Hz/N
    (20 Hz at 30 N), 0.3 N sensor noise."""
    return ForceTableParameters(stiction_n=4.8, runout_mm=runout_mm, disk_frequency_hz=50.0,
                                disk_slowdown_hz_per_n=1.0, sensor_noise_n=0.3, contact_mm=0.0)


def simulate(gain_scale: float, rate_hz: float, roll_off: RollOff, setpoint, duration_s: float,
             *, parameters: ForceTableParameters, seed: int = 0, step_s: float = 1e-3) -> dict:
    """The sampled loop on the nonlinear table, started at rest in contact at setpoint(0)."""
    period = 1.0 / rate_hz
    substeps = max(1, round(period / step_s))
    table = ForceTable(parameters, step_s=period / substeps, seed=seed)
    start_mm = parameters.contact_mm + setpoint(0.0) / parameters.stiffness_n_per_mm
    table.reset(start_mm)
    kp, ki = (gain_scale * g for g in BASE_GAINS)
    law = PIForceLaw(TustinPI(kp, ki, period, parameters.contact_mm - 2.0, parameters.contact_mm + 2.0),
                     roll_off_filter(roll_off.kind, roll_off.frequency_hz, period, roll_off.quality))
    law.reset(start_mm)
    return simulate_force_loop(table, law, setpoint, period, duration_s)


def mean_force_rms(log: dict, window_s: float = 0.05) -> tuple[float, float]:
    """(RMS of desired minus mean force, RMS of the ripple about that mean), in N. The mean
    is a centred moving average over ``window_s`` (one disk revolution at 20 Hz): what the
    removal integrates. The ends, where the average is one-sided, are left out."""
    period = log["time"][1] - log["time"][0]
    n = max(1, int(round(window_s / period)))
    mean = np.convolve(log["force"], np.ones(n) / n, mode="same")
    keep = slice(n, len(mean) - n)
    return (float(np.sqrt(np.mean((log["setpoint"][keep] - mean[keep]) ** 2))),
            float(np.sqrt(np.mean((log["force"][keep] - mean[keep]) ** 2))))


def runout_amplification(log: dict, parameters: ForceTableParameters, after_s: float = 1.0) -> float:
    """Amplitude of the true force at the (fixed) disk frequency over the open-loop runout
    force K_x x runout: the simulated |S| at that frequency."""
    frequency = parameters.disk_frequency_hz
    t, force = log["time"], log["force"]
    keep = t >= after_s
    t, force = t[keep], force[keep]
    whole = t < t[0] + math.floor((t[-1] - t[0]) * frequency) / frequency  # whole periods only
    amplitude = 2 * abs(np.mean(force[whole] * np.exp(-2j * math.pi * frequency * t[whole])))
    return float(amplitude / (parameters.stiffness_n_per_mm * parameters.runout_mm))
