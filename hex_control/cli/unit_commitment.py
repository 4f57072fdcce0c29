"""hexctl unit-commitment: seed 000 part 2, scheduling a power system
(hex_control/seeds/unit_commitment/)."""

from __future__ import annotations

import json


def add_parsers(commands) -> None:
    commitment = commands.add_parser("unit-commitment", help="seed 000 part 2: scheduling table, off-line day, "
                                     "on-line stochastic scheduling of a power system (PNG, JSON)")
    commitment_verbs = commitment.add_subparsers(dest="verb", required=True)
    for verb, text in (("table", "build the scheduling table (section 4)"),
                       ("day", "schedule the example day off-line (sections 3, 5)"),
                       ("online", "schedule days of random demand on-line, both load models (sections 6, 7)"),
                       ("campaign", "the on-line statistics as a campaign of seeded blocks of days, in parallel "
                                    "(section 7; writes <output>/unit_commitment_online_<fleet>.{json,txt})")):
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
        if verb == "campaign":
            job.add_argument("--blocks", type=int, default=10, help="jobs per load model")
            job.add_argument("--days-per-block", type=int, default=10, help="days each job schedules")
            job.add_argument("--workers", type=int, default=None, help="local worker processes (default: the CPUs)")
            job.add_argument("--store", choices=("full", "reserved", "unbounded"), default="full",
                             help="the plan's store: the whole (the paper's), less a reserve, or energy unbounded")
            job.add_argument("--random-model", choices=("paper", "identified"), default="paper",
                             help="random load predicted as the last fluctuation (the paper's) or by the identified "
                                  "predictor (its mean)")
            job.add_argument("--std", type=float, default=0.0142, help="relative std of the fluctuation")
            job.add_argument("--a", type=float, default=0.8, help="Gauss-Markov coefficient per hour")
            job.add_argument("--seed", type=int, default=0, help="the first block's seed")
    commitment.set_defaults(func=_unit_commitment)


def _unit_commitment(args) -> int:
    from hex_control.seeds.unit_commitment import report

    if args.verb == "campaign":
        return _campaign(args, report)
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


def _campaign(args, report) -> int:
    from pathlib import Path

    from hex_control.campaign.executors import ProcessExecutor
    from hex_control.campaign.unit_commitment import online_jobs, run_online_campaign, table_text
    from hex_control.seeds.unit_commitment.fleet import Fleet
    from hex_control.seeds.unit_commitment.online import LoadFluctuation

    for kind in ("uniform", "gauss_markov"):
        LoadFluctuation(kind, args.std, args.a)  # the numbers, checked before any work
    fleet = Fleet.from_yaml(args.fleet)
    output = Path(args.output)
    report.build_table(args.fleet, output, args.k, args.step)  # once, read by every job
    table = output / f"table_{report.file_name(fleet)}_k{args.k}_step{args.step:g}.json"
    jobs = online_jobs(fleet=str(args.fleet), table=str(table.resolve()), blocks=args.blocks,
                       days_per_block=args.days_per_block, store=args.store, random_model=args.random_model,
                       std=args.std, a=args.a, first_seed=args.seed)
    name = f"unit_commitment_online_{report.file_name(fleet)}_{args.store}_{args.random_model}"
    stats = run_online_campaign(jobs, ProcessExecutor(args.workers), output, name=name)
    settings = {key: value for key, value in jobs[0].settings.items() if key != "kind"}
    record = json.loads((output / f"{name}.json").read_text())["campaign"]
    print(table_text(stats, settings, record))
    print(f"wrote {output / name}.json and .txt")
    return 0
