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


@dataclass(frozen=True)
class ChargeSpread:
    """How the charges of many jobs of a policy spread (issue 42 item 2): J is their mean, but
    a job's charge is skewed -- most jobs pay little, a few pay the overgrind charge or end
    far above the band -- so a handful of jobs mostly see the median. ``overgrind`` and
    ``undergrind`` are the mean's parts from jobs that end below the parent (X < 0) and above
    the band (charges units); ``p_overgrind`` the fraction of jobs that overgrind."""

    jobs: int
    mean: float
    standard_error: float
    median: float
    overgrind: float
    undergrind: float
    p_overgrind: float
    p_within: float  # ending with 0 <= X <= the band's top
    mean_final_mm: float


def charge_spread(policy: Policy, process: GrindingProcess, charges: Charges, cut_model: CutDepthModel, *,
                  time_remaining_s: float, material_mm: float, jobs: int = 2000, seed: int = 0) -> ChargeSpread:
    """``jobs`` seeded jobs of ``policy`` on the model (``run_job``) from (t, X): their charges' spread."""
    if not 1 <= int(jobs) <= 1_000_000:
        raise ValueError(f"jobs must be in [1, 1000000], got {jobs}")
    rng = np.random.default_rng(seed)
    outcomes = [run_job(policy, process, charges, cut_model, time_remaining_s, material_mm=material_mm, rng=rng)
                for _ in range(int(jobs))]
    charge = np.array([o.total_charge for o in outcomes])
    final = np.array([o.material_mm for o in outcomes])
    tolerance = charges.deadline.tolerance_mm
    return ChargeSpread(len(outcomes), float(charge.mean()), float(charge.std() / np.sqrt(len(charge))),
                        float(np.median(charge)), float(np.where(final < 0, charge, 0.0).mean()),
                        float(np.where(final > tolerance, charge, 0.0).mean()), float(np.mean(final < 0)),
                        float(np.mean((final >= 0) & (final <= tolerance))), float(final.mean()))


def run_on_estimate(policy: Policy, process: GrindingProcess, charges: Charges, time_remaining_s: float, *,
                    material_mm: float, k1_of_pass, estimator, max_passes: int = 1000) -> JobOutcome:
    """One job whose passes are planned on an estimated K1 and cut with their own (issue 42 item 2),
    as a planner re-solving its policy on each estimate runs it: at the measured state the
    policy decides a pass, its cut delta-hat (eq. 4.6 with ``process``, the sequence
    planner's command), which the pass is planned to cut at the estimate K-hat and cuts
    delta-hat K-hat / K1 with its own K1 = ``k1_of_pass(pass index)`` (eq. 4.6: C1 and C2
    are both proportional to 1/K1). ``estimator(k1)`` takes the pass's measured K1 and
    returns the next estimate (the nominal K1 of ``process`` at first). Units: mm, s, J/mm^3."""
    t, x, passes = float(time_remaining_s), float(material_mm), 0
    estimate = process.specific_energy_j_mm3
    while passes < max_passes:
        decision = policy.lookup(t, x)
        if decision["action"] != "grind":
            return JobOutcome(float(charges.deadline(x)), passes, x, t, decision["action"] == "quit")
        k1 = float(k1_of_pass(passes))
        x -= float(process.cut_depth_mm(decision["force_n"], decision["feed_mm_s"])) * estimate / k1
        t = decision["stage_time_s"] - decision["duration_s"]
        estimate = float(estimator(k1))
        passes += 1
    raise RuntimeError(f"no end after {max_passes} passes")
