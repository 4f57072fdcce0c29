"""Issue 42's grid table from campaign directories: per (variant, machine, bead, deadline) cell
the parts within +-0.1 mm everywhere, the worst highest point, the mean realized charge
against the mean expected J at the start, and the jobs that ended with time for another
pass left but outside the band.

    python scripts/grid_table.py RUNS_DIR [--markdown]

RUNS_DIR holds ``<variant>_<machine>_h<bead mm>_d<deadline s>[_s<seed>]/job_<seed>/job.json``.
Units: mm, s.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections import defaultdict
from pathlib import Path

from hex_control.config import cell_configuration

#: the top feed of the cell (config/cell.yaml), which makes the fastest pass
FEED_MAX_MM_S = cell_configuration().value("process.feed_max_mm_s")
NAME = re.compile(r"(?P<variant>[a-z]+)_(?P<machine>[a-z0-9]+)_h(?P<height>[0-9.]+)_d(?P<deadline>[0-9.]+)(_s\d+)?$")


def jobs(root: Path):
    for directory in sorted(root.iterdir()):
        match = NAME.match(directory.name)
        if not match or not directory.is_dir():
            continue
        for path in sorted(directory.glob("job_*/job.json")):
            job = json.loads(path.read_text())
            if "outcome" not in job:
                continue
            yield (match["variant"], match["machine"], float(match["height"]), float(match["deadline"])), job


def summary(job: dict) -> dict:
    goal, outcome, part = job["goal"], job["outcome"], job["part_quality"]
    shortest_s = goal["bead_length_mm"] / FEED_MAX_MM_S + goal["reset_time_s"]  # the fastest pass
    within = abs(part["highest_mm"]) <= 0.1 and part["gouge_mm"] <= 0.1
    return {"seed": goal["seed"], "within": within, "highest": part["highest_mm"], "charge": outcome["total_charge"],
            "expected": job["expected_penalty_at_start"], "passes": outcome["passes"],
            "time_left": outcome["time_remaining_s"], "x": outcome["material_remaining_mm"],
            "left_time_outside": (not within) and outcome["time_remaining_s"] >= shortest_s,
            # the K1 the plant drew for the job's passes (its jobs' measured K1): a soft seed cuts deep
            "k1": [p["measured_specific_energy_j_mm3"] for p in job["passes"] if "measured_specific_energy_j_mm3" in p]}


def _mean(values) -> float:
    return sum(values) / len(values) if values else float("nan")


def table(root: Path) -> list[dict]:
    cells = defaultdict(list)
    for key, job in jobs(root):
        cells[key].append(summary(job))
    rows = []
    for (variant, machine, height, deadline), items in sorted(cells.items(), key=lambda kv: (kv[0][1], kv[0][2],
                                                                                              kv[0][3], kv[0][0])):
        n = len(items)
        charge = sum(i["charge"] for i in items) / n
        expected = sum(i["expected"] for i in items) / n
        rows.append({"machine": machine, "bead_mm": height, "deadline_s": deadline, "variant": variant, "jobs": n,
                     "seeds": sorted(i["seed"] for i in items), "within": sum(i["within"] for i in items),
                     "worst_highest_mm": max(i["highest"] for i in items), "mean_charge": charge,
                     "mean_expected_j": expected, "charge_over_j": charge / expected if expected > 0 else float("nan"),
                     "ended_early_outside": sum(i["left_time_outside"] for i in items),
                     "mean_k1": _mean([k for i in items for k in i["k1"]])})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path)
    args = parser.parse_args(argv)
    if not args.runs.is_dir():
        print(f"no directory {args.runs}", file=sys.stderr)
        return 2
    print("| machine | bead mm | deadline s | code | jobs (seeds) | within +-0.1 mm | worst highest mm | "
          "mean charge | mean J at start | charge / J | ended with a pass's time left, outside | mean K1 measured |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in table(args.runs):
        seeds = ",".join(str(s) for s in r["seeds"])
        print(f"| {r['machine']} | {r['bead_mm']:g} | {r['deadline_s']:g} | {r['variant']} | {r['jobs']} ({seeds}) | "
              f"{r['within']}/{r['jobs']} | {r['worst_highest_mm']:+.3f} | {r['mean_charge']:.4f} | "
              f"{r['mean_expected_j']:.4f} | {r['charge_over_j']:.2f} | {r['ended_early_outside']} | "
              f"{r['mean_k1']:.2f} |")
    print()
    print("| machine | bead mm | code | jobs | mean charge | mean J at start | charge / J |")
    print("|---|---|---|---|---|---|---|")
    rows = defaultdict(list)
    for key, job in jobs(args.runs):
        variant, machine, height, _ = key
        rows[(machine, height, variant)].append(summary(job))
    for (machine, height, variant), items in sorted(rows.items()):
        charge = sum(i["charge"] for i in items) / len(items)
        expected = sum(i["expected"] for i in items) / len(items)
        print(f"| {machine} | {height:g} | {variant} | {len(items)} | {charge:.4f} | {expected:.4f} | "
              f"{charge / expected:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
