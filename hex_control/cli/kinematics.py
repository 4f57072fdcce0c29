"""hexctl workspace: the machine's workspace maps (hex_control/kinematics/)."""

from __future__ import annotations


def add_parsers(commands) -> None:
    workspace = commands.add_parser("workspace", help="workspace maps, slices and roll sweep (PNG, JSON)")
    workspace.add_argument("--machine", default="machines/nist_ingersoll.yaml",
                           help="machine YAML (path, or a name under config/)")
    workspace.add_argument("--rolls", type=float, nargs="*", default=[0.0, 10.0, 20.0],
                           help="rolls (deg) of the 3-D maps")
    workspace.add_argument("--sweep", type=float, nargs=3, default=[0.0, 30.0, 1.0],
                           metavar=("START", "STOP", "STEP"), help="roll sweep (deg), inclusive")
    workspace.add_argument("--heights", type=float, nargs="*", default=[-2600.0, -2100.0, -1600.0],
                           help="cross-section heights (mm); the seed's are -2.6, -2.1, -1.6 m")
    workspace.add_argument("--sectors", type=int, default=1250, help="sectors per map")
    workspace.add_argument("--eps", type=float, default=1.0, help="boundary precision (mm)")
    workspace.add_argument("--output", default="output/workspace", help="report directory")
    workspace.add_argument("--json", action="store_true", help="print the summary as JSON")
    workspace.set_defaults(func=_workspace)


def _workspace(args) -> int:
    import json
    import math
    from pathlib import Path

    import numpy as np
    from tqdm import tqdm

    from hex_control.config import config_path
    from hex_control.kinematics import load_machine
    from hex_control.kinematics.report import workspace_report

    geometry, document = load_machine(config_path(args.machine))
    if not geometry.maps_workspace:
        raise ValueError(f"workspace maps are for machines with a 6-DOF workspace, as the hexapod of seed 000; "
                         f"machine {geometry.name!r} ({args.machine}) has none")
    cube = document.get("workspace", {}).get("search_cube_mm")
    if cube is None:
        raise ValueError(f"{args.machine} has no workspace.search_cube_mm section")
    start, stop, step = args.sweep
    sweep = np.arange(start, stop + step / 2, step) if step > 0 else np.array([])
    n_phi = max(3, round(math.sqrt(args.sectors / 2)))
    with tqdm(total=len(args.rolls) + len(sweep), desc="workspace", unit="map") as bar:
        summary = workspace_report(geometry, cube, Path(args.output), args.rolls, sweep.tolist(),
                                   heights_mm=args.heights,
                                   n_theta=2 * n_phi, n_phi=n_phi, eps_mm=args.eps, progress=lambda: bar.update(1))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for entry in summary["maps"]:
            shares = ", ".join(f"{k} {v:.0%}" for k, v in entry["limiting_share"].items() if v)
            print(f"roll {entry['roll_deg']:5.1f} deg: volume {entry['volume_m3']:.3f} m^3, "
                  f"centre {entry['center_mm']} mm, limited by {shares}")
        print(f"wrote {args.output}/ (workspace_roll_*.png, slices.png, roll_sweep.png, summary.json)")
    return 0
