"""3-PRU head of seed 001: IK (2.1.1), Jacobian, accelerations, FK (2.1.2)."""

import math

import numpy as np
import pytest

from hex_control.config import config_file
from hex_control.kinematics.pru3 import (
    Pru3Geometry,
    forward_kinematics,
    inverse_kinematics,
    slider_accelerations,
    velocity_jacobian,
)

PRU3 = Pru3Geometry.from_yaml(config_file("machines/pru3.yaml"))
OMEGA = 4 * math.pi  # rad/s, seed 4.2


def seed_trajectory(t):
    """Seed 4.2: z = 220 mm, alpha = 0.15 cos(wt), beta = 0.15 sin(wt)."""
    t = np.asarray(t, float)
    return np.stack([np.full_like(t, 220.0), 0.15 * np.cos(OMEGA * t), 0.15 * np.sin(OMEGA * t)], axis=-1)


def random_q(n, rng):
    q = np.column_stack([rng.uniform(150, 260, 4 * n), rng.uniform(-0.4, 0.4, (4 * n, 2))])
    return q[inverse_kinematics(PRU3, q).reachable][:n]


def test_geometry_is_the_seeds():
    """Seed 4.2: b_1 = (120, 0, 0), b_2 = (-60, 103.9230, 0), R_2 = (-90, 155.8846, 0) mm."""
    np.testing.assert_allclose(PRU3.platform_joints_mm[1], [-60.0, 103.9230, 0.0], atol=5e-5)
    np.testing.assert_allclose(PRU3.rails_mm[2], [-90.0, -155.8846, 0.0], atol=5e-5)


def test_ik_formula_equals_the_vector_loop():
    """L_i from the seed's closed form equals the vector-loop closure |P_i - A_i| = l with
    each platform joint in its rail's vertical plane."""
    q = random_q(500, np.random.default_rng(0))
    pose = inverse_kinematics(PRU3, q)
    z, alpha, beta = q.T
    angles = np.array(PRU3.rail_angles_rad)
    r, l = PRU3.platform_radius_mm, PRU3.rocker_length_mm
    closed_form = (z[:, None] - r * np.cos(angles) * np.sin(beta)[:, None]
                   + r * np.sin(angles) * (np.sin(alpha) * np.cos(beta))[:, None]
                   - np.sqrt(l**2 - np.sum(pose.horizontal_mm**2, axis=-1)))
    np.testing.assert_allclose(pose.lengths_mm, closed_form, atol=1e-9)
    sliders = PRU3.rails_mm + np.concatenate([np.zeros(pose.lengths_mm.shape + (2,)),
                                              pose.lengths_mm[..., None]], axis=-1)
    np.testing.assert_allclose(np.linalg.norm(pose.joints_mm - sliders, axis=-1), l, atol=1e-9)
    np.testing.assert_allclose(np.einsum("ki,nki->nk", PRU3.plane_normals, pose.joints_mm), 0, atol=1e-9)


