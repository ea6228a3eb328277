"""Grid D* over (cell, elbow branch) states, and its execution with stop / return backward."""

import math
import tomllib
from importlib import resources

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

import mpd_pin as mp
from mpd_pin.twolink.fcs import FreeCartesianSpace, Grid
from mpd_pin.twolink.grid_dstar import GridDStar, build_state_graph
from mpd_pin.twolink.ik import BRANCHES, TwoLinkKinematics
from mpd_pin.twolink.moving import (
    MovingObstacle,
    MovingScene,
    SampledCollisionChecker,
    back_and_forth,
    static,
    straight,
)
from mpd_pin.twolink.planner import DynamicProblem, TrappedError, execute_dstar, plan_dynamic
from mpd_pin.twolink.pso import PSOOptions
from mpd_pin.twolink.scenario import parse_dynamic_scenario

ARM = mp.builtin_arm("planar_2link")


def _fcs(scene, step=0.1, margin=0.03):
    kin = TwoLinkKinematics(ARM)
    grid = Grid(-1.0, 1.0, -1.0, 1.0, step)
    return FreeCartesianSpace(kin, grid, SampledCollisionChecker(ARM, scene, margin=margin))


def _scipy_distance(graph, src, dst):
    s, d, c = graph.to_arrays()
    keep = np.isfinite(c)
    # csgraph drops explicit zeros: shift every cost by a tiny epsilon per hop.
    m = csr_matrix((c[keep] + 1e-12, (s[keep], d[keep])), shape=(graph.num_nodes,) * 2)
    return dijkstra(m, indices=src)[dst]


def test_state_graph_edges():
    fcs = _fcs(MovingScene([]), step=0.1)
    grid = fcs.grid
    g, src, dst, cost = build_state_graph(fcs, 0.5, [fcs.state(5, 0)], switch_penalty=0.07)
    nc = grid.num_cells
    pts = grid.points()
    inner = dst != 2 * nc
    s, d, c = src[inner], dst[inner], cost[inner]
    cs, bs = s % nc, s // nc
    cd, bd = d % nc, d // nc
    step = np.abs(pts[cd] - pts[cs])
    assert np.all(step <= 0.1 + 1e-12)  # 8-connected (or the same cell)
    expect = np.hypot(step[:, 0], step[:, 1]) + 0.07 * (bs != bd)
    np.testing.assert_allclose(c, expect, rtol=1e-12)
    jump = np.abs(fcs.q_states[d] - fcs.q_states[s]).max(axis=1)
    assert np.all(jump <= 0.5)
    assert fcs.reachable[s].all() and fcs.reachable[d].all()
    # Completeness: every pair of neighbouring reachable states within the joint step is an edge.
    have = set(zip(s.tolist(), d.tolist(), strict=True))
    rng = np.random.default_rng(0)
    for u in rng.choice(np.flatnonzero(fcs.reachable), 60, replace=False):
        cu = int(u) % nc
        for cv in [cu, *grid.neighbours(cu)]:
            for bv in (0, 1):
                v = bv * nc + cv
                if v == u or not fcs.reachable[v]:
                    continue
                ok = np.abs(fcs.q_states[v] - fcs.q_states[u]).max() <= 0.5
                assert ((int(u), v) in have) == ok
    # Branch switches only where both branches nearly coincide (near the outer rim).
    sw = bs != bd
    assert sw.any()
    assert np.all(np.linalg.norm(pts[cd[sw]], axis=1) > 0.85)


