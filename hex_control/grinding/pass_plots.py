"""Figures of one planned pass (seed 002 Fig. 6-11/6-12 counterparts, PNG)."""

from __future__ import annotations

import numpy as np

from hex_control.grinding.contour import Contour
from hex_control.grinding.pass_plan import PassPlan
from hex_control.plotting import plt, save


def plot_pass(path, initial: Contour, plan: PassPlan, executed: dict[str, Contour] | None = None) -> None:
    """Contours (initial, desired, planned final, and any executed ones), the force and
    power trajectories, and the disk angle against time."""
    h = plan.simulation.history
    fig, axes = plt.subplots(3, 1, figsize=(11, 10), gridspec_kw={"height_ratios": [2, 1.3, 1]})
    ax = axes[0]
    ax.plot(initial.x_mm, initial.z_mm, color="0.5", lw=1.2, label="before the pass")
    ax.plot(plan.target.contour.x_mm, plan.target.contour.z_mm, "k--", lw=1.2, label="desired (eq. 6.2)")
    ax.plot(plan.simulation.final.x_mm, plan.simulation.final.z_mm, color="C0", lw=1.0, label="planned (simulated)")
    for (name, contour), colour in zip((executed or {}).items(), ("C3", "C2", "C4")):
        ax.plot(contour.x_mm, contour.z_mm, color=colour, lw=0.9, label=name)
    ax.plot(initial.x_mm, initial.parent_mm, color="0.3", lw=0.6)
    ax.set_xlabel("position along the bead (mm)")
    ax.set_ylabel("height (mm)")
    ax.set_title(f"pass planned for {plan.planned_depth_mm:.3f} mm at {plan.feed_mm_s:g} mm/s "
                 f"(Fig. 6-12a counterpart)" + (f"\n{plan.reason}" if plan.reason else ""))
    ax.legend(loc="lower center", fontsize=8, ncol=3)
    ax = axes[1]
    ax.plot(h["time_s"], h["force_n"], color="C0", label="normal force (N)")
    ax.set_ylabel("force (N)")
    ax.set_xlabel("time from the start of grinding (s)")
    twin = ax.twinx()
    twin.plot(h["time_s"], h["power_w"], color="C1", lw=0.8, label="power (W)")
    twin.set_ylabel("power (W)", color="C1")
    ax.set_title("force trajectory handed to the force controller, and the grinding power")
    ax = axes[2]
    ax.plot(h["time_s"], np.degrees(h["angle_rad"]), color="C2", label="disk angle theta")
    ax.plot(h["time_s"], np.degrees(h["relaxed_angle_rad"]), color="C4", lw=0.8, label="relaxed angle theta_0")
    ax.set_ylabel("angle (deg)")
    ax.set_xlabel("time (s)")
    ax.legend(fontsize=8)
    save(fig, path, dpi=100)
