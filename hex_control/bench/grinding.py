"""Benchmark of the pass planner (issue target: one 150 mm pass at the default resolution
simulated in under 0.5 s), against the naive contact search that scans the whole contour
at every evaluation."""

from __future__ import annotations

from hex_control.bench import benchmark, best_time
from hex_control.grinding.contact import contact_patch_scan
from hex_control.grinding.contour import final_contour, weld_bead
from hex_control.grinding.dynamic import DiskModel, HeightControl, simulate_pass


@benchmark("pass")
def pass_speed(quick: bool) -> list[str]:
    model = DiskModel()
    bead = weld_bead(150.0, 3.0, ripple_mm=0.15, seed=3)
    target = final_contour(bead, 0.4, model.process.bead_width_mm)

    def run(search=None):
        drive = HeightControl(model, bead.x_mm, target.tip_mm, bead.x_mm[0])
        extra = {} if search is None else {"contact_search": search}
        return simulate_pass(bead, model, drive, 10.0, step_mm=0.1, **extra)

    steps = run().history["time_s"].size
    fast = best_time(run, repeat=1 if quick else 3)
    naive = best_time(lambda: run(contact_patch_scan), repeat=1)
    return [f"150 mm pass at 10 mm/s, 0.1 mm steps ({steps} steps, 4 contact searches each): "
            f"{fast:.3f} s (target < 0.5 s), {steps / fast:.0f} steps/s",
            f"naive whole-contour contact search: {naive:.3f} s, ratio {naive / fast:.1f}x"]
