"""hexctl unit-commitment, chatter, platform: the seed systems outside the grinding cell
(hex_control/seeds/)."""

from __future__ import annotations


def add_parsers(commands) -> None:
    commitment = commands.add_parser("unit-commitment", help="seed 000 part 2: scheduling table, off-line day, "
                                     "on-line stochastic scheduling of a power system (PNG, JSON)")
    commitment_verbs = commitment.add_subparsers(dest="verb", required=True)
    for verb, text in (("table", "build the scheduling table (section 4)"),
                       ("day", "schedule the example day off-line (sections 3, 5)"),
                       ("online", "schedule days of random demand on-line, both load models (sections 6, 7)")):
        job = commitment_verbs.add_parser(verb, help=text)
        job.add_argument("--fleet", default="fleet_41.yaml", help="fleet file (config/unit_commitment/ or a path)")
        job.add_argument("--k", type=int, default=5, help="candidates per level")
        job.add_argument("--step", type=float, default=100.0, help="nominal level step of rule 4.1 (MW)")
        job.add_argument("--output", default="output/unit_commitment")
        if verb == "day":
            job.add_argument("--milp", action="store_true", help="also solve the day as a MILP (the peer)")
        if verb == "online":
            job.add_argument("--days", type=int, default=40, help="simulated days per load model")
            job.add_argument("--history-days", type=int, default=80, help="days measured to identify a, W, V")
            job.add_argument("--std", type=float, default=0.0142, help="relative std of the fluctuation")
            job.add_argument("--a", type=float, default=0.8, help="Gauss-Markov coefficient per hour")
            job.add_argument("--seed", type=int, default=0)
            job.add_argument("--unbounded-store", action="store_true",
                             help="the store's energy unbounded (its rates kept), as in the 7-machine test")

    chatter = commands.add_parser("chatter", help="seed 004 section 3: chatter in slender ball-end milling, "
                                  "spindle-speed programmes and stability lobes (PNG, JSON)")
    chatter.add_argument("--case", default="chatter.yaml", help="case file (config/milling/ or a path)")
    chatter.add_argument("--output", default="output/chatter")

    platform = commands.add_parser("platform", help="seed 004 section 4: the two-wheeled platform, energy-index "
                                   "control against two PIDs (PNG, JSON)")
    platform_verbs = platform.add_subparsers(dest="verb", required=True)
    for verb, text in (("compare", "both controllers on Fig. 7's and Fig. 10's paths, as modelled and loaded"),
                       ("tune", "tune both controllers by the same ITAE minimization (prints the gains)")):
        job = platform_verbs.add_parser(verb, help=text)
        job.add_argument("--case", default="platform.yaml", help="case file (config/mobile_platform/ or a path)")
        job.add_argument("--output", default="output/platform")
        if verb == "tune":
            job.add_argument("--iterations-per-gain", type=int, default=40, help="Nelder-Mead iterations per gain")
    commitment.set_defaults(func=_unit_commitment)
    chatter.set_defaults(func=_chatter)
    platform.set_defaults(func=_platform)