@pytest.mark.parametrize("blocked_cost", [1000.0, math.inf])
def test_dstar_is_optimal_and_repairs(blocked_cost):
    scene = MovingScene([MovingObstacle("o", 0.15, back_and_forth((0.0, 0.9), (0.0, 0.2), 3.0))])
    fcs = _fcs(scene, step=0.1)
    grid = fcs.grid
    start = fcs.state(grid.nearest_cell((0.7, 0.2)), 0)
    goals = [fcs.state(grid.nearest_cell((-0.6, 0.3)), b) for b in (0, 1)]
    ds = GridDStar(fcs, start, goals, fcs.free_states(0), max_joint_step=0.6,
                   blocked_cost=blocked_cost)
    for k in (0, 5, 10, 15):
        ds.set_free(fcs.free_states(k))
        path = ds.plan_from(start)
        assert path[0] == start and path[-1] in goals
        cost = sum(ds.graph.cost(u, v) for u, v in zip(path[:-1], path[1:], strict=True))
        ref = _scipy_distance(ds.graph, start, ds.goal_node)
        assert cost == pytest.approx(ref, abs=1e-9 * len(path))
        assert ds.cost_to_goal(start) == pytest.approx(ref, abs=1e-9 * len(path))
        if math.isfinite(blocked_cost) and cost < blocked_cost:
            assert not any(ds.is_blocked(s) for s in path)


def _scenario(name):
    path = resources.files("mpd_pin") / "scenarios" / f"{name}.toml"
    return parse_dynamic_scenario(tomllib.loads(path.read_text())).problem


@pytest.fixture(scope="module", params=["env1", "env2"])
def executed(request):
    prob = _scenario(request.param)
    kin = TwoLinkKinematics(prob.arm)
    fcs = FreeCartesianSpace(kin, prob.grid,
                             SampledCollisionChecker(prob.arm, prob.scene, margin=prob.margin))
    start = fcs.state(prob.grid.nearest_cell(prob.start), BRANCHES.index(prob.start_branch))
    goals = [fcs.state(prob.grid.nearest_cell(prob.goal), b) for b in (0, 1)]
    mot = execute_dstar(fcs, start, goals, max_joint_step=prob.joint_step_limit,
                        max_samples=prob.max_samples, lookahead=prob.lookahead,
                        switch_penalty=prob.switch_penalty, substeps=prob.substeps)
    return prob, fcs, goals, mot


def _neighbour_states(fcs, s, limit):
    """States one grid move (or a same-cell switch) from s within the joint step limit."""
    nc, grid = fcs.grid.num_cells, fcs.grid
    c = s % nc
    out = []
    for cv in [c, *grid.neighbours(c)]:
        for bv in (0, 1):
            v = bv * nc + cv
            if v != s and fcs.reachable[v] and np.abs(fcs.q_states[v] - fcs.q_states[s]).max() \
                    <= limit:
                out.append(v)
    return out


def test_execution_stops_and_returns_backward(executed):
    prob, fcs, goals, mot = executed
    chk, n, limit = fcs.checker, prob.substeps, prob.joint_step_limit
    assert limit == pytest.approx(0.1) and n == 4
    kinds = {e["type"] for e in mot.events}
    assert {"stop", "backward"} <= kinds
    states = mot.states
    assert states[-1] in goals
    nc = fcs.grid.num_cells

    def valid(u, v, k):  # the move u (sample k-1) -> v (sample k)
        return bool(fcs.free_states(k)[v]) and chk.is_free_between(
            fcs.q_states[u], fcs.q_states[v], k - 1, n)

    for k, s in enumerate(states):
        assert fcs.free_states(k)[s], k  # collision-free at every motion sample
        if k:
            cells = (states[k - 1] % nc, s % nc)
            d = np.abs(fcs.grid.point(cells[0]) - fcs.grid.point(cells[1]))
            assert np.all(d <= fcs.grid.step + 1e-12)  # one grid move at most
            assert np.abs(fcs.q_states[s] - fcs.q_states[states[k - 1]]).max() <= limit
            assert valid(states[k - 1], s, k), k  # and free at the sub-steps in between
    goal_pt = fcs.grid.point(goals[0] % nc)

    def dist(v):
        return float(np.linalg.norm(fcs.grid.point(v % nc) - goal_pt))

    for e in mot.events:
        k = e["sample"]
        prev, new = states[k - 1], states[k]
        if e["type"] == "stop":
            assert new == prev
        elif e["type"] == "backward":
            # The arm left because staying was about to be hit (at sample k or in between).
            assert not valid(prev, prev, k)
            assert new != prev and new in _neighbour_states(fcs, prev, limit)
            # Return *backward*: if some valid neighbour is not closer to the goal, the arm
            # went to one of those; only otherwise closer (and the event says so).
            options = [v for v in _neighbour_states(fcs, prev, limit) if valid(prev, v, k)]
            back = [v for v in options if dist(v) >= dist(prev) - 1e-9]
            assert e["retreat"] == bool(back)
            if back:
                assert dist(new) >= dist(prev) - 1e-9, e
            assert e["goal_distance"] == pytest.approx([dist(prev), dist(new)], abs=1e-12)
    np.testing.assert_allclose(mot.length, np.sum(np.linalg.norm(np.diff(mot.points, axis=0),
                                                                 axis=1)))


