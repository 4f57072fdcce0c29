"""Seed 004 Fig. 2-3 as numbers: each spindle programme's displacement spectrum, its chatter
peak and its RMS displacement along x_e2 (the y axis here, normal to the feed), relative to
constant 15 000 rev/min. Two time-domain measures besides: the largest amplitude (a spectral
peak also falls when a varying speed spreads the chatter over more frequencies, the
amplitude does not) and the energy over the window, int (y - mean)^2 dt."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.seeds.milling.case import ChatterCase
from hex_control.seeds.milling.simulation import MillingRecord, MillingSimulator


def displacement_spectrum(record: MillingRecord, settle_s: float, axis: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(frequency Hz, single-sided amplitude m) of the tip deflection after ``settle_s``,
    mean removed, Hann window (amplitude-corrected)."""
    y = record.deflection_m[record.time_s >= settle_s, axis]
    y = y - y.mean()
    window = np.hanning(y.size)
    return np.fft.rfftfreq(y.size, record.step_s), 2 * np.abs(np.fft.rfft(y * window)) / window.sum()


@dataclass(frozen=True)
class ProgrammeResult:
    name: str
    rms_m: float
    chatter_peak_m: float
    chatter_hz: float
    max_amplitude_m: float
    energy_m2_s: float
    speed_range_rpm: tuple[float, float]
    record: MillingRecord


def run_programme(case: ChatterCase, name: str, programme) -> ProgrammeResult:
    record = MillingSimulator(case.modes, case.cut, case.step_s).run(programme, case.duration_s)
    frequency, amplitude = displacement_spectrum(record, case.settle_s)
    band = (frequency >= case.chatter_band_hz[0]) & (frequency <= case.chatter_band_hz[1])
    peak = int(np.argmax(np.where(band, amplitude, -1.0)))
    y = record.deflection_m[record.time_s >= case.settle_s, 1]
    y = y - y.mean()
    return ProgrammeResult(name, float(np.std(y)), float(amplitude[peak]), float(frequency[peak]),
                           float(np.abs(y).max()), float(np.sum(y ** 2) * record.step_s),
                           (float(record.speed_rpm.min()), float(record.speed_rpm.max())), record)


def compare_programmes(case: ChatterCase, names=None, progress=None) -> list[ProgrammeResult]:
    """Every programme of the case (or ``names``); ``progress(name)`` after each run."""
    programmes = case.programmes()
    results = []
    for name in names or programmes:
        results.append(run_programme(case, name, programmes[name]))
        if progress:
            progress(name)
    return results


def programme_table(results: list[ProgrammeResult], reference: str = "constant 15000") -> str:
    """The per-programme table: RMS, chatter peak, largest amplitude and energy, each also in %
    of the reference (Fig. 3's way)."""
    base = next(r for r in results if r.name == reference)
    lines = [f"{'programme':28s} {'speed rev/min':>15s} {'RMS um':>7s} {'%':>4s} {'peak um':>7s} {'%':>4s} "
             f"{'at Hz':>6s} {'max um':>7s} {'%':>4s} {'energy':>6s}"]
    for r in results:
        lines.append(f"{r.name:28s} {r.speed_range_rpm[0]:7.0f}-{r.speed_range_rpm[1]:<7.0f} {r.rms_m * 1e6:7.2f} "
                     f"{100 * r.rms_m / base.rms_m:4.0f} {r.chatter_peak_m * 1e6:7.2f} "
                     f"{100 * r.chatter_peak_m / base.chatter_peak_m:4.0f} {r.chatter_hz:6.1f} "
                     f"{r.max_amplitude_m * 1e6:7.2f} {100 * r.max_amplitude_m / base.max_amplitude_m:4.0f} "
                     f"{100 * r.energy_m2_s / base.energy_m2_s:5.0f}%")
    return "\n".join(lines)
