"""CollisionChecker against an independent exact 2-D geometry (tests/planar_geometry.py).

A planar link is a cylinder of radius r whose axis lies in the x–z plane; planar
obstacles are extruded across the plane and symmetric about y = 0, so overlap and
distance equal those of the y = 0 cross-sections (see planar_geometry).
"""

import math

import numpy as np
import pinocchio as pin
import pytest
from planar_geometry import brute_force, min_signed_distance, scene_2d

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker, bisection_order, edge_configurations
from mpd_pin.collision.bounds import max_abs, motion_bounds, pair_weights
from mpd_pin.collision.geometry import build_geometry, pair_state
from mpd_pin.collision.motion import LevelCache
from mpd_pin.world import Box, Cylinder, Hazard, Polygon, Sphere, World

NEAR = 1e-6  # m: configurations this close to contact may go either way (GJK tolerance)


SPEC = mp.BUILTIN_ARMS


def scene(nlinks):
    if nlinks == 3:
        return World([
            Cylinder.planar((0.55, 0.35), 0.12, name="disc"),
            Box.planar((-0.45, 0.45), 0.30, 0.20, angle=0.4, name="box"),
            Polygon.planar([(0.2, -0.7), (0.8, -0.5), (0.5, -0.25)], name="tri"),
            Sphere.planar((-0.6, -0.5), 0.1, name="ball"),
        ])
    return World([
        Box.planar((0.0, 0.85), 0.8, 0.15, name="shelf"),
        Polygon.planar([(0.4, 0.0), (0.9, -0.2), (0.9, 0.3)], name="tri"),
        Cylinder.planar((-0.5, -0.3), 0.15, name="post"),
    ])


# ---------------------------------------------------------------- tests
@pytest.mark.parametrize("backend", ["pairs", "broadphase"])
@pytest.mark.parametrize("name", ["planar_3link", "planar_4link"])
def test_is_free_matches_brute_force(name, backend):
    spec = SPEC[name]
    arm = mp.builtin_arm(name)
    world = scene(len(spec.lengths))
    checker = CollisionChecker(arm, world, single_backend=backend)
    assert checker.single_backend == backend
    rng = np.random.default_rng(7)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(10_000, arm.nq))
    free = np.array([checker.is_free(q) for q in Q])
    discs, polys = scene_2d(world)
    obs, selfd = brute_force(Q, spec.lengths, spec.radius, discs, polys)
    sd = np.minimum(obs, selfd)
    near = np.abs(sd) < NEAR
    disagree = free != (sd > 0)
    assert not np.any(disagree & ~near), np.flatnonzero(disagree & ~near)[:10]
    assert near.sum() <= 5
    # the scene is informative: both outcomes, and self-collisions for 4 links
    assert 0.2 < free.mean() < 0.9
    if len(spec.lengths) >= 3:
        assert np.any((selfd < -1e-3) & (obs > 1e-3))
    np.testing.assert_array_equal(checker.is_free_batch(Q), free)
    if backend == "pairs":  # a security margin m: free exactly when the distance exceeds m
        wide = CollisionChecker(arm, world, margin=0.02).is_free_batch(Q)
        assert not np.any((wide != (sd > 0.02)) & (np.abs(sd - 0.02) >= NEAR))
    print(f"{name} ({backend}): free {free.mean():.3f}, near-contact {near.sum()}, "
          f"disagreements {disagree.sum()}")


def test_self_collision_matches_brute_force_4link():
    spec = SPEC["planar_4link"]
    arm = mp.builtin_arm("planar_4link")
    checker = CollisionChecker(arm, World())
    assert len(checker.self_pairs) == 3  # (1,3), (1,4), (2,4)
    rng = np.random.default_rng(11)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(10_000, arm.nq))
    free = checker.is_free_batch(Q)
    _, selfd = brute_force(Q, spec.lengths, spec.radius)
    near = np.abs(selfd) < NEAR
    assert not np.any((free != (selfd > 0)) & ~near)
    assert 0.02 < 1 - free.mean() < 0.5
    off = CollisionChecker(arm, World(), self_collision=False)
    assert off.self_pairs == [] and off.is_free_batch(Q).all()


def test_near_contact_tolerance():
    """Configurations placed at known signed distances from contact, 1e-10 … 1e-2 m.

    Contacts are found by bisecting the brute-force signed distance along random
    edges that cross the obstacle boundary; the checker must agree wherever
    |d| >= 1e-6 m. Disagreements closer than that are counted (and printed).
    """
    spec = SPEC["planar_3link"]
    arm = mp.builtin_arm("planar_3link")
    world = scene(3)
    checker = CollisionChecker(arm, world, self_collision=False)
    discs, polys = scene_2d(world)

    def sd(Q):
        return brute_force(Q, spec.lengths, spec.radius, discs, polys, False)[0]

    rng = np.random.default_rng(3)
    A = rng.uniform(-np.pi, np.pi, (3000, 3))
    B = A + rng.uniform(-0.5, 0.5, (3000, 3))
    sa, sb = sd(A), sd(B)
    cross = (sa > 0) != (sb > 0)
    lo = np.where((sa > 0)[:, None], A, B)[cross][:150]  # free end
    hi = np.where((sa > 0)[:, None], B, A)[cross][:150]  # colliding end
    for _ in range(60):
        mid = (lo + hi) / 2
        free = sd(mid) > 0
        lo = np.where(free[:, None], mid, lo)
        hi = np.where(free[:, None], hi, mid)
    u = (lo - hi) / np.linalg.norm(lo - hi, axis=1, keepdims=True)  # towards the free side
    steps = np.logspace(-10, -2, 33)
    offsets = np.concatenate([-steps, steps])
    Q = (hi[:, None, :] + offsets[None, :, None] * u[:, None, :]).reshape(-1, 3)
    d = sd(Q)
    free = checker.is_free_batch(Q)
    wrong = free != (d > 0)
    assert np.abs(d).max() > 1e-3 and np.sum(np.abs(d) < 1e-8) > 500
    assert not np.any(wrong & (np.abs(d) >= NEAR)), np.abs(d[wrong]).max()
    unsafe = wrong & free  # reported free although penetrating
    print(f"near contact: {wrong.sum()} of {len(Q)} disagree, all |d| < "
          f"{np.abs(d[wrong]).max() if wrong.any() else 0:.1e} m; {unsafe.sum()} unsafe")


