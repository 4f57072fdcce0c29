"""Figures of the platform comparison (PNG): the desired and performed paths of H with the
final positions (seed 004 Fig. 10-11), and the heading with its error (Fig. 8)."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save

STYLE = {"energy index": "C0", "two PID": "C3"}


def plot_paths(path, runs: dict, point_h_ahead_m: float, title: str) -> None:
    """runs: {(plant, controller): (record, desired)}."""
    plants = sorted({plant for plant, _ in runs})
    fig, axes = plt.subplots(1, len(plants) + 1, figsize=(5 * (len(plants) + 1), 4.8))
    for ax, plant in zip(axes, plants):
        for (p, name), (record, desired) in runs.items():
            if p != plant:
                continue
            ax.plot(desired.path_m[:, 0], desired.path_m[:, 1], color="0.6", lw=3, alpha=0.5)
            wanted = np.column_stack([np.interp(record.time_s, desired.time_s, desired.position_m[:, i])
                                      for i in (0, 1)])
            error = record.point_h_m - wanted
            ax.plot(wanted[:, 0] + 100 * error[:, 0], wanted[:, 1] + 100 * error[:, 1], color=STYLE[name], lw=1,
                    label=f"{name} (error x 100)")
        ax.set_aspect("equal")
        ax.set_title(f"{plant}: path of H", fontsize="small")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(fontsize="small")
    final = axes[-1]
    for (plant, name), (record, desired) in runs.items():
        offset = (record.point_h_m[-1] - desired.position_m[-1]) * 1e3
        final.plot(offset[0], offset[1], "+" if plant == plants[0] else "x", color=STYLE[name], ms=10, mew=2,
                   label=f"{name}, {plant}")
    final.axhline(0, color="0.7", lw=0.5)
    final.axvline(0, color="0.7", lw=0.5)
    final.set_aspect("equal", adjustable="datalim")
    final.set_title("final position of H from its target (mm), Fig. 11", fontsize="small")
    final.legend(fontsize="small")
    fig.suptitle(f"{title}: desired and performed path of H (Fig. 10)")
    save(fig, path)


def plot_heading(path, runs: dict, title: str) -> None:
    fig, (ax, ax_error) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    drawn = False
    for (plant, name), (record, desired) in runs.items():
        if not drawn:
            ax.plot(desired.time_s, np.degrees(desired.heading_rad), color="0.6", lw=3, alpha=0.5, label="desired")
            drawn = True
        ax.plot(record.time_s, np.degrees(record.states[:, 2]), color=STYLE[name], lw=0.8,
                ls="-" if plant == "as modelled" else "--", label=f"{name}, {plant}")
        error = record.states[:, 2] - np.interp(record.time_s, desired.time_s, desired.heading_rad)
        ax_error.plot(record.time_s, np.degrees(error), color=STYLE[name], lw=0.8,
                      ls="-" if plant == "as modelled" else "--")
    ax.set_ylabel("heading beta (deg)")
    ax.legend(fontsize="small")
    ax_error.set_ylabel("error (deg)")
    ax_error.set_xlabel("time (s)")
    fig.suptitle(f"{title}: heading and its error (Fig. 8)")
    save(fig, path)