def _unit_commitment(args) -> int:
    from hex_control.seeds.unit_commitment import report

    if args.verb == "table":
        summary = report.build_table(args.fleet, args.output, args.k, args.step)
        built = "read from the output folder" if summary["build_s"] is None else f"built in {summary['build_s']:.1f} s"
        print(f"{summary['fleet']}: {summary['levels']} levels {summary['levels_mw'][0]:g}..{summary['levels_mw'][1]:g}"
              f" MW, {args.k} candidates each, {built}; wrote {args.output}/table_{summary['fleet']}.png")
    elif args.verb == "day":
        summary = report.schedule_day(args.fleet, args.output, args.k, args.step, args.milp)
        print(f"{summary['fleet']}: daily cost {summary['cost']:,.1f} (running {summary['running_cost']:,.1f}, "
              f"starting {summary['starting_cost']:,.1f}), {summary['unit_cost_per_mwh']:.4f} per MWh, "
              f"scheduled in {summary['schedule_s']:.2f} s")
        if "milp" in summary:
            peer = summary["milp"]
            print(f"MILP: {peer['cost']:,.1f} (lower bound {peer['lower_bound']:,.1f}) in {peer['solve_s']:.1f} s; "
                  f"the table algorithm is {100 * peer['table_over_lower_bound']:.3f} % above the lower bound")
        print(f"wrote {args.output}/day_{summary['fleet']}.png")
    else:
        summary = report.run_online(args.fleet, args.output, args.days, args.history_days, args.std, a=args.a,
                                    seed=args.seed, k=args.k, step_mw=args.step, unbounded_store=args.unbounded_store)
        print(f"{summary['fleet']}{' (store unbounded)' if args.unbounded_store else ''}: unit cost increase over "
              f"{args.days} days, fluctuation {100 * args.std:.2f} % std (mean ± standard error)")
        for kind, result in summary["models"].items():
            hindsight, plan = result["over_hindsight"], result["over_plan"]
            print(f"  {kind:13s} over hindsight {hindsight['mean_percent']:+.4f} ± "
                  f"{hindsight['standard_error_percent']:.4f} %, over the mean day's plan {plan['mean_percent']:+.4f}"
                  f" ± {plan['standard_error_percent']:.4f} %  (identified a = {result['identified_a']:.2f})")
        print(f"wrote {args.output}/online_{summary['fleet']}.png")
    return 0


def _chatter(args) -> int:
    from tqdm import tqdm

    from hex_control.seeds.milling.case import ChatterCase
    from hex_control.seeds.milling.study import write_study

    case = ChatterCase.from_yaml(args.case)
    with tqdm(total=len(case.programmes()) + 1, desc="chatter", unit="run") as bar:
        summary = write_study(args.output, case, progress=lambda done: (bar.set_postfix_str(done), bar.update(1)))
    print(f"tool's first bending mode {summary['first_mode_hz']:.0f} Hz, a_p = {1e3 * summary['depth_m']:.3f} mm")
    print(summary["table"])
    for speed, row in summary["lobes"].items():
        print(f"{speed} rev/min: lobe limit {1e3 * row['zero_order_limit_m']:.4f} mm (zero-order), "
              f"{1e3 * row['semi_discretization_limit_m']:.4f} mm (semi-discretization); at the chosen depth the "
              f"Floquet radius is {row['spectral_radius_at_chosen_depth']:.4f} "
              f"({'unstable' if row['spectral_radius_at_chosen_depth'] > 1 else 'stable'})")
    print(f"wrote {args.output}/chatter_spectra.png, chatter_programmes.png, chatter_lobes.png, chatter.json")
    return 0


def _platform(args) -> int:
    from pathlib import Path

    import yaml
    from tqdm import tqdm

    from hex_control.seeds.mobile_platform import study, tuning
    from hex_control.seeds.mobile_platform.case import PlatformCase

    case = PlatformCase.from_yaml(args.case)
    if args.verb == "compare":
        runs = len(study.PATHS) * len(case.tuning_plants) * len(study.CONTROLLERS)
        with tqdm(total=runs, desc="platform", unit="run") as bar:
            summary = study.write_study(args.output, case, lambda done: (bar.set_postfix_str(done), bar.update(1)))
        print(summary["table"])
        print(f"wrote {args.output}/platform_path_fig7.png, platform_path_fig10.png, platform_heading_fig7.png, "
              "platform_heading_fig10.png, platform.json")
        return 0
    tuned = {}
    for name, tune in (("energy_index", tuning.tune_energy_index), ("two_pid", tuning.tune_two_pid)):
        with tqdm(desc=f"tuning {name}", unit="run") as bar:
            tuned[name], itae = tune(case, args.iterations_per_gain, progress=lambda: bar.update(1))
        print(f"{name}: ITAE {itae:.3e} m s^2 (summed over the tuning plants)")
    Path(args.output).mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(tuned, default_flow_style=None, sort_keys=False)
    (Path(args.output) / "tuned.yaml").write_text(text)
    print(text + f"wrote {args.output}/tuned.yaml (copy it into the case file's energy_index / two_pid)")
    return 0