@pytest.mark.parametrize("name", ["planar_3link", "planar_4link"])
def test_clearance_matches_brute_force(name):
    """clearance(q): min signed distance to obstacles and hazards (raw geometry), against
    the exact 2-D geometry; ``hazards=False``: obstacles only."""
    spec = SPEC[name]
    arm = mp.builtin_arm(name)
    pit = Hazard(Cylinder.planar((0.0, -0.95), 0.15, name="pit"), 0.05)
    world = World([*scene(len(spec.lengths)), HAZARD, pit])
    checker = CollisionChecker(arm, world)
    rng = np.random.default_rng(5)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(1500, arm.nq))
    got = np.array([checker.clearance(q) for q in Q])
    obs_only = np.array([checker.clearance(q, hazards=False) for q in Q])
    ref = min_signed_distance(Q, spec.lengths, spec.radius, world, self_collision=False)
    ref_obs = min_signed_distance(Q, spec.lengths, spec.radius, world, hazards=False,
                                  self_collision=False)
    ref_haz = min_signed_distance(Q, spec.lengths, spec.radius, World([HAZARD, pit]),
                                  self_collision=False)
    for g, r in ((got, ref), (obs_only, ref_obs)):
        pos = r > 0
        assert pos.sum() > 300
        np.testing.assert_allclose(g[pos], r[pos], atol=1e-6, rtol=0)
        # penetrating: negative as well (EPA depth close to the 2-D depth for shallow contact)
        assert np.all(g[r < -1e-6] < 0)
    # the hazard decides the clearance of a good share of configurations
    hazard_nearest = (ref_haz < ref_obs - 1e-3) & (ref > 0)
    assert hazard_nearest.sum() > 30
    assert np.all(got[hazard_nearest] < obs_only[hazard_nearest] - 1e-3)
    per = checker.distances(Q[0])
    assert set(per) == set(world.names)
    assert min(per.values()) == pytest.approx(got[0], abs=1e-8)
    # hazard_margin = distance to the hazard − its clearance
    i = int(np.flatnonzero(ref_haz > 0)[0])
    margin = min(
        min_signed_distance(Q[i], spec.lengths, spec.radius, World([h]), self_collision=False)[0]
        - h.clearance
        for h in (HAZARD, pit)
    )
    assert checker.hazard_margin(Q[i]) == pytest.approx(margin, abs=1e-6)


def test_batch_equals_loop_and_hidden_obstacles():
    arm = mp.builtin_arm("planar_3link")
    world = World([
        Cylinder.planar((0.55, 0.35), 0.12, name="disc"),
        Box.planar((-0.5, 0.2), 0.2, 0.5, name="wall", hidden=True),
    ])
    checker = CollisionChecker(arm, world)
    truth = CollisionChecker(arm, world, include_hidden=True)
    rng = np.random.default_rng(2)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(2500, 3))
    loop = np.array([checker.is_free(q) for q in Q])
    np.testing.assert_array_equal(checker.is_free_batch(Q), loop)
    truth_loop = np.array([truth.is_free(q) for q in Q])
    np.testing.assert_array_equal(truth.is_free_batch(Q), truth_loop)
    # the hidden wall is invisible until revealed
    q_wall = np.array([math.pi - 0.35, 0.0, 0.0])  # link 1 points at (-0.47, 0.17)
    assert checker.is_free(q_wall) and not truth.is_free(q_wall)
    assert checker.known_obstacles == ["disc"]
    assert checker.clearance(q_wall) > 0.3
    assert np.any(loop & ~truth_loop)
    assert checker.reveal("wall") == ["wall"]
    assert not checker.is_free(q_wall)
    np.testing.assert_array_equal(checker.is_free_batch(Q), truth_loop)
    assert checker.clearance(q_wall) < 0
    # the checker follows reveals made on the world directly, and a reset
    world.reset()
    assert checker.is_free(q_wall)
    world.reveal("wall")
    assert not checker.is_free(q_wall)
    world.reset()
    checker.set_include_hidden(True)
    assert not checker.is_free(q_wall)
    checker.set_include_hidden(False)
    assert checker.is_free(q_wall)
    # certified edges follow reveals too (their cached per-level requests are rebuilt)
    sweep = (np.array([math.pi - 1.0, 0.0, 0.0]), np.array([math.pi + 0.3, 0.0, 0.0]))
    assert truth.is_free(sweep[0]) and truth.is_free(sweep[1])
    assert checker.edge_free(*sweep, 0.05) and not truth.edge_free(*sweep, 0.05)
    world.reveal("wall")
    assert not checker.edge_free(*sweep, 0.05)
    assert not checker.edges_free(sweep[0][None], sweep[1][None], 0.05)[0]
    world.reset()
    assert checker.edges_free(sweep[0][None], sweep[1][None], 0.05)[0]
    twin = checker.copy()
    assert twin is not checker and twin.geom_data is not checker.geom_data
    np.testing.assert_array_equal(twin.is_free_batch(Q), loop)
    # a security margin only removes configurations
    wide = CollisionChecker(arm, world, margin=0.05)
    assert np.all(wide.is_free_batch(Q) <= loop) and wide.is_free_batch(Q).sum() < loop.sum()


