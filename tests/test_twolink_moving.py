"""Obstacle trajectories (straight, back and forth, square) and the per-sample checker."""

import math

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.twolink.moving import (
    MovingObstacle,
    MovingScene,
    PolylineTrajectory,
    SampledCollisionChecker,
    back_and_forth,
    square,
    static,
    straight,
)
from mpd_pin.world import Cylinder


def test_straight_moves_at_speed_then_stays():
    tr = straight((0.0, 0.0), (0.3, 0.4), 2.0, delay=0.05)  # 0.5 m at 2 m/s: 0.25 s
    t = np.array([0.0, 0.05, 0.10, 0.30, 1.0])
    expect = np.array([[0, 0], [0, 0], [0.06, 0.08], [0.3, 0.4], [0.3, 0.4]])
    np.testing.assert_allclose(tr.position(t), expect, atol=1e-15)
    # Displacement per motion sample = speed * Ts (paper 002: v = dx / (MS * Ts)).
    p = tr.position(np.array([0.10, 0.11]))
    assert math.isclose(np.linalg.norm(p[1] - p[0]), 2.0 * 0.01, rel_tol=1e-12)


def test_back_and_forth_reflects_with_period():
    tr = back_and_forth((-0.5, 0.6), (0.5, 0.6), 1.0)  # 1 m each way: period 2 s
    t = np.array([0.0, 0.25, 1.0, 1.25, 2.0, 2.75])
    x = np.array([-0.5, -0.25, 0.5, 0.25, -0.5, 0.25])
    np.testing.assert_allclose(tr.position(t)[:, 0], x, atol=1e-12)
    np.testing.assert_allclose(tr.position(t)[:, 1], 0.6)
    half = back_and_forth((-0.5, 0.6), (0.5, 0.6), 1.0, phase=0.5)  # starts at b, going back
    np.testing.assert_allclose(half.position([0.0, 0.25]), [[0.5, 0.6], [0.25, 0.6]], atol=1e-12)


@pytest.mark.parametrize("clockwise", [False, True])
def test_square_visits_corners_in_order(clockwise):
    tr = square((0.2, -0.1), 0.4, 2.0, clockwise=clockwise)  # 1.6 m loop, 0.2 s per side
    corners = tr.position(np.array([0.0, 0.2, 0.4, 0.6, 0.8]))
    bl, br, tr_, tl = [0.0, -0.3], [0.4, -0.3], [0.4, 0.1], [0.0, 0.1]
    order = [bl, tl, tr_, br, bl] if clockwise else [bl, br, tr_, tl, bl]
    np.testing.assert_allclose(corners, order, atol=1e-12)
    mid = tr.position(0.1)  # halfway along the first side
    np.testing.assert_allclose(mid, [0.0, -0.1] if clockwise else [0.2, -0.3], atol=1e-12)
    # Constant speed along the loop.
    t = np.arange(0, 81) * 0.01
    d = np.linalg.norm(np.diff(tr.position(t), axis=0), axis=1)
    assert np.all(d <= 0.02 + 1e-12) and np.sum(d) > 1.6 - 0.03


def test_static_and_zero_speed():
    np.testing.assert_allclose(static((0.1, 0.2)).position([0, 5.0]), [[0.1, 0.2]] * 2)
    tr = PolylineTrajectory(((0, 0), (1, 0)), 0.0, "loop")
    assert tr.is_static
    np.testing.assert_allclose(tr.position(3.0), [0, 0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(points=((0, 0), (1, 0)), speed=-1.0), "speed"),
        (dict(points=((0, 0), (1, 0)), speed=1.0, phase=1.0), "phase"),
        (dict(points=((0, 0), (0, 0)), speed=1.0), "repeated"),
        (dict(points=((0, 0), (1, 0)), speed=1.0, mode="zigzag"), "mode"),
        (dict(points=((0, 0), (1, np.nan)), speed=1.0), "finite"),
        (dict(points=((0, 0), (1, 0)), speed=1.0, delay=-0.1), "delay"),
    ],
)
def test_trajectory_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PolylineTrajectory(**kwargs)


