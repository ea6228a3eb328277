"""Motions (docs/design.md §9): what a path costs stop-and-go and non-stop, the non-stop
spline and its collision certificate, and energy-aware shortcutting.

References: the roadmap's own edge energies and :func:`simulate_edge` (the per-edge
reference implementation) for stop-and-go; an independent RK4 on the sympy model of
``test_energy_sympy`` for non-stop (its reference built by scipy at the stretched knots,
its feed-forward from the sympy D, C, G with τ̇ by central differences); dense sampling
for the curve certificate; networkx on a layered graph for the shortcut DP.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from scipy.interpolate import make_interp_spline

import mpd_pin as mp
from mpd_pin.app.kinds import load_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.motion.energy import simulate_nonstop, trajectory_energy
from mpd_pin.motion.refine import OPTIMIZED, MotionOptions, refine_candidates
from mpd_pin.motion.series import motion_series
from mpd_pin.motion.shortcut import _dp, densify, shortcut_path
from mpd_pin.motion.spline import arc_boxes, pieces, unit_knots, via_spline
from mpd_pin.planning.roadmap import RoadmapOptions, build_roadmap
from mpd_pin.world import Box, World

try:
    from test_energy_sympy import GEARED_PAPER, _motor_args, sympy_drive
except ImportError:  # pragma: no cover
    from tests.test_energy_sympy import GEARED_PAPER, _motor_args, sympy_drive


@pytest.fixture(scope="module")
def quick():
    """quickstart: its drive, checker and options (3-link arm, sized motors)."""
    scn = load_scenario("quickstart")
    return scn, scn.drive(), CollisionChecker(scn.arm, scn.world)


@pytest.fixture(scope="module")
def quick_roadmap(quick):
    """quickstart's own roadmap (its options), every edge simulated, and its energy-optimal
    path by networkx."""
    scn, drive, checker = quick
    opts = scn.options
    rm = build_roadmap(mp.dynamics.EnergyCost(drive, opts.dt), checker, scn.start, scn.goal,
                       opts, show_progress=False)
    G = nx.DiGraph()
    for s, d, e in zip(rm.src, rm.dst, rm.energy.sum(axis=1), strict=True):
        G.add_edge(int(s), int(d), weight=float(e))
    return rm, nx.shortest_path(G, 0, 1, weight="weight")


@pytest.fixture(scope="module")
def free_path(quick_roadmap):
    """A certified-free path from start to goal: the roadmap's energy optimum (rad)."""
    rm, path = quick_roadmap
    return rm.nodes[path]


# ----------------------------------------------------------------------------- stop
def test_stop_energy_is_the_roadmaps_edge_energy(quick, quick_roadmap):
    """"stop" prices a roadmap path at exactly the roadmap's energy (same integrator, same
    durations), and matches simulate_edge edge by edge."""
    scn, drive, checker = quick
    rm, path = quick_roadmap
    opts = scn.options
    assert len(path) >= 3
    me = trajectory_energy(drive, rm.nodes[path], "stop", options=opts, checker=checker)
    assert me.feasible and me.execution == "stop"
    np.testing.assert_array_equal(me.energy_per_joint, rm.path_energy(path))
    ids = rm.edge_ids(path)
    np.testing.assert_array_equal(me.piece_durations, rm.durations[ids])
    ref = sum(mp.simulate_edge(drive, rm.nodes[u], rm.nodes[v], float(T), opts.dt).energy
              for u, v, T in zip(path[:-1], path[1:], rm.durations[ids], strict=True))
    np.testing.assert_allclose(me.energy_per_joint, ref, rtol=1e-9)
    assert me.stops == len(path) - 2
    assert me.duration == pytest.approx(float(rm.durations[ids].sum()))


def test_stop_refuses_a_colliding_segment(quick):
    scn, drive, checker = quick
    me = trajectory_energy(drive, [scn.start, scn.goal], "stop", options=scn.options,
                           checker=checker)
    assert not checker.edges_free(scn.start[None], scn.goal[None], 0.05)[0]
    assert not me.feasible and "from waypoint 1 to 2" in me.reason


