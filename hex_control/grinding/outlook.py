"""What a job can still reach, said up front (issue 42 item 3): the GrindBead feedback's
``deadline_reachable``, ``expected_final_material_mm`` and ``note``.

- **Reachable** means the band's top (the deadline charge's tolerance) can be reached on
  the planner's model at all: the most material the policy's controls can remove in the
  time left (every pass at the force the plans reach, the feeds that remove the most,
  a dynamic program over the stages) is at least X - tolerance. A deadline that fails it
  cannot be met by any sequence of passes, whatever the draws.
- **The expected end state** is the mean final X of ``rollouts`` seeded jobs of the policy
  on its own stochastic model (``rollout.run_job``, the seed fixed: the same state gives
  the same words), with the expected charge beside it, its median and the share of jobs
  that overgrind (the charge is skewed: a few jobs mostly see about the median).

Units: mm, s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.rollout import run_job
from hex_control.grinding.sdp import Charges, PlannerGrid, Policy, build_controls
from hex_control.grinding.stochastic import CutDepthModel


@dataclass(frozen=True)
class Outlook:
    reachable: bool
    max_removal_mm: float  # the most the controls remove in the time left (mean cuts)
    expected_final_mm: float  # mean final X of the rollouts
    expected_charge: float  # mean charge of the rollouts
    within_band: float  # fraction of the rollouts ending within the band
    note: str
    median_charge: float = float("nan")  # the charge is skewed: a few jobs mostly see about this
    overgrind: float = float("nan")  # fraction of the rollouts ending below the parent (X < 0)


def max_removal_mm(process: GrindingProcess, grid: PlannerGrid, cut_model: CutDepthModel, time_left_s: float) -> float:
    """The most material (mm, mean cuts) passes of the policy's controls remove in ``time_left_s``."""
    controls = build_controls(process, grid, cut_model)
    best = np.where(controls.feasible, controls.mean_cut_mm, 0.0).max(axis=0)  # per feed
    stages = int(np.floor(time_left_s / grid.time_step_s + 1e-9))
    removal = np.zeros(max(stages, 0) + 1)
    for k in range(1, stages + 1):
        removal[k] = removal[k - 1]
        for duration, cut in zip(controls.duration_stages, best):
            if duration <= k:
                removal[k] = max(removal[k], removal[k - duration] + cut)
    return float(removal[-1])


def outlook(policy: Policy, process: GrindingProcess, charges: Charges, cut_model: CutDepthModel, *,
            time_remaining_s: float, material_mm: float, rollouts: int = 256) -> Outlook:
    """The job's outlook from the state (t, X) under ``policy`` solved with ``process``."""
    grid = PlannerGrid(**policy.metadata["grid"])
    tolerance = charges.deadline.tolerance_mm
    most = max_removal_mm(process, grid, cut_model, time_remaining_s)
    reachable = material_mm - most <= tolerance
    rng = np.random.default_rng(0)
    jobs = [run_job(policy, process, charges, cut_model, time_remaining_s, material_mm=material_mm, rng=rng)
            for _ in range(int(rollouts))]
    final = np.array([job.material_mm for job in jobs])
    charges_each = np.array([job.total_charge for job in jobs])
    charge, median = float(charges_each.mean()), float(np.median(charges_each))
    within, below = float(np.mean((final >= 0) & (final <= tolerance))), float(np.mean(final < 0))
    spread = f" (median {median:.4f}; {below:.1%} of the jobs overground)"
    if reachable:
        note = (f"expected end X = {final.mean():+.4f} mm (within the band in {within:.0%} of {len(jobs)} jobs on "
                f"the planner's model), expected charge {charge:.4f}{spread}")
    else:
        note = (f"deadline out of reach: {time_remaining_s:.1f} s of passes remove at most {most:.3f} mm of the "
                f"{material_mm:.3f} mm (force the plans reach {process.force_max_n:.1f} N); expected end X = "
                f"{final.mean():+.4f} mm, expected charge {charge:.4f}{spread}")
    return Outlook(bool(reachable), most, float(final.mean()), charge, within, note, median, below)