def test_pair_state_epochs():
    """The pair state is plain read-only data; it keeps its epoch while the world and the
    settings ask for the same pairs and margins, and gets a new one when they change."""
    arm = mp.builtin_arm("planar_3link")
    world = World([Cylinder.planar((0.55, 0.35), 0.12, name="disc"),
                   Box.planar((-0.5, 0.2), 0.2, 0.5, name="wall", hidden=True), HAZARD])
    geometry = build_geometry(arm, world, None)
    kw = dict(margin=0.01, include_hidden=False, hazard_clearance=False)
    s0 = pair_state(geometry, world, **kw)
    assert s0.epoch == 0 and not s0.active.flags.writeable and not s0.margins.flags.writeable
    wall, disc, hot = (geometry.obstacle_pairs["wall"], geometry.obstacle_pairs["disc"],
                       geometry.hazard_pairs["hot"])
    assert not s0.active[wall].any() and s0.active[disc].all() and s0.active[hot].all()
    assert s0.obstacle_idx == disc and s0.hazard_idx == hot
    assert pair_state(geometry, world, **kw, previous=s0) is s0
    world.reveal("wall")
    s1 = pair_state(geometry, world, **kw, previous=s0)
    assert s1.epoch == 1 and s1.active[wall].all() and s1.obstacle_idx == disc + wall
    world.reset()
    s2 = pair_state(geometry, world, **kw, previous=s1)
    assert s2.epoch == 2 and np.array_equal(s2.active, s0.active)
    s3 = pair_state(geometry, world, **{**kw, "hazard_clearance": True}, previous=s2)
    assert s3.epoch == 3 and np.all(s3.margins[hot] == HAZARD.clearance)
    assert np.all(np.delete(s3.margins, hot) == 0.01)
    # a level cache stamped with another epoch is emptied on use
    cache = LevelCache().at(s2.epoch)
    cache.normalised[b"x"] = (np.zeros(1), np.zeros(1))
    assert cache.at(s2.epoch).normalised and not cache.at(s3.epoch).normalised
    # the checker's state follows the world the same way
    checker = CollisionChecker(arm, world)
    e0 = checker.pair_state.epoch
    checker.set_include_hidden(False)
    assert checker.pair_state.epoch == e0
    checker.reveal("wall")
    assert checker.pair_state.epoch == e0 + 1
    world.reset()


def test_bisection_order():
    for n in range(40):
        order = bisection_order(n)
        np.testing.assert_array_equal(np.sort(order), np.arange(n + 1))
        assert not order.flags.writeable
        if n >= 1:
            assert order[:2].tolist() == [0, n]
    assert bisection_order(8).tolist() == [0, 8, 4, 2, 6, 1, 3, 5, 7]


# ------------------------------------------------------------- edge checks
def clearance_fn(spec, world, margin=0.0, hazard_clearance=False):
    """f(Q): min over obstacles, self pairs and hazards of (2-D signed distance − required
    clearance); an edge is valid when f > 0 all along it."""
    discs, polys = scene_2d(world)  # obstacles only
    hazards = [h for h in world if isinstance(h, Hazard)]
    haz_polys = [list(h.shape.vertices_xz) for h in hazards]
    haz_need = [max(margin, h.clearance if hazard_clearance else 0.0) for h in hazards]

    def f(Q):
        obs, selfd = brute_force(Q, spec.lengths, spec.radius, discs, polys)
        out = np.minimum(obs, selfd) - margin
        for P, need in zip(haz_polys, haz_need, strict=True):
            d, _ = brute_force(Q, spec.lengths, spec.radius, (), [P], False)
            out = np.minimum(out, d - need)
        return out

    return f


def brute_force_edges(f, Q0, Q1, reach, tau=0.0, step=1e-4):
    """Exact 2-D verdict on straight edges, sampled at joint steps ≤ ``step`` where needed.

    Returns (status, evaluations): +1 if f > tau is proven all along the edge, -1 if
    a sample has f ≤ tau, 0 if neither after sampling at ≤ ``step`` rad (near contact,
    every sample above tau). Independent of mpd_pin: f is the exact 2-D geometry and
    the only bound is the crude |df/dt| ≤ 2·reach·Σ|Δq_k| (every point of the arm is
    within ``reach`` of every joint axis; two links' relative speed is at most the sum
    of theirs). An interval [a, b] with (f(a) + f(b) − L·(b − a)) / 2 > tau is free;
    otherwise it is bisected. So wherever the edge is not proven free it is sampled at
    ≤ ``step``: "a sample at step 1e-4 collides" is decided exactly as by sampling the
    whole edge at that step, at a fraction of the cost.
    """
    D = Q1 - Q0
    lipschitz = 2 * reach * np.abs(D).sum(axis=1)
    fa, fb = f(Q0), f(Q1)
    status = np.where((fa <= tau) | (fb <= tau), -1, 1)
    e = np.flatnonzero(status > 0)
    a, b, va, vb = np.zeros(e.size), np.ones(e.size), fa[e], fb[e]
    evals = 2 * len(Q0)
    while e.size:
        open_ = (va + vb - lipschitz[e] * (b - a)) / 2 <= tau
        e, a, b, va, vb = e[open_], a[open_], b[open_], va[open_], vb[open_]
        fine = np.abs(D[e]).max(axis=1) * (b - a) <= step
        status[e[fine]] = np.minimum(status[e[fine]], 0)
        e, a, b, va, vb = e[~fine], a[~fine], b[~fine], va[~fine], vb[~fine]
        if not e.size:
            break
        m = (a + b) / 2
        vm = f(Q0[e] + m[:, None] * D[e])
        evals += e.size
        status[e[vm <= tau]] = -1
        go = status[e] >= 0
        e, a, b, va, vb, m, vm = (x[go] for x in (e, a, b, va, vb, m, vm))
        e = np.concatenate([e, e])
        a, b = np.concatenate([a, m]), np.concatenate([m, b])
        va, vb = np.concatenate([va, vm]), np.concatenate([vm, vb])
    return status, evals


HAZARD = Hazard(Polygon.planar([(0.9, -0.4), (1.3, -0.4), (1.1, -0.1)], name="hot"), 0.08)


