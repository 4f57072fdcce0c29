"""The example day (seed 000 part 2, sections 5-7): a standard-shaped daily demand scaled
to a fleet, and a pumped-hydro store scaled to that demand (``config/unit_commitment/
day.yaml`` says where the shape comes from and why the numbers).

Units: MW (an hour's mean demand), MWh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import yaml

from hex_control.config import config_path
from hex_control.seeds.unit_commitment.fleet import Fleet
from hex_control.seeds.unit_commitment.storage import Storage


@dataclass(frozen=True)
class ExampleDay:
    demand_mw: np.ndarray  # (24,) hour by hour
    storage: Storage


def example_day(fleet: Fleet, source="day.yaml") -> ExampleDay:
    """The configured day for ``fleet``: the shape times peak fraction times capacity."""
    path = config_path(source, "unit_commitment")
    data = yaml.safe_load(path.read_text())
    shape = np.asarray(data["shape_percent_of_peak"], float) / 100.0
    if shape.ndim != 1 or shape.size < 2 or not np.all(shape > 0) or shape.max() != 1.0:
        raise ValueError(f"{path}: the shape is positive percentages of a peak of 100, got {shape * 100}")
    peak_mw = float(data["peak_fraction_of_capacity"]) * fleet.capacity_mw[1]
    store = data["storage"]
    rate_mw = float(store["rate_fraction_of_peak"]) * peak_mw
    capacity_mwh = float(store["hours_at_full_rate"]) * rate_mw
    storage = Storage(-rate_mw, rate_mw, 0.0, capacity_mwh, float(store["start_fraction_full"]) * capacity_mwh)
    return ExampleDay(shape * peak_mw, storage)
