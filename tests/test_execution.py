"""Execution with replanning on a real roadmap, and hazard re-planning (paper 000 §5.2)."""

import dataclasses
import math
import warnings

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.results import to_jsonable
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost
from mpd_pin.planning.execution import blocked_edges, execute
from mpd_pin.planning.hazards import (
    HazardClearanceWarning,
    penalised_cost,
    penalised_roadmap,
    plan_avoiding_hazards,
)
from mpd_pin.planning.roadmap import Roadmap, RoadmapOptions, build_roadmap
from mpd_pin.search import Dijkstra
from mpd_pin.world import Box, Cylinder, Hazard, Polygon, World

START = np.array([0.6, 0.3, 0.2])
GOAL = np.array([2.4, -0.3, -0.2])
OPTIONS = RoadmapOptions(num_nodes=120, k=8, seed=1, resolution=0.05, duration=0.5, dt=0.01)


def _nx_graph(rm, blocked=()):
    G = nx.DiGraph()
    cut = {(u, v) for u, v in blocked} | {(v, u) for u, v in blocked}
    for u, v, c in zip(rm.src.tolist(), rm.dst.tolist(), rm.cost.tolist(), strict=True):
        if (u, v) not in cut:
            G.add_edge(u, v, weight=c)
    return G


@pytest.fixture(scope="module")
def arm_drive():
    arm = mp.builtin_arm("planar_3link")
    return arm, mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)


