"""hexctl chatter, platform: seed 004's systems outside the grinding cell
(hex_control/seeds/milling, hex_control/seeds/mobile_platform)."""

from __future__ import annotations


def add_parsers(commands) -> None:
    chatter = commands.add_parser("chatter", help="seed 004 section 3: chatter in slender ball-end milling, "
                                  "spindle-speed programmes and stability lobes (PNG, JSON)")
    chatter.add_argument("--case", default="chatter.yaml", help="case file (config/milling/ or a path)")
    chatter.add_argument("--output", default="output/chatter")

    platform = commands.add_parser("platform", help="seed 004 section 4: the two-wheeled platform, energy-index "
                                   "control against two PIDs (PNG, JSON)")
    platform_verbs = platform.add_subparsers(dest="verb", required=True)
    for verb, text in (("compare", "both controllers on Fig. 7's and Fig. 10's paths, as modelled and loaded"),
                       ("tune", "tune both controllers by one optimizer, criterion and budget (prints the gains)")):
        job = platform_verbs.add_parser(verb, help=text)
        job.add_argument("--case", default="platform.yaml", help="case file (config/mobile_platform/ or a path)")
        job.add_argument("--output", default="output/platform")
        if verb == "tune":
            job.add_argument("--budget", type=int, default=60,
                             help="evaluations per controller (2 simulations each; Sobol start, then Nelder-Mead)")
            job.add_argument("--criterion", choices=("rms_path", "itae"), default="rms_path",
                             help="RMS path error or ITAE of |H - H_bar|, summed over both plants")
    chatter.set_defaults(func=_chatter)
    platform.set_defaults(func=_platform)


def _chatter(args) -> int:
    import time

    from hex_control.seeds.blas import limit_blas_threads

    limit_blas_threads(1)  # 6x6 products 10^5 times a second: BLAS threads only contend (7x slower)
    from tqdm import tqdm

    from hex_control.seeds.milling.case import ChatterCase
    from hex_control.seeds.milling.study import write_study

    case = ChatterCase.from_yaml(args.case)
    start = time.perf_counter()
    with tqdm(total=len(case.programmes()) + 1, desc="chatter", unit="run") as bar:
        summary = write_study(args.output, case, progress=lambda done: (bar.set_postfix_str(done), bar.update(1)))
    print(f"tool's first bending mode {summary['first_mode_hz']:.0f} Hz, a_p = {1e3 * summary['depth_m']:.3f} mm")
    print(summary["table"])
    for speed, row in summary["lobes"].items():
        print(f"{speed} rev/min: lobe limit {1e3 * row['zero_order_limit_m']:.4f} mm (zero-order), "
              f"{1e3 * row['semi_discretization_limit_m']:.4f} mm (semi-discretization); at the chosen depth the "
              f"Floquet radius is {row['spectral_radius_at_chosen_depth']:.4f} "
              f"({'unstable' if row['spectral_radius_at_chosen_depth'] > 1 else 'stable'})")
    print(f"wrote {args.output}/chatter_spectra.png, chatter_programmes.png, chatter_lobes.png, chatter.json "
          f"in {time.perf_counter() - start:.0f} s")
    return 0


def _platform(args) -> int:
    from pathlib import Path

    from hex_control.seeds.blas import limit_blas_threads

    limit_blas_threads(1)

    import yaml
    from tqdm import tqdm

    from hex_control.seeds.mobile_platform import study
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
    from hex_control.seeds.mobile_platform import fair

    if args.budget < 6:
        raise ValueError(f"--budget must be >= 6, got {args.budget}")
    tuned = {}
    for name in ("energy_index", "two_pid"):
        with tqdm(total=args.budget, desc=f"tuning {name}", unit="run") as bar:
            result = fair.tune(case, name, args.budget, args.criterion, progress=lambda: bar.update(1))
        tuned[name] = fair.as_case_gains(name, result.gains)
        print(f"{name}: {args.criterion} {result.value:.3e} (summed over the tuning plants) after "
              f"{result.evaluations} evaluations")
    Path(args.output).mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(tuned, default_flow_style=None, sort_keys=False)
    (Path(args.output) / "tuned.yaml").write_text(text)
    print(text + f"wrote {args.output}/tuned.yaml (copy it into the case file's energy_index / two_pid)")
    return 0
