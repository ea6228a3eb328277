"""Occupancy analysis (paper 000 §4) against the analytic workspace of a two-link arm."""

import math

import matplotlib
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker
from mpd_pin.viz.occupancy import default_frame, frame_positions, occupancy_analysis
from mpd_pin.world import Box, Cylinder, Hazard, Polygon, World

matplotlib.use("Agg")

L1, L2 = 0.6, 0.4


@pytest.fixture(scope="module")
def arm2():
    return mp.Arm.from_urdf(mp.planar_arm_urdf([L1, L2], [1.0, 1.0], radius=0.02, name="two"))


def test_reachable_area_matches_annulus(arm2):
    """Reachable cells ≈ annulus π((l1+l2)² − (l1−l2)²), with bounds from cell size and N.

    Every end-effector position lies in the closed annulus, so every reached cell
    intersects it and lies within the annulus dilated by the cell diagonal
    δ = c√2: an exact upper bound. Every cell inside the annulus eroded by δ lies
    in the annulus, where the end-effector density (uniform joint angles, two
    IK branches) is 2 / (4π² l1 l2 |sin q2|) ≥ 1/(2π² l1 l2); such a cell is
    missed with probability ≤ exp(−N c² / (2π² l1 l2)), which bounds the
    expected number of missed cells from below.
    """
    c, n = 0.025, 80_000
    occ = occupancy_analysis(arm2, None, n, seed=1, cell_size=c)
    r_out, r_in = L1 + L2, L1 - L2
    annulus = math.pi * (r_out**2 - r_in**2)
    delta = c * math.sqrt(2)
    upper = math.pi * ((r_out + delta) ** 2 - max(r_in - delta, 0.0) ** 2)
    lower = math.pi * ((r_out - delta) ** 2 - (r_in + delta) ** 2)
    n_inner = lower / c**2
    expected_missed = n_inner * math.exp(-n * c**2 / (2 * math.pi**2 * L1 * L2))
    assert expected_missed < 0.5
    area = occ.reachable_fraction * occ.grid_area
    assert area == pytest.approx(occ.reachable_area)
    assert lower - 3 * c**2 <= area <= upper
    # the grid's cells outside the dilated annulus are never reached
    u = (occ.edges[0][:-1] + occ.edges[0][1:]) / 2
    R = np.hypot(u[:, None], u[None, :])
    assert not occ.reachable[(R > r_out + delta) | (R < r_in - delta)].any()
    assert occ.reachable[(R < r_out - delta) & (R > r_in + delta)].all()
    assert abs(area - annulus) / annulus < 0.06
    print(f"reachable area {area:.4f} m², annulus {annulus:.4f}, bounds [{lower:.4f}, {upper:.4f}]")
    # no obstacles and two links: everything free
    assert occ.free.all() and np.array_equal(occ.free_cells, occ.reachable)


def test_points_are_forward_kinematics(arm2):
    occ = occupancy_analysis(arm2, None, 200, seed=np.random.default_rng(3), cell_size=0.05)
    q = occ.samples
    x = L1 * np.cos(q[:, 0]) + L2 * np.cos(q[:, 0] + q[:, 1])
    z = L1 * np.sin(q[:, 0]) + L2 * np.sin(q[:, 0] + q[:, 1])
    np.testing.assert_allclose(occ.points[:, 0], x, atol=1e-12)
    np.testing.assert_allclose(occ.points[:, 2], z, atol=1e-12)
    np.testing.assert_allclose(occ.points[:, 1], 0.0, atol=1e-12)
    assert np.all(q >= arm2.lower_limits) and np.all(q <= arm2.upper_limits)
    assert occ.reached.sum() == 200
    # seeded: same seed, same samples
    again = occupancy_analysis(arm2, None, 200, seed=np.random.default_rng(3), cell_size=0.05)
    np.testing.assert_array_equal(again.samples, occ.samples)


def test_free_fraction_decreases_with_obstacle():
    arm = mp.builtin_arm("planar_3link")
    world = World([Box.planar((0.6, 0.0), 0.3, 0.3, name="block")])
    blocked = occupancy_analysis(arm, world, 6000, seed=5, cell_size=0.05, extent=1.3)
    empty = occupancy_analysis(arm, World(), 6000, seed=5, cell_size=0.05, extent=1.3)
    np.testing.assert_array_equal(blocked.samples, empty.samples)
    assert blocked.free_sample_fraction < empty.free_sample_fraction
    assert blocked.free_fraction < empty.free_fraction
    assert np.all(blocked.free <= empty.free)  # an obstacle never frees a configuration
    assert np.array_equal(blocked.reachable, empty.reachable)
    # no end effector of a free sample inside the block
    p = blocked.points[blocked.free]
    inside = (np.abs(p[:, 0] - 0.6) < 0.15) & (np.abs(p[:, 2]) < 0.15)
    assert not inside.any()


def test_hidden_obstacles_and_checker(arm2):
    world = World([Cylinder.planar((0.5, 0.0), 0.2, name="post", hidden=True)])
    known = occupancy_analysis(arm2, world, 3000, seed=2, cell_size=0.05)
    truth = occupancy_analysis(arm2, world, 3000, seed=2, cell_size=0.05, include_hidden=True)
    assert known.free.all() and not truth.free.all()
    checker = CollisionChecker(arm2, world, include_hidden=True)
    via = occupancy_analysis(arm2, None, 3000, seed=2, cell_size=0.05, checker=checker)
    np.testing.assert_array_equal(via.free, truth.free)


def test_plot_runs_and_shows_obstacles():
    import matplotlib.pyplot as plt

    arm = mp.builtin_arm("planar_3link")
    world = World([
        Box.planar((0.6, 0.2), 0.2, 0.3, name="block"),
        Polygon.planar([(-0.6, 0.3), (-0.3, 0.3), (-0.45, 0.6)], name="tri"),
        Hazard(Cylinder.planar((0.0, -0.7), 0.15, name="hot"), 0.1),
        Cylinder.planar((-0.5, -0.5), 0.1, name="later", hidden=True),
    ])
    occ = occupancy_analysis(arm, world, 2000, seed=0, cell_size=0.05)
    ax = occ.plot()
    assert isinstance(ax, matplotlib.axes.Axes)
    gids = {p.get_gid() for p in ax.patches}
    assert gids == {"block", "tri", "hot", "later"}
    fig, ax2 = plt.subplots()
    assert occ.plot(ax=ax2) is ax2
    plt.close("all")


def test_default_frame_and_bad_input(arm2):
    assert default_frame(arm2) == "ee"
    panda = mp.Arm.from_example_robot_data("panda")
    assert default_frame(panda) == panda.model.frames[len(panda.model.frames) - 1].name
    occ = occupancy_analysis(panda, None, 50, seed=0, cell_size=0.1, plane="xy")
    ref = np.array([panda.frame_position(q, occ.frame) for q in occ.samples])
    np.testing.assert_allclose(occ.points, ref, atol=1e-12)
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 0)
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 10, cell_size=-0.1)
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 10, cell_size=float("nan"))
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 10, frame="nope")
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 10, plane="ab")
    with pytest.raises(ValueError):
        occupancy_analysis(arm2, None, 10, seed="x")
    with pytest.raises(ValueError):
        frame_positions(arm2, np.zeros((1, 2)), "nope")