def test_scene_world_and_snapshot():
    scene = MovingScene(
        [
            MovingObstacle("a", 0.1, back_and_forth((-0.5, 0.5), (0.5, 0.5), 1.0)),
            MovingObstacle("b", 0.2, static((0.0, -0.6))),
        ],
        ts=0.01,
    )
    c = scene.centers_at_samples(np.arange(3))
    assert c.shape == (3, 2, 2)
    np.testing.assert_allclose(c[2, 0], [-0.48, 0.5], atol=1e-12)
    w = scene.world_at_sample(2)
    a = w["a"]
    assert isinstance(a, Cylinder) and a.radius == 0.1
    np.testing.assert_allclose(a.position, [-0.48, 0.0, 0.5], atol=1e-12)
    snap = scene.snapshot(0.02)
    assert snap[1] == {"name": "b", "center": [0.0, -0.6], "radius": 0.2}
    with pytest.raises(ValueError, match="duplicate"):
        MovingScene([MovingObstacle("a", 0.1, static((0, 0)))] * 2)


def test_sampled_checker_follows_the_obstacle():
    arm = mp.builtin_arm("planar_2link")
    # A disc coming down onto the stretched arm (q = 0: links along +x, z = 0).
    scene = MovingScene([MovingObstacle("d", 0.1, straight((0.7, 0.5), (0.7, 0.0), 5.0))])
    chk = SampledCollisionChecker(arm, scene, margin=0.03)
    q = np.zeros(2)
    # Centre z at sample k: 0.5 - 0.05 k; clearance to the cylinder link = z - 0.1 - 0.03.
    for k in range(0, 11):
        z = max(0.5 - 0.05 * k, 0.0)
        free = z - 0.1 - 0.03 > 0.03
        assert chk.is_free(q, k) == free, k
        assert math.isclose(chk.clearance(q, k), z - 0.13, abs_tol=1e-6)
    assert chk.is_free_batch(np.zeros((3, 2)), 0).tolist() == [True] * 3
    assert chk.builds == 11


def test_checker_between_samples_sees_what_the_samples_miss():
    arm = mp.builtin_arm("planar_2link")
    # A small fast disc crossing link 1 (q = 0: along +x at z = 0) between samples 0 and 1:
    # centre x = 0.3, z from 0.2 to -0.2 in 0.01 s (40 m/s); at the samples it is 0.2 m away.
    scene = MovingScene([MovingObstacle("fast", 0.05, straight((0.3, 0.2), (0.3, -0.2), 40.0))])
    chk = SampledCollisionChecker(arm, scene, margin=0.03)
    q = np.zeros(2)
    assert chk.is_free(q, 0) and chk.is_free(q, 1)
    # Sub-steps j/4: centre z = 0.2 - 0.1 j; j = 2 puts it on the link.
    assert not chk.is_free_between(q, q, 0, 4)
    assert chk.is_free_between(q, q, 0, 1)  # samples only: nothing checked in between
    np.testing.assert_allclose(chk.at_time(0, 1, 4).world["fast"].position, [0.3, 0.0, 0.1],
                               atol=1e-12)
    assert chk.at_time(0, 2, 4) is chk.at_time(0, 1, 2)  # one checker per instant
    # Joints interpolated linearly: from q1 = -0.6 to q1 = 0.6 the link sweeps through z = 0
    # half-way (j = 2 of 4), when the disc is there too; a static disc off the sweep is missed.
    q0, q1 = np.array([-0.6, 0.0]), np.array([0.6, 0.0])
    slow = MovingScene([MovingObstacle("s", 0.05, static((0.45, 0.0)))])
    chk2 = SampledCollisionChecker(arm, slow, margin=0.03)
    assert chk2.is_free(q0, 0) and chk2.is_free(q1, 1)
    assert not chk2.is_free_between(q0, q1, 0, 4)
    ok = chk2.is_free_between_batch(np.stack([q0, q0]), np.stack([q1, q0]), 0, 4)
    assert ok.tolist() == [False, True]
    with pytest.raises(ValueError, match="sub-step"):
        chk.at_time(0, 4, 4)
