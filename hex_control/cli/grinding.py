"""hexctl sdp, pass: the grinding sequence's SDP and one pass's plan (hex_control/grinding/)."""

from __future__ import annotations


def add_parsers(commands) -> None:
    sdp = commands.add_parser("sdp", help="solve the grinding-sequence SDP and plot the policy")
    sdp.add_argument("--config", default="sequence_planner.yaml",
                     help="planner YAML (process, charges, grid, cut_model); path or name under config/")
    sdp.add_argument("--late", type=float, default=None, help="override grid.late_horizon_s (s)")
    sdp.add_argument("--burn", type=float, default=None, help="override process.burn_coefficient")
    sdp.add_argument("--output", default="output/sdp", help="report directory")
    sdp.add_argument("--json", action="store_true", help="print the summary as JSON")

    grind = commands.add_parser("pass", help="plan one grinding pass on a bead and plot it (seed 002 ch. 6)")
    grind.add_argument("--config", default="pass_planner.yaml", help="pass planner YAML; path or name under config/")
    grind.add_argument("--contour", default=None, help="CSV with x_mm, z_mm[, parent_mm]; default: a test bead")
    grind.add_argument("--length", type=float, default=150.0, help="test bead length (mm)")
    grind.add_argument("--height", type=float, default=3.0, help="test bead height (mm)")
    grind.add_argument("--ripple", type=float, default=0.15, help="test bead ripple RMS (mm)")
    grind.add_argument("--seed", type=int, default=3, help="test bead seed")
    grind.add_argument("--depth", type=float, default=0.4, help="mean cut depth delta (mm)")
    grind.add_argument("--feed", type=float, default=10.0, help="feed speed (mm/s)")
    grind.add_argument("--control", choices=["height", "relaxed_angle"], default=None, help="override the config")
    grind.add_argument("--k1-error", type=float, nargs="*", default=[0.15],
                       help="also execute the plan with K1 off by these fractions")
    grind.add_argument("--output", default="output/pass", help="report directory")
    grind.add_argument("--json", action="store_true", help="print the summary as JSON")
    sdp.set_defaults(func=_sdp)
    grind.set_defaults(func=_pass)


def _sdp(args) -> int:
    import dataclasses
    import json
    from pathlib import Path

    import numpy as np
    from tqdm import tqdm

    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.plots import plot_action_map, plot_policy_map
    from hex_control.grinding.sdp import GRIND, QUIT, solve

    process, charges, grid, cut_model = load_planner_config(args.config)
    if args.late is not None:
        grid = dataclasses.replace(grid, late_horizon_s=args.late)
    if args.burn is not None:
        process = dataclasses.replace(process, burn_coefficient=args.burn)
    output = Path(args.output)
    output.mkdir(parents=True, exist_ok=True)
    with tqdm(total=len(grid.time_s) - 1, desc="SDP stages", unit="stage") as bar:
        policy = solve(process, charges, grid, cut_model, progress=bar.update)
    policy.save(output / "policy.npz")
    plot_policy_map(output / "policy_map.png", policy)
    plot_action_map(output / "actions.png", policy)
    grinding = policy.action == GRIND
    summary = {
        "states": [len(policy.time_s), len(policy.material_mm)],
        "feeds_mm_s": policy.metadata["feeds_mm_s"],
        "grind_share": float(grinding.mean()), "quit_share": float((policy.action == QUIT).mean()),
        "max_cut_mm": float(np.nanmax(policy.cut_mm)),
        "penalty_at": {f"t={t:g}s,X={x:g}mm": policy.expected_penalty(t, x)
                       for t, x in ((grid.horizon_s, 1.0), (grid.horizon_s / 2, 1.0), (20.0, 0.5))},
    }
    (output / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2) if args.json else
          f"solved {summary['states'][0]} x {summary['states'][1]} states; max cut {summary['max_cut_mm']:.3f} mm; "
          f"wrote {output}/policy.npz, policy_map.png, actions.png, summary.json")
    return 0


def _pass(args) -> int:
    import dataclasses
    import json
    from pathlib import Path

    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.contour import Contour, weld_bead
    from hex_control.grinding.pass_plan import execute_plan, plan_pass
    from hex_control.grinding.pass_plots import plot_pass

    config = load_pass_planner_config(args.config)
    contour = Contour.from_csv(args.contour) if args.contour else \
        weld_bead(args.length, args.height, ripple_mm=args.ripple, seed=args.seed)
    model = config.model
    plan = plan_pass(contour, model, args.depth, args.feed, args.control or config.control, step_mm=config.step_mm,
                     gains=config.gains if args.control in (None, config.control) else None,
                     warm_start=config.search_start)
    executed = {"executed, same coefficients": execute_plan(contour, model, plan)}
    for error in args.k1_error:
        process = dataclasses.replace(model.process,
                                      specific_energy_j_mm3=model.process.specific_energy_j_mm3 * (1 + error))
        executed[f"executed, K1 {error:+.0%}"] = execute_plan(contour, dataclasses.replace(model, process=process),
                                                             plan)
    output = Path(args.output)
    output.mkdir(parents=True, exist_ok=True)
    plot_pass(output / "pass.png", contour, plan, {name: sim.final for name, sim in executed.items()})
    plan.simulation.final.to_csv(output / "final_contour.csv")
    wanted = plan.target.removed_mm3
    summary = {**plan.summary(), "executed_volume_error": {
        name: sim.removed_mm3 / wanted - 1 for name, sim in executed.items()}}
    (output / "summary.json").write_text(json.dumps(summary, indent=2))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"planned {plan.planned_depth_mm:.3f} mm at {plan.feed_mm_s:g} mm/s: {summary['duration_s']:.1f} s, "
              f"peak force {summary['peak_force_n']:.1f} N, peak power {summary['peak_power_w']:.0f} W; "
              f"simulated volume {plan.simulation.removed_mm3:.1f} of {wanted:.1f} mm^3")
        for name, error in summary["executed_volume_error"].items():
            print(f"  {name}: volume error {error:+.1%}")
        if plan.reason:
            print(f"  {plan.reason}")
        print(f"wrote {output}/pass.png, final_contour.csv, summary.json")
    return 0
