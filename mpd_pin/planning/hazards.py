"""Re-planning around "No Enter" zones (paper 000 §5.2, Fig. 17; docs/design.md §5).

A hazard is a zone the arm may not come closer to than its clearance (m).
:func:`plan_avoiding_hazards` plans, then re-plans LazySP-style: only the edges
on candidate paths are checked, and an edge that comes too close gets the cost
:func:`penalised_cost` (∞ removes it) until the path keeps every clearance.
:attr:`HazardResult.satisfied` says whether it does in the end (a finite penalty
can leave a violating path cheapest; a :class:`HazardClearanceWarning` is issued
then). :meth:`HazardResult.planning_roadmap` is the roadmap with those same
penalties (:func:`penalised_roadmap`), for planning on after the hazard step
(execution with sensing); energies are always reported from the original roadmap.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

import numpy as np

from ..collision import CollisionChecker, edge_configurations
from ..search import MPDStarLite, Planner
from .roadmap_data import Roadmap

__all__ = [
    "HazardClearanceWarning",
    "HazardResult",
    "penalised_cost",
    "penalised_roadmap",
    "plan_avoiding_hazards",
]


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
    :func:`penalised_cost`; ``penalty`` is ∞ when the offending edges were removed, and
    ``penalty_floor`` is then ∞ too (unused).
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
    #: the energies the two paths draw from the drive's supply (J, docs/design.md §3i);
    #: None: Σ E⁺ (the paper's per-joint supplies)
    first_supply_energy: float | None = None
    final_supply_energy: float | None = None

    def to_dict(self) -> dict:
        """Plain data for result.json (``hazard_replanning``), written by
        :func:`mpd_pin.app.results.write_json`, where a non-finite number is ``null``:
        ``penalty: null`` — ∞, the offending edges were removed; ``penalty_floor: null`` —
        unused (the penalty is ∞); ``first_margin``/``final_margin: null`` — +∞, no known
        hazard to keep clear of."""
        return {
            "first_path": [int(n) for n in self.first_path],
            "first_energy_per_joint": [float(e) for e in self.first_energy],
            "first_total_energy": _total(self.first_supply_energy, self.first_energy),
            "first_margin": float(self.first_margin),
            "final_path": [int(n) for n in self.final_path],
            "final_energy_per_joint": [float(e) for e in self.final_energy],
            "final_total_energy": _total(self.final_supply_energy, self.final_energy),
            "final_margin": float(self.final_margin),
            "satisfied": bool(self.satisfied),
            "penalty": float(self.penalty),
            "penalty_floor": float(self.penalty_floor),
            "penalised_edges": [[int(u), int(v)] for u, v in self.penalised],
            "rounds": self.rounds,
            "plan_seconds": self.plan_seconds,
        }

    def planning_roadmap(self, roadmap: Roadmap) -> Roadmap:
        """``roadmap`` with the edges this re-planning penalised costed as it costed them
        (:func:`penalised_roadmap`); ``roadmap`` itself if none was. Only for planning."""
        if not self.penalised:
            return roadmap
        return penalised_roadmap(roadmap, self.penalised, self.penalty, self.penalty_floor)


def penalised_roadmap(
    roadmap: Roadmap, pairs: Iterable[tuple[int, int]], penalty: float, floor: float = 0.0
) -> Roadmap:
    """A copy of ``roadmap`` in which the edges between the undirected node pairs ``pairs``
    (both directions) cost ``penalised_cost(cost, penalty, floor)`` (∞ removes them), as in
    :func:`plan_avoiding_hazards`. Each such edge's per-joint energies (J) are scaled (or,
    for a zero-cost edge, raised evenly) so that their sum is the penalised cost. Only for
    planning: report energies from the original. With a supply other than the paper's
    (docs/design.md §3i) the penalty applies to the search's cost (the supply energy,
    reweighted by the node potential: ≥ 0) carried by :meth:`Roadmap.with_costs`."""
    pen = {(min(u, v), max(u, v)) for u, v in pairs}
    if not roadmap.supply.is_default:
        costs = np.array(roadmap.cost, dtype=float)
        for e, (u, v) in enumerate(zip(roadmap.src.tolist(), roadmap.dst.tolist(),
                                       strict=True)):
            if (min(u, v), max(u, v)) in pen:
                costs[e] = penalised_cost(float(costs[e]), penalty, floor)
        return roadmap.with_costs(costs)
    energy = np.array(roadmap.energy, dtype=float, copy=True)
    nq = energy.shape[1]
    for e, (u, v) in enumerate(zip(roadmap.src.tolist(), roadmap.dst.tolist(), strict=True)):
        if (min(u, v), max(u, v)) not in pen:
            continue
        cost = float(energy[e].sum())
        target = float(penalised_cost(cost, penalty, floor))
        if not math.isfinite(target):
            energy[e] = math.inf
        elif cost > 0.0:
            energy[e] *= target / cost
        else:
            energy[e] += target / nq
    return replace(roadmap, energy=energy)


def plan_avoiding_hazards(
    roadmap: Roadmap,
    checker: CollisionChecker,
    *,
    resolution: float,
    penalty: float = math.inf,
    penalty_floor: float | None = None,
    planner: Callable[..., Planner] = MPDStarLite,
    view=None,
) -> HazardResult:
    """Plan, then re-plan until the path keeps every hazard's clearance (Fig. 17).

    With ``view`` (a :class:`~mpd_pin.planning.lazy.CostView` of a lazy roadmap) the
    planner searches the view's costs, every path is settled (its edges simulated) before
    its clearance is checked, and the penalties go into the view (docs/design.md §4g).

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
    graph = roadmap.graph() if view is None else view.graph()
    solve = (lambda p: p.plan()) if view is None else view.settle
    if not math.isfinite(penalty):
        floor = math.inf
    elif penalty_floor is not None:
        floor = float(penalty_floor)
    else:
        c = np.asarray(roadmap.cost if view is None else view.costs(), dtype=float)
        c = c[np.isfinite(c) & (c > 0)]
        floor = (penalty - 1.0) * (float(c.mean()) if c.size else 1.0)
    p = planner(graph, roadmap.start, roadmap.goal)
    margins: dict[tuple[int, int], float] = {}

    def edge_margin(u: int, v: int) -> float:
        key = (min(u, v), max(u, v))
        if key not in margins:
            q0 = roadmap.nodes[key[0]]
            q1 = checker.arm.edge_target(q0, roadmap.nodes[key[1]])  # shorter way (§1d)
            Q = edge_configurations(q0, q1, resolution)
            margins[key] = min(checker.hazard_margin(q) for q in Q)
        return margins[key]

    t0 = time.perf_counter()
    path = solve(p)
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
            if view is not None:
                view.penalise(p, [(u, v)], penalty, floor)
                continue
            for a, b in ((u, v), (v, u)):
                if graph.has_edge(a, b):
                    p.update_edge(a, b, penalised_cost(graph.cost(a, b), penalty, floor))
        path = solve(p)
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
        **({} if roadmap.supply.is_default else {
            "first_supply_energy": roadmap.path_supply_energy(first),
            "final_supply_energy": roadmap.path_supply_energy(final)}),
    )


def _total(supply_energy: float | None, energy: np.ndarray) -> float:
    """A path's total (J): its supply energy when given, else Σ E⁺ (§3i)."""
    return float(np.sum(energy)) if supply_energy is None else float(supply_energy)
