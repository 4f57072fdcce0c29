"""The pass planner's core (hex_control.grinding.pass_session), without ROS: which command
is planned on which contour, the refusals and their reasons, re-delivery, the reachability
check's outcome, and the part-safety invariant (issue 37 item 1): no plan cuts below the
parent, whatever the command says."""

import dataclasses
import math

import numpy as np
import pytest

from hex_control.grinding.config import load_pass_planner_config
from hex_control.grinding.contour import Contour, weld_bead
from hex_control.grinding.pass_plan import plan_forces
from hex_control.grinding.pass_session import (
    PARENT_TOLERANCE_MM,
    PassRequest,
    PassSession,
    Scan,
    checked_positions,
    material_left_mm,
    parent_dip,
    pass_start_s,
)

CONFIG = load_pass_planner_config("pass_planner.yaml")
BEAD = weld_bead(length_mm=30.0, height_mm=1.0, end_ramp_mm=6.0, ripple_mm=0.05, seed=2)
WIDTH = 12.5


def _request(pass_index=0, depth=0.2, feed=20.0, job="job-a", specific_energy_j_mm3=0.0, *, force=45.0):
    return PassRequest(job, pass_index, depth, feed, specific_energy_j_mm3, force)


def _scan(pass_index=0, contour=BEAD, job="job-a", stamp_s=40.0, error=""):
    return Scan(job, pass_index, stamp_s, WIDTH, contour, error)


def _plan(session, request, scan):
    """Through the session as the node drives it: command, scan, plan, outcome."""
    session.on_scan(scan)
    assert session.on_command(request, 0.0) == []
    ready = session.next_to_plan()
    assert ready == (request, scan)
    return session.planned(session.plan(*ready), 0.0)


def _model(specific_energy_j_mm3=None):
    process = dataclasses.replace(CONFIG.model.process, bead_width_mm=WIDTH, specific_energy_j_mm3=(
        specific_energy_j_mm3 or CONFIG.model.process.specific_energy_j_mm3))
    return dataclasses.replace(CONFIG.model, process=process)


def _direct(contour, depth, feed, specific_energy_j_mm3=None):
    """plan_forces as the node called it before the core (the happy path's reference)."""
    return plan_forces(contour, _model(specific_energy_j_mm3), depth, feed, CONFIG.planner, control=CONFIG.control,
                       gains=CONFIG.gains, step_mm=CONFIG.step_mm, compliance=CONFIG.compliance)


# -- which command on which contour ---------------------------------------------------------

def test_a_command_waits_for_its_contour_and_is_planned_on_it_as_before():
    session = PassSession(CONFIG)
    request = _request(depth=0.1, feed=5.0, specific_energy_j_mm3=15.0)  # within F_max: a level top
    assert session.on_command(request, 0.0) == [] and session.next_to_plan() is None  # no contour yet
    session.on_scan(_scan(pass_index=1))
    assert session.next_to_plan() is None  # not its contour
    session.on_scan(_scan(job="job-b"))
    assert session.next_to_plan() is None  # another job's
    scan = _scan()
    session.on_scan(scan)
    ready = session.next_to_plan()
    assert ready == (request, scan) and session.next_to_plan() is None  # being planned
    verdict = session.planned(session.plan(*ready), 0.0)
    assert not verdict.refused and verdict.counter == "planned" and verdict.reason == "" and verdict.fault is None
    planned = verdict.planned
    reference = _direct(BEAD, 0.1, 5.0, 15.0)  # the command's K1, bit for bit as the node planned it
    for name in ("time_s", "centre_x_mm", "height_mm", "force_n"):
        np.testing.assert_array_equal(getattr(planned.plan, name), getattr(reference, name))
    assert planned.plan.planned_depth_mm == reference.planned_depth_mm == 0.1
    assert planned.contour_s == 40.0 and planned.process.specific_energy_j_mm3 == 15.0
    assert planned.values["planned_cut_depth_mm"] == 0.1 and planned.values["material_left_mm"] == pytest.approx(
        material_left_mm(BEAD))
    assert session.in_hand(request)
    # the path starts start_delay_s after the later of the scan and the node's clock
    assert pass_start_s(40.0, 0.0, 0.6) == pytest.approx(40.6) and pass_start_s(40.0, 50.0, 0.0) == 50.0
    # ... after the scan while the clock is within plan_ahead_s of it (a lock-step plant runs on that far)
    assert pass_start_s(40.0, 40.4, 0.6, 0.4) == pytest.approx(40.6)
    assert pass_start_s(40.0, 40.41, 0.6, 0.4) == pytest.approx(41.01)
    assert pass_start_s(40.0, 40.0, 0.2, 0.4) == pytest.approx(40.6)  # a shaped path not before the plant stands


