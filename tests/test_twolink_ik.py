"""Analytic two-link IK (paper 002 eqs. 3-6) against Pinocchio's forward kinematics."""

import math

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.twolink.ik import (
    TwoLinkKinematics,
    forward_kinematics,
    inverse_kinematics,
    link_lengths,
)


@pytest.fixture(scope="module")
def kin():
    return TwoLinkKinematics(mp.builtin_arm("planar_2link"))


def _annulus_points(rng, n, r_lo=1e-3, r_hi=1.0 - 1e-9):
    r = np.sqrt(rng.uniform(r_lo**2, r_hi**2, n))  # uniform over the disc's area
    a = rng.uniform(-math.pi, math.pi, n)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def test_link_lengths_from_model(kin):
    assert (kin.l1, kin.l2) == (0.5, 0.5)
    assert link_lengths(mp.builtin_arm("planar_2link")) == (0.5, 0.5)


def test_rejects_arms_that_are_not_two_link():
    with pytest.raises(ValueError, match="not a two-link arm"):
        TwoLinkKinematics(mp.builtin_arm("planar_3link"))


@pytest.mark.parametrize("branch", ["up", "down"])
def test_round_trip_through_pinocchio(kin, branch):
    rng = np.random.default_rng(7)
    pts = _annulus_points(rng, 1200)
    sol = kin.ik(pts, branch)
    assert sol.reachable.all()
    assert np.all(np.isfinite(sol.q))
    assert np.all(sol.q >= -math.pi) and np.all(sol.q <= math.pi)
    # Pinocchio's framesForwardKinematics, one configuration at a time (the reference).
    arm = kin.arm
    for q, p in zip(sol.q, pts, strict=True):
        xyz = arm.frame_position(q, "ee")
        assert abs(xyz[1]) < 1e-15  # the arm stays in the x-z plane
        assert np.hypot(xyz[0] - p[0], xyz[2] - p[1]) < 1e-12
    # The vectorised numpy FK agrees with Pinocchio too.
    assert np.abs(kin.fk(sol.q) - pts).max() < 1e-12


def test_branches_put_the_elbow_on_either_side(kin):
    rng = np.random.default_rng(3)
    pts = _annulus_points(rng, 500, 0.05, 0.98)
    up = kin.ik(pts, "up").q
    down = kin.ik(pts, "down").q
    assert np.all(up[:, 1] < 0) and np.all(down[:, 1] > 0)
    # Elbow up: the elbow lies counter-clockwise of the base -> end-effector ray
    # (above it when x > 0), elbow down clockwise of it.
    for q, sign in ((up, 1.0), (down, -1.0)):
        e = kin.elbow(q)
        cross = pts[:, 0] * e[:, 1] - pts[:, 1] * e[:, 0]
        assert np.all(sign * cross > 0)
    right = pts[:, 0] > 0.1
    assert np.all(kin.elbow(up)[right, 1] > kin.elbow(down)[right, 1])


def test_paper_equations_by_hand(kin):
    # x = 0.7, z = 0.3: D = (0.58 - 0.5) / 0.5 = 0.16 (eq. 3)
    x, z = 0.7, 0.3
    D = (x * x + z * z - 0.5) / 0.5
    s = math.sqrt(1 - D * D)
    for branch, s2 in (("up", -s), ("down", s)):
        q2 = math.atan2(s2, D)  # eq. 5
        q1 = math.atan2(z, x) - math.atan2(0.5 * s2, 0.5 + 0.5 * D)  # eq. 6
        np.testing.assert_allclose(kin.ik_point([x, z], branch), [q1, q2], atol=1e-15)


def test_workspace_boundaries(kin):
    # Outer circle: both branches coincide (stretched arm, q2 = 0).
    for a in np.linspace(-3.0, 3.0, 7):
        p = [math.cos(a), math.sin(a)]
        qu, qd = kin.ik_point(p, "up"), kin.ik_point(p, "down")
        np.testing.assert_allclose(qu, qd, atol=1e-7)
        np.testing.assert_allclose(kin.fk(qu), p, atol=1e-12)
    # The base itself (|l1 - l2| = 0): folded arm, still a valid solution.
    q = kin.ik_point([0.0, 0.0], "up")
    assert abs(abs(q[1]) - math.pi) < 1e-15
    np.testing.assert_allclose(kin.fk(q), [0.0, 0.0], atol=1e-15)


def test_unreachable_points_are_reported_not_nan(kin):
    pts = np.array([[1.2, 0.0], [0.0, -1.0001], [0.3, 0.4], [-2.0, 5.0]])
    for branch in ("up", "down"):
        sol = kin.ik(pts, branch)
        assert sol.reachable.tolist() == [False, False, True, False]
        assert sol.in_workspace.tolist() == [False, False, True, False]
        assert np.all(np.isfinite(sol.q))
        assert np.all(sol.q[~sol.reachable] == 0.0)
    with pytest.raises(ValueError, match="unreachable.*outside"):
        kin.ik_point([1.2, 0.0], "up")


def test_joint_limits_make_points_unreachable():
    sol = inverse_kinematics([[0.0, 0.8], [0.0, -0.8]], 0.5, 0.5, "up", lower=[-0.5, -3.2],
                             upper=[3.2, 3.2])
    # (0, -0.8) needs q1 < -0.5 with the elbow up; (0, 0.8) does not.
    assert sol.reachable.tolist() == [True, False]
    assert sol.in_workspace.tolist() == [True, True]


def test_unequal_links_and_shapes():
    l1, l2 = 0.7, 0.3
    rng = np.random.default_rng(1)
    q = rng.uniform(-math.pi, math.pi, (4, 5, 2))
    p = forward_kinematics(q, l1, l2)
    for branch in ("up", "down"):
        sol = inverse_kinematics(p, l1, l2, branch)
        assert sol.q.shape == (4, 5, 2)
        assert sol.reachable.all()
        np.testing.assert_allclose(forward_kinematics(sol.q, l1, l2), p, atol=1e-12)
    # Inside the inner circle r < |l1 - l2| = 0.4: unreachable.
    assert not inverse_kinematics([0.1, 0.1], l1, l2, "up").reachable


def test_bad_input(kin):
    with pytest.raises(ValueError, match="branch"):
        kin.ik([0.5, 0.5], "sideways")
    with pytest.raises(ValueError, match="NaN"):
        kin.ik([np.nan, 0.5], "up")
    with pytest.raises(ValueError, match="shape"):
        kin.ik([0.1, 0.2, 0.3], "up")
