"""Figures of the chatter study (PNG): displacement spectra per programme (seed 004 Fig. 2),
the spindle-speed programmes (Fig. 2c), and the stability lobes with the operating points."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save
from hex_control.seeds.milling.report import ProgrammeResult, displacement_spectrum


def plot_spectra(path, results: list[ProgrammeResult], settle_s: float, band_hz) -> None:
    fig, axes = plt.subplots(len(results), 1, figsize=(9, 2.0 * len(results)), sharex=True, sharey=True)
    for ax, result in zip(np.atleast_1d(axes), results):
        frequency, amplitude = displacement_spectrum(result.record, settle_s)
        ax.plot(frequency, amplitude * 1e6, lw=0.7)
        ax.axvspan(*band_hz, color="C1", alpha=0.08)
        ax.plot(result.chatter_hz, result.chatter_peak_m * 1e6, "v", color="C3")
        ax.set_title(f"{result.name}: chatter peak {result.chatter_peak_m * 1e6:.2f} um at {result.chatter_hz:.0f} Hz, "
                     f"RMS {result.rms_m * 1e6:.2f} um", fontsize="small")
        ax.set_ylabel("um")
    ax.set_xlim(0, 2000)
    ax.set_xlabel("frequency (Hz); shaded: the chatter band, between the tooth-passing harmonics")
    fig.suptitle("Tool-tip displacement spectra along x_e2 (seed 004 Fig. 2)")
    save(fig, path)


def plot_programmes(path, results: list[ProgrammeResult]) -> None:
    fig, ax = plt.subplots(figsize=(9, 3.5))
    for result in results:
        ax.plot(result.record.time_s, result.record.speed_rpm, lw=1.0, label=result.name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("spindle speed (rev/min)")
    ax.set_title("Spindle-speed programmes (seed 004 Fig. 2c; the optimal-linear one from eq. 18)")
    ax.legend(fontsize="small", ncol=3)
    save(fig, path)


def plot_lobes(path, lobes, speeds_rpm, depth_limit_m, checked, *, operating) -> None:
    """lobes: zero-order Lobe list; depth_limit_m: their boundary at speeds_rpm; checked:
    (speed, semi-discretization critical depth) pairs; operating: (speed, depth, label)."""
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for lobe in lobes:
        ax.plot(lobe.speed_rpm, lobe.depth_limit_m * 1e3, color="0.8", lw=0.6)
    ax.plot(speeds_rpm, depth_limit_m * 1e3, color="C0", lw=1.5, label="zero-order approximation")
    if checked:
        s, d = zip(*checked)
        ax.plot(s, np.array(d) * 1e3, "o", color="C2", ms=4, label="semi-discretization")
    for speed, depth, label in operating:
        ax.plot(speed, depth * 1e3, "x", color="C3", ms=9, mew=2)
        ax.annotate(label, (speed, depth * 1e3), textcoords="offset points", xytext=(5, 6), fontsize="small")
    ax.set_xlim(speeds_rpm[0], speeds_rpm[-1])
    ax.set_ylim(0, 4 * np.nanmin(depth_limit_m) * 1e3)
    ax.set_xlabel("spindle speed (rev/min)")
    ax.set_ylabel("axial depth of cut a_p (mm)")
    ax.set_title("Stability lobes of the slender ball-end mill, full immersion (stable below)")
    ax.legend(fontsize="small")
    save(fig, path)