@pytest.mark.parametrize(
    "name, margin, hazard_clearance",
    [("planar_3link", 0.0, True), ("planar_4link", 0.01, False)],
)
def test_certified_edges_vs_brute_force(name, margin, hazard_clearance):
    """1100 random edges per arm (2200 in all) among obstacles and a hazard.

    Every edge the certified check accepts is free at 100× finer discrete resolution
    and against the exact 2-D geometry sampled at 1e-4 rad; it accepts every edge
    whose exact clearance exceeds 0.05 m all along (not uselessly conservative).
    """
    spec = SPEC[name]
    arm = mp.builtin_arm(name)
    world = World([*scene(len(spec.lengths)), HAZARD])
    checker = CollisionChecker(arm, world, margin=margin, hazard_clearance=hazard_clearance)
    assert checker.edge_mode == "certified"
    rng = np.random.default_rng(21)
    K, res = 1100, 0.1
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, size=(K, arm.nq))
    Q1 = Q0 + rng.uniform(-0.4, 0.4, size=(K, arm.nq))
    cert = checker.edges_free(Q0, Q1, res)
    stats = dict(checker.last_certify_stats)
    disc = checker.edges_free(Q0, Q1, res, mode="discrete")
    f = clearance_fn(spec, world, margin, hazard_clearance)
    reach = sum(spec.lengths) + 2 * spec.radius
    truth, evals = brute_force_edges(f, Q0, Q1, reach)
    far, _ = brute_force_edges(f, Q0, Q1, reach, tau=0.05)
    # informative: plenty of both, some near contact
    assert 0.25 < cert.mean() < 0.75 and (far > 0).sum() > 100
    # sound: nothing accepted collides, at 100x finer resolution or in exact 2-D
    assert not np.any(cert & (truth < 0)), np.flatnonzero(cert & (truth < 0))
    assert checker.edges_free(Q0[cert], Q1[cert], res / 100, mode="discrete").all()
    # never accepts what the discrete check rejects; misses nothing exactly free by 0.05 m
    assert not np.any(cert & ~disc)
    assert cert[far > 0].all()
    # at most the near-contact band separates it from the exact verdict
    lost = (truth > 0) & ~cert
    assert lost.sum() <= 2, np.flatnonzero(lost)
    print(f"{name}: certified accepts {cert.mean():.4f}, discrete {disc.mean():.4f}, exact "
          f"free {(truth > 0).mean():.4f} (+{(truth == 0).sum()} near contact), free by "
          f"0.05 m {(far > 0).sum()}: certified {cert[far > 0].mean():.3f}, discrete "
          f"{disc[far > 0].mean():.3f}; discrete accepts {(disc & (truth < 0)).sum()} "
          f"colliding; {stats}; brute force {evals} evaluations")


def test_certified_single_equals_batch_and_endpoints():
    arm = mp.builtin_arm("planar_3link")
    world = World([*scene(3), HAZARD])
    checker = CollisionChecker(arm, world, hazard_clearance=True)
    rng = np.random.default_rng(9)
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, size=(150, 3))
    Q1 = Q0 + rng.uniform(-1.0, 1.0, size=(150, 3))
    for mode in ("certified", "discrete"):
        batch = checker.edges_free(Q0, Q1, 0.05, mode=mode)
        loop = [checker.edge_free(a, b, 0.05, mode=mode) for a, b in zip(Q0, Q1, strict=True)]
        np.testing.assert_array_equal(batch, loop)
        assert 0.1 < batch.mean() < 0.9
    # a discrete checker by default, and copies keep the mode
    discrete = CollisionChecker(arm, world, hazard_clearance=True, edge_mode="discrete")
    np.testing.assert_array_equal(discrete.edges_free(Q0, Q1, 0.05),
                                  checker.edges_free(Q0, Q1, 0.05, mode="discrete"))
    assert discrete.copy().edge_mode == "discrete"
    # both ends count, and a free point is an edge
    free_q = Q0[checker.is_free_batch(Q0)][0]
    bad_q = Q0[~checker.is_free_batch(Q0)][0]
    for mode in ("certified", "discrete"):
        assert not checker.edge_free(free_q, bad_q, 0.05, mode=mode)
        assert not checker.edge_free(bad_q, free_q, 0.05, mode=mode)
        assert checker.edge_free(free_q, free_q, 0.05, mode=mode)
    assert checker.edges_free(np.zeros((0, 3)), np.zeros((0, 3)), 0.05).shape == (0,)
    E = edge_configurations(np.zeros(3), np.array([1.0, -0.3, 0.0]), 0.1)
    assert len(E) == 11 and np.allclose(E[0], 0) and np.allclose(E[-1], [1.0, -0.3, 0.0])
    assert np.abs(np.diff(E, axis=0)).max() <= 0.1 + 1e-12


def test_certified_thin_obstacle_and_too_close_to_call():
    """A thin wall between two checks of the discrete edge check; a graze at 1e-8 m."""
    arm = mp.builtin_arm("planar_3link")  # links 0.5, 0.4, 0.3 m, radius 0.03 m
    # Joint 1 turns 0 → 0.1 rad: the tip sweeps an arc of 0.12 m. A 2 mm wall across it
    # at 0.05 rad sits between the discrete checks at 0.1 rad resolution.
    c, s = math.cos(0.05), math.sin(0.05)
    wall = Box.planar((1.1 * c, 1.1 * s), 0.002, 0.15, angle=0.05 + math.pi / 2, name="wall")
    checker = CollisionChecker(arm, World([wall]))
    q0, q1 = np.zeros(3), np.array([0.1, 0.0, 0.0])
    assert checker.is_free(q0) and checker.is_free(q1)
    assert not checker.is_free(np.array([0.05, 0.0, 0.0]))
    assert checker.edge_free(q0, q1, 0.1, mode="discrete")  # the discrete check misses it
    assert not checker.edge_free(q0, q1, 0.1)
    assert not checker.edges_free(q0[None], q1[None], 0.1)[0]
    # Straight arm along x: its end face is at x = 1.2. A disc just beyond it.
    for gap, expect in ((1e-8, False), (1e-3, True)):
        disc = Cylinder.planar((1.2 + 0.1 + gap, 0.0), 0.1, name="disc")
        near = CollisionChecker(arm, World([disc]))
        assert near.is_free(q0)
        assert near.edge_free(q0, q0, 0.05) is expect
        assert near.last_certify_stats["too_close"] == (0 if expect else 1)
    # a coarser minimum step gives up sooner
    coarse = CollisionChecker(arm, World([Cylinder.planar((1.3 + 1e-3, 0.0), 0.1)]),
                              min_step=0.01)
    assert not coarse.edge_free(q0, q0, 0.05)


