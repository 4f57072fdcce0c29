"""What the live view of a cell (``hexctl view``, :mod:`hex_control.ros.app.foxglove_view`)
keeps and sends, without ROS: the cell's sim time as far as heard, the pass table, the
contours to draw, and each message's bounded share of a telemetry batch or a contour.

Every batch and contour is cut to ``MAX_OUTLINE_POINTS`` evenly spaced points (the ends
kept), so the work per message and per second's republish stays bounded whatever arrives.
Units: mm, N, s; times in ns of the cell's sim time.
"""

from __future__ import annotations

import math

from hex_control.grinding.bead_outline import MAX_CONTOUR_POINTS, MAX_OUTLINE_POINTS, spaced_indices


def seconds_to_ns(seconds: float) -> int:
    """A sim time (s) in ns; a negative one as 0."""
    return max(0, round(seconds * 1e9))


def json_number(value: float):
    """JSON has no NaN: None instead."""
    return float(value) if math.isfinite(value) else None


def contour_refusal(x_points: int, z_points: int, parent_points: int) -> str | None:
    """Why a contour of these lengths is not drawn (beyond the pass planner's limit, or its
    arrays unlike), or None."""
    if x_points == z_points <= MAX_CONTOUR_POINTS and parent_points in (0, x_points):
        return None
    return f"contour of {x_points} points refused (at most {MAX_CONTOUR_POINTS}, x, z and parent alike)"


def force_samples(time_s, force_n) -> list[tuple[int, float | None]]:
    """A telemetry batch's force plot: (ns, N; NaN as None) at most MAX_OUTLINE_POINTS times,
    none past the end of a short ``force_n``."""
    return [(seconds_to_ns(time_s[k]), json_number(force_n[k]))
            for k in spaced_indices(len(time_s), MAX_OUTLINE_POINTS).tolist() if k < len(force_n)]


def contour_points(x_mm, z_mm, parent_mm) -> dict:
    """A contour's plot: x, z and (if given) parent at most MAX_OUTLINE_POINTS points (mm)."""
    keep = spaced_indices(len(x_mm), MAX_OUTLINE_POINTS).tolist()
    return {"x_mm": [x_mm[i] for i in keep], "z_mm": [z_mm[i] for i in keep],
            "parent_mm": [parent_mm[i] for i in keep] if len(parent_mm) else []}


class LiveView:
    """The view's state between messages: the sim time heard (ns, never backwards), the pass
    table by (job, pass), the first and the latest contour (any object with ``pass_index``)."""

    def __init__(self):
        self.time_ns = 0
        self.rows: dict[tuple[str, int], dict] = {}
        self.first_contour = self.last_contour = None

    def heard(self, ns: int) -> None:
        self.time_ns = max(self.time_ns, int(ns))

    def contour(self, contour) -> None:
        """Keep ``contour`` as the latest, and as the first if none is or it is pass 0's."""
        if self.first_contour is None or contour.pass_index == 0:
            self.first_contour = contour
        self.last_contour = contour

    def row(self, job_id: str, pass_index: int, values: dict) -> None:
        """Fold ``values`` (numbers JSON-safe, NaN as None) into the row of (job, pass)."""
        row = self.rows.setdefault((job_id, pass_index), {"job": job_id, "pass": pass_index})
        row.update({k: json_number(v) if isinstance(v, float) else v for k, v in values.items()})

    def table(self) -> dict:
        return {"rows": [self.rows[key] for key in sorted(self.rows)]}
