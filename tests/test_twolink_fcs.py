"""Free-Cartesian-space maps against a brute-force 2-D check of the links at that time."""

import tomllib
from importlib import resources

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.twolink.fcs import FreeCartesianSpace, Grid
from mpd_pin.twolink.ik import TwoLinkKinematics
from mpd_pin.twolink.moving import SampledCollisionChecker
from mpd_pin.twolink.scenario import parse_dynamic_scenario

LINK_RADIUS = 0.03  # the URDF cylinders of robots/planar_2link.urdf


def _elbows(p, l1, l2):
    """Both elbow positions for end-effector points p (N, 2), by intersecting two circles.

    Independent of the package's IK: returns (elbow counter-clockwise of the
    base->ee ray, elbow clockwise of it, reachable mask).
    """
    r = np.linalg.norm(p, axis=1)
    ok = (r <= l1 + l2) & (r >= abs(l1 - l2)) & (r > 1e-9)
    rs = np.where(ok, r, 1.0)
    a = (l1**2 - l2**2 + rs**2) / (2 * rs)
    h = np.sqrt(np.maximum(l1**2 - a**2, 0.0))
    u = p / rs[:, None]
    perp = np.column_stack([-u[:, 1], u[:, 0]])
    m = a[:, None] * u
    return m + h[:, None] * perp, m - h[:, None] * perp, ok


def _rect_distance(c, A, B, half_width):
    """Distance from points c (N, 2) to the rectangle around segment A-B (flat ends)."""
    d = B - A
    L = np.linalg.norm(d, axis=1)
    dh = d / np.maximum(L, 1e-12)[:, None]
    n = np.column_stack([-dh[:, 1], dh[:, 0]])
    w = c - A
    s = np.einsum("ij,ij->i", w, dh)
    t = np.abs(np.einsum("ij,ij->i", w, n))
    dx = np.maximum(np.maximum(-s, s - L), 0.0)
    dy = np.maximum(t - half_width, 0.0)
    return np.hypot(dx, dy)


@pytest.fixture(scope="module")
def env2():
    path = resources.files("mpd_pin") / "scenarios" / "env2.toml"
    scn = parse_dynamic_scenario(tomllib.loads(path.read_text()))
    prob = scn.problem
    kin = TwoLinkKinematics(prob.arm)
    checker = SampledCollisionChecker(prob.arm, prob.scene, margin=prob.margin)
    return prob, kin, FreeCartesianSpace(kin, prob.grid, checker)


@pytest.mark.parametrize("k", [0, 17, 33, 60])
def test_fcs_agrees_with_brute_force(env2, k):
    prob, kin, fcs = env2
    grid = prob.grid
    pts = grid.points()
    m = fcs.map_at(k)
    centers = prob.scene.centers(k * prob.scene.ts)
    radii = prob.scene.radii
    up_elbow, down_elbow, reach = _elbows(pts, kin.l1, kin.l2)
    base = np.zeros_like(pts)
    undecided = 0
    for b, elbow in ((0, up_elbow), (1, down_elbow)):
        clear = np.full(len(pts), np.inf)
        for c, R in zip(centers, radii, strict=True):
            cc = np.broadcast_to(c, pts.shape)
            d1 = _rect_distance(cc, base, elbow, LINK_RADIUS)
            d2 = _rect_distance(cc, elbow, pts, LINK_RADIUS)
            clear = np.minimum(clear, np.minimum(d1, d2) - R)
        expect = reach & (clear > prob.margin)
        got = m.free[b].ravel()
        near = reach & (np.abs(clear - prob.margin) < 1e-6)  # Coal's documented band
        # Disagreements excused by the band (cells in it that agree do not count: on the
        # 0.025 m grid some cells are exact geometric ties, clearance = margin to 1e-16).
        undecided += int((near & (got != expect)).sum())
        mism = (got != expect) & ~near
        origin = np.linalg.norm(pts, axis=1) < 1e-9  # elbow anywhere: not comparable
        mism &= ~origin
        assert not mism.any(), (k, b, pts[mism][:5], clear[mism][:5])
        # Unreachable cells are free on neither branch.
        assert not got[~reach & ~origin].any()
    assert undecided <= 2
    counts = m.counts()
    assert sum(counts.values()) == grid.num_cells
    assert counts["both"] == int(m.both.sum())
    assert np.array_equal(m.classes == 3, m.up & m.down)
    assert 0 < counts["up_only"] and 0 < counts["down_only"]


def test_fcs_changes_as_obstacles_move(env2):
    _, _, fcs = env2
    a, b = fcs.map_at(0), fcs.map_at(20)
    assert (a.free != b.free).sum() > 50
    assert fcs.map_at(0).t == 0.0 and fcs.map_at(20).t == pytest.approx(0.2)
    # Cached: the same array object is returned again.
    assert fcs.free_states(20) is fcs.free_states(20)


def test_grid_geometry():
    g = Grid(-1.0, 1.0, -0.5, 0.5, 0.05)
    assert (g.nx, g.nz) == (41, 21)
    pts = g.points()
    assert pts.shape == (41 * 21, 2)
    c = g.nearest_cell((0.26, -0.24))
    np.testing.assert_allclose(g.point(c), [0.25, -0.25], atol=1e-12)
    np.testing.assert_allclose(pts[c], g.point(c))
    assert len(g.neighbours(c)) == 8 and len(g.neighbours(0)) == 3
    with pytest.raises(ValueError, match="outside the grid"):
        g.nearest_cell((1.5, 0.0))
    with pytest.raises(ValueError, match="step"):
        Grid(-1, 1, -1, 1, 0.0)


def test_empty_scene_is_the_annulus():
    from mpd_pin.twolink.moving import MovingScene

    arm = mp.builtin_arm("planar_2link")
    kin = TwoLinkKinematics(arm)
    g = Grid(-1.0, 1.0, -1.0, 1.0, 0.1)
    fcs = FreeCartesianSpace(kin, g, SampledCollisionChecker(arm, MovingScene([])))
    m = fcs.map_at(0)
    r = np.linalg.norm(g.points(), axis=1).reshape(g.nz, g.nx)
    assert np.array_equal(m.both, r <= 1.0 + 1e-12)
