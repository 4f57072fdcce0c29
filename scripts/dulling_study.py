"""Does the sequence planner cope with a disk that dulls, and does the drift IMM help?

Jobs on the planner's own process model (the demo's job: 150 mm bead, X0 0.936 mm, 60 s,
shipped config), no ROS. Pass k grinds with K1 = 10 (1 + dulling)^k J/mm^3 times the
plant's 15 % log-normal scatter. Like the graph: the policy picks (F, V) and the cut it
expects with the K1 it was solved with; the pass planner sets the force for that cut with
the latest K1 estimate (at most F_max); the cut follows from the pass's true K1. The
measured K1 goes to the pass-rate predictor -- seed 000's Gauss-Markov filter or the drift
IMM, as config/load_predictor.yaml sets them -- and the policy is re-solved when the
estimate moves more than 5 %. Nothing else varies, so this isolates the K1 estimate.

    python scripts/dulling_study.py --jobs 40 [--dulling 0.0 0.25]
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np
from scipy.optimize import brentq

from hex_control.config import config_file, node_parameters
from hex_control.estimation import GaussMarkovModel, OneStepPredictor
from hex_control.estimation.drift import DriftingLoadPredictor
from hex_control.grinding.coefficients import PassModelUpdate
from hex_control.grinding.config import load_planner_config
from hex_control.grinding.sdp import solve

# the pass-rate instance as config/load_predictor.yaml sets it
PASS = node_parameters("load_predictor.yaml", "load_predictor/pass")
PASS_MODEL = GaussMarkovModel(PASS["a"], PASS["process_variance"], PASS["measurement_variance"])
SCATTER = math.sqrt(math.log1p(0.15 ** 2))
PREDICTORS = {"seed 000": lambda: OneStepPredictor(PASS_MODEL, PASS["mean"]),
              "drift IMM": lambda: DriftingLoadPredictor(PASS_MODEL, PASS["mean"], PASS["drift_rate_variance"],
                                                         PASS["drift_switch_probability"],
                                                         PASS["drift_initial_rate_variance"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=40)
    parser.add_argument("--dulling", type=float, nargs="+", default=[0.0, 0.25])
    parser.add_argument("--seed", type=int, default=42)
    args = parser.parse_args()
    nominal, charges, grid, cut_model = load_planner_config(config_file("sequence_planner.yaml"))
    nominal = dataclasses.replace(nominal, bead_length_mm=150.0)
    material_mm, deadline_s = 0.936, 60.0
    grid = grid.covering(deadline_s, material_mm)
    policies = {}

    def with_k1(k1: float):
        return dataclasses.replace(nominal, specific_energy_j_mm3=k1)

    def policy_for(k1: float):
        if k1 not in policies:
            policies[k1] = solve(with_k1(k1), charges, grid, cut_model)
        return policies[k1]

    def job(dulling: float, predictor, rng):
        model = PassModelUpdate(nominal, 0.05)
        policy, t, x, feeds = policy_for(model.solved_with), deadline_s, material_mm, []
        while (decision := policy.lookup(t, x))["action"] == "grind":
            force, feed = decision["force_n"], decision["feed_mm_s"]
            cut_mm = float(model.solved_process.cut_depth_mm(force, feed))
            plan = with_k1(model.process.specific_energy_j_mm3)
            if float(plan.cut_depth_mm(nominal.force_max_n, feed)) > cut_mm:
                force = brentq(lambda f: float(plan.cut_depth_mm(f, feed)) - cut_mm,
                               plan.zero_cut_force_n(), nominal.force_max_n)
            else:
                force = nominal.force_max_n
            k1 = 10.0 * (1 + dulling) ** len(feeds) * rng.lognormal(-SCATTER ** 2 / 2, SCATTER)
            x -= max(float(with_k1(k1).cut_depth_mm(force, feed)), 0.0)
            t -= decision["duration_s"]
            feeds.append(feed)
            if model.observe(float(np.clip(predictor.step(k1).prediction, 1.0, 99.0))):
                policy = policy_for(model.process.specific_energy_j_mm3)
                model.mark_solved()
        return float(charges.deadline(x)), len(feeds), x, float(np.mean(feeds)) if feeds else math.nan

    for dulling in args.dulling:
        for name, make in PREDICTORS.items():
            rng = np.random.default_rng(args.seed)
            charge, passes, final, feed = np.array([job(dulling, make(), rng) for _ in range(args.jobs)]).T
            print(f"dulling {dulling:.2f}/pass, {name:9s}: charge {charge.mean():.4f} +- "
                  f"{charge.std() / math.sqrt(args.jobs):.4f}, {passes.mean():.2f} passes at {feed.mean():.1f} mm/s, "
                  f"final X 5-95 % {np.percentile(final, 5):+.4f}..{np.percentile(final, 95):+.4f} mm, "
                  f"overground {np.mean(final < -charges.deadline.tolerance_mm):.2f}", flush=True)


if __name__ == "__main__":
    main()
