"""Policy maps of the sequence planner, counterparts of seed 002 Fig. 5-23 and 5-36 (PNG)."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import ListedColormap

from hex_control.grinding.sdp import GRIND, QUIT, Policy
from hex_control.plotting import plt, save


def _window(ax, policy: Policy, values, title, label, *, cmap="viridis", trajectory=None):
    extent = (policy.material_mm[0], policy.material_mm[-1], policy.time_s[0], policy.time_s[-1])
    image = ax.imshow(values, origin="lower", aspect="auto", extent=extent, cmap=cmap, interpolation="nearest")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("material remaining (mm)")
    ax.set_ylabel("time remaining (s)")
    ax.set_title(title)
    plt.colorbar(image, ax=ax, label=label)
    if trajectory is not None and len(trajectory):
        path = np.asarray(trajectory)
        ax.plot(path[:, 1], path[:, 0], "o-", color="red", ms=3, lw=1.2)


def plot_policy_map(path, policy: Policy, trajectory=None) -> None:
    """Four windows as in Fig. 5-23: feed, normal force, cut fraction, optimal penalty.
    ``trajectory`` (optional): (time, material) points of a job, drawn on every window."""
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    _window(axes[0, 0], policy, policy.feed_mm_s, "optimal feed speed", "V_f (mm/s)", trajectory=trajectory)
    _window(axes[0, 1], policy, policy.force_n, "optimal normal force", "F_N (N)", trajectory=trajectory)
    _window(axes[1, 0], policy, np.clip(policy.cut_fraction, 0, 1), "cut fraction delta/X", "fraction",
            trajectory=trajectory)
    _window(axes[1, 1], policy, policy.penalty, "optimal expected penalty J", "J", cmap="magma",
            trajectory=trajectory)
    fig.suptitle("Grinding sequence policy (seed 002 Fig. 5-23 counterpart; blank = no pass)")
    save(fig, path, dpi=100)


def plot_action_map(path, policy: Policy) -> None:
    """Wait / grind / quit regions over the state space (Fig. 5-36/5-37 style)."""
    fig, ax = plt.subplots(figsize=(7, 6))
    cmap = ListedColormap(["#dddddd", "#3b75af", "#c03d3e"])
    _window(ax, policy, policy.action.astype(float), "actions: wait (grey), grind (blue), quit (red)",
            "action", cmap=cmap)
    ax.images[0].set_clim(-0.5, 2.5)
    assert GRIND == 1 and QUIT == 2  # the colour map's order
    save(fig, path, dpi=100)