def test_a_contour_without_a_job_id_serves_any_job():
    session = PassSession(CONFIG)
    session.on_command(_request(job="whatever"), 0.0)
    session.on_scan(_scan(job=""))
    assert session.next_to_plan() is not None


def test_a_command_in_hand_or_answered_is_a_redelivery():
    session = PassSession(CONFIG, check_reach=True)
    request = _request()
    assert not session.in_hand(request)
    session.on_command(request, 0.0)
    assert session.in_hand(request)  # waiting
    session.on_scan(_scan())
    ready = session.next_to_plan()
    assert session.in_hand(request)  # being planned
    assert session.planned(session.plan(*ready), 0.0) is None  # its path is checked first
    assert session.in_hand(request)  # being checked
    assert not session.reach_answer(-1).refused
    assert session.in_hand(request)  # answered
    assert not session.in_hand(_request(pass_index=1)) and not session.in_hand(_request(job="job-b"))


def test_a_waiting_command_is_never_dropped_silently():
    """Issue 21 item 5: each command ends exactly once: the older of two waiting ones is
    refused as superseded, and a late, earlier pass of the same job too."""
    session = PassSession(CONFIG)
    assert session.on_command(_request(pass_index=1), 0.0) == []
    [refused] = session.on_command(_request(pass_index=2), 0.0)
    assert refused.request.pass_index == 1 and refused.counter == "rejected_superseded"
    assert "superseded by pass 2 of job 'job-a'" in refused.reason
    [refused] = session.on_command(_request(pass_index=0), 0.0)  # late, older than 2
    assert refused.request.pass_index == 0 and "superseded by pass 2" in refused.reason
    [refused] = session.on_command(_request(pass_index=0, job="job-b"), 0.0)  # another job supersedes
    assert refused.request.pass_index == 2 and "superseded by pass 0 of job 'job-b'" in refused.reason
    assert session.pending == _request(pass_index=0, job="job-b")
    assert all(session.in_hand(_request(pass_index=k)) for k in (0, 1, 2))


def test_a_stop_is_never_planned_and_ends_the_pass_not_yet_published():
    """Issue 37 item 7: a cancelled job sends the pass in flight again with ``stop``. A stop
    never starts a plan (a restarted planner that never saw the pass must not plan it); a
    pass of its key that waits, is being planned or is being checked ends as stopped (once);
    one already published is left to the force controller."""
    stop = dataclasses.replace(_request(), stop=True)
    fresh = PassSession(CONFIG)
    fresh.on_scan(_scan())
    assert not fresh.in_hand(stop) and fresh.on_command(stop, 0.0) == [] and fresh.next_to_plan() is None
    waiting = PassSession(CONFIG)
    waiting.on_command(_request(), 0.0)
    [verdict] = waiting.on_command(stop, 0.0)
    assert verdict.refused and verdict.counter == "rejected_stopped" and "stopped: job 'job-a' ended" in verdict.reason
    waiting.on_scan(_scan())
    assert waiting.next_to_plan() is None and waiting.in_hand(stop) and waiting.in_hand(_request())
    planning = PassSession(CONFIG)
    planning.on_command(_request(), 0.0)
    planning.on_scan(_scan())
    ready = planning.next_to_plan()
    assert not planning.in_hand(stop) and planning.on_command(stop, 0.0) == []
    assert planning.in_hand(stop)  # a second delivery of the stop is a re-delivery
    verdict = planning.planned(planning.plan(*ready), 0.0)
    assert verdict.refused and verdict.counter == "rejected_stopped"
    assert "while pass 0 was being planned" in verdict.reason
    checking = PassSession(CONFIG, check_reach=True)
    _plan(checking, _request(), _scan())
    [verdict] = checking.on_command(stop, 0.0)
    assert verdict.refused and checking.checking is None
    published = PassSession(CONFIG)
    assert not _plan(published, _request(), _scan()).refused
    assert published.in_hand(stop)  # answered: nothing more to do


