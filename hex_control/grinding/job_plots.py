"""The PNGs of one grinding job's report (:mod:`hex_control.grinding.job_report`): the
scanned contours after each pass against the +-0.1 mm band, force tracking, the strut
lengths, K1 per pass with the predictor's estimate, and the policy map with the job's
trajectory. Apart from the report so that a process that only records (a test's job, a
campaign without plots) never imports matplotlib.

Units: mm, N, s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.ticker import MaxNLocator

from hex_control.grinding.job_report import JobRecord, specific_energy_by_pass
from hex_control.grinding.part_quality import TOLERANCE_MM
from hex_control.grinding.plots import plot_policy_map
from hex_control.plotting import plt, save


def plot_job(record: JobRecord, out: Path, policy=None) -> None:
    """Every PNG of the job into ``out``; ``policy`` (the start policy) for the map."""
    _plot_contours(record, out / "contours.png")
    _plot_force(record, out / "force_tracking.png")
    _plot_struts(record, out / "strut_lengths.png")
    _plot_specific_energy(record, out / "specific_energy.png")
    if policy is not None:
        trajectory = [(c["time_remaining_s"], c["material_mm"]) for _, c in sorted(record.commands.items())]
        if record.outcome:
            trajectory.append((record.outcome["time_remaining_s"], record.outcome["material_remaining_mm"]))
        plot_policy_map(out / "policy_map.png", policy, trajectory)


def _plot_contours(record: JobRecord, path: Path) -> None:
    if not record.contours:
        return
    fig, (ax, deviation) = plt.subplots(2, 1, figsize=(11, 7), sharex=True, height_ratios=(3, 2))
    colours = plt.cm.viridis(np.linspace(0, 1, max(len(record.contours), 2)))
    first = record.contours[min(record.contours)][0]
    for colour, (index, (contour, _)) in zip(colours, sorted(record.contours.items())):
        label = "initial" if index == 0 else f"after pass {index}"
        ax.plot(contour.x_mm, contour.z_mm, color=colour, lw=1.1, label=label)
        if index > 0:
            deviation.plot(contour.x_mm, contour.z_mm - contour.parent_mm, color=colour, lw=1.1, label=label)
    ax.plot(first.x_mm, first.parent_mm, "k--", lw=0.8, label="parent surface")
    for axis in (ax, deviation):  # the buyer's band (seed 002 section 3)
        offset = first.parent_mm if axis is ax else np.zeros_like(first.x_mm)
        axis.fill_between(first.x_mm, offset - TOLERANCE_MM, offset + TOLERANCE_MM, color="tab:green", alpha=0.15,
                          lw=0, label=f"+-{TOLERANCE_MM:g} mm of the parent")
    ax.set_ylabel("height (mm)")
    ax.set_title("Scanned profile after each pass")
    ax.legend(fontsize=8, ncol=2)
    deviation.axhline(0.0, color="k", ls="--", lw=0.8)
    quality = record.part_quality
    if quality is not None:
        deviation.plot([quality["gouge_x_mm"]], [-quality["gouge_mm"]], "rv",
                       label=f"deepest gouge {quality['gouge_mm']:.3f} mm")
    last = record.contours[max(record.contours)][0]
    worst = float(np.max(np.abs(last.z_mm - last.parent_mm))) if len(record.contours) > 1 else TOLERANCE_MM
    deviation.set_ylim(-max(worst, 2 * TOLERANCE_MM) * 1.2, max(worst, 2 * TOLERANCE_MM) * 1.2)
    deviation.set_xlabel("x along the bead (mm)")
    deviation.set_ylabel("above the parent (mm)")
    deviation.legend(fontsize=8, ncol=3)
    save(fig, path, dpi=100)


def _plot_force(record: JobRecord, path: Path) -> None:
    if not record.force:
        return
    force = np.asarray(record.force)
    fig, ax = plt.subplots(figsize=(11, 4.5))
    ax.plot(force[:, 0], force[:, 1], lw=0.5, color="tab:blue", label="measured (sensor)")
    for index, (start, t, f) in sorted(record.trajectories.items()):
        ax.plot(start + np.asarray(t), f, lw=1.2, color="tab:red", label="desired" if index == 0 else None)
    ax.set_xlabel("plant time (s)")
    ax.set_ylabel("normal force (N)")
    ax.set_title("Force tracking over the job")
    ax.legend()
    save(fig, path, dpi=100)


def _plot_specific_energy(record: JobRecord, path: Path) -> None:
    rows = specific_energy_by_pass(record)
    if not rows:
        return
    k, measured, predicted, drift = (np.array(column, dtype=float) for column in zip(*rows))
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(k, measured, "o", color="tab:blue", label="measured on the pass (grinder energy / scanned volume)")
    ax.plot(k + 1, predicted, "s-", color="tab:red", label="predicted after the pass before (planned with)")
    ax.set_xlabel("pass")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("specific energy K1 (J/mm³)")
    ax.set_title("The disk's K1 per pass and the pass-rate predictor's estimate")
    ax.legend(fontsize=8, loc="upper left")
    if np.isfinite(drift).any():
        odds = ax.twinx()
        odds.bar(k + 0.5, drift, width=0.3, color="tab:gray", alpha=0.4, label="P(the disk dulls) after pass k")
        odds.axhline(0.5, color="tab:gray", ls=":", lw=0.8)
        odds.set_ylim(0.0, 1.0)
        odds.set_ylabel("P(the disk dulls)")
        odds.legend(fontsize=8, loc="lower right")
    save(fig, path, dpi=100)


def strut_figure(record: JobRecord):
    """Every joint of the machine over the job (mm), labelled with the plant's joint names."""
    struts = np.asarray(record.struts)
    fig, ax = plt.subplots(figsize=(11, 4.5))
    names = record.strut_names or [f"strut_{k}" for k in range(struts.shape[1] - 1)]
    for k, name in enumerate(names, start=1):
        ax.plot(struts[:, 0], struts[:, k] * 1000.0, lw=1.0, label=name)
    ax.set_xlabel("plant time (s)")
    ax.set_ylabel("length / position (mm)")
    ax.set_title("Strut lengths (and the feed stage's position, on the 3-PRU)")
    ax.legend(fontsize=8, ncol=3)
    return fig


def _plot_struts(record: JobRecord, path: Path) -> None:
    if record.struts:
        save(strut_figure(record), path, dpi=100)