def _geometry_points(go, rng, n=12):
    """Corners of a geometry's local AABB and random points inside, in its joint frame."""
    geom = go.geometry
    lo, hi = np.asarray(geom.aabb_local.min_), np.asarray(geom.aabb_local.max_)
    corners = np.array([[(lo, hi)[b >> i & 1][i] for i in range(3)] for b in range(8)])
    P = np.vstack([corners, rng.uniform(lo, hi, size=(n, 3))])
    return P @ go.placement.rotation.T + go.placement.translation


SLIDER_URDF = """<?xml version="1.0"?>
<robot name="slider">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0.25 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.03" length="0.5"/></geometry></collision></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0.2 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.03" length="0.4"/></geometry></collision></link>
  <link name="l3"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0.15 0.02 0" rpy="0 0 0.3"/>
      <geometry><box size="0.3 0.05 0.08"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 -1 0"/>
    <limit effort="10" velocity="1" lower="-3.1" upper="3.1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0" rpy="0 0 0"/><axis xyz="0.6 0 0.8"/>
    <limit effort="10" velocity="1" lower="-0.2" upper="0.4"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0" rpy="0.2 0 0"/><axis xyz="0 0 1"/>
    <limit effort="10" velocity="1" lower="-3.1" upper="3.1"/></joint>
</robot>
"""


def test_pair_weights_prismatic():
    """With a prismatic joint the levers grow with |q| of the joint: W is monotone in
    ``qabs``, equals the revolute-only part at qabs = 0, and max_abs reads the
    configurations' largest |q| per coordinate."""
    arm = mp.Arm.from_urdf(SLIDER_URDF)
    checker = CollisionChecker(arm, World([Box((0.2, 0.2, 0.2), (0.8, 0.0, 0.3))]))
    bounds = motion_bounds(arm.model, arm.collision_model, checker.geom_model)
    assert bounds.prismatic is not None and bounds.constant is None and not bounds.unsupported
    Q = np.array([[0.1, -0.2, 1.0], [-0.3, 0.35, 0.0]])
    np.testing.assert_array_equal(max_abs(bounds, Q[:1], Q[1:]), [0.3, 0.35, 1.0])
    W0 = pair_weights(bounds, np.zeros(3))
    W1 = pair_weights(bounds, np.array([0.0, 0.4, 0.0]))
    assert np.all(W1 >= W0) and np.any(W1 > W0)
    # only the revolute joint 1 sees the prismatic extension (joint 3 is beyond it)
    grew = W1 - W0
    assert np.all(grew[:, 1:] == 0) and np.all(grew[:, 0] >= 0)


@pytest.mark.parametrize("name", ["planar_3link", "planar_4link", "panda", "slider"])
def test_displacement_bound(name):
    """Points of the geometries (AABB corners and random points inside), moved by forward
    kinematics along random segments in 400 steps: their path lengths never exceed the
    pair's bound. Obstacle pairs: the arm geometry's points in the world. Self pairs:
    both geometries' points in the frame of their deepest common joint (the distance
    does not depend on the frame; the joints they share move both rigidly), summed.
    "slider": revolute, prismatic (oblique axis), revolute out of the plane."""
    if name == "panda":
        arm = mp.Arm.from_example_robot_data("panda")
        world = World([Box((0.2, 0.2, 0.2), (0.5, 0.0, 0.4), name="box")])
    elif name == "slider":
        arm = mp.Arm.from_urdf(SLIDER_URDF)
        world = World([Box((0.2, 0.2, 0.2), (0.8, 0.0, 0.3), name="box")])
    else:
        arm = mp.builtin_arm(name)
        world = scene(len(SPEC[name].lengths))
    checker = CollisionChecker(arm, world)
    model, gm = checker.model, checker.geom_model
    data = model.createData()
    rng = np.random.default_rng(5)
    n_arm = len(checker.arm_geometry_ids)
    points = [_geometry_points(gm.geometryObjects[g], rng) for g in range(n_arm)]
    joint_of = [gm.geometryObjects[g].parentJoint for g in range(n_arm)]

    def chain(j):
        out = [j]
        while j > 0:
            j = model.parents[j]
            out.append(j)
        return out

    ratios = []
    for _ in range(6 if name == "panda" else 25):
        q0 = rng.uniform(arm.lower_limits, arm.upper_limits)
        q1 = q0 + rng.uniform(-0.5, 0.5, size=arm.nq)
        bound = checker.displacement_bounds(q0, q1)
        assert bound.shape == (len(gm.collisionPairs),) and np.all(bound >= 0)
        R = np.empty((401, model.njoints, 3, 3))  # joint placements at 401 configurations
        p = np.empty((401, model.njoints, 3))
        for s, t in enumerate(np.linspace(0.0, 1.0, 401)):
            pin.forwardKinematics(model, data, q0 + t * (q1 - q0))
            for j in range(model.njoints):
                R[s, j], p[s, j] = data.oMi[j].rotation, data.oMi[j].translation

        def path_length(g, frame, R=R, p=p):
            """Longest path of geometry g's points, expressed in joint ``frame``'s frame."""
            j = joint_of[g]
            X = np.einsum("sij,nj->sni", R[:, j], points[g]) + p[:, j, None, :]
            X = np.einsum("sji,snj->sni", R[:, frame], X - p[:, frame, None, :])
            return np.linalg.norm(np.diff(X, axis=0), axis=-1).sum(axis=0).max()

        for k, cp in enumerate(gm.collisionPairs):
            a, b = int(cp.first), int(cp.second)
            if a >= n_arm:
                a, b = b, a
            if b >= n_arm:  # fixed obstacle
                length = path_length(a, 0)
            else:
                common = set(chain(joint_of[b]))
                lca = next(j for j in chain(joint_of[a]) if j in common)
                length = path_length(a, lca) + path_length(b, lca)
            assert length <= bound[k] * (1 + 1e-9) + 1e-12, (k, length, bound[k])
            if bound[k] > 0:
                ratios.append(length / bound[k])
    ratios = np.array(ratios)
    assert ratios.max() > 0.5  # not vacuous
    print(f"{name}: path length / bound over {len(ratios)} pair-segments: "
          f"median {np.median(ratios):.2f}, max {ratios.max():.3f}")