def test_a_command_without_its_contour_is_refused_after_contour_wait_s():
    session = PassSession(CONFIG, contour_wait_s=1.0)
    session.on_scan(_scan())
    session.on_command(_request(pass_index=3), 10.0)
    assert session.expired(10.9) is None
    verdict = session.expired(11.1)
    assert verdict.refused and verdict.counter == "rejected_no_contour"
    assert verdict.reason == "no contour for pass 3 (latest: the one after 0 passes)"
    assert session.pending is None and session.expired(20.0) is None
    session.on_command(_request(pass_index=4), 0.0)
    session.scan = None
    assert "(latest: none)" in session.expired(2.0).reason
    busy = PassSession(CONFIG, contour_wait_s=1.0)  # not while another command is being planned
    busy.on_scan(_scan())
    busy.on_command(_request(), 0.0)
    assert busy.next_to_plan() is not None
    busy.on_command(_request(pass_index=1), 0.0)
    assert busy.expired(5.0) is None


@pytest.mark.parametrize("request_, scan, reason", [
    (_request(depth=math.nan), _scan(), "non-finite command"),
    (_request(feed=math.inf), _scan(), "non-finite command"),
    (_request(feed=500.0), _scan(), "feed speed 500.0 mm/s outside [5.0, 75.0]"),
    (_request(feed=4.9), _scan(), "feed speed 4.9 mm/s outside"),
    (_request(specific_energy_j_mm3=1e300), _scan(), "implausible K1"),
    (_request(specific_energy_j_mm3=-1.0), _scan(), "implausible K1"),
    (_request(specific_energy_j_mm3=math.nan), _scan(), "implausible K1"),
    (_request(force=60.1), _scan(), "commanded force 60.1 N outside [0, F_max 60 N]"),
    (_request(force=-1.0), _scan(), "commanded force -1.0 N outside"),
    (_request(force=math.nan), _scan(), "commanded force nan N outside"),
    (_request(depth=-0.1), _scan(), "cut depth must be finite and > 0 mm"),
    (_request(depth=0.0), _scan(), "cut depth must be finite and > 0 mm"),
    (_request(), _scan(contour=None, error="200000 points exceed the limit of 100000"),
     "bad contour: 200000 points exceed the limit of 100000"),
    (_request(), _scan(stamp_s=-1.0), "bad contour: stamp -1.0 s"),
    (_request(), _scan(stamp_s=math.nan), "bad contour: stamp nan s"),
    (_request(), _scan(contour=Contour(BEAD.x_mm, BEAD.parent_mm - 0.01, BEAD.parent_mm)),
     "no material left over the parent on the scan after 0 passes"),
    # a helper's attack (2026-12-07): 1e300 mm over the parent looped for ever in the final
    # contour's search, and a bead of 1e307 mm with a 1e300 mm cut made an infinite plan
    (_request(), _scan(contour=Contour(BEAD.x_mm, BEAD.z_mm, np.full_like(BEAD.x_mm, -1e300))),
     "no level removes"),
    (_request(depth=1e300), _scan(contour=Contour(BEAD.x_mm, BEAD.z_mm * 1e307)), "the plan is not finite"),
])
def test_a_command_that_cannot_be_planned_is_refused_with_a_reason(request_, scan, reason):
    verdict = _plan(PassSession(CONFIG), request_, scan)
    assert verdict.refused and verdict.counter == "rejected_unplannable" and reason in verdict.reason
    assert verdict.fault == ("refused", f"pass 0 of job 'job-a' refused: {verdict.reason}")  # WARN, says why


