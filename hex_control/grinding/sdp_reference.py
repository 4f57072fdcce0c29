"""Brute-force backward induction: the SDP of :mod:`hex_control.grinding.sdp` as plain loops
over stages, states, forces and feeds, with np.interp for J. Independent of the kernel /
Toeplitz machinery; same grid, same controls, same quadrature nodes (transition
probabilities) and the same tie rule. For cross-checks on small grids and as the
benchmark baseline."""

from __future__ import annotations

import numpy as np

from hex_control.grinding.sdp import GRIND, QUIT, WAIT, Charges, PlannerGrid, build_controls


def solve_reference(process, charges: Charges, grid: PlannerGrid, cut_model) -> tuple[np.ndarray, np.ndarray]:
    """(penalty J (n_t, n_x), action (n_t, n_x))."""
    x, times = grid.material_mm, grid.time_s
    controls = build_controls(process, grid, cut_model)
    late = grid.late_horizon_s > 0
    penalty = np.zeros((len(times), len(x)))
    action = np.zeros((len(times), len(x)), int)
    no_grind_after = np.ones((len(times), len(x)))
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
                    after = xi - controls.cut_nodes_mm[f, v]
                    value = np.mean(np.interp(after, x, penalty[k - duration])) + charges.in_path.per_pass
                    if charges.in_path.surface_finish_per_mm_s > 0:
                        value += (charges.in_path.surface_finish_per_mm_s * controls.feeds_mm_s[v]
                                  * np.mean(np.interp(after, x, no_grind_after[k - duration])))
                    best = min(best, value)
            tie = 1e-12 * max(1.0, abs(idle))
            grinds = best <= idle + tie if xi > charges.deadline.tolerance_mm else best < idle - tie
            penalty[k, i] = best if grinds else idle
            action[k, i] = GRIND if grinds else idle_action
            no_grind_after[k, i] = 0.0 if grinds else 1.0
    return penalty, action
