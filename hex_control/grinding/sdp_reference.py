"""Brute-force backward induction: the SDP of :mod:`hex_control.grinding.sdp` as plain loops
over stages, states, forces and feeds, with np.interp for J. Independent of the kernel /
FFT machinery; same grid, same controls, same transition weights (the exact
expectation over J linear between nodes) and the same tie rule. For cross-checks on small
grids and as the benchmark baseline."""

from __future__ import annotations

import numpy as np

from hex_control.grinding.sdp import (
    GRIND,
    QUIT,
    WAIT,
    Charges,
    PlannerGrid,
    build_controls,
    transition_offsets,
    transition_weights,
)


def solve_reference(process, charges: Charges, grid: PlannerGrid, cut_model) -> tuple[np.ndarray, np.ndarray]:
    """(penalty J (n_t, n_x), action (n_t, n_x))."""
    x, times = grid.material_mm, grid.time_s
    controls = build_controls(process, grid, cut_model)
    late = grid.late_horizon_s > 0
    penalty = np.zeros((len(times), len(x)))
    action = np.zeros((len(times), len(x)), int)
    no_grind_after = np.ones((len(times), len(x)))
    step = x[1] - x[0]
    transitions = {}  # (f, v) -> (offsets m in material steps, their weights)
    for f in range(len(controls.forces_n)):
        for v in range(len(controls.feeds_mm_s)):
            mean, std = controls.mean_cut_mm[f, v], controls.cut_std_mm[f, v]
            offsets = transition_offsets(cut_model, mean, std, step)
            transitions[f, v] = (offsets, transition_weights(cut_model, mean, std, step, offsets))
    for k in range(len(times)):
        for i, xi in enumerate(x):
            stop = charges.deadline(xi) + (charges.lateness(-times[k]) if late else 0.0)
            if k == 0:
                penalty[k, i], action[k, i] = stop, (QUIT if late else WAIT)
                continue
            rest = penalty[k - 1, i] if times[k] > 0 else np.inf
            if late and stop <= rest:
                idle, idle_action = float(stop), QUIT
            else:
                idle, idle_action = float(rest), WAIT
            best = np.inf
            for f in range(len(controls.forces_n)):
                for v, duration in enumerate(controls.duration_stages):
                    if not controls.feasible[f, v] or k - duration < 0:
                        continue
                    offsets, weights = transitions[f, v]
                    after = np.clip(i - offsets, 0, len(x) - 1)  # J constant beyond the grid's ends
                    value = float(weights @ penalty[k - duration, after]) + charges.in_path.per_pass
                    if charges.in_path.surface_finish_per_mm_s > 0:
                        value += (charges.in_path.surface_finish_per_mm_s * controls.feeds_mm_s[v]
                                  * float(weights @ no_grind_after[k - duration, after]))
                    best = min(best, value)
            tie = 1e-12 * max(1.0, abs(idle))
            grinds = best <= idle + tie if xi > charges.deadline.tolerance_mm else best < idle - tie
            penalty[k, i] = best if grinds else idle
            action[k, i] = GRIND if grinds else idle_action
            no_grind_after[k, i] = 0.0 if grinds else 1.0
    return penalty, action
