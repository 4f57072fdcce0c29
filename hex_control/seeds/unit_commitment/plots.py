"""Figures of the unit-commitment examples (PNG): the table's cost against its levels, a
day's stacked generation with the store, and the on-line cost increase per load model."""

from __future__ import annotations

import numpy as np

from hex_control.plotting import plt, save
from hex_control.seeds.unit_commitment.dispatch import dispatch_hours
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.table import TableRow, commitment_class


def plot_table(path, fleet: Fleet, rows: list[TableRow]) -> None:
    """Fig. 2 as a picture: per level the cheapest and the K-th cost per MWh, with a mark
    wherever the cheapest commitment changes (rule 4.1's shortened steps)."""
    levels = np.array([row.total_mw for row in rows])
    cheapest = np.array([row.cheapest.cost_per_h for row in rows]) / levels
    last = np.array([row.candidates[-1].cost_per_h for row in rows]) / levels
    units_on = [sum(row.cheapest.on) for row in rows]
    changes = [j for j in range(1, len(rows))
               if commitment_class(fleet, rows[j].cheapest.on) != commitment_class(fleet, rows[j - 1].cheapest.on)]
    fig, (ax, ax_on) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(levels, cheapest, color="C0", lw=1.2, label="cheapest commitment")
    ax.plot(levels, last, color="C1", lw=0.8, label=f"K-th cheapest (K = {max(len(r.candidates) for r in rows)})")
    ax.plot(levels[changes], cheapest[changes], "|", color="C3", ms=10, label="cheapest commitment changes")
    ax.set_ylabel("running cost per MWh")
    ax.set_title(f"Scheduling table of {fleet.name}: {len(rows)} levels (seed 000 part 2, section 4)")
    ax.legend(fontsize="small")
    ax_on.step(levels, units_on, where="post", color="C0")
    ax_on.set_ylabel("units on")
    ax_on.set_xlabel("total generation G (MW)")
    save(fig, path)


def plot_day(path, fleet: Fleet, demand_mw, transfers_mw, commitments, *, title: str) -> None:
    """A day's generation stacked by unit (largest first), the demand and G = L + r, and
    below the store's transfers and stored energy."""
    demand, transfers = np.asarray(demand_mw, float), np.asarray(transfers_mw, float)
    hours = np.arange(demand.size)
    levels = dispatch_hours(fleet.arrays, commitments, demand + transfers)[2]
    order = np.argsort([-u.g_max_mw for u in fleet.units], kind="stable")
    fig, (ax, ax_store) = plt.subplots(2, 1, figsize=(10, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    colours = plt.cm.viridis(np.linspace(0, 1, len(fleet)))
    ax.stackplot(np.append(hours, hours[-1] + 1), np.vstack([levels, levels[-1]]).T[order], step="post",
                 colors=colours, linewidth=0)
    ax.step(np.append(hours, hours[-1] + 1), np.append(demand, demand[-1]), where="post", color="k", lw=1.5,
            label="demand L")
    ax.set_ylabel("generation (MW), one band a unit")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize="small")
    ax_store.bar(hours + 0.5, transfers, width=0.9, color=np.where(transfers >= 0, "C0", "C3"),
                 label="transfer r (+ pumped)")
    ax_store.set_ylabel("r (MW)")
    ax_energy = ax_store.twinx()
    ax_energy.plot(np.arange(demand.size + 1), np.concatenate([[0.0], np.cumsum(transfers)]), color="k", lw=1,
                   label="stored energy change")
    ax_energy.set_ylabel("S(t) - S(0) (MWh)")
    ax_store.set_xlabel("hour")
    ax_store.legend(loc="upper left", fontsize="small")
    save(fig, path)


def plot_online(path, comparisons) -> None:
    """The on-line unit-cost increase per load model, its mean with 2 standard errors,
    over hindsight and over the mean day's plan."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, field, label in zip(axes, ("over_hindsight", "over_plan"),
                                ("over the day's demand known in advance", "over the mean day's plan (the paper's)")):
        for x, comparison in enumerate(comparisons):
            values = 100 * getattr(comparison, field)
            error = 2 * values.std(ddof=1) / np.sqrt(values.size)
            ax.bar(x, values.mean(), yerr=error, color=f"C{x}", capsize=6)
            ax.plot(np.full(values.size, x) + np.linspace(-0.25, 0.25, values.size), values, ".", color="0.3",
                    ms=3)
        ax.set_xticks(range(len(comparisons)), [c.fluctuation.kind.replace("_", "-") for c in comparisons])
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylabel("unit cost increase (%)")
        ax.set_title(label, fontsize="medium")
    fig.suptitle(f"On-line scheduling, fluctuation {100 * comparisons[0].fluctuation.relative_std:.2f} % std "
                 f"({comparisons[0].over_plan.size} days; bars: mean ± 2 SE)")
    save(fig, path)
