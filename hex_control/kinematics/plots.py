"""Workspace figures, counterparts of seed 000 part 1 Fig. 8, 12, 13 and 14 (PNG, Agg)."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save

SET_NAMES = ("I strut length", "II platform joint", "III base joint", "IV strut distance")
SET_COLORS = ("tab:blue", "tab:red", "tab:green", "tab:purple")


def plot_workspace_3d(path, workspace, title: str) -> None:
    """Boundary points coloured by the constraint set that limits them (Fig. 8)."""
    points = workspace.boundary_mm.reshape(-1, 3) / 1000.0
    limits = workspace.limiting_set.ravel()
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    for k, (name, color) in enumerate(zip(SET_NAMES, SET_COLORS)):
        mask = limits == k
        if mask.any():
            ax.scatter(*points[mask].T, s=4, color=color, label=name)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(f"{title}\nvolume {workspace.volume_mm3 / 1e9:.3f} m³")
    ax.legend(loc="upper left", fontsize="small", markerscale=3)
    save(fig, path)


def plot_slices(path, polygons: dict, heights_mm) -> None:
    """Cross-sections at several heights for several rolls (Fig. 12).
    ``polygons[roll_deg][k]`` is the (n, 2) polygon (mm) at ``heights_mm[k]``."""
    fig, axes = plt.subplots(1, len(heights_mm), figsize=(4.2 * len(heights_mm), 4.2), squeeze=False)
    for k, (ax, z) in enumerate(zip(axes[0], heights_mm)):
        for roll, shapes in polygons.items():
            polygon = np.vstack([shapes[k], shapes[k][:1]]) / 1000.0
            ax.plot(polygon[:, 0], polygon[:, 1], label=f"roll {roll:g}°")
        ax.set_title(f"z = {z / 1000:.2f} m")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal")
        ax.legend(fontsize="small")
    save(fig, path)


def plot_roll_sweep(path, rolls_deg, volumes_mm3, centers_mm, areas_mm2: dict) -> None:
    """Volume and centre vs roll (Fig. 14) and normalized slice areas vs roll (Fig. 13)."""
    fig, (ax_v, ax_a) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax_v.plot(rolls_deg, np.asarray(volumes_mm3) / 1e9, "o-", color="C0")
    ax_v.set_xlabel("roll (deg)")
    ax_v.set_ylabel("workspace volume (m³)", color="C0")
    ax_c = ax_v.twinx()
    ax_c.plot(rolls_deg, np.asarray(centers_mm)[:, 1] / 1000.0, "s--", color="C1", ms=3)
    ax_c.set_ylabel("centre y (m)", color="C1")
    ax_v.set_title("Volume and centre vs roll (seed Fig. 14)")
    for z, areas in areas_mm2.items():
        areas = np.asarray(areas)
        ax_a.plot(rolls_deg, areas / areas[0] if areas[0] > 0 else areas, "o-", ms=3, label=f"z = {z / 1000:.2f} m")
    ax_a.set_xlabel("roll (deg)")
    ax_a.set_ylabel("normalized cross-section area")
    ax_a.set_title("Cross-section area vs roll (seed Fig. 13)")
    ax_a.legend(fontsize="small")
    save(fig, path)