def test_execute_with_revealed_obstacle(arm_drive):
    arm, drive = arm_drive
    wall = Box.planar((0.0, 0.9), 0.3, 0.4, name="wall")
    rm = build_roadmap(
        EnergyCost(drive, OPTIONS.dt),
        CollisionChecker(arm, World((wall,))),
        START,
        GOAL,
        OPTIONS,
        show_progress=False,
    )
    # Hide a disc at the hand of a node in the middle of the first plan: the plan
    # made on the known map runs into it, so the arm must replan on the way.
    first = Dijkstra(rm.graph(), rm.start, rm.goal).plan().nodes
    assert len(first) >= 4
    mid = rm.nodes[first[len(first) // 2]]
    x, _, z = arm.frame_position(mid, "ee")
    world = World((wall, Cylinder.planar((x, z), 0.05, name="surprise", hidden=True)))
    checker = CollisionChecker(arm, world)
    truth = CollisionChecker(arm, world, include_hidden=True)
    assert truth.is_free(START) and truth.is_free(GOAL)
    assert not all(
        truth.edge_free(rm.nodes[u], rm.nodes[v], 0.01)
        for u, v in zip(first[:-1], first[1:], strict=True)
    )

    res = execute(rm, checker, sensor_range=0.15, resolution=OPTIONS.resolution)
    assert res.initial_path == first
    assert world.is_known("surprise")
    assert len(res.replans) >= 1 and res.replans[0].revealed == ["surprise"]
    assert res.travelled[0] == rm.start and res.travelled[-1] == rm.goal
    # Travelled path is collision-free against the full world, at 5x finer resolution.
    for u, v in zip(res.travelled[:-1], res.travelled[1:], strict=True):
        assert truth.edge_free(rm.nodes[u], rm.nodes[v], OPTIONS.resolution / 5), (u, v)
    # Reported energy = sum of the travelled edges' costs (independent lookup).
    cost = {
        (u, v): c
        for u, v, c in zip(rm.src.tolist(), rm.dst.tolist(), rm.cost.tolist(), strict=True)
    }
    total = sum(cost[(u, v)] for u, v in zip(res.travelled[:-1], res.travelled[1:], strict=True))
    assert res.total_energy == pytest.approx(total, rel=1e-12)
    # Each repair is optimal on the updated graph (networkx from the replan node).
    cut = blocked_edges(rm, arm, World((world["surprise"],)), OPTIONS.resolution)
    G = _nx_graph(rm, cut)
    ev = res.replans[0]
    assert ev.blocked_edges == len(cut) > 0
    assert ev.path_after[0] == ev.node
    length = sum(
        G[u][v]["weight"] for u, v in zip(ev.path_after[:-1], ev.path_after[1:], strict=True)
    )
    assert length == pytest.approx(nx.dijkstra_path_length(G, ev.node, rm.goal), rel=1e-12)
    # Blocked edges really collide with the revealed obstacle (and the others do not).
    for u, v in cut[:20]:
        assert not truth.edge_free(rm.nodes[u], rm.nodes[v], OPTIONS.resolution)


def test_goal_cut_off_raises_no_path(arm_drive):
    arm, drive = arm_drive
    # A hidden disc right on the goal configuration's hand.
    x, _, z = arm.frame_position(GOAL, "ee")
    world = World((Cylinder.planar((x, z), 0.1, name="trap", hidden=True),))
    checker = CollisionChecker(arm, world)
    opts = RoadmapOptions(num_nodes=30, k=6, seed=2, duration=0.5, dt=0.01)
    rm = build_roadmap(EnergyCost(drive, opts.dt), checker, START, GOAL, opts, show_progress=False)
    assert not CollisionChecker(arm, world, include_hidden=True).is_free(GOAL)
    with pytest.raises(mp.NoPathError):
        execute(rm, checker, sensor_range=0.5, resolution=opts.resolution)


@pytest.fixture(scope="module")
def hazard_setup(arm_drive):
    arm, drive = arm_drive
    # A small hot triangle beside the cheapest route (found by scanning placements once).
    cx, cz = -0.65, 0.2
    tri = Polygon.planar(
        [(cx - 0.08, cz - 0.06), (cx + 0.08, cz - 0.06), (cx, cz + 0.08)], name="hot"
    )
    world = World((Box.planar((0.0, 0.95), 0.25, 0.3, name="wall"),), (Hazard(tri, 0.15),))
    checker = CollisionChecker(arm, world)
    rm = build_roadmap(
        EnergyCost(drive, OPTIONS.dt), checker, START, GOAL, OPTIONS, show_progress=False
    )
    return arm, checker, rm


def _penalised_nx(rm, pairs, penalty, floor):
    """networkx graph of ``rm`` with the edges of ``pairs`` re-costed by penalised_cost."""
    pen = {(min(u, v), max(u, v)) for u, v in pairs}
    G = nx.DiGraph()
    for u, v, c in zip(rm.src.tolist(), rm.dst.tolist(), rm.cost.tolist(), strict=True):
        if (min(u, v), max(u, v)) in pen:
            c = penalised_cost(c, penalty, floor)
        if math.isfinite(c):
            G.add_edge(u, v, weight=c)
    return G


def _sum_costs(G, nodes):
    total = 0.0
    for u, v in zip(nodes[:-1], nodes[1:], strict=True):
        total += G[u][v]["weight"]
    return total


def test_hazard_replanning(hazard_setup):
    arm, checker, rm = hazard_setup
    with warnings.catch_warnings():
        warnings.simplefilter("error", HazardClearanceWarning)
        res = plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution)
    assert res.first_margin < 0, "the scenario must make the cheapest path violate the clearance"
    assert res.final_margin >= 0
    assert res.satisfied is True and res.to_dict()["satisfied"] is True
    assert res.penalty == math.inf and res.penalty_floor == math.inf  # floor unused
    assert to_jsonable(res.to_dict())["penalty_floor"] is None  # null in result.json
    assert res.rounds >= 1 and res.penalised
    assert res.final_energy.sum() >= res.first_energy.sum()
    # Brute-force margin of the final path at the check resolution.
    from mpd_pin.collision import edge_configurations

    margins = [
        checker.hazard_margin(q)
        for u, v in zip(res.final_path[:-1], res.final_path[1:], strict=True)
        for q in edge_configurations(rm.nodes[u], rm.nodes[v], OPTIONS.resolution)
    ]
    # GJK warm starts make repeated distance queries differ at ~1e-12 m.
    assert min(margins) == pytest.approx(res.final_margin, abs=1e-9)
    # Final path optimal among edges that keep the clearance (networkx reference).
    G = _nx_graph(rm, res.penalised)
    assert res.final_energy.sum() == pytest.approx(
        nx.dijkstra_path_length(G, rm.start, rm.goal), rel=1e-12
    )
    with pytest.raises(ValueError, match="penalty"):
        plan_avoiding_hazards(rm, checker, resolution=0.05, penalty=0.5)
    with pytest.raises(ValueError, match="penalty_floor"):
        plan_avoiding_hazards(rm, checker, resolution=0.05, penalty=2.0, penalty_floor=-1.0)
    assert math.isfinite(res.plan_seconds)


def test_planning_roadmap_carries_the_hazard_penalties(hazard_setup):
    """Planning on HazardResult.planning_roadmap (what the runner hands to execution) finds
    the re-planned path at the cost the hazard planner found it, for ∞ and finite penalties."""
    arm, checker, rm = hazard_setup
    for penalty in (math.inf, 10.0):
        res = plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution, penalty=penalty)
        assert res.penalised
        pm = res.planning_roadmap(rm)
        np.testing.assert_array_equal(pm.nodes, rm.nodes)
        path = Dijkstra(pm.graph(), pm.start, pm.goal).plan()
        G = _penalised_nx(rm, res.penalised, penalty, res.penalty_floor)
        assert path.cost == pytest.approx(_sum_costs(G, res.final_path), rel=1e-12)
        assert path.cost == pytest.approx(nx.dijkstra_path_length(G, rm.start, rm.goal), rel=1e-12)