def test_panda_certified_edges():
    arm = mp.Arm.from_example_robot_data("panda")
    world = World([Box((0.3, 0.3, 0.3), (0.5, 0.0, 0.3), name="box"),
                   Box((0.2, 0.6, 0.1), (-0.4, 0.2, 0.6), name="shelf")])
    checker = CollisionChecker(arm, world)
    rng = np.random.default_rng(8)
    K = 40
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, size=(K, arm.nq))
    Q1 = np.clip(Q0 + rng.uniform(-0.4, 0.4, size=Q0.shape), arm.lower_limits, arm.upper_limits)
    cert = checker.edges_free(Q0, Q1, 0.05)
    stats = dict(checker.last_certify_stats)
    meshes = [go.name for go in arm.collision_model.geometryObjects if "finger" not in go.name]
    assert checker.certification_hulls == sorted(meshes) and len(meshes) == 9
    fine = checker.edges_free(Q0, Q1, 0.002, mode="discrete")
    # clear by 2 cm at samples 0.002 rad apart, hence free all along (between two samples
    # no point is farther than 0.001 rad x 4.6 m/rad = 4.6 mm from one: S_p < 4.6 m/rad)
    clear = CollisionChecker(arm, world, margin=0.02).edges_free(Q0, Q1, 0.002, mode="discrete")
    assert not np.any(cert & ~fine)
    assert cert[clear].all()
    assert 0.2 < cert.mean() < 0.9 and clear.sum() >= 5
    assert checker.displacement_bounds(np.zeros(7), np.ones(7)).max() < 4.6  # = max S_p
    loop = [checker.edge_free(a, b, 0.05) for a, b in zip(Q0[:10], Q1[:10], strict=True)]
    np.testing.assert_array_equal(loop, cert[:10])
    print(f"panda: certified {cert.mean():.3f}, fine discrete {fine.mean():.3f}, clear by 2 cm "
          f"{clear.mean():.3f}; {stats}")
    # certified on the meshes themselves: never rejects what the hulls accept (a hull's
    # clearance is at most its mesh's), and its fingerprint says so (the default's has no
    # such key: roadmap keys built on it are unchanged)
    plain = CollisionChecker(arm, world, certify_on_hulls=False)
    on_mesh = plain.edges_free(Q0[:20], Q1[:20], 0.05)
    assert plain.certification_hulls == [] and plain.copy().certify_on_hulls is False
    assert not np.any(cert[:20] & ~on_mesh) and not np.any(on_mesh & ~fine[:20])
    assert "certify_on_hulls" not in checker.describe()
    assert plain.describe() == {**checker.describe(), "certify_on_hulls": False}


def test_hazards():
    arm = mp.builtin_arm("planar_3link")
    zone = Hazard(Polygon.planar([(0.9, -0.4), (1.3, -0.4), (1.1, -0.1)], name="hot"), 0.1)
    checker = CollisionChecker(arm, World([zone]))
    q_far = np.array([math.pi / 2, 0.0, 0.0])  # arm straight up: far from the zone
    q_in = np.array([-0.25, 0.0, 0.0])  # tip (1.163, -0.297) inside the triangle
    assert checker.is_free(q_far) and not checker.is_free(q_in)
    # clearance measures to the hazard's geometry; obstacles only: none here
    assert math.isinf(checker.clearance(q_far, hazards=False))
    spec = SPEC["planar_3link"]
    Q3 = np.array([q_far, q_in, np.zeros(3)])
    ref = min_signed_distance(Q3, spec.lengths, spec.radius, World([zone]), self_collision=False)
    assert ref[0] > 0.5 and ref[1] < 0 and ref[2] == pytest.approx(0.07, abs=1e-12)
    assert checker.clearance(q_far) == pytest.approx(ref[0], abs=1e-6)
    assert checker.clearance(q_far) == pytest.approx(checker.distances(q_far)["hot"], abs=1e-12)
    assert checker.clearance(q_in) < 0
    assert checker.hazard_margin(q_far) == pytest.approx(ref[0] - 0.1, abs=1e-6)
    # at q = 0 the arm (along x, radius 0.03) passes 0.07 m above the apex (1.1, -0.1)
    q0 = np.zeros(3)
    d = checker.distances(q0)["hot"]
    assert d == pytest.approx(0.07, abs=1e-6)
    assert checker.is_free(q0)
    assert checker.hazard_margin(q0) == pytest.approx(d - 0.1, abs=1e-9)
    checker.set_hazard_clearance(True)
    assert not checker.is_free(q0) and checker.is_free(q_far)
    Q = np.array([q0, q_far, q_in])
    np.testing.assert_array_equal(checker.is_free_batch(Q), [False, True, False])
    assert checker.hazard_margin(q_far) > 0