def test_velocity_jacobian_matches_finite_differences():
    q = random_q(100, np.random.default_rng(1))
    h = 1e-6
    numeric = np.stack([(inverse_kinematics(PRU3, q + h * e).lengths_mm
                         - inverse_kinematics(PRU3, q - h * e).lengths_mm) / (2 * h) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(velocity_jacobian(PRU3, q), numeric, atol=1e-6)


def test_slider_accelerations_on_the_seed_trajectory():
    """Along seed 4.2's path, J q'' + J' q' equals the second difference of L(t)."""
    t = np.linspace(0.0, 0.5, 11)
    h = 1e-4
    q = seed_trajectory(t)
    q_dot = (seed_trajectory(t + h) - seed_trajectory(t - h)) / (2 * h)
    q_ddot = (seed_trajectory(t + h) - 2 * q + seed_trajectory(t - h)) / h**2
    lengths = lambda s: inverse_kinematics(PRU3, seed_trajectory(s)).lengths_mm  # noqa: E731
    numeric = (lengths(t + h) - 2 * lengths(t) + lengths(t - h)) / h**2
    np.testing.assert_allclose(slider_accelerations(PRU3, q, q_dot, q_ddot), numeric, rtol=1e-4, atol=1e-2)
    # by the printed formula this path peaks at L = 101.2 mm, 1.2 mm past the seed's
    # 0..100 mm stroke (its L datum is presumably offset); the rockers stay valid
    assert np.all(np.isfinite(inverse_kinematics(PRU3, q).lengths_mm))


def test_fk_round_trip():
    """FK(IK(q)) = q to 1e-9 over random reachable poses (seed 2.1.2 Newton-Raphson)."""
    rng = np.random.default_rng(2)
    for q in random_q(300, rng):
        found, iterations = forward_kinematics(PRU3, inverse_kinematics(PRU3, q).lengths_mm[0],
                                               initial_guess=(220.0, 0.0, 0.0))
        np.testing.assert_allclose(found, q, atol=1e-9)
        assert iterations <= 8


def test_unreachable_and_bad_inputs():
    assert not inverse_kinematics(PRU3, [400.0, 0.0, 0.0]).reachable[0]  # beyond the stroke
    assert not inverse_kinematics(PRU3, [220.0, math.radians(35), 0.0]).reachable[0]  # tilt
    with pytest.raises(ValueError):
        inverse_kinematics(PRU3, [220.0, math.nan, 0.0])
    with pytest.raises(ValueError):  # 500 mm between sliders: no rocker of 150 mm spans it
        forward_kinematics(PRU3, [0.0, 500.0, 0.0])


def test_on_a_feed_stage_the_tool_reaches_x_with_the_stage():
    """pru3_feed.yaml: the stage carries x; the head's parasitic x is taken off the stage's
    command, and the tool locator puts the tool back where the pose asked for."""
    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.kinematics import load_machine
    from hex_control.kinematics.pru3 import feed_positions_mm, tool_positions_mm
    from hex_control.plant.tool_locator import ToolLocator

    hybrid, document = load_machine(config_file("machines/pru3_feed.yaml"))
    assert hybrid.feed_stroke_mm == (-250.0, 450.0) and hybrid.joint_names[-1] == "feed_x"
    assert PRU3.feed_stroke_mm is None and len(PRU3.joint_names) == 3
    q = np.array([[200.0, 0.1, -0.05], [190.0, -0.2, 0.1]])
    pose = inverse_kinematics(hybrid, q)
    x_mm = np.array([37.0, -120.0])
    feed = feed_positions_mm(x_mm, pose)
    assert np.all(np.abs(pose.full[:, 0]) > 0.1)  # tilted: the head's x wanders and the stage makes up for it
    np.testing.assert_allclose(tool_positions_mm(pose, feed)[:, 0], x_mm, atol=1e-12)
    frame = load_pass_planner_config("pass_planner.yaml", document).frame
    assert frame.origin_mm == (-75.0, 0.0, 160.0)  # the machine file's bead frame wins
    locator = ToolLocator(hybrid, frame)
    joints_m = np.append(pose.lengths_mm[0], feed[0]) / 1000.0
    along, up = locator.centre_mm(joints_m)
    assert (along, up) == pytest.approx((37.0 + 75.0, 200.0 - 160.0), abs=1e-6)


@pytest.mark.parametrize("machine_file", ["machines/pru3_feed.yaml", "machines/nist_ingersoll.yaml"])
def test_a_whole_trajectory_is_checked_at_once_as_row_by_row(machine_file):
    """The plant checks a pass's strut trajectory before it holds it: every row at once
    (the 3-PRU head's forward kinematics row by row took 0.6 s of its executor for one pass).
    A good trajectory passes; one row out of the stroke, the feed stage's travel or the tilt
    limit is refused with that row named, where the row-by-row check refuses it too."""
    from hex_control.kinematics import load_machine

    machine, _ = load_machine(config_file(machine_file))
    home = np.asarray(machine.home_pose, float)
    path = home + np.outer(np.linspace(-1.0, 1.0, 400), [20.0, 0.0, 2.0, 0.0, 0.0, 0.0])
    rows, reachable = machine.joint_positions_mm(path)
    assert reachable.all()
    machine.check_joint_trajectory_mm(rows)
    for row in rows[::40]:
        machine.check_joint_positions_mm(row)
    bad = {"stroke": rows[0] + np.r_[1e4, np.zeros(rows.shape[1] - 1)]}
    if rows.shape[1] == 4:  # the head: its feed stage's travel, and a tilt the sliders alone make
        bad["feed"] = rows[0] + np.r_[np.zeros(3), 1e4]
        # z 195 mm, beta 1.1 tilt limits: every slider within its stroke, the platform tilted beyond
        sliders = inverse_kinematics(machine, [195.0, 0.0, 1.1 * machine.tilt_max_rad]).lengths_mm[0]
        assert np.all((sliders > 5.0) & (sliders < 95.0))
        bad["tilt"] = np.r_[sliders, rows[0, 3]]
    messages = {"stroke": "stroke", "feed": "feed stage", "tilt": "tilt the platform"}
    for what, row in bad.items():
        with pytest.raises(ValueError, match=messages[what]):
            machine.check_joint_positions_mm(row)
        broken = rows.copy()
        broken[217] = row
        with pytest.raises(ValueError, match="^row 217: "):
            machine.check_joint_trajectory_mm(broken)
