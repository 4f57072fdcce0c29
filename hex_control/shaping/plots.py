"""Shaper figures: sensitivity curves (seed 003 Fig. 6, 11, 12 counterparts) and the
response of a lightly damped mode to a shaped and an unshaped step (PNG, Agg)."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save
from hex_control.shaping.filter import ShaperFilter
from hex_control.shaping.vibration import mode_response, residual_vibration


def plot_sensitivity(path, shapers: dict, design_hz: float, damping: float = 0.0, tolerance: float = 0.05) -> None:
    """Residual vibration V (%) against the frequency ratio for several shapers."""
    ratios = np.linspace(0.3, 2.0, 1000)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for name, shaper in shapers.items():
        ax.plot(ratios, 100 * residual_vibration(shaper, ratios * design_hz, damping),
                label=f"{name} ({shaper.delay_s * design_hz:.2f} T)")
    ax.axhline(100 * tolerance, color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("mode frequency / design frequency")
    ax.set_ylabel("residual vibration V (%)")
    ax.set_ylim(0, 100)
    ax.set_title(f"Shaper sensitivity (design {design_hz:g} Hz, damping {damping:g})")
    ax.legend(fontsize="small")
    save(fig, path)


def plot_step_responses(path, shapers: dict, mode_hz: float, damping: float, duration_s: float = 3.0,
                        *, dt_s: float = 1e-3) -> None:
    """A unit step through the mode, unshaped and through each shaper."""
    t = np.arange(0.0, duration_s, dt_s)
    raw = np.where(t >= 0.05, 1.0, 0.0)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(t, mode_response(t, raw, mode_hz, damping), color="0.6", label="unshaped")
    for name, shaper in shapers.items():
        command = ShaperFilter(shaper, dt_s, interpolate=True).filter(raw[:, None])[:, 0]
        ax.plot(t, mode_response(t, command, mode_hz, damping), label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("mode position (unit step)")
    ax.set_title(f"Step through a {mode_hz:g} Hz mode, damping {damping:g}")
    ax.legend(fontsize="small")
    save(fig, path)