def test_panda_box():
    arm = mp.Arm.from_example_robot_data("panda")
    world = World([Box((0.2, 0.2, 0.2), (0.55, 0.0, 0.45), name="box"),
                   Box((1.0, 1.0, 0.05), (0.0, 0.0, -0.2), name="floor")])
    checker = CollisionChecker(arm, world)
    assert len(checker.self_pairs) == len(arm.collision_model.collisionPairs) > 0
    q_ref = arm.q_reference
    assert checker.is_free(q_ref)  # the robot's reference posture clears the box
    # move the end effector into the box: find a configuration whose hand is in it
    hand = np.array(arm.frame_position(q_ref, "panda_hand_tcp"))
    moved = World([Box((0.2, 0.2, 0.2), tuple(hand), name="box")])
    assert not CollisionChecker(arm, moved).is_free(q_ref)
    # links 4-6 reach through the box; with the shoulder lower the fingers hit the floor
    q_box, q_floor = q_ref.copy(), q_ref.copy()
    q_box[[1, 3]] = (1.0, -1.0)
    q_floor[[1, 3]] = (1.5, -1.0)
    assert not checker.is_free(q_box) and not checker.is_free(q_floor)
    assert {b for _, b in checker.in_collision_pairs(q_box)} == {"obstacle:box"}
    assert {b for _, b in checker.in_collision_pairs(q_floor)} == {"obstacle:floor"}
    assert checker.in_collision_pairs(q_ref) == []
    rng = np.random.default_rng(4)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(300, arm.nq))
    loop = np.array([checker.is_free(q) for q in Q])
    np.testing.assert_array_equal(checker.is_free_batch(Q), loop)
    assert 0 < loop.mean() < 1
    assert checker.clearance(q_ref) > 0


@pytest.mark.parametrize(
    "bad",
    [
        lambda c: c.is_free([0.0, np.nan, 0.0]),
        lambda c: c.is_free([0.0, 0.0]),
        lambda c: c.is_free_batch(np.zeros((3, 2))),
        lambda c: c.is_free_batch(np.full((2, 3), np.inf)),
        lambda c: c.edge_free(np.zeros(3), np.ones(3), 0.0),
        lambda c: c.edge_free(np.zeros(3), np.ones(3), -0.1),
        lambda c: c.edges_free(np.zeros((2, 3)), np.zeros((3, 3)), 0.1),
        lambda c: c.edge_free(np.zeros(3), np.ones(3), 0.1, mode="exact"),
        lambda c: c.edges_free(np.zeros((1, 3)), np.ones((1, 3)), 0.1, mode="continuous"),
        lambda c: c.displacement_bounds(np.zeros(3), np.ones(2)),
        lambda c: c.clearance([np.nan] * 3),
        lambda c: c.reveal("nonexistent"),
    ],
)
def test_bad_input(bad):
    checker = CollisionChecker(mp.builtin_arm("planar_3link"), scene(3))
    with pytest.raises(ValueError):
        bad(checker)


def test_bad_constructor():
    arm = mp.builtin_arm("planar_3link")
    with pytest.raises(ValueError):
        CollisionChecker(arm, world=[Box((1, 1, 1))])
    with pytest.raises(ValueError):
        CollisionChecker(arm, margin=-1.0)
    with pytest.raises(ValueError):
        CollisionChecker(arm, num_threads=0)
    with pytest.raises(ValueError):
        CollisionChecker(arm, single_backend="gpu")
    with pytest.raises(ValueError):
        CollisionChecker(arm, edge_mode="fast")
    with pytest.raises(ValueError):
        CollisionChecker(arm, min_step=0.0)
    assert CollisionChecker(arm).single_backend == "pairs"
    assert CollisionChecker(mp.Arm.from_example_robot_data("panda")).single_backend == "broadphase"


def test_the_hull_screen_gives_the_meshes_answers(monkeypatch):
    """The UR5's meshes are not nearly convex, so certification queries them; with the
    hull screen (the default) each query asks every mesh's convex hull first and the
    meshes only where the hull is not clear. Reference: the same checker without the
    screen (meshes only) gives the same edges and boxes, and every accepted edge is free
    at 60 samples (brute force); the screen answered queries the meshes then did not get."""
    import mpd_pin.collision.motion as cm
    import mpd_pin.collision.validity as cv

    arm = mp.Arm.from_example_robot_data("ur5")
    world = World((Box((0.3, 0.3, 0.3), position=(0.35, 0.15, 0.35), name="crate"),
                   Box((1.5, 1.5, 0.02), position=(0.0, 0.0, -0.02), name="table")))
    on, off = CollisionChecker(arm, world), CollisionChecker(arm, world, screen_on_hulls=False)
    rng = np.random.default_rng(3)
    lo, hi = np.maximum(arm.lower_limits, -np.pi), np.minimum(arm.upper_limits, np.pi)
    Q = rng.uniform(lo, hi, size=(600, arm.nq))
    Q = Q[on.is_free_batch(Q)][:240]
    Q0, Q1 = Q[:120], Q[:120] + rng.uniform(-0.6, 0.6, size=(120, arm.nq))
    rows = []
    original = cv.batch_collides

    def counted(model, data, state, X, pools):
        rows.append((state.screen is None, state.gm, X.shape[0]))  # the calls that query
        return original(model, data, state, X, pools)

    monkeypatch.setattr(cv, "batch_collides", counted)
    monkeypatch.setattr(cm, "batch_collides", counted)
    got = on.edges_free(Q0, Q1, 0.05)
    monkeypatch.undo()
    hulls, meshes = on._cert_model().screen[0], on._cert_model().gm
    screened = sum(n for q, gm, n in rows if q and gm is hulls)
    asked = sum(n for q, gm, n in rows if q and gm is meshes)
    want = off.edges_free(Q0, Q1, 0.05)
    assert on._cert_model().screen is not None and off._cert_model().screen is None
    np.testing.assert_array_equal(got, want)
    assert 10 < got.sum() < len(got) - 10  # both kinds of edge
    t = np.linspace(0.0, 1.0, 60)
    for q0, q1 in zip(Q0[got], Q1[got], strict=True):
        assert on.is_free_batch(q0 + t[:, None] * (q1 - q0)).all()
    assert 0 < asked < screened  # the hulls cleared queries on their own
    # boxes (the curves' certificate): on a level whose margins grow by more than
    # HULL_ONLY_ABOVE the hulls answer alone (never the meshes; a box they certify, the
    # meshes do too; the centre's exact check is the same); below it, the meshes' answers
    C = Q[120:]
    assert len(C) >= 20
    for size, coarse in ((0.02, True), (0.002, False)):
        Delta = np.full(C.shape, size)
        h = float(on.box_sizes(C, Delta).max())
        rows.clear()
        monkeypatch.setattr(cm, "batch_collides", counted)
        clear, hit = on.boxes_clear(C, Delta, h)
        monkeypatch.undo()
        level_rows = [r for r in rows if r[2] == len(C)]  # the level query (all centres)
        want_clear, want_hit = off.boxes_clear(C, Delta, h)
        np.testing.assert_array_equal(hit, want_hit)
        assert not (clear & ~want_clear).any()
        assert 0 < clear.sum() < len(C)
        if coarse:
            assert [gm for _, gm, _ in level_rows] == [hulls]
            assert clear.sum() < want_clear.sum()  # the hulls alone are more cautious
        else:
            assert [gm for _, gm, _ in level_rows] == [meshes]  # screened on the hulls
            np.testing.assert_array_equal(clear, want_clear)
    # curves certify to the same answer and the same first failure (bisection only
    # goes deeper where the hulls alone could not certify what the meshes do)
    from mpd_pin.motion.certify import first_failure
    from mpd_pin.motion.spline import unit_knots, via_spline

    outcomes = set()
    for k in range(12):
        W = np.vstack([Q[k], Q[k + 12], Q[k + 24]])
        vs = via_spline(W, unit_knots(W, np.ones(arm.nq)))
        got_t, want_t = first_failure(on, vs, 0.05), first_failure(off, vs, 0.05)
        assert got_t == want_t
        outcomes.add(got_t is None)
    assert outcomes == {True, False}


