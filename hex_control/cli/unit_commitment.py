"""hexctl unit-commitment: seed 000 part 2, scheduling a power system
(hex_control/seeds/unit_commitment/)."""

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
    commitment.set_defaults(func=_unit_commitment)


def _unit_commitment(args) -> int:
    from hex_control.seeds.unit_commitment import report

    if args.verb == "table":
        summary = report.build_table(args.fleet, args.output, args.k, args.step)
        built = "read from the output folder" if summary["build_s"] is None else f"built in {summary['build_s']:.1f} s"
        print(f"{summary['fleet']}: {summary['levels']} levels {summary['levels_mw'][0]:g}..{summary['levels_mw'][1]:g}"
              f" MW, {args.k} candidates each, {built}; wrote {summary['png']}")
    elif args.verb == "day":
        summary = report.schedule_day(args.fleet, args.output, args.k, args.step, args.milp)
        print(f"{summary['fleet']}: daily cost {summary['cost']:,.1f} (running {summary['running_cost']:,.1f}, "
              f"starting {summary['starting_cost']:,.1f}), {summary['unit_cost_per_mwh']:.4f} per MWh, "
              f"scheduled in {summary['schedule_s']:.2f} s")
        if "milp" in summary:
            peer = summary["milp"]
            print(f"MILP: {peer['cost']:,.1f} (lower bound {peer['lower_bound']:,.1f}) in {peer['solve_s']:.1f} s; "
                  f"the table algorithm is {100 * peer['table_over_lower_bound']:.3f} % above the lower bound")
        print(f"wrote {summary['png']}")
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
        print(f"wrote {summary['png']}")
    return 0
