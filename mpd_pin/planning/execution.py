"""Executing a roadmap path while the world changes (paper 000 §5.2; docs/design.md §5).

:func:`execute` — the arm moves node by node along the planned path. Before
each move a sensor looks for obstacles that are not on the map: every hidden
obstacle within ``sensor_range`` (m) of the arm, at its current configuration
or anywhere along the edge it is about to take, is revealed. The roadmap edges
that now collide (:func:`blocked_edges`) are set to ∞ in the planner, which
repairs its plan from the current node (MPD* Lite: incremental). The result
records every replan and the path actually travelled with its energy.

Re-planning around "No Enter" zones is :mod:`mpd_pin.planning.hazards`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from ..collision import CollisionChecker, edge_configurations
from ..search import MPDStarLite, Planner
from ..world import World
from .roadmap_data import Roadmap

__all__ = ["ReplanEvent", "ExecutionResult", "execute", "blocked_edges"]

PlannerFactory = Callable[..., Planner]


@dataclass
class ReplanEvent:
    """One repair: where the arm was, what it saw and what the repair cost."""

    step: int
    node: int
    revealed: list[str]
    blocked_edges: int
    expansions: int
    edge_evaluations: int
    check_seconds: float
    plan_seconds: float
    path_before: list[int]
    path_after: list[int]


@dataclass
class ExecutionResult:
    """Outcome of :func:`execute`.

    initial_path: the first plan (node ids); travelled: the nodes actually visited;
    energy: E⁺ per joint (J) along ``travelled`` (sum of its edges' costs);
    replans: one :class:`ReplanEvent` per repair; initial_plan_seconds, expansions;
    supply_energy: the energy ``travelled`` draws from the drive's supply (J, docs/design.md
    §3i; None: Σ E⁺, the paper's per-joint supplies). ``initial_cost`` is the search's cost,
    which with regeneration includes the node potential's φ(start) − φ(goal).
    """

    initial_path: list[int]
    initial_cost: float
    travelled: list[int]
    energy: np.ndarray
    replans: list[ReplanEvent] = field(default_factory=list)
    initial_plan_seconds: float = 0.0
    initial_expansions: int = 0
    supply_energy: float | None = None

    @property
    def total_energy(self) -> float:
        if self.supply_energy is not None:
            return float(self.supply_energy)
        return float(np.sum(self.energy))

    def to_dict(self) -> dict:
        return {
            "initial_path": [int(n) for n in self.initial_path],
            "initial_cost": float(self.initial_cost),
            "travelled": [int(n) for n in self.travelled],
            "energy_per_joint": [float(e) for e in self.energy],
            "total_energy": self.total_energy,
            "initial_plan_seconds": self.initial_plan_seconds,
            "initial_expansions": self.initial_expansions,
            "replans": [asdict(r) for r in self.replans],
        }


def _undirected_pairs(roadmap: Roadmap) -> np.ndarray:
    """(P, 2) unique node pairs u < v that carry an edge in either direction."""
    lo = np.minimum(roadmap.src, roadmap.dst)
    hi = np.maximum(roadmap.src, roadmap.dst)
    return np.unique(np.stack([lo, hi], axis=1), axis=0)


def blocked_edges(
    roadmap: Roadmap, arm, obstacles: World, resolution: float
) -> list[tuple[int, int]]:
    """Undirected roadmap edges (u, v) along which the arm hits any obstacle of ``obstacles``.

    Checks only against the given obstacles (no self-collision: roadmap edges
    were self-collision-free already), in parallel at the given resolution (rad).
    """
    if len(obstacles) == 0:
        return []
    checker = CollisionChecker(arm, obstacles, include_hidden=True, self_collision=False)
    pairs = _undirected_pairs(roadmap)
    free = checker.edges_free(roadmap.nodes[pairs[:, 0]], roadmap.nodes[pairs[:, 1]], resolution)
    return [(int(u), int(v)) for u, v in pairs[~free]]


def _sense(truth: CollisionChecker, world: World, configs: np.ndarray, sensor_range: float):
    """Hidden obstacles within ``sensor_range`` (m) of the arm at any of ``configs``."""
    hidden = set(world.hidden_names())
    if not hidden:
        return []
    seen: set[str] = set()
    for q in configs:
        for name, d in truth.distances(q).items():
            if name in hidden and d <= sensor_range:
                seen.add(name)
        if seen == hidden:
            break
    return sorted(seen)


def execute(
    roadmap: Roadmap,
    checker: CollisionChecker,
    *,
    sensor_range: float,
    resolution: float,
    planner: PlannerFactory = MPDStarLite,
    max_steps: int | None = None,
    view=None,
) -> ExecutionResult:
    """Move along the planned path node by node, revealing hidden obstacles and repairing.

    With ``view`` (a :class:`~mpd_pin.planning.lazy.CostView` of a lazy roadmap) the
    planner searches the view's costs; every plan and repair is settled (the unevaluated
    edges of the path simulated, the search repaired, until its edges are known) before
    the arm moves, and newly found obstacles block edges in the view, evaluated or not, in
    one ``update_edges`` batch (docs/design.md §4g).

    ``checker`` is the planning checker; its ``world`` holds the hidden
    obstacles (they are revealed in it). ``sensor_range`` in metres, ``resolution``
    (rad) for the edge checks. Raises :class:`~mpd_pin.NoPathError` if a revealed
    obstacle cuts the goal off.
    """
    if not (isinstance(sensor_range, (int, float)) and sensor_range >= 0):
        raise ValueError(f"sensor_range must be a number ≥ 0 (m), got {sensor_range!r}")
    world = checker.world
    arm = checker.arm
    truth = CollisionChecker(arm, world, include_hidden=True)
    graph = roadmap.graph() if view is None else view.graph()
    solve = (lambda p: p.plan()) if view is None else view.settle
    p = planner(graph, roadmap.start, roadmap.goal)
    t0 = time.perf_counter()
    path = solve(p)
    initial_seconds = time.perf_counter() - t0
    result = ExecutionResult(
        initial_path=list(path.nodes),
        initial_cost=float(path.cost),
        travelled=[roadmap.start],
        energy=np.zeros(arm.nq),
        initial_plan_seconds=initial_seconds,
        initial_expansions=p.stats.expansions,
    )
    current = roadmap.start
    step = 0
    limit = max_steps if max_steps is not None else 10 * roadmap.num_nodes + 10
    while current != roadmap.goal:
        if step >= limit:
            raise RuntimeError(f"execution did not reach the goal in {limit} steps")
        nxt = path.nodes[1]
        look = np.vstack(
            [
                roadmap.nodes[current][None],
                edge_configurations(
                    roadmap.nodes[current],
                    arm.edge_target(roadmap.nodes[current], roadmap.nodes[nxt]),  # §1d
                    resolution,
                ),
            ]
        )
        seen = _sense(truth, world, look, float(sensor_range))
        if seen:
            tc = time.perf_counter()
            checker.reveal(*seen)
            newly = World(tuple(world[n] for n in seen))
            cut = blocked_edges(roadmap, arm, newly, resolution)
            check_seconds = time.perf_counter() - tc
            before = list(path.nodes)
            before_stats = p.stats.copy()
            tp = time.perf_counter()
            if view is not None:
                view.block(p, cut)
            else:  # one batch: every changed tail repaired once (docs/design.md §5f)
                p.update_edges([(a, b, math.inf) for u, v in cut for a, b in ((u, v), (v, u))
                                if graph.has_edge(a, b)])
            path = solve(p)
            plan_seconds = time.perf_counter() - tp
            result.replans.append(
                ReplanEvent(
                    step=step,
                    node=int(current),
                    revealed=list(seen),
                    blocked_edges=len(cut),
                    expansions=p.stats.expansions - before_stats.expansions,
                    edge_evaluations=p.stats.edge_evaluations - before_stats.edge_evaluations,
                    check_seconds=check_seconds,
                    plan_seconds=plan_seconds,
                    path_before=before,
                    path_after=list(path.nodes),
                )
            )
            continue  # sense again along the (possibly new) next edge
        current = nxt
        result.travelled.append(int(current))
        if current != roadmap.goal:
            p.move_start(current)
            path = solve(p)
        step += 1
    result.energy = roadmap.path_energy(result.travelled)
    if not roadmap.supply.is_default:
        result.supply_energy = roadmap.path_supply_energy(result.travelled)
    return result
