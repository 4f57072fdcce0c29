"""The ``hexctl workspace`` job: maps, slices and a roll sweep of a Stewart machine,
written as PNGs and a JSON summary (seed 000 part 1, section 5)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from hex_control.kinematics.plots import plot_roll_sweep, plot_slices, plot_workspace_3d
from hex_control.kinematics.stewart import StewartGeometry
from hex_control.kinematics.workspace import compute_workspace, cross_section


def workspace_report(geometry: StewartGeometry, search_cube_mm, output: Path, map_rolls_deg, sweep_rolls_deg,
                     *, heights_mm, n_theta: int = 50, n_phi: int = 25, eps_mm: float = 1.0, progress=None) -> dict:
    """Compute everything, write PNGs into ``output``, return the summary (also summary.json).
    ``progress`` is called once per unit of work (maps + sweep steps)."""
    output.mkdir(parents=True, exist_ok=True)
    tick = progress or (lambda: None)
    summary = {"machine": geometry.name, "sectors": n_theta * n_phi, "eps_mm": eps_mm, "maps": [], "sweep": []}
    polygons = {}
    for roll in map_rolls_deg:
        orientation = (math.radians(roll), 0.0, 0.0)
        workspace = compute_workspace(geometry, orientation, search_cube_mm, n_theta, n_phi, eps_mm=eps_mm)
        plot_workspace_3d(output / f"workspace_roll_{roll:g}.png", workspace, f"{geometry.name}, roll {roll:g}°")
        counts = np.bincount(workspace.limiting_set.ravel(), minlength=4)
        polygons[roll] = [cross_section(geometry, orientation, z, workspace.center_mm[:2], 180, eps_mm=eps_mm)[1]
                          for z in heights_mm]
        summary["maps"].append({
            "roll_deg": roll, "volume_m3": workspace.volume_mm3 / 1e9,
            "center_mm": workspace.center_mm.round(1).tolist(),
            "limiting_share": {s: float(c) / counts.sum() for s, c in zip(geometry.constraint_sets, counts)}})
        tick()
    plot_slices(output / "slices.png", polygons, heights_mm)
    volumes, centers, areas = [], [], {z: [] for z in heights_mm}
    for roll in sweep_rolls_deg:
        orientation = (math.radians(roll), 0.0, 0.0)
        workspace = compute_workspace(geometry, orientation, search_cube_mm, n_theta, n_phi, eps_mm=eps_mm)
        volumes.append(workspace.volume_mm3)
        centers.append(workspace.center_mm)
        for z in heights_mm:
            areas[z].append(cross_section(geometry, orientation, z, workspace.center_mm[:2], 180, eps_mm=eps_mm)[0])
        summary["sweep"].append({"roll_deg": roll, "volume_m3": workspace.volume_mm3 / 1e9,
                                 "center_y_mm": float(workspace.center_mm[1]),
                                 "slice_area_m2": {f"{z:g}": areas[z][-1] / 1e6 for z in heights_mm}})
        tick()
    if len(sweep_rolls_deg):
        plot_roll_sweep(output / "roll_sweep.png", list(sweep_rolls_deg), volumes, centers, areas)
    (output / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
