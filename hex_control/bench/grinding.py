"""Benchmarks of the pass planner (issue 39 item 1), each against the old code path kept in
the same process (``grinding.contact_reference``: the whole-face contact search and the
whole-contour truncation with np.unique / np.isin at every step; no warm start).

- ``pass``: one 150 mm pass simulated at the default resolution, also with the contact
  kernel in Python instead of compiled (``grinding/_contact_c.c``).
- ``search-start``: where a job's first guarded search starts (the pass planner's
  ``search_start``), calibrated on cold searches, and what it saves on other beads.
- ``pass-planning``: the demo's job replayed without ROS: ``hexctl demo``'s bead (300 mm,
  1 mm, seed 0) and its six pass commands (depth, feed, K1 as the sequence planner sent
  them on 2026-12-06), each planned by the pass planner's core and executed under force
  control on the contour the last pass left, once with the old path (its contours grow by
  about 6000 points a pass, as the plant's scans did) and once with the new one.

``planning_share`` reads a ``hexctl demo`` run's node logs: the share of the job's wall time
between the first pass command and the job's end spent planning (in lock-step the plant's
clock stands still meanwhile); ``python scripts/planning_share.py DIR`` prints it.
"""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path
from unittest import mock

from hex_control.bench import benchmark, best_time
from hex_control.grinding import contact
from hex_control.grinding.contact import contact_patch_scan
from hex_control.grinding.contact_reference import contact_patch_reference
from hex_control.grinding.contour import final_contour, weld_bead
from hex_control.grinding.dynamic import DiskModel, ForceSchedule, HeightControl, simulate_pass

#: ``hexctl demo`` (seed 0, 300 mm bead, deadline 100 s), 2026-12-06: the pass commands
#: (cut depth mm, feed mm/s, K1 J/mm^3, normal force N) in the pass planner's log
DEMO_JOB = ((0.5195, 10.24, 10.0, 60.0), (0.3026, 14.09, 10.0634, 49.9), (0.0767, 56.66, 9.86558, 49.9),
            (0.0733, 56.66, 10.3288, 49.9), (0.0661, 56.66, 10.2018, 45.3), (0.0234, 56.66, 9.74587, 20.5))


@benchmark("pass")
def pass_speed(quick: bool) -> list[str]:
    model = DiskModel()
    bead = weld_bead(150.0, 3.0, ripple_mm=0.15, seed=3)
    target = final_contour(bead, 0.4, model.process.bead_width_mm)

    def run(search=None):
        drive = HeightControl(model, bead.x_mm, target.tip_mm, bead.x_mm[0])
        return simulate_pass(bead, model, drive, 10.0, step_mm=0.1, contact_search=search)

    def in_python():
        with mock.patch.object(contact, "_compiled", None):
            return run()

    steps = run().history["time_s"].size
    fast = best_time(run, repeat=1 if quick else 3)
    python = best_time(in_python, repeat=1 if quick else 3)
    old = best_time(lambda: run(contact_patch_reference), repeat=1 if quick else 3)
    naive = best_time(lambda: run(contact_patch_scan), repeat=1)
    kernel = "compiled" if contact._compiled is not None else "in Python: _contact_c not built"
    return [f"150 mm pass at 10 mm/s, 0.1 mm steps ({steps} steps, 4 contact searches each), contact kernel "
            f"{kernel}: {fast:.3f} s (target < 0.5 s), {steps / fast:.0f} steps/s",
            f"the same kernel in Python: {python:.3f} s, ratio {python / fast:.1f}x",
            f"old kernel (whole-face search, whole-contour truncation): {old:.3f} s, ratio {old / fast:.1f}x",
            f"naive whole-contour contact search: {naive:.3f} s, ratio {naive / fast:.1f}x"]


