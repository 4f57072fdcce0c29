"""``hexctl platform``: the comparison of seed 004 section 4 written to a folder: both
controllers on Fig. 7's path and on Fig. 10's test path, on the platform as modelled and as
loaded. Out come the figures' table, the path, heading and error PNGs and a JSON summary."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from hex_control.seeds.mobile_platform.case import PlatformCase
from hex_control.seeds.mobile_platform.plots import plot_heading, plot_paths
from hex_control.seeds.mobile_platform.simulation import tracking_figures

CONTROLLERS = ("energy index", "two PID")
PATHS = {"Fig. 7 path": False, "Fig. 10 test path": True}


def compare(case: PlatformCase, progress=None) -> dict:
    """{(path, plant, controller): (record, figures)} for the two paths, plants and controllers."""
    runs = {}
    for path_name, test_path in PATHS.items():
        desired = case.desired(test_path)
        for plant_name, plant in zip(("as modelled", "loaded"), case.tuning_plants):
            for name, make in zip(CONTROLLERS, (case.energy_controller, case.pid_controller)):
                record = case.run(plant, make(), desired)
                runs[(path_name, plant_name, name)] = (record, tracking_figures(record, desired), desired)
                if progress:
                    progress(f"{path_name}, {plant_name}, {name}")
    return runs


def figures_table(runs: dict) -> str:
    """um and mrad: the errors are a few encoder counts (5.2 um of wheel arc each)."""
    lines = [f"{'path':18s} {'plant':12s} {'controller':13s} {'max |H-H_bar| um':>16s} {'path err max/RMS um':>19s} "
             f"{'final um':>8s} {'heading max/final mrad':>22s} {'friction':>8s}"]
    for (path, plant, name), (_, f, _) in runs.items():
        lines.append(f"{path:18s} {plant:12s} {name:13s} {1e6 * f.max_position_error_m:16.1f} "
                     f"{1e6 * f.max_path_error_m:9.1f} / {1e6 * f.rms_path_error_m:7.2f} "
                     f"{1e6 * f.final_position_error_m:8.1f} {1e3 * f.max_heading_error_rad:10.3f} / "
                     f"{1e3 * f.final_heading_error_rad:9.4f} {f.max_required_friction:8.3f}")
    return "\n".join(lines)


def write_study(output, case: PlatformCase | None = None, progress=None) -> dict:
    case = case or PlatformCase.from_yaml()
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    runs = compare(case, progress)
    for path_name, slug in zip(PATHS, ("fig7", "fig10")):
        chosen = {(plant, name): (record, desired) for (path, plant, name), (record, _, desired) in runs.items()
                  if path == path_name}
        plot_paths(output / f"platform_path_{slug}.png", chosen, case.model.point_h_ahead_m, path_name)
        plot_heading(output / f"platform_heading_{slug}.png", chosen, path_name)
    summary = {"table": figures_table(runs),
               "runs": [{"path": path, "plant": plant, "controller": name, **asdict(figures)}
                        for (path, plant, name), (_, figures, _) in runs.items()],
               "gains": {"energy_index": case.energy_index, "two_pid": case.two_pid}}
    (output / "platform.json").write_text(json.dumps(summary, indent=1))
    return summary