def test_penalised_roadmap_scales_energies_by_the_hazard_rule():
    """The planning copy costs each penalised edge penalised_cost(cost, penalty, floor)
    (zero-cost edges included), leaves the rest and the original untouched, and keeps
    per-joint energies proportional."""
    energy = np.array([[1.0, 3.0], [2.0, 2.0], [0.0, 0.0], [0.0, 0.0], [5.0, 1.0], [0.5, 0.5]])
    src, dst = np.array([0, 1, 1, 2, 2, 3]), np.array([1, 0, 2, 1, 3, 2])
    rm = Roadmap(nodes=np.zeros((4, 2)), start=0, goal=3, src=src, dst=dst,
                 durations=np.ones(6), energy=energy.copy(), key="k", timings={})
    pen = penalised_roadmap(rm, [(1, 0), (1, 2)], 3.0, 10.0)
    np.testing.assert_array_equal(rm.energy, energy)  # the original is not modified
    expected = [penalised_cost(c, 3.0, 10.0) for c in energy.sum(axis=1)[:4]]
    assert expected == [14.0, 14.0, 10.0, 10.0]
    np.testing.assert_allclose(pen.cost[:4], expected, rtol=1e-15)
    np.testing.assert_allclose(pen.energy[0], [3.5, 10.5], rtol=1e-15)  # proportional
    np.testing.assert_allclose(pen.energy[2], [5.0, 5.0], rtol=1e-15)  # zero cost: evenly
    np.testing.assert_array_equal(pen.energy[4:], energy[4:])
    inf = penalised_roadmap(rm, [(2, 3)], math.inf, 0.0)
    assert np.all(np.isinf(inf.cost[4:])) and np.array_equal(inf.cost[:4], rm.cost[:4])


def test_penalised_cost_is_at_least_an_additive_floor() -> None:
    assert penalised_cost(0.0, 10.0, 2.5) == 2.5
    assert penalised_cost(1.0, 10.0, 2.5) == 10.0
    assert penalised_cost(0.1, 10.0, 2.5) == 2.6
    assert penalised_cost(0.0, math.inf, 0.0) == math.inf
    assert penalised_cost(3.0, 1.0, 0.0) == 3.0


def test_finite_penalty_also_penalises_zero_cost_edges(hazard_setup):
    """A violating path of zero-cost edges: a product alone would keep it; the floor does not."""
    arm, checker, rm = hazard_setup
    first = plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution).first_path
    on_first = {(min(u, v), max(u, v)) for u, v in zip(first[:-1], first[1:], strict=True)}
    energy = np.array(rm.energy, dtype=float, copy=True)
    for k, (u, v) in enumerate(zip(rm.src.tolist(), rm.dst.tolist(), strict=True)):
        if (min(u, v), max(u, v)) in on_first:
            energy[k] = 0.0
    rm0 = dataclasses.replace(rm, energy=energy)
    positive = rm0.cost[np.isfinite(rm0.cost) & (rm0.cost > 0)]

    with warnings.catch_warnings():
        warnings.simplefilter("error", HazardClearanceWarning)
        res = plan_avoiding_hazards(rm0, checker, resolution=OPTIONS.resolution, penalty=10.0)
    assert res.first_path == first and res.first_energy.sum() == 0.0
    assert res.first_margin < 0
    assert res.penalty_floor == pytest.approx(9.0 * positive.mean(), rel=1e-12)
    assert res.satisfied is True and res.final_margin >= 0
    assert res.final_path != first
    # The final path is optimal on the penalised graph (networkx, same costs).
    G = _penalised_nx(rm0, res.penalised, 10.0, res.penalty_floor)
    assert _sum_costs(G, res.final_path) == nx.dijkstra_path_length(G, rm0.start, rm0.goal)

    # Multiplicative only (floor 0): the zero-cost violating path stays cheapest,
    # and the result says so instead of passing silently.
    with pytest.warns(HazardClearanceWarning, match="closer to a hazard"):
        res0 = plan_avoiding_hazards(
            rm0, checker, resolution=OPTIONS.resolution, penalty=10.0, penalty_floor=0.0
        )
    assert res0.final_path == first
    assert res0.satisfied is False and res0.final_margin < 0
    assert res0.to_dict()["satisfied"] is False


def test_unsatisfiable_clearance_is_flagged(hazard_setup, arm_drive):
    """A hazard around the goal's hand: no path can keep the clearance."""
    arm, _, rm = hazard_setup
    x, _, z = arm.frame_position(GOAL, "ee")
    hot = Cylinder.planar((x, z), 0.02, name="hot goal")
    world = World((Box.planar((0.0, 0.95), 0.25, 0.3, name="wall"),), (Hazard(hot, 0.05),))
    checker = CollisionChecker(arm, world)
    assert checker.hazard_margin(rm.nodes[rm.goal]) < 0
    with pytest.warns(HazardClearanceWarning):
        res = plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution, penalty=100.0)
    assert res.satisfied is False and res.final_margin < 0
    assert res.final_path[-1] == rm.goal and res.rounds >= 1
    # With edges removed instead (the default), the goal is cut off.
    with pytest.raises(mp.NoPathError):
        plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution)