def test_a_plan_is_refused_or_published_on_the_reachability_answer():
    session = PassSession(CONFIG, contour_wait_s=5.0, check_reach=True)
    assert _plan(session, _request(), _scan()) is None
    request, planned, _ = session.checking
    positions = checked_positions(planned.path)
    assert positions.shape == (len(planned.path.positions_mm[::10]) + 1, 3)
    np.testing.assert_array_equal(positions[-1], planned.path.positions_mm[-1])
    verdict = session.reach_answer(3)
    x, y, z = positions[3]
    assert verdict.refused and verdict.counter == "rejected_unreachable"
    assert verdict.reason == f"path pose ({x:.1f}, {y:.1f}, {z:.1f}) mm (machine frame) is out of the machine's reach"
    # a second command: the service never answers
    session.on_command(_request(pass_index=1), 100.0)
    session.on_scan(_scan(pass_index=1))
    session.planned(session.plan(*session.next_to_plan()), 100.0)
    assert not session.reach_overdue(104.9) and session.reach_overdue(105.1)
    assert session.next_to_plan() is None  # one pass at a time: the next waits for the check
    verdict = session.reach_failed("reachability service /kinematics/test_pose did not answer")
    assert verdict.refused and verdict.counter == "rejected_unchecked" and session.checking is None


# -- the part-safety invariant (issue 37 item 1) ----------------------------------------------

LEFT_HALF_MM = weld_bead(length_mm=30.0, height_mm=0.55, end_ramp_mm=6.0, ripple_mm=0.05, seed=11)


def test_a_forged_deep_command_is_capped_to_the_material_left_and_cuts_nothing_below_the_parent():
    """The attack of issue 37: a command for 2.0 mm at 5 mm/s on a bead with 0.5 mm left.
    Planned as it came (the old planner) its level top lies far below the parent; the core
    caps the cut to the material left and the plan stays on or above the parent."""
    left = material_left_mm(LEFT_HALF_MM)
    assert 0.45 < left < 0.55
    unguarded = _direct(LEFT_HALF_MM, 2.0, 5.0)
    assert parent_dip(unguarded, LEFT_HALF_MM)[0] > 0.3  # what the old planner sent the plant
    verdict = _plan(PassSession(CONFIG), _request(depth=2.0, feed=5.0), _scan(contour=LEFT_HALF_MM))
    assert not verdict.refused
    plan = verdict.planned.plan
    assert plan.planned_depth_mm <= left * (1 + 1e-9)
    assert f"cut depth capped from 2.0000 mm to the {left:.4f} mm left over the parent" in verdict.reason
    assert verdict.fault[0] == "part_safety" and "cut depth capped from 2.0000 mm" in verdict.fault[1]
    values = verdict.planned.values
    assert values["requested_cut_depth_mm"] == 2.0 and values["material_left_mm"] == pytest.approx(left)
    assert values["planned_cut_depth_mm"] == plan.planned_depth_mm
    assert parent_dip(plan, LEFT_HALF_MM)[0] <= PARENT_TOLERANCE_MM
    assert np.min(plan.final.z_mm - plan.final.parent_mm) >= -PARENT_TOLERANCE_MM
    assert np.max(plan.force_n) <= CONFIG.model.process.force_max_n


def test_a_gouge_already_in_the_scan_is_not_the_plans():
    """A scan already 5 um below the parent at one end (an earlier pass's): the plan is
    judged on what it cuts, not refused for what it found."""
    z = BEAD.z_mm.copy()
    z[-1] = BEAD.parent_mm[-1] - 0.005
    gouged = Contour(BEAD.x_mm, z, BEAD.parent_mm)
    verdict = _plan(PassSession(CONFIG), _request(depth=0.1), _scan(contour=gouged))
    assert not verdict.refused and verdict.reason == ""
    assert parent_dip(verdict.planned.plan, gouged)[0] <= PARENT_TOLERANCE_MM