def test_no_branch_switch_fits_the_velocity_limit():
    # Why env1/env2 never switch the elbow (grid_dstar docstring): with 0.1 rad per sample
    # (10 rad/s x 0.01 s) on the 0.025 m grid, the only branch-changing edges are same-cell
    # switches on the rim (r = 1, where both branches coincide), and those cells have no
    # other edge: a switch is unreachable.
    prob = _scenario("env2")
    fcs = _fcs(MovingScene([]), step=prob.grid.step)
    nc = fcs.grid.num_cells
    _, src, dst, _ = build_state_graph(fcs, prob.joint_step_limit, [0])
    inner = dst != 2 * nc
    src, dst = src[inner], dst[inner]
    sw = (src // nc) != (dst // nc)
    assert sw.any()
    assert np.all(src[sw] % nc == dst[sw] % nc)
    r = np.linalg.norm(fcs.grid.points()[src[sw] % nc], axis=1)
    np.testing.assert_allclose(r, 1.0, atol=1e-12)
    assert set(src[sw].tolist()).isdisjoint(src[~sw].tolist())
    assert set(dst[sw].tolist()).isdisjoint(dst[~sw].tolist())


def _switch_problem(step=0.05, **kw):
    # Elbow up at the start; at the goal a disc sits on the elbow-up arm's second link, so
    # only elbow down reaches it: a switch is forced, and it is possible only near the rim
    # r = 1 m, where both branches come within the joint step.
    ob = MovingObstacle("blocker", 0.05, static((0.56, -0.42)))
    return DynamicProblem(
        ARM, MovingScene([ob]), Grid(-1.0, 1.0, -1.0, 1.0, step), (0.55, 0.7), (0.55, -0.7),
        start_branch="up", goal_branch="any", pso=PSOOptions(particles=16, iterations=20),
        num_via=6, **kw)


def test_forced_branch_switch_is_continuous():
    # max_joint_step = 0.5 rad (50 rad/s, above the URDF's 10 rad/s): this test exercises the
    # switch itself, which the velocity-limited default cannot reach (test above and below).
    res = plan_dynamic(_switch_problem(max_joint_step=0.5), seed=3)
    goal_cell = res.fcs.grid.nearest_cell((0.55, -0.7))
    assert not res.fcs.free_states(0)[res.fcs.state(goal_cell, 0)]  # up blocked at the goal
    assert res.fcs.free_states(0)[res.fcs.state(goal_cell, 1)]
    for name, m in (("dstar", res.dstar), ("pso", res.motion)):
        b = np.asarray(m.branches)
        assert b[0] == 0 and b[-1] == 1, name
        sw = np.flatnonzero(np.diff(b)) + 1
        assert sw.size >= 1, name
        q = np.asarray(m.q)
        step = np.abs(np.diff(q, axis=0)).max(axis=1)
        assert step.max() <= 0.5 + 1e-12, name  # continuous across every sample
        for k in sw:  # ... and across each switch, where both branches nearly coincide
            assert step[k - 1] <= 0.5 + 1e-12
            assert np.linalg.norm(m.points[k]) > 0.85, (name, k)
        # The joint angles are the IK of the points on the branch they claim.
        np.testing.assert_allclose(res.kin.fk(q), m.points, atol=1e-9)
        for k in range(len(q)):
            assert res.checker.is_free(q[k], k), (name, k)
    assert any(e["type"] == "switch" for e in res.dstar.events)
    assert res.pso_improved and res.motion.length < res.dstar.length


def test_forced_branch_switch_is_refused_at_the_velocity_limit():
    # Same task with the default step (velocity limit x Ts = 0.1 rad) on the 0.025 m grid of
    # env1/env2: no continuous switch exists, so the free (elbow-down) goal state cannot be
    # reached at all, although the (blocked) elbow-up one could be without the disc. The arm
    # never jumps branches; the executor would wait and finally raise TrappedError.
    prob = _switch_problem(step=0.025)
    assert prob.joint_step_limit == pytest.approx(0.1)
    kin = TwoLinkKinematics(ARM)
    cases = ((prob.scene, 1, False), (MovingScene([]), 1, False), (MovingScene([]), 0, True))
    for scene, branch, reachable in cases:
        fcs = FreeCartesianSpace(kin, prob.grid, SampledCollisionChecker(ARM, scene, margin=0.03))
        start = fcs.state(prob.grid.nearest_cell(prob.start), 0)
        goal = fcs.state(prob.grid.nearest_cell(prob.goal), branch)
        free = fcs.free_states(0)
        assert free[start] and free[goal]
        ds = GridDStar(fcs, start, [goal], free, max_joint_step=prob.joint_step_limit,
                       blocked_cost=math.inf)
        if reachable:
            path = ds.plan_from(start)
            assert {s // fcs.grid.num_cells for s in path} == {0}
        else:
            with pytest.raises(mp.NoPathError):
                ds.plan_from(start)


def _problem(obstacles, start, goal, **kw):
    return DynamicProblem(
        ARM, MovingScene(obstacles), Grid(-1.0, 1.0, -1.0, 1.0, 0.1), start, goal,
        pso=PSOOptions(particles=4, iterations=2), num_via=3, **kw
    )


def test_trapped_when_an_obstacle_sweeps_over_the_base():
    # A large disc rolls over the base: no configuration survives, stop/return cannot help.
    big = MovingObstacle("roller", 0.45, straight((1.0, 0.0), (0.0, 0.0), 8.0))
    with pytest.raises(TrappedError, match="neither stopping nor returning backward"):
        plan_dynamic(_problem([big], (-0.6, 0.3), (0.3, -0.8)))


def test_trapped_when_the_goal_is_never_reached():
    # A static disc cuts the way (q1 cannot wrap past ±π either): D* waits until max_samples.
    wall = MovingObstacle("wall", 0.2, static((0.0, 0.45)))
    lower = MovingObstacle("wall2", 0.2, static((0.0, -0.45)))
    with pytest.raises(TrappedError, match="did not reach the goal within 30"):
        plan_dynamic(_problem([wall, lower], (0.7, 0.0), (-0.7, 0.0), max_samples=30))


@pytest.mark.parametrize(
    "start, goal, match",
    [
        ((0.9, 0.9), (-0.5, 0.5), "start cell .* unreachable"),
        ((0.5, 0.5), (0.0, -1.2), "goal: point .* outside the grid"),
        ((0.5, 0.5), (0.9, -0.9), "goal cell .* unreachable"),
        ((0.0, 0.6), (-0.5, -0.5), "start .* in collision at t = 0"),
        ((0.6, -0.5), (0.0, 0.6), "goal .* in collision at t = 0"),
    ],
)
def test_bad_start_and_goal(start, goal, match):
    ob = MovingObstacle("o", 0.1, static((0.0, 0.6)))
    with pytest.raises(ValueError, match=match):
        plan_dynamic(_problem([ob], start, goal))


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(margin=-0.01), "margin"),
        (dict(max_joint_step=0.0), "max_joint_step"),
        (dict(start_branch="left"), "branch"),
        (dict(goal_branch="middle"), "branch"),
        (dict(spline_bc="periodic"), "spline_bc"),
        (dict(lookahead=0), "lookahead"),
        (dict(substeps=0), "substeps"),
    ],
)
def test_problem_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        _problem([], (0.5, 0.5), (-0.5, 0.5), **kw)