def replay_demo_job(passes: int, *, baseline: bool) -> list[dict]:
    """The demo's job through the pass planner's core (module docstring): per pass the
    planning's wall and CPU time (s), its simulations, the scan's points, the depth planned."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.pass_session import PassRequest, PassSession, Scan

    config = load_pass_planner_config("pass_planner.yaml")
    search = contact_patch_reference if baseline else None
    session = PassSession(config, contact_search=search, warm_start=not baseline)
    contour = weld_bead(300.0, 1.0, 12.0, ripple_mm=0.05, seed=0)
    rows = []
    for k, (depth, feed, k1, force) in enumerate(DEMO_JOB[:passes]):
        session.planning = request = PassRequest("bench", k, depth, feed, k1, force)
        wall, cpu = time.perf_counter(), time.process_time()
        planned = session.plan(request, Scan("bench", k, 0.0, 0.0, contour))
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        session.planned(planned, 0.0)
        plan = planned.plan
        rows.append({"wall_s": wall, "cpu_s": cpu, "simulations": plan.simulations, "points": contour.x_mm.size,
                     "planned_mm": plan.planned_depth_mm})
        process = dataclasses.replace(config.model.process, specific_energy_j_mm3=k1)
        model = dataclasses.replace(config.model, process=process)
        # executed as pass_plan.execute_plan does, from the force plan's histories
        drive = ForceSchedule(model, plan.centre_x_mm, plan.height_mm, plan.force_n, model.relaxed_angle_rad)
        step_mm = min(0.05, feed * model.approach_time_constant_s / 4)
        contour = simulate_pass(contour, model, drive, feed, step_mm=step_mm, contact_search=search).final
    return rows


@benchmark("pass-planning")
def pass_planning(quick: bool) -> list[str]:
    passes = 3 if quick else len(DEMO_JOB)
    old = replay_demo_job(passes, baseline=True)
    new = replay_demo_job(passes, baseline=False)
    lines = [f"the demo's job without ROS ({passes} passes, 300 mm bead): planning CPU time per pass (less load-"
             "sensitive than wall), old path -> new"]
    for k, (a, b) in enumerate(zip(old, new)):
        depth, feed = DEMO_JOB[k][:2]
        lines.append(f"pass {k} ({depth:.4f} mm at {feed:.2f} mm/s): {a['cpu_s']:.2f} CPU s ({a['simulations']} sim, "
                     f"{a['points']} scan points) -> {b['cpu_s']:.2f} ({b['simulations']} sim, {b['points']} pts), "
                     f"{a['cpu_s'] / b['cpu_s']:.1f}x; planned {a['planned_mm']:.4f} -> {b['planned_mm']:.4f} mm")
    total = {name: {key: sum(r[key] for r in rows) for key in ("wall_s", "cpu_s", "simulations")}
             for name, rows in (("old", old), ("new", new))}
    lines.append(f"job: {total['old']['wall_s']:.2f} s wall ({total['old']['cpu_s']:.2f} CPU s, "
                 f"{total['old']['simulations']} simulations) -> {total['new']['wall_s']:.2f} s wall "
                 f"({total['new']['cpu_s']:.2f} CPU s, {total['new']['simulations']} simulations): "
                 f"{total['old']['wall_s'] / total['new']['wall_s']:.1f}x; per simulation "
                 f"{total['old']['cpu_s'] / total['old']['simulations']:.2f} -> "
                 f"{total['new']['cpu_s'] / total['new']['simulations']:.2f} CPU s")
    return lines


#: the first guarded searches ``search-start`` calibrates on (demo-like beads: 60 mm, end ramps
#: 12 mm, ripple 0.05 mm; each asked the depth F_max cuts at its feed) and checks on
SEARCH_START_BEADS = tuple((height, seed) for height in (0.8, 1.0) for seed in range(4))
SEARCH_START_HELD_OUT = ((0.9, 5), (1.2, 6), (0.7, 7), (1.0, 8))
SEARCH_START_FEEDS = (8.0, 12.0, 18.0)


def first_searches(beads, feeds, start=None) -> list:
    """Plans of each bead's first pass at F_max's depth for each feed (mm/s), their searches
    started at ``start`` (None: cold); shipped pass planner config."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.pass_plan import plan_pass

    config = load_pass_planner_config("pass_planner.yaml")
    process = config.model.process
    return [plan_pass(weld_bead(60.0, height, 12.0, ripple_mm=0.05, seed=seed), config.model,
                      float(process.cut_depth_mm(process.force_max_n, feed)), feed, config.control,
                      step_mm=config.step_mm, gains=config.gains, warm_start=start)
            for height, seed in beads for feed in feeds]


@benchmark("search-start")
def search_start(quick: bool) -> list[str]:
    """The pass planner's ``search_start`` (a job's first guarded search starts there): the
    typical end of cold first searches, and what starting there saves on beads it was not
    taken from."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.pass_plan import typical_search_start

    feeds = SEARCH_START_FEEDS[::2] if quick else SEARCH_START_FEEDS
    cold = first_searches(SEARCH_START_BEADS[:4] if quick else SEARCH_START_BEADS, feeds)
    typical = typical_search_start([plan.warm_start for plan in cold if plan.warm_start])
    shipped = load_pass_planner_config("pass_planner.yaml").search_start
    held_cold = first_searches(SEARCH_START_HELD_OUT, feeds)
    held_warm = first_searches(SEARCH_START_HELD_OUT, feeds, shipped)
    removed = sum(w.planned_depth_mm for w in held_warm) / sum(c.planned_depth_mm for c in held_cold)
    return [f"{len(cold)} cold first searches end at a typical {typical.family} guess scale "
            f"{typical.guess_scale:.3f}, intercept {typical.intercept_load:.3f} (shipped: {shipped})",
            f"{len(held_cold)} first passes on other beads: {sum(p.simulations for p in held_cold)} simulations "
            f"cold, {sum(p.simulations for p in held_warm)} from the shipped start; "
            f"depth planned {removed:.3f}x the cold searches'"]


_STAMP = r"\[(?:INFO|WARN|ERROR)\] \[(\d+\.\d+)\]"


def planning_share(output: Path) -> dict:
    """From a ``hexctl demo`` run's logs (``output/logs``, or ``output/job_NNN/logs``):
    each pass's planning (s of wall time from the pass planner's "pass k ...: cut" line to its
    "planned"/"refused" line), the job's wall time from the first command to the sequence
    planner's "ended" line, and the share planning took."""
    logs = Path(output) / "logs"
    planner = (logs / "pass_planner.log").read_text()
    received = {m.group(2): float(m.group(1)) for m in re.finditer(_STAMP + r" \[pass_planner\]: pass (\d+) of job "
                                                                           r"'[^']*': cut", planner)}
    done = {m.group(2): float(m.group(1)) for m in re.finditer(_STAMP + r" \[pass_planner\]: pass (\d+) of job "
                                                                       r"'[^']*' (?:planned|refused)", planner)}
    ended = re.search(_STAMP + r" \[sequence_planner\]: job \S+ ended", (logs / "sequence_planner.log").read_text())
    if not received or ended is None:
        raise ValueError(f"{logs}: no pass command or no job end in the logs")
    planning = {int(k): done[k] - received[k] for k in received if k in done}
    job_s = float(ended.group(1)) - min(received.values())
    return {"planning_s": planning, "job_s": job_s, "share": sum(planning.values()) / job_s}
