"""Monte-Carlo execution of a policy against the stochastic process model: the planner's
promise J(t0, X0) checked by simulating jobs (feedback from the table, thesis Fig. 5-7)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.sdp import Charges, Policy
from hex_control.grinding.stochastic import CutDepthModel


@dataclass(frozen=True)
class JobOutcome:
    total_charge: float
    passes: int
    material_mm: float  # final X
    time_remaining_s: float  # final t (negative = late)
    quit: bool


def run_job(policy: Policy, process: GrindingProcess, charges: Charges, cut_model: CutDepthModel,
            time_remaining_s: float, *, material_mm: float, rng: np.random.Generator,
            max_passes: int = 1000) -> JobOutcome:
    """Execute one job: look the policy up at the measured state, grind with a cut drawn from
    the model, repeat until it waits out the deadline or quits."""
    late = policy.metadata["grid"]["late_horizon_s"] > 0
    t, x, total, passes = float(time_remaining_s), float(material_mm), 0.0, 0
    while passes < max_passes:
        decision = policy.lookup(t, x)
        if decision["action"] != "grind":
            if decision["action"] == "wait" and late and t > 0:
                t = max(decision["stage_time_s"] - (policy.time_s[1] - policy.time_s[0]), 0.0)
                continue
            lateness = charges.lateness(-t) if late else 0.0
            return JobOutcome(total + float(charges.deadline(x)) + float(lateness), passes, x, t,
                              decision["action"] == "quit")
        force, feed = decision["force_n"], decision["feed_mm_s"]
        cut = cut_model.sample(process.cut_depth_mm(force, feed), cut_model.std_mm(process, force, feed), rng)
        next_policy = policy.lookup(decision["stage_time_s"] - decision["duration_s"], x - cut)
        total += charges.in_path.per_pass + charges.in_path.surface_finish_per_mm_s * feed * (
            next_policy["action"] != "grind")
        x -= cut
        t = decision["stage_time_s"] - decision["duration_s"]
        passes += 1
    raise RuntimeError(f"no end after {max_passes} passes")
