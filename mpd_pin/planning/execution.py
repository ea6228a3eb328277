"""Executing a roadmap path while the world changes (paper 000 §5.2; docs/design.md §5).

* :func:`execute` — the arm moves node by node along the planned path. Before
  each move a sensor looks for obstacles that are not on the map: every hidden
  obstacle within ``sensor_range`` (m) of the arm, at its current configuration
  or anywhere along the edge it is about to take, is revealed. The roadmap edges
  that now collide are set to ∞ in the planner, which repairs its plan from the
  current node (MPD* Lite: incremental). The result records every replan and the
  path actually travelled with its energy.
* :func:`plan_avoiding_hazards` — a path that passes closer to a "No Enter"
  zone than its clearance is re-planned with the offending edges removed (or,
  for a finite penalty, made dearer: see :func:`penalised_cost`), LazySP-style:
  only edges on candidate paths are checked, until the path keeps every
  clearance. :attr:`HazardResult.satisfied` says whether it does in the end (a
  finite penalty can leave a violating path cheapest; a
  :class:`HazardClearanceWarning` is issued then).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from ..collision.checker import CollisionChecker, edge_configurations
from ..search import MPDStarLite, Planner
from ..world import World
from .roadmap import Roadmap

__all__ = [
    "ReplanEvent",
    "ExecutionResult",
    "HazardResult",
    "HazardClearanceWarning",
    "execute",
    "plan_avoiding_hazards",
    "penalised_cost",
    "blocked_edges",
]

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
    replans: one :class:`ReplanEvent` per repair; initial_plan_seconds, expansions.
    """

    initial_path: list[int]
    initial_cost: float
    travelled: list[int]
    energy: np.ndarray
    replans: list[ReplanEvent] = field(default_factory=list)
    initial_plan_seconds: float = 0.0
    initial_expansions: int = 0

    @property
    def total_energy(self) -> float:
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
) -> ExecutionResult:
    """Move along the planned path node by node, revealing hidden obstacles and repairing.

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
    graph = roadmap.graph()
    p = planner(graph, roadmap.start, roadmap.goal)
    t0 = time.perf_counter()
    path = p.plan()
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
                edge_configurations(roadmap.nodes[current], roadmap.nodes[nxt], resolution),
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
            for u, v in cut:
                for a, b in ((u, v), (v, u)):
                    if graph.has_edge(a, b):
                        p.update_edge(a, b, math.inf)
            path = p.plan()
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
            path = p.plan()
        step += 1
    result.energy = roadmap.path_energy(result.travelled)
    return result


# ------------------------------------------------------------------------ hazards
class HazardClearanceWarning(UserWarning):
    """plan_avoiding_hazards ended with a path that still violates a hazard clearance."""


def penalised_cost(cost: float, penalty: float, floor: float) -> float:
    """Cost of an edge too close to a hazard: ``max(cost * penalty, cost + floor)``.

    ``penalty`` ≥ 1 is the multiplicative factor (``math.inf`` removes the edge:
    the result is ∞ whatever ``cost``); ``floor`` ≥ 0 (cost units, J) is an
    additive minimum, so that edges of zero (or tiny) cost are penalised too —
    a product alone leaves a zero-cost edge free.
    """
    if not math.isfinite(penalty):
        return math.inf
    return max(cost * penalty, cost + floor)


@dataclass
class HazardResult:
    """Outcome of :func:`plan_avoiding_hazards`.

    first_path / final_path: node ids; *_energy: E⁺ per joint (J);
    *_margin: min over the path of (distance to a hazard − its clearance) (m);
    penalised: the undirected edges removed or penalised; rounds: re-plans;
    satisfied: ``final_margin >= 0`` (the final path keeps every clearance);
    penalty, penalty_floor: the factor and the additive floor (J) used by
    :func:`penalised_cost` (floor unused, reported as ∞ -> None in JSON, when the
    penalty is ∞).
    """

    first_path: list[int]
    first_energy: np.ndarray
    first_margin: float
    final_path: list[int]
    final_energy: np.ndarray
    final_margin: float
    penalised: list[tuple[int, int]]
    rounds: int
    plan_seconds: float
    satisfied: bool
    penalty: float
    penalty_floor: float

    def to_dict(self) -> dict:
        return {
            "first_path": [int(n) for n in self.first_path],
            "first_energy_per_joint": [float(e) for e in self.first_energy],
            "first_total_energy": float(np.sum(self.first_energy)),
            "first_margin": float(self.first_margin),
            "final_path": [int(n) for n in self.final_path],
            "final_energy_per_joint": [float(e) for e in self.final_energy],
            "final_total_energy": float(np.sum(self.final_energy)),
            "final_margin": float(self.final_margin),
            "satisfied": bool(self.satisfied),
            "penalty": float(self.penalty),
            "penalty_floor": (
                float(self.penalty_floor) if math.isfinite(self.penalty_floor) else None
            ),
            "penalised_edges": [[int(u), int(v)] for u, v in self.penalised],
            "rounds": self.rounds,
            "plan_seconds": self.plan_seconds,
        }


def plan_avoiding_hazards(
    roadmap: Roadmap,
    checker: CollisionChecker,
    *,
    resolution: float,
    penalty: float = math.inf,
    penalty_floor: float | None = None,
    planner: PlannerFactory = MPDStarLite,
) -> HazardResult:
    """Plan, then re-plan until the path keeps every hazard's clearance (Fig. 17).

    Edges whose configurations (at ``resolution`` rad) come closer to a hazard
    than its clearance get the cost ``penalised_cost(cost, penalty, floor)``
    (∞ = removed), both directions, and MPD* Lite repairs. ``penalty_floor``
    (J, ≥ 0) is the additive minimum; ``None`` means ``(penalty − 1)`` times the
    mean positive finite edge cost of the roadmap (1 J if it has none), so a
    zero-cost edge is penalised like an edge of average cost. Stops when the
    path keeps all clearances or when every offending edge on it is already
    penalised; in the latter case the result has ``satisfied=False`` and a
    :class:`HazardClearanceWarning` is issued. With ``penalty=inf`` (the
    default) an unsatisfiable clearance raises :class:`~mpd_pin.NoPathError`
    instead, as the offending edges are removed.
    """
    if not (penalty >= 1.0):
        raise ValueError(f"penalty must be ≥ 1 (or inf to remove edges), got {penalty!r}")
    if penalty_floor is not None and not (math.isfinite(penalty_floor) and penalty_floor >= 0.0):
        raise ValueError(f"penalty_floor must be finite and ≥ 0 (J), got {penalty_floor!r}")
    graph = roadmap.graph()
    if not math.isfinite(penalty):
        floor = math.inf
    elif penalty_floor is not None:
        floor = float(penalty_floor)
    else:
        c = np.asarray(roadmap.cost, dtype=float)
        c = c[np.isfinite(c) & (c > 0)]
        floor = (penalty - 1.0) * (float(c.mean()) if c.size else 1.0)
    p = planner(graph, roadmap.start, roadmap.goal)
    margins: dict[tuple[int, int], float] = {}

    def edge_margin(u: int, v: int) -> float:
        key = (min(u, v), max(u, v))
        if key not in margins:
            Q = edge_configurations(roadmap.nodes[key[0]], roadmap.nodes[key[1]], resolution)
            margins[key] = min(checker.hazard_margin(q) for q in Q)
        return margins[key]

    t0 = time.perf_counter()
    path = p.plan()
    first = list(path.nodes)
    penalised: list[tuple[int, int]] = []
    done: set[tuple[int, int]] = set()
    rounds = 0
    while True:
        bad = []
        for u, v in path.edges:
            key = (min(u, v), max(u, v))
            if key not in done and edge_margin(u, v) < 0:
                done.add(key)
                bad.append(key)
        if not bad:
            break
        for u, v in bad:
            penalised.append((u, v))
            for a, b in ((u, v), (v, u)):
                if graph.has_edge(a, b):
                    p.update_edge(a, b, penalised_cost(graph.cost(a, b), penalty, floor))
        path = p.plan()
        rounds += 1
    seconds = time.perf_counter() - t0

    def path_margin(nodes: list[int]) -> float:
        if len(nodes) == 1:
            return checker.hazard_margin(roadmap.nodes[nodes[0]])
        return min(edge_margin(u, v) for u, v in zip(nodes[:-1], nodes[1:], strict=True))

    final = list(path.nodes)
    final_margin = path_margin(final)
    satisfied = bool(final_margin >= 0.0)
    if not satisfied:
        warnings.warn(
            f"plan_avoiding_hazards: the final path still comes {-final_margin:.4g} m closer "
            f"to a hazard than its clearance (penalty {penalty:g}, floor {floor:.4g} J): with "
            "a finite penalty the violating path stayed the cheapest; raise the penalty or "
            "use inf to remove those edges",
            HazardClearanceWarning,
            stacklevel=2,
        )
    return HazardResult(
        first_path=first,
        first_energy=roadmap.path_energy(first),
        first_margin=path_margin(first),
        final_path=final,
        final_energy=roadmap.path_energy(final),
        final_margin=final_margin,
        penalised=penalised,
        rounds=rounds,
        plan_seconds=seconds,
        satisfied=satisfied,
        penalty=float(penalty),
        penalty_floor=floor,
    )