def test_parent_dip_sees_the_final_contour_and_the_tip_path():
    plan = _direct(BEAD, 0.2, 20.0)
    assert parent_dip(plan, BEAD)[0] <= 0.0
    low = dataclasses.replace(plan, tip_z_mm=plan.tip_z_mm.copy())
    i = int(np.searchsorted(low.tip_x_mm, 15.0))
    low.tip_z_mm[i] = np.interp(low.tip_x_mm[i], BEAD.x_mm, BEAD.parent_mm) - 0.05
    dip, at = parent_dip(low, BEAD)
    assert dip == pytest.approx(0.05) and at == pytest.approx(low.tip_x_mm[i])
    final = plan.final
    z = final.z_mm.copy()
    z[100] = final.parent_mm[100] - 0.02
    dip, at = parent_dip(dataclasses.replace(plan, final=Contour(final.x_mm, z, final.parent_mm)), BEAD)
    assert dip == pytest.approx(0.02) and at == final.x_mm[100]


FINISHING = weld_bead(30.0, 0.1, 2.0, ripple_mm=0.05, seed=7)  # a bead nearly ground: steep ends, ripple


@pytest.mark.parametrize("feed", [5.0, 39.5, 75.0])
def test_a_finishing_pass_on_steep_rippled_ends_stays_on_the_parent_at_every_feed(feed):
    """Issue 37 item 5: the last pass (all that is left) on a bead with steep ends and
    ripple: planned as commanded, the simulated pass overshoots 2 um (5 mm/s) to 15 um
    (39.5 mm/s) below the parent; the core plans it over a shape raised by
    that, so it stays within PARENT_TOLERANCE_MM, and the depth it states is what its
    simulation removes, within the search's 2 %."""
    left = material_left_mm(FINISHING)
    assert parent_dip(_direct(FINISHING, left, feed), FINISHING)[0] > PARENT_TOLERANCE_MM
    verdict = _plan(PassSession(CONFIG), _request(depth=left, feed=feed, force=30.0), _scan(contour=FINISHING))
    assert not verdict.refused
    plan = verdict.planned.plan
    assert parent_dip(plan, FINISHING)[0] <= PARENT_TOLERANCE_MM
    removed = WIDTH * (np.trapezoid(FINISHING.z_mm, FINISHING.x_mm) - np.trapezoid(plan.final.z_mm, plan.final.x_mm))
    assert removed / (WIDTH * FINISHING.length_mm) == pytest.approx(plan.planned_depth_mm, rel=0.02)
    assert 0 < verdict.planned.values["shape_raised_mm"] < 0.025


def test_the_session_hands_each_search_the_last_ones_end_and_counts_planning_time():
    """Issue 39: the pass planner's core starts each guarded search from the last one's end
    (pass_plan.plan_pass's warm_start) and adds up the wall time spent planning (the node
    publishes it in /diagnostics as planning_wall_s: in lock-step the sim clock stands still
    meanwhile); the benchmark's baseline turns the warm start off."""
    ripple = weld_bead(60.0, 1.0, 12.0, ripple_mm=0.15, seed=4)
    depth = float(CONFIG.model.process.cut_depth_mm(CONFIG.model.process.force_max_n, 39.5))
    for warm_start in (True, False):
        session = PassSession(CONFIG, warm_start=warm_start)
        first = _plan(session, _request(0, depth, 39.5), _scan(0, ripple))
        assert not first.refused and first.planned.planning_s > 0
        assert session.planning_s == pytest.approx(first.planned.planning_s)
        assert (session.warm_start is not None) == warm_start
        second = _plan(session, _request(1, depth, 39.5), _scan(1, ripple))
        assert session.plans == 2 and session.planning_s > first.planned.planning_s
        sims = (first.planned.plan.simulations, second.planned.plan.simulations)
        assert sims[1] < sims[0] if warm_start else sims[1] == sims[0]
        assert np.max(second.planned.plan.force_n) <= CONFIG.model.process.force_max_n
