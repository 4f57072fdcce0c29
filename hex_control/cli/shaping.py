"""hexctl shaper: input shapers, designed and plotted (hex_control/shaping/)."""

from __future__ import annotations

#: the names of shaping.shapers.SHAPERS (test_shaper_cli checks they agree): hexctl's start-up
#: builds every verb's parser, and importing the shapers would load numpy for each hexctl call
SHAPER_NAMES = ("zv", "zvd", "zvdd", "mzv", "ei", "2hump_ei", "3hump_ei")


def add_parsers(commands) -> None:
    shaper = commands.add_parser("shaper", help="design and plot input shapers (seed 003)")
    shaper_verbs = shaper.add_subparsers(dest="verb", required=True)
    shaper_design = shaper_verbs.add_parser("design", help="print the impulse sequence of a shaper")
    shaper_design.add_argument("--type", default="zvd", choices=[*SHAPER_NAMES, "optimized"],
                               help="a closed-form shaper, or optimized (the seed's evolution design)")
    shaper_design.add_argument("--frequency", type=float, default=1.0, help="design frequency (Hz)")
    shaper_design.add_argument("--damping", type=float, default=0.0)
    shaper_design.add_argument("--vtol", type=float, default=0.05, help="vibration tolerance of EI shapers")
    shaper_design.add_argument("--frequencies", type=float, nargs="*", default=[0.85, 1.0, 1.5],
                               help="optimized: frequencies to cancel (Hz)")
    shaper_design.add_argument("--impulses", type=int, default=5, help="optimized: number of impulses")
    shaper_design.add_argument("--max-delay", type=float, default=1.5, help="optimized: longest delay (s)")
    shaper_design.add_argument("--seed", type=int, default=1)
    shaper_design.add_argument("--band", type=float, nargs=2, default=[0.7, 1.3],
                               help="report the worst V over this band of frequency ratios")
    shaper_design.add_argument("--json", action="store_true")
    shaper_plot = shaper_verbs.add_parser("plot", help="sensitivity curves and step responses (PNG)")
    shaper_plot.add_argument("--types", nargs="*", default=["zv", "zvd", "ei", "2hump_ei", "3hump_ei"],
                             choices=list(SHAPER_NAMES))
    shaper_plot.add_argument("--frequency", type=float, default=5.0, help="design frequency (Hz)")
    shaper_plot.add_argument("--damping", type=float, default=0.02)
    shaper_plot.add_argument("--mode", type=float, default=None, help="mode frequency of the step responses (Hz)")
    shaper_plot.add_argument("--output", default="output/shaper")
    shaper.set_defaults(func=_shaper)


def _shaper(args) -> int:
    import json
    from pathlib import Path

    import numpy as np

    from hex_control.shaping.shapers import design
    from hex_control.shaping.vibration import insensitivity, residual_vibration

    if args.verb == "plot":
        from hex_control.shaping.plots import plot_sensitivity, plot_step_responses

        output = Path(args.output)
        output.mkdir(parents=True, exist_ok=True)
        shapers = {kind: design(kind, args.frequency, args.damping) for kind in args.types}
        plot_sensitivity(output / "sensitivity.png", shapers, args.frequency, args.damping)
        plot_step_responses(output / "step_responses.png", shapers, args.mode or args.frequency, args.damping)
        print(f"wrote {output}/sensitivity.png and step_responses.png")
        return 0
    if args.type == "optimized":
        from tqdm import tqdm

        from hex_control.shaping.optimize import DesignProblem, optimize

        problem = DesignProblem(frequencies_hz=tuple(args.frequencies), impulses=args.impulses,
                                max_delay_s=args.max_delay)
        with tqdm(desc="evolution", unit="generation") as bar:
            result = optimize(problem, seed=args.seed, progress=lambda: bar.update(1))
        shaper, extra = result.shaper, {"criterion": result.criterion}
    else:
        shaper = design(args.type, args.frequency, args.damping, args.vtol)
        extra = {"insensitivity_5pct": insensitivity(shaper, args.frequency, args.damping)}
    band = np.linspace(args.band[0], args.band[1], 201) * (args.frequency if args.type != "optimized" else 1.0)
    summary = {"type": args.type, "amplitudes": shaper.amplitudes.tolist(), "times_s": shaper.times_s.tolist(),
               "delay_s": shaper.delay_s, "worst_vibration_in_band": float(residual_vibration(shaper, band,
                                                                                                   args.damping).max()),
               **extra}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for a, t in zip(shaper.amplitudes, shaper.times_s):
            print(f"A = {a:.4f}   t = {t:.5f} s")
        print(f"delay {shaper.delay_s:.4f} s; worst V over the band {summary['worst_vibration_in_band']:.4f}; "
              + ", ".join(f"{k} {v:.4g}" for k, v in extra.items()))
    return 0
