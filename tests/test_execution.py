"""Execution with replanning on a real roadmap, and hazard re-planning (paper 000 §5.2)."""

import math

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker
from mpd_pin.execution import blocked_edges, execute, plan_avoiding_hazards
from mpd_pin.roadmap import EnergyCost, RoadmapOptions, build_roadmap
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


def test_hazard_replanning(arm_drive):
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
    res = plan_avoiding_hazards(rm, checker, resolution=OPTIONS.resolution)
    assert res.first_margin < 0, "the scenario must make the cheapest path violate the clearance"
    assert res.final_margin >= 0
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
    assert math.isfinite(res.plan_seconds)
