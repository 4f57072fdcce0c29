"""``hexctl chatter``: the chatter study of seed 004 section 3 written to a folder: the
programme table (Fig. 2-3), the stability-lobe check, their PNGs and a JSON summary."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from hex_control.seeds.milling.case import ChatterCase
from hex_control.seeds.milling.lobes import chatter_frequency, depth_limit, stability_lobes
from hex_control.seeds.milling.plots import plot_lobes, plot_programmes, plot_spectra
from hex_control.seeds.milling.report import compare_programmes, programme_table
from hex_control.seeds.milling.semi_discretization import critical_depth, spectral_radius


def zero_order_lobes(case: ChatterCase):
    """The case's zero-order lobes over 0.7-1.5 x the first natural frequency."""
    f1 = case.modes.omega_rad_s[0] / (2 * math.pi)
    cut = case.cut
    return stability_lobes(case.modes.tip_frf, cut.teeth, cut.cutting_pressure_pa, cut.force_ratio, cut.start_rad,
                           exit_rad=cut.exit_rad, chatter_hz=np.linspace(0.7 * f1, 1.5 * f1, 6000), lobes=range(8))


def lobe_check(case: ChatterCase) -> dict:
    """At the two reference speeds: both methods' limits, the chosen depth against them."""
    lobes = zero_order_lobes(case)
    rows = {}
    for speed in (case.low_rpm, case.high_rpm):
        zero_order = float(depth_limit(lobes, speed)[0])
        rows[f"{speed:.0f}"] = {
            "zero_order_limit_m": zero_order,
            "semi_discretization_limit_m": critical_depth(case.modes, case.cut, speed, 0.5 * zero_order,
                                                          2.0 * zero_order),
            "spectral_radius_at_chosen_depth": spectral_radius(case.modes, case.cut, speed),
            "lobe_chatter_hz": chatter_frequency(lobes, speed)}
    return rows


def write_study(output, case: ChatterCase | None = None, progress=None) -> dict:
    """Run every programme and the lobe check; write chatter_*.png and chatter.json.
    ``progress(step)`` is called after each programme and after the lobe sweep."""
    case = case or ChatterCase.from_yaml()
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    results = compare_programmes(case, progress=progress)
    plot_spectra(output / "chatter_spectra.png", results, case.settle_s, case.chatter_band_hz)
    plot_programmes(output / "chatter_programmes.png", results)
    lobes = zero_order_lobes(case)
    speeds = np.linspace(10000, 30000, 801)
    boundary = depth_limit(lobes, speeds)
    checked = [(s, critical_depth(case.modes, case.cut, s, 0.3 * b, 3.0 * b))
               for s, b in zip(speeds[::80], boundary[::80]) if np.isfinite(b)]
    if progress:
        progress("lobes")
    operating = [(s, case.cut.depth_m, f"{s:.0f}") for s in (case.low_rpm, case.high_rpm)]
    plot_lobes(output / "chatter_lobes.png", lobes, speeds, boundary, checked, operating=operating)
    base = results[0]
    summary = {
        "first_mode_hz": float(case.modes.omega_rad_s[0] / (2 * math.pi)),
        "depth_m": case.cut.depth_m,
        "programmes": {r.name: {"rms_m": r.rms_m, "chatter_peak_m": r.chatter_peak_m, "chatter_hz": r.chatter_hz,
                                "max_amplitude_m": r.max_amplitude_m, "energy_m2_s": r.energy_m2_s,
                                "speed_range_rpm": list(r.speed_range_rpm),
                                "rms_percent_of_reference": 100 * r.rms_m / base.rms_m,
                                "peak_percent_of_reference": 100 * r.chatter_peak_m / base.chatter_peak_m,
                                "max_amplitude_percent_of_reference": 100 * r.max_amplitude_m / base.max_amplitude_m,
                                "energy_percent_of_reference": 100 * r.energy_m2_s / base.energy_m2_s}
                       for r in results},
        "table": programme_table(results),
        "lobes": lobe_check(case),
        "semi_discretization_vs_zero_order": [
            {"speed_rpm": float(s), "semi_discretization_m": float(d),
             "zero_order_m": float(depth_limit(lobes, s)[0])} for s, d in checked],
    }
    (output / "chatter.json").write_text(json.dumps(summary, indent=1))
    return summary