# ----------------------------------------------------------------------------- spline
def test_two_point_spline_is_the_edge_quintic(quick):
    """A non-stop piece through two points is the rest-to-rest quintic: same energy as the
    edge (different code paths: spline tables vs the quintic batch)."""
    scn, drive, _ = quick
    q0, q1 = scn.start, scn.start + np.array([0.4, -0.3, 0.5])
    vs = via_spline(np.array([q0, q1]), [0.0, 1.0])
    E, *_ = simulate_nonstop(drive, vs, np.array([1.5]), 5e-3)
    ref = mp.edge_energies(drive, q0, q1, 1.5, 5e-3)
    np.testing.assert_allclose(E, ref, rtol=1e-9)


def test_spline_passes_through_waypoints_at_rest():
    W = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.2], [2.0, 0.0]])
    vs = via_spline(W, unit_knots(W, np.array([1.0, 2.0])))
    np.testing.assert_allclose(vs.spline(vs.knots), W, atol=1e-12)
    q, v, a, j = vs.derivatives(np.array([0.0, 4.0, 9.0]), 4.0)
    np.testing.assert_allclose(v[[0, 1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(a[[0, 1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(q[2], W[-1])  # holds the end after T, at rest
    assert np.all(j[1] != 0) and np.all(j[2] == 0) and np.all(v[2] == 0)
    # stretching: q_T(t) = q(t t_m / T), derivatives scale by (t_m/T)^k
    T, t = 5.0, np.array([0.7, 2.1])
    s = vs.unit_duration / T
    q, v, a, j = vs.derivatives(t, T)
    for k, d in enumerate((q, v, a, j)):
        np.testing.assert_allclose(d, vs.spline(t * s, k) * s**k, rtol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_arc_boxes_contain_the_curve(seed):
    rng = np.random.default_rng(seed)
    W = rng.uniform(-2, 2, (5, 3))
    vs = via_spline(W, unit_knots(W, np.ones(3)))
    a, b = pieces(vs)
    # split each piece at random points: the boxes of sub-arcs must hold them too
    cut = a + rng.uniform(0.2, 0.8, a.size) * (b - a)
    a2, b2 = np.concatenate([a, cut]), np.concatenate([cut, b])
    C, D = arc_boxes(vs, a2, b2)
    for k in range(a2.size):
        q = vs.spline(np.linspace(a2[k], b2[k], 400))
        assert np.all(np.abs(q - C[k]) <= D[k] + 1e-12)
    # tight: the box is not wildly larger than the sampled range
    q = vs.spline(np.linspace(a[0], b[0], 400))
    assert np.all(D[0] <= (q.max(0) - q.min(0)) + 1e-9)


# ----------------------------------------------------------------------------- non-stop
def _sympy_nonstop(drive, W, knots_T, dt, ff=True):
    """Independent classic RK4 on the sympy 3-link model tracking the quintic spline built
    by scipy directly at the stretched knots ``knots_T`` (s); returns E⁺ per joint (J)."""
    sd = sympy_drive("planar_3link")
    arm, nq = sd.arm, sd.nq
    mot = _motor_args(drive)
    zero = np.zeros(nq)
    spl = make_interp_spline(knots_T, W, k=5, bc_type=([(1, zero), (2, zero)],
                                                       [(1, zero), (2, zero)]))
    T = float(knots_T[-1])
    armature, damping = drive.armature, drive.damping

    def ref(t):
        t = min(t, T)
        return spl(t), spl(t, 1), spl(t, 2)

    def tau_ff(t):
        q, v, a = ref(t)
        return (arm.mass_matrix(q) @ a + arm.coriolis_matrix(q, v) @ v + arm.gravity(q)
                + armature * a + damping * v)

    kt = drive.torque_per_amp

    def voltage(t, q, v):
        qr, vr, _ = ref(t)
        V = drive.kp_vec * (qr - q) + drive.kd_vec * (vr - v)
        if ff:
            d = 1e-6
            dtau = (tau_ff(min(t + d, T)) - tau_ff(max(t - d, 0.0))) / (
                min(t + d, T) - max(t - d, 0.0))
            i_ff = tau_ff(t) / kt
            V = V + drive.R * i_ff + drive.L * dtau / kt + drive.emf_per_rad_s * vr
        return V

    def rate(t, x):
        q, v, i = x[:nq], x[nq:2 * nq], x[2 * nq:3 * nq]
        V = voltage(t, q, v)
        M = np.array(sd.mass(q, mot)).reshape(nq, nq)
        a = np.linalg.solve(M, np.array(sd.force(q, v, i, mot)))
        di = np.array(sd.didt(v, i, V, mot))
        return np.concatenate([v, a, di, np.maximum(V * i, 0.0)])

    x = np.concatenate([W[0], zero, arm.gravity(W[0]) / kt, zero])
    steps = round(T / dt)
    h = T / steps
    for k in range(steps):
        t = k * h
        k1 = rate(t, x)
        k2 = rate(t + h / 2, x + h / 2 * k1)
        k3 = rate(t + h / 2, x + h / 2 * k2)
        k4 = rate(t + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x[3 * nq:]


@pytest.mark.parametrize("ff", [True, False], ids=["ff", "pd"])
def test_nonstop_energy_matches_independent_sympy_rk4(ff):
    arm = mp.builtin_arm("planar_3link")
    # the paper's motor geared 5:1 (L/R = 0.5 s): not stiff at 5 ms, so the plain RK4 of the
    # reference integrates the currents as they are (as in test_energy_sympy)
    drive = mp.Drive(arm, GEARED_PAPER, 200.0, 150.0, feedforward=ff)
    W = np.array([[0.3, 0.2, -0.1], [0.9, -0.3, 0.4], [1.2, 0.1, 0.2], [1.0, -0.4, 0.5]])
    vs = via_spline(W, unit_knots(W, arm.model.velocityLimit))
    T = 2.4
    E, _, err, _, _, _ = simulate_nonstop(drive, vs, np.array([T, 3.0]), 5e-3)
    ref = _sympy_nonstop(drive, W, vs.knots * T / vs.unit_duration, 5e-3, ff=ff)
    np.testing.assert_allclose(E[0], ref, rtol=1e-6)
    assert np.all(np.isfinite(err[0]))
    # a second row in the same batch (longer) does not disturb the first
    E1, *_ = simulate_nonstop(drive, vs, np.array([T]), 5e-3)
    np.testing.assert_array_equal(E1[0], E[0])


def test_nonstop_duration_is_searched_and_within_limits(quick, free_path):
    scn, drive, checker = quick
    W = free_path
    me = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
    assert me.execution == "nonstop" and me.feasible, me.reason
    curve = np.array(me.duration_curve)
    ideal = np.array(me.ideal_curve)
    assert curve.shape[0] >= 1 and ideal.shape[0] >= 10
    assert me.total_energy == pytest.approx(curve[:, 1].min())  # the least E⁺ simulated
    assert me.duration == pytest.approx(curve[np.argmin(curve[:, 1]), 0])
    # the screen picked it: the simulated optimum sits at the screen's least E⁺ (or next to
    # it), and the screen is within 3 % of the simulation where both exist
    best = ideal[np.argmin(ideal[:, 1]), 0]
    neighbours = np.sort(ideal[:, 0])
    k = int(np.searchsorted(neighbours, best))
    assert neighbours[max(k - 1, 0)] - 1e-9 <= me.duration <= neighbours[
        min(k + 1, len(neighbours) - 1)] + 1e-9
    for T, E in curve:
        e_ideal = ideal[np.argmin(np.abs(ideal[:, 0] - T)), 1]
        assert e_ideal == pytest.approx(E, rel=0.03)
    assert me.velocity_ratio <= 1.0 and me.effort_ratio <= 1.0
    # max_duration caps the search
    cap = float(ideal[:, 0].min()) + 0.2
    capped = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker,
                               max_duration=cap)
    assert capped.duration <= cap + 1e-9
    assert capped.total_energy >= me.total_energy - 1e-9
    # too short for the velocity limits: infeasible, saying the minimum
    tiny = trajectory_energy(drive, W, "nonstop", options=scn.options, max_duration=0.05)
    assert not tiny.feasible and "needs" in tiny.reason


def test_auto_returns_the_cheaper_feasible(quick, free_path):
    scn, drive, checker = quick
    W = free_path
    auto = trajectory_energy(drive, W, "auto", options=scn.options, checker=checker)
    by = auto.energy_by_execution
    assert set(by) == {"stop", "nonstop"}
    assert auto.total_energy == pytest.approx(min(v for v in by.values() if v is not None))
    assert auto.alternative is not None and auto.alternative.execution != auto.execution


def test_series_integrates_to_the_reported_energy(quick, free_path):
    scn, drive, checker = quick
    W = free_path
    for ex in ("stop", "nonstop"):
        me = trajectory_energy(drive, W, ex, options=scn.options, checker=checker)
        s = motion_series(drive, me, scn.options.dt)
        np.testing.assert_allclose(s["energy_t"][-1], me.energy_per_joint, rtol=1e-9)
        sampled = np.trapezoid(np.maximum(s["V"] * s["i"], 0.0), s["t"], axis=0).sum()
        assert sampled == pytest.approx(me.total_energy, rel=0.02)
        assert s["t"][-1] == pytest.approx(me.duration)
        np.testing.assert_allclose(s["q"][-1], W[-1], atol=scn.options.arrival_tolerance)
        assert checker.is_free_batch(s["q"]).all()


def test_nonstop_curve_certificate_keeps_a_stop_where_the_curve_collides():
    """Via points around a block whose polyline is free but whose smooth curve cuts the
    corner: the certificate finds it and the motion keeps a stop there; every sample of the
    returned curve is free (brute force at 1 ms)."""
    arm = mp.builtin_arm("planar_2link")
    world = World((Box.planar((0.55, 0.55), 0.3, 0.3),))
    checker = CollisionChecker(arm, world)
    drive = mp.Drive(arm, mp.sized_motors(arm), 40.0, 4.0)
    opts = RoadmapOptions()
    W = None
    rng = np.random.default_rng(0)
    lo, hi = arm.model.lowerPositionLimit, arm.model.upperPositionLimit
    for _ in range(20000):  # a free polyline whose spline is not free
        cand = rng.uniform(lo, hi, (4, 2))
        if not (checker.is_free_batch(cand).all()
                and checker.edges_free(cand[:-1], cand[1:], 0.05).all()):
            continue
        vs = via_spline(cand, unit_knots(cand, arm.model.velocityLimit))
        if not checker.is_free_batch(vs.spline(np.linspace(0, vs.unit_duration, 2000))).all():
            W = cand
            break
    assert W is not None
    me = trajectory_energy(drive, W, "nonstop", options=opts, checker=checker)
    assert me.stops >= 1
    s = motion_series(drive, me, opts.dt)
    for a, b in me.pieces:
        vs = via_spline(W[a:b + 1], unit_knots(W[a:b + 1], arm.model.velocityLimit))
        dense = vs.spline(np.linspace(0, vs.unit_duration, 20000))
        assert checker.is_free_batch(dense).all()
    assert s["q"].shape[0] > 1


@pytest.mark.parametrize("seed", range(3))
def test_range_failure_agrees_with_dense_sampling(seed):
    """``range_failure`` against brute force: via splines through random waypoints near a
    joint range's ends (Panda-like: [-3.07, -0.07] and [-0.02, 3.75] rad). None exactly
    where 200,000 samples stay within the range (beyond 1e-6 rad of its tolerance either
    way), and where it names a time the curve is outside there. Both outcomes occur (about
    a third of these curves stay within)."""
    from mpd_pin.motion.certify import range_failure
    from mpd_pin.motion.outcome import RANGE_TOLERANCE

    rng = np.random.default_rng(seed)
    lo, hi = np.array([-3.0718, -0.0175]), np.array([-0.0698, 3.7525])
    seen = {True: 0, False: 0}
    for _ in range(60):
        W = rng.uniform(lo, hi, (5, 2))
        k, j = rng.integers(1, 4), rng.integers(0, 2)  # one via point near an upper limit
        W[k, j] = hi[j] - rng.uniform(0.0, 0.3)
        vs = via_spline(W, unit_knots(W, np.array([2.0, 2.5])))
        q = vs.spline(np.linspace(0.0, vs.unit_duration, 200_000))
        excess = float(np.max(np.maximum(q - hi, lo - q)))
        if abs(excess - RANGE_TOLERANCE) < 1e-6:
            continue  # too close to the tolerance for the samples to judge
        t = range_failure(vs, lo, hi)
        assert (t is not None) == (excess > RANGE_TOLERANCE), (excess, t)
        if t is not None:
            qt = vs.spline(np.array([t]))[0]
            assert np.max(np.maximum(qt - hi, lo - qt)) > RANGE_TOLERANCE
        seen[t is None] += 1
    assert seen[True] >= 5 and seen[False] >= 5, seen


def test_nonstop_pieces_keep_within_the_joint_range():
    """Waypoints within a Panda's range whose one non-stop curve swings past a joint limit
    (found by brute force: dense samples of the spline): priced non-stop, the motion keeps
    a stop where it would, and every piece's curve stays within the range (20,000 samples);
    so does the simulated series."""
    scn = load_scenario("panda")
    arm = scn.arm
    drive = scn.drive()
    lo, hi = arm.model.lowerPositionLimit.copy(), arm.model.upperPositionLimit.copy()
    vlim = arm.model.velocityLimit
    rng = np.random.default_rng(1)
    W = None
    for _ in range(2000):
        cand = rng.uniform(lo, hi, (4, arm.nq))
        cand[1, 3] = hi[3] - 0.01  # the elbow near its limit, between two far waypoints
        vs = via_spline(cand, unit_knots(cand, vlim))
        q = vs.spline(np.linspace(0.0, vs.unit_duration, 20_000))
        if np.max(np.maximum(q - hi, lo - q)) > 0.05:
            W = cand
            break
    assert W is not None
    me = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=None)
    assert me.stops >= 1
    for a, b in me.pieces:
        vs = via_spline(W[a:b + 1], unit_knots(W[a:b + 1], vlim))
        q = vs.spline(np.linspace(0.0, vs.unit_duration, 20_000))
        assert np.max(np.maximum(q - hi, lo - q)) <= 1e-6
    s = motion_series(drive, me, scn.options.dt)
    assert np.max(np.maximum(s["q"] - hi, lo - s["q"])) <= 1e-3  # tracking error only
    # the same curve as a timed trajectory (its own knot times, slowed 3×) is refused,
    # naming the joint the dense samples find furthest past its limit
    vs = via_spline(W, unit_knots(W, vlim))
    timed = trajectory_energy(drive, W, "timed", times=3.0 * vs.knots, options=scn.options)
    assert not timed.feasible
    q = vs.spline(np.linspace(0.0, vs.unit_duration, 20_000))
    worst = arm.joint_names[int(np.argmax(np.maximum(q - hi, lo - q).max(axis=0)))]
    assert "the curve leaves the joint range at t = " in timed.reason, timed.reason
    assert f"joint {worst!r} passes its" in timed.reason, timed.reason


# ----------------------------------------------------------------------------- shortcut
@pytest.mark.parametrize("seed", range(6))
def test_capped_dp_matches_networkx_on_a_layered_graph(seed):
    rng = np.random.default_rng(seed)
    n, cap = 9, 3
    I, J = np.triu_indices(n, 1)
    keep = rng.random(I.size) < 0.7
    keep |= J == I + 1  # the path itself is always there
    I, J = I[keep], J[keep]
    cost = rng.uniform(0.5, 3.0, I.size) * (J - I) ** 0.5
    cost[rng.random(I.size) < 0.1] = np.inf  # refused edges
    cost[J == I + 1] = np.where(np.isfinite(cost[J == I + 1]), cost[J == I + 1], 5.0)
    seq = _dp(n, I, J, cost, cap)
    G = nx.DiGraph()
    for i, j, c in zip(I, J, cost, strict=True):
        if np.isfinite(c):
            for layer in range(cap):
                G.add_edge((layer, int(i)), (layer + 1, int(j)), weight=float(c))
    for layer in range(1, cap + 1):
        G.add_edge((layer, n - 1), "goal", weight=0.0)
    ref = nx.shortest_path_length(G, (0, 0), "goal", weight="weight")
    got = sum(cost[np.flatnonzero((I == a) & (J == b))[0]]
              for a, b in zip(seq[:-1], seq[1:], strict=True))
    assert got == pytest.approx(ref, rel=1e-12)
    assert len(seq) - 1 <= cap and seq[0] == 0 and seq[-1] == n - 1


def test_densify_points_lie_on_the_segments():
    W = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 2.0]])
    P, seg = densify(W, 3)
    assert P.shape == (9, 2)
    np.testing.assert_allclose(P[[0, 4, 8]], W)
    np.testing.assert_allclose(P[2], [0.5, 1.0])
    assert seg.tolist() == [0, 0, 0, 0, 1, 1, 1, 1, 2]


def test_shortcut_lowers_energy_and_stays_certified(quick, quick_roadmap):
    scn, drive, checker = quick
    rm, path = quick_roadmap
    opts = scn.options
    W = rm.nodes[path]
    res = shortcut_path(drive, W, checker, opts)
    assert res.initial_energy == pytest.approx(float(rm.path_energy(path).sum()), rel=1e-12)
    assert res.total_energy <= res.initial_energy
    assert res.waypoints.shape[0] <= W.shape[0]
    Q = res.waypoints
    assert checker.edges_free(Q[:-1], Q[1:], 0.05).all()
    dense = np.concatenate([Q[k] + np.linspace(0, 1, 500)[:, None] * (Q[k + 1] - Q[k])
                            for k in range(len(Q) - 1)])
    assert checker.is_free_batch(dense).all()
    # the reported energy is the stop-and-go energy of the result
    me = trajectory_energy(drive, Q, "stop", options=opts)
    np.testing.assert_allclose(me.energy_per_joint, res.energy_per_joint, rtol=1e-12)


def test_relaxation_keeps_only_a_real_improvement(quick, free_path, monkeypatch):
    """The screen is trusted only as far as the final simulation confirms it: with a screen
    that prefers the costliest candidates, the relaxed path would cost more, and the path
    given comes back unchanged; with the true screen the energy falls."""
    import mpd_pin.motion.relax as relax

    scn, drive, checker = quick
    good = relax.relax_path(drive, free_path, checker, scn.options, rounds=2)
    assert good.total_energy < good.initial_energy and good.moves > 0
    true_screen = relax.ideal_costs
    monkeypatch.setattr(relax, "ideal_costs", lambda *a, **k: -true_screen(*a, **k))
    bad = relax.relax_path(drive, free_path, checker, scn.options, rounds=2)
    np.testing.assert_array_equal(bad.waypoints, free_path)
    assert bad.total_energy == pytest.approx(bad.initial_energy) and bad.moves == 0


def test_refine_picks_the_cheapest_candidate(quick, free_path):
    """Without the whole-motion optimisation (docs/design.md §9g) the motion returned is
    the cheapest candidate as priced."""
    scn, drive, checker = quick
    W = free_path
    W2 = np.vstack([W[:1], (W[:1] + W[1:2]) / 2, W[1:]])  # one more stop on the way
    out = refine_candidates(drive, checker, scn.options, {"a": W, "b": W2},
                            MotionOptions(execution="stop", refine=False, optimize=False))
    e = {r["name"]: r["total_energy"] for r in out.candidates}
    assert out.candidate == min(e, key=e.get)
    assert out.motion.total_energy == pytest.approx(min(e.values()))
    assert out.optimization is None and set(out.by_name) == {"a", "b"}


def test_refine_returns_the_optimum_of_the_candidates(quick, free_path):
    """With the optimisation (the default) the motion returned is the optimum ("optimised"):
    seeded by a priced candidate, at that candidate's duration, cheaper than every
    candidate's priced motion, its energy that of a recorded re-simulation, free at dense
    samples of its curve and from the start to the goal."""
    scn, drive, checker = quick
    W = free_path
    W2 = np.vstack([W[:1], (W[:1] + W[1:2]) / 2, W[1:]])
    out = refine_candidates(drive, checker, scn.options, {"a": W, "b": W2},
                            MotionOptions(refine=False))
    priced = {n: m for n, m in out.by_name.items() if n != OPTIMIZED}
    assert set(priced) == {"a", "b"} and all(m.feasible for m in priced.values())
    assert out.candidate == OPTIMIZED and out.motion is out.by_name[OPTIMIZED]
    opt = out.optimization
    assert opt["kept_seed"] is False and opt["certified"] is True
    seed = priced[opt["seed"]]
    assert out.motion.alternative is seed
    assert opt["energy_before"] == seed.total_energy
    assert opt["energy_after"] == out.motion.total_energy
    assert out.motion.feasible and out.motion.execution == "nonstop"
    assert out.motion.total_energy < min(m.total_energy for m in priced.values())
    assert out.motion.duration == pytest.approx(seed.duration, abs=1e-12)
    series = motion_series(drive, out.motion, scn.options.dt)
    np.testing.assert_allclose(series["energy_t"][-1], out.motion.energy_per_joint, rtol=1e-9)
    assert series["t"][-1] == pytest.approx(out.motion.duration, abs=1e-9)
    Q = out.motion.curve.spline(np.linspace(0.0, out.motion.duration, 5000))
    assert checker.is_free_batch(Q).all()
    np.testing.assert_allclose(Q[[0, -1]], W[[0, -1]], atol=1e-12)


def test_optional_candidates_are_pruned_after_their_shortcut(quick, free_path, monkeypatch):
    import mpd_pin.motion.refine as refine

    scn, drive, checker = quick
    W2 = np.vstack([free_path[:1], (free_path[:1] + free_path[1:2]) / 2, free_path[1:]])
    monkeypatch.setattr(refine, "PRUNE", 0.0)  # any detour costs more than 0 × the best
    out = refine_candidates(drive, checker, scn.options, {"a": free_path, "b": W2},
                            MotionOptions(), optional=frozenset({"b"}))
    rec = {r["name"]: r for r in out.candidates}
    assert rec["b"]["reason"].startswith("pruned") and "stop_energy_relaxed" not in rec["b"]
    assert "b" not in out.by_name
    # the pruned detour seeds no optimisation either: the optimum returned is "a"'s
    assert [r["seed"] for r in out.optimization["runs"]] == ["a"]
    assert out.candidate == OPTIMIZED and out.optimization["seed"] == "a"
    assert out.motion.total_energy < out.by_name["a"].total_energy
    monkeypatch.setattr(refine, "PRUNE", 1e9)  # never: both refined and priced
    out = refine_candidates(drive, checker, scn.options, {"a": free_path, "b": W2},
                            MotionOptions(optimize=False), optional=frozenset({"b"}))
    assert set(out.by_name) == {"a", "b"}


@pytest.mark.parametrize("bad, what", [
    ({"execution": "fast"}, "execution"),
    ({"max_duration": -1.0}, "max_duration"),
    ({"max_duration": math.nan}, "max_duration"),
    ({"interior": -1}, "interior"),
])
def test_motion_options_reject_bad_values(bad, what):
    with pytest.raises(ValueError, match=what):
        MotionOptions(**bad)


def test_trajectory_energy_rejects_bad_waypoints(quick):
    _, drive, _ = quick
    with pytest.raises(ValueError, match="shape"):
        trajectory_energy(drive, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="row 2"):
        trajectory_energy(drive, [[0, 0, 0], [0, math.nan, 0]])
    with pytest.raises(ValueError, match="two distinct"):
        trajectory_energy(drive, [[0, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match="execution"):
        trajectory_energy(drive, [[0, 0, 0], [0, 0.1, 0]], execution="fast")