def test_the_hull_screen_follows_a_revealed_obstacle_and_hazard_margins():
    """The screen's query states are derived from the pair state (margins, active pairs)
    and cached per epoch: after a hidden obstacle is revealed, and with a hazard's
    clearance enforced, the UR5's certified edges with the screen are those without it,
    and the reveal changed some of them."""

    def world():
        return World((Box((0.3, 0.3, 0.3), position=(0.35, 0.15, 0.35), name="crate"),
                      Box((0.1, 0.1, 0.6), position=(-0.3, -0.3, 0.3), name="post",
                          hidden=True),
                      Hazard(Sphere(0.1, position=(0.0, 0.45, 0.5), name="hot"), 0.05)))

    arm = mp.Arm.from_example_robot_data("ur5")
    on = CollisionChecker(arm, world(), hazard_clearance=True)
    off = CollisionChecker(arm, world(), hazard_clearance=True, screen_on_hulls=False)
    rng = np.random.default_rng(5)
    lo, hi = np.maximum(arm.lower_limits, -np.pi), np.minimum(arm.upper_limits, np.pi)
    Q = rng.uniform(lo, hi, size=(900, arm.nq))
    Q = Q[on.is_free_batch(Q)][:150]
    Q0, Q1 = Q[:75], Q[75:150]
    before = on.edges_free(Q0, Q1, 0.05)
    np.testing.assert_array_equal(before, off.edges_free(Q0, Q1, 0.05))
    assert on.reveal("post") == ["post"] and off.reveal("post") == ["post"]
    after = on.edges_free(Q0, Q1, 0.05)
    np.testing.assert_array_equal(after, off.edges_free(Q0, Q1, 0.05))
    assert np.any(before & ~after) and not np.any(after & ~before)
    assert on._cert_model().screen is not None


def test_an_arm_without_collision_shapes_is_refused_among_obstacles():
    """example-robot-data's asr_twodof has no <collision> element (counted in its URDF
    text): every check would pass, so among obstacles the checker refuses it, naming why;
    without obstacles it is a valid (collision-free) problem."""
    import re

    from mpd_pin.arm.model import _erd_files

    urdf = open(_erd_files("asr_twodof").df_path, encoding="utf-8").read()
    assert re.search(r"<collision[\s>]", urdf) is None and "<link" in urdf
    arm = mp.Arm.from_example_robot_data("asr_twodof")
    with pytest.raises(ValueError, match=r"asr_twodof.*no collision geometry.*1 obstacle"):
        CollisionChecker(arm, World((Box((0.2, 0.2, 0.2), position=(0.3, 0.0, 0.3)),)))
    free = CollisionChecker(arm, World(()))
    assert free.is_free_batch(np.zeros((2, arm.nq))).all()


def test_one_joint_arm_edges_against_dense_sampling():
    """A one-joint arm (its Jacobian comes back 1-D from Pinocchio): the certified edge
    check agrees with a dense brute-force sampling of the same edges."""
    import mpd_pin as mp
    from mpd_pin.collision import CollisionChecker

    arm = mp.Arm.from_urdf(mp.planar_arm_urdf([0.5], [1.0]))
    checker = CollisionChecker(arm, mp.World([mp.Box.planar([0.3, 0.0], 0.1, 0.1)]))
    Q0 = np.array([[1.5], [1.0], [-2.0], [0.5], [-0.5]])
    Q1 = np.array([[-1.5], [2.0], [-0.5], [3.0], [0.5]])
    got = np.asarray(checker.edges_free(Q0, Q1, 0.05), dtype=bool)
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    brute = [all(checker.is_free(q0 + t * (q1 - q0)) for t in s)
             for q0, q1 in zip(Q0, Q1, strict=True)]
    assert got.tolist() == brute == [False, True, True, True, False]
