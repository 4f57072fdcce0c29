"""The workpiece as last scanned, kept on disk: the part stays on the machine when the
plant's process stops, so a restarted plant (or ``hexctl demo --resume``) carries on
grinding the part the job left, not a fresh bead.

What is kept is what the scanner last saw: the profile after ``passes`` passes of job
``job_id``, and that pass's result (its message's fields), which the plant reports again
on start-up in case nobody had taken it in. A pass that was running when the process
stopped is lost with it: its grinding was never scanned; the file says which one it was
(``started``: job id, pass index and the plant time its path began, written when it
begins), so the plant after the restart reports that plan, if it runs it, as having run
across the restart. The file is replaced atomically,
so a crash leaves the previous scan or the new one, never half of one.

Units: mm.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from hex_control.grinding.contour import Contour


@dataclass(frozen=True)
class StoredWorkpiece:
    job_id: str  # '' before any job
    passes: int  # passes ground on the part, as its scan's pass index
    contour: Contour
    last_result: dict | None = None  # the last pass's PassResult, field by field
    started: tuple[str, int, float] | None = None  # a pass begun on the part and not yet scanned

    def __post_init__(self):
        if not isinstance(self.passes, int) or self.passes < 0:
            raise ValueError(f"passes must be a whole number >= 0, got {self.passes!r}")
        if self.started is not None:
            job_id, pass_index, path_start_s = self.started
            object.__setattr__(self, "started", (str(job_id), int(pass_index), float(path_start_s)))


def save_workpiece(path, workpiece: StoredWorkpiece) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    c = workpiece.contour
    document = {"job_id": workpiece.job_id, "passes": workpiece.passes, "x_mm": c.x_mm.tolist(),
                "z_mm": c.z_mm.tolist(), "parent_mm": c.parent_mm.tolist(), "last_result": workpiece.last_result,
                "started": list(workpiece.started) if workpiece.started is not None else None}
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(document))
    os.replace(partial, path)


def load_workpiece(path) -> StoredWorkpiece | None:
    """The stored part, None if there is none; ValueError naming the file if it is not one."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        d = json.loads(path.read_text())
        started = d.get("started")
        return StoredWorkpiece(str(d["job_id"]), d["passes"], Contour(d["x_mm"], d["z_mm"], d["parent_mm"]),
                               d.get("last_result"), tuple(started) if started is not None else None)
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path} is not a stored workpiece: {exc}") from None
