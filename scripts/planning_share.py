"""The share of a ``hexctl demo`` job's wall time spent planning passes (issue 39), from its
node logs: ``python scripts/planning_share.py OUTPUT_DIR [...]`` (a demo's --output, or one
job's directory of a --jobs run)."""

import sys
from pathlib import Path

from hex_control.bench.grinding import planning_share

if __name__ == "__main__":
    for directory in sys.argv[1:] or ["."]:
        figures = planning_share(Path(directory))
        per_pass = ", ".join(f"{k}: {s:.2f}" for k, s in sorted(figures["planning_s"].items()))
        planning_s = sum(figures["planning_s"].values())
        print(f"{directory}: planning {planning_s:.1f} s of the job's {figures['job_s']:.1f} s wall = "
              f"{figures['share']:.1%} (per pass, s: {per_pass})")
