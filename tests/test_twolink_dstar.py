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
from mpd_pin.twolink.ik import TwoLinkKinematics
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


def test_env1_execution_stops_and_returns_backward():
    path = resources.files("mpd_pin") / "scenarios" / "env1.toml"
    scn = parse_dynamic_scenario(tomllib.loads(path.read_text()))
    prob = scn.problem
    kin = TwoLinkKinematics(prob.arm)
    fcs = FreeCartesianSpace(kin, prob.grid,
                             SampledCollisionChecker(prob.arm, prob.scene, margin=prob.margin))
    start = fcs.state(prob.grid.nearest_cell(prob.start), 0)
    goals = [fcs.state(prob.grid.nearest_cell(prob.goal), b) for b in (0, 1)]
    mot = execute_dstar(fcs, start, goals, max_joint_step=prob.max_joint_step,
                        max_samples=prob.max_samples, switch_penalty=prob.switch_penalty)
    kinds = {e["type"] for e in mot.events}
    assert {"stop", "backward"} <= kinds
    states = mot.states
    assert states[-1] in goals
    for k, s in enumerate(states):
        assert fcs.free_states(k)[s], k  # collision-free at every motion sample
        if k:
            cells = (states[k - 1] % fcs.grid.num_cells, s % fcs.grid.num_cells)
            d = np.abs(fcs.grid.point(cells[0]) - fcs.grid.point(cells[1]))
            assert np.all(d <= fcs.grid.step + 1e-12)  # one grid move at most
            assert np.abs(fcs.q_states[s] - fcs.q_states[states[k - 1]]).max() <= 0.5
    for e in mot.events:
        k = e["sample"]
        if e["type"] == "stop":
            assert states[k] == states[k - 1]
        elif e["type"] == "backward":
            # The arm left because its state was about to be hit at sample k.
            assert not fcs.free_states(k)[states[k - 1]]
            assert states[k] != states[k - 1]
    np.testing.assert_allclose(mot.length, np.sum(np.linalg.norm(np.diff(mot.points, axis=0),
                                                                 axis=1)))


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
    ],
)
def test_problem_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        _problem([], (0.5, 0.5), (-0.5, 0.5), **kw)
