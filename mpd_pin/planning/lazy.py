"""Lazy energy roadmaps: simulate only the edges the search needs (docs/design.md §4g).

LazySP (Dellin & Srinivasa 2016) on MPD* Lite. Every collision-free directed edge
enters the search graph at a lower bound of its E⁺ (:class:`~mpd_pin.dynamics.bound.
EnergyBound`). The planner's current best path has its unevaluated edges simulated
together (one batch through ``EnergyCost.outcomes``, the feasibility rules of
docs/design.md §4e applied: a refused edge becomes ∞), their true costs enter through
one ``update_edges`` call, MPD* Lite repairs, and so on until the best path consists of
evaluated edges only. Its cost is then ≤ the bound-cost of every other path, which is ≤
that path's true cost as long as the bound holds: the exact eager optimum.

The bound is an estimate (tracking error), so every evaluated edge is checked against
it. A violation (bound > true) is counted, its ratio recorded, and the bounds of all
unevaluated edges are scaled by ``SAFETY`` × the smallest true/bound ratio seen so far,
entered in one batch, before the search goes on: the loop's stopping test is then made
against bounds below every ratio observed.

:class:`LazyEdges` holds the evaluation state of one roadmap (shared by every search of
a run: the energy-optimal one, the shortest-path comparison, hazard re-planning,
execution). :class:`CostView` is what one search sees: energy or length costs, edges
blocked by obstacles found later, hazard penalties; :meth:`CostView.settle` is the loop.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..dynamics.bound import EnergyBound
from ..dynamics.cost import EnergyCost
from ..progress import bar
from ..search import Graph, Path, Planner
from .evaluate import SMALL_BATCH, certify_pairs, edge_target, evaluate_edges
from .options import RoadmapOptions
from .roadmap_data import NegativeCostError, Roadmap

__all__ = ["LazyEdges", "CostView", "LandmarkHeuristic", "SAFETY", "SMALL_BATCH",
           "evaluate_edges", "lazy_plan"]

#: After a bound violation, unevaluated bounds are scaled to this fraction of the smallest
#: true/bound ratio observed (docs/design.md §4g).
SAFETY = 0.9

#: Edges per call of the lower bound in :class:`LazyEdges` (the bar's step; measured on a
#: 10,000-node Panda roadmap: ~0.2 s per chunk).
BOUND_CHUNK = 8192


class LandmarkHeuristic:
    """h(a, b) = max(0, D[b] − D[a]) (J or rad), D the shortest distance from a landmark
    node on the current lower costs (docs/design.md §5d).

    With the landmark the search's start, h(start, v) = D[v]: the bound-distance from the
    start. ``d(L, b) ≤ d(L, a) + d(a, b)`` makes it a lower bound of d(a, b) for every pair
    (also after the start moves), with h(a, a) = 0 and the triangle inequality: admissible
    and consistent for every cost at least the one D was computed on — true costs above
    their bounds, ∞ for refused or blocked edges. Nodes the landmark cannot reach get a
    finite D above every reachable one (they cannot reach the goal from it either).

    ``weight`` < 1 scales D (still admissible and consistent): with the exact distances,
    every node of an optimal path would tie with the start's key, and D* Lite stops at
    the first key not below the start's, leaving such nodes inconsistent and their
    pointers stale; the weight keeps them strictly below.
    """

    def __init__(self, dist: np.ndarray, weight: float = 0.999) -> None:
        dist = np.asarray(dist, dtype=float)
        finite = np.isfinite(dist)
        top = float(dist[finite].max()) + 1.0 if finite.any() else 1.0
        # list: cheap scalar look-ups
        self._d = (weight * np.where(finite, dist, top)).tolist()

    def __call__(self, a: int, b: int) -> float:
        d = self._d[b] - self._d[a]
        return d if d > 0.0 else 0.0


@dataclass
class _Counters:
    rounds: int = 0
    simulated: int = 0
    refused: int = 0
    violations: int = 0
    simulate_seconds: float = 0.0
    #: undirected node pairs whose edge the collision checker certified or blocked
    pairs_checked: int = 0
    #: directed edges found in collision by those checks
    collided: int = 0
    check_seconds: float = 0.0


class LazyEdges:
    """The edges of ``roadmap`` (NaN energies = not evaluated), simulated on demand.

    ``cost`` simulates (``EnergyCost``); ``options`` give the feasibility rules;
    ``bound`` (default: :class:`EnergyBound` of the cost's drive) the lower bounds. Edges
    already evaluated (a cached file) are reused and checked against the bound at once.
    Energies are written into ``roadmap.energy`` in place. ``progress``: every
    :meth:`CostView.settle` on these edges shows a "lazy search" bar (rounds, edges
    simulated) on stderr; an attribute, so it may be switched later.

    A roadmap whose edges are not all collision-checked (``roadmap.checked``, lazy
    collision checking) needs ``checker``: the search certifies an edge at ``resolution``
    rad (default ``options.resolution``) before simulating it, and a blocked edge (both
    directions) becomes ∞ like a refused one (docs/design.md §4g).
    """

    def __init__(self, roadmap: Roadmap, cost: EnergyCost, options: RoadmapOptions,
                 bound=None, progress: bool = False, checker=None,
                 resolution: float | None = None) -> None:
        self.roadmap = roadmap
        self.cost = cost
        self.options = options
        self.progress = bool(progress)
        self.checker = checker
        self.resolution = options.resolution if resolution is None else float(resolution)
        if roadmap.checked is not None:
            roadmap.checked = np.asarray(roadmap.checked, dtype=bool)  # updated in place
            if checker is None and not roadmap.checked.all():
                raise ValueError("a roadmap with unchecked edges needs a collision checker")
        self.bound = bound if bound is not None else EnergyBound(
            cost.drive, arrival_tolerance=options.arrival_tolerance)
        rm = roadmap
        t0 = time.perf_counter()
        Q0 = rm.nodes[rm.src]
        self._Q1 = edge_target(cost, Q0, rm.nodes[rm.dst])  # shorter way round (§1d)
        self.lower = self._bounds(Q0)
        self.bound_seconds = time.perf_counter() - t0
        if self.lower.shape != (rm.num_edges,) or not np.all(np.isfinite(self.lower)
                                                              & (self.lower >= 0)):
            raise ValueError("the lower bound must give one finite value >= 0 (J) per edge")
        self.refused = np.zeros(rm.num_edges, dtype=bool)
        self.scale = 1.0
        self.count = _Counters()
        self._ratios: list[np.ndarray] = []
        self.worst_ratio: float | None = None
        self._lookup = {(int(u), int(v)): e for e, (u, v) in
                        enumerate(zip(rm.src.tolist(), rm.dst.tolist(), strict=True))}
        known = rm.evaluated
        self.reused = int(known.sum())
        if self.reused:
            self._check(np.flatnonzero(known))

    def _bounds(self, Q0: np.ndarray) -> np.ndarray:
        """The lower bound (J) of every edge, in chunks of :data:`BOUND_CHUNK` edges (each
        edge's bound is its own: the chunks give the same numbers as one call), with an
        "edge bounds" bar when ``progress`` (issue 34: a phase of seconds on big roadmaps).
        With a regenerating bus, the bound of the reweighted cost (docs/design.md §3i)."""
        rm = self.roadmap
        E = rm.num_edges
        out = np.empty(E)
        with bar(E, "edge bounds", unit="edge",
                 enabled=self.progress and E > BOUND_CHUNK) as shown:
            for a in range(0, E, BOUND_CHUNK):
                c = slice(a, min(a + BOUND_CHUNK, E))
                if rm.potential is None:
                    lower = self.bound(Q0[c], self._Q1[c], rm.durations[c])
                else:
                    lower = self.bound(Q0[c], self._Q1[c], rm.durations[c],
                                       potential=(rm.potential[rm.src[c]],
                                                  rm.potential[rm.dst[c]]))
                lower = np.asarray(lower, dtype=float)
                if lower.shape != (c.stop - c.start,):
                    raise ValueError("the lower bound must give one finite value >= 0 (J) per "
                                     "edge")
                out[c] = lower
                shown.update(c.stop - c.start)
        return out

    # ------------------------------------------------------------------ state
    @property
    def known(self) -> np.ndarray:
        """(E,) bool: evaluated or refused (nothing left to simulate)."""
        return self.roadmap.evaluated | self.refused

    @property
    def checked(self) -> np.ndarray:
        """(E,) bool: edges certified collision-free (the roadmap's, updated in place)."""
        return self.roadmap.checked_mask

    def certify(self, ids: np.ndarray) -> np.ndarray:
        """Collision-check the unchecked edges among ``ids`` (each undirected pair once, in
        one batch); both directions of a blocked pair are refused (∞). Returns the ids of
        the edges newly refused for collision (docs/design.md §4g)."""
        rm = self.roadmap
        ids = np.asarray(ids, dtype=np.int64)
        ids = ids[~self.checked[ids]]
        if ids.size == 0:
            return ids
        t0 = time.perf_counter()
        lo = np.minimum(rm.src[ids], rm.dst[ids])
        hi = np.maximum(rm.src[ids], rm.dst[ids])
        pairs = np.unique(np.stack([lo, hi], axis=1), axis=0)
        free = certify_pairs(self.checker, rm.nodes, pairs, self.resolution)
        rm.checked[self.pair_ids(pairs.tolist())] = True
        blocked = self.pair_ids(pairs[~free].tolist())
        self.refused[blocked] = True
        self.count.pairs_checked += int(len(pairs))
        self.count.collided += int(blocked.size)
        self.count.check_seconds += time.perf_counter() - t0
        return blocked

    @property
    def edges_evaluated(self) -> int:
        """Edges whose energy was simulated for planning, this run or reused (refused
        ones included: they were simulated too)."""
        return self.reused + self.count.simulated

    def edge_ids(self, nodes: list[int]) -> np.ndarray:
        """Edge indices along a node path."""
        lk = self._lookup
        return np.array([lk[(a, b)] for a, b in zip(nodes[:-1], nodes[1:], strict=True)],
                        dtype=np.int64)

    def pair_ids(self, pairs) -> np.ndarray:
        """Indices of the edges u → v and v → u of undirected node pairs (those existing)."""
        lk = self._lookup
        out = [lk[k] for u, v in pairs for k in ((u, v), (v, u)) if k in lk]
        return np.array(sorted(set(out)), dtype=np.int64)

    def energy_costs(self, ids: np.ndarray | None = None) -> np.ndarray:
        """Planning energy costs (J): true E⁺ sum where evaluated, ∞ where refused, the
        (scaled) bound elsewhere."""
        ids = np.arange(self.roadmap.num_edges) if ids is None else np.asarray(ids)
        e = self.roadmap.edge_costs(ids)
        out = np.where(np.isnan(e), self.scale * self.lower[ids], e)
        out[self.refused[ids]] = math.inf
        return out

    def length_costs(self, ids: np.ndarray | None = None) -> np.ndarray:
        """Joint-space lengths (rad), ∞ where refused (docs/design.md §7c)."""
        rm = self.roadmap
        ids = np.arange(rm.num_edges) if ids is None else np.asarray(ids)
        out = np.linalg.norm(self._Q1[ids] - rm.nodes[rm.src[ids]], axis=1)
        out[self.refused[ids]] = math.inf
        return out

    # ------------------------------------------------------------- evaluation
    def evaluate(self, ids: np.ndarray) -> bool:
        """Simulate the edges ``ids`` (not yet known) in one batch; returns True if a
        bound violation changed the scale (every unevaluated cost then changed)."""
        ids = np.asarray(ids, dtype=np.int64)
        if ids.size == 0:
            return False
        t0 = time.perf_counter()
        refused = evaluate_edges(self.cost, self.roadmap, ids, self.options)
        self.count.simulate_seconds += time.perf_counter() - t0
        self.count.simulated += int(ids.size)
        self.count.refused += int(refused.sum())
        self.refused[ids[refused]] = True
        return self._check(ids[~refused])

    def _check(self, ids: np.ndarray) -> bool:
        """Compare bound and true cost on evaluated edges ``ids``; scale on a violation."""
        if ids.size == 0:
            return False
        true = self.roadmap.edge_costs(ids)
        if np.any(true < 0):  # the searches and the bounds need costs >= 0 (§3i)
            j = int(np.flatnonzero(true < 0)[0])
            k, c, rm = int(ids[j]), float(true[j]), self.roadmap
            raise NegativeCostError(f"edge {int(rm.src[k])} -> {int(rm.dst[k])} costs "
                                    f"{c:.6g} J < 0; the searches need costs >= 0 (a supply "
                                    "with regeneration is reweighted by the node potential, "
                                    "docs/design.md §3i)", (int(rm.src[k]), int(rm.dst[k])), c)
        lb = self.lower[ids]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(true > 0, lb / np.where(true > 0, true, 1.0),
                             np.where(lb > 0, math.inf, 0.0))
        self._ratios.append(ratio)
        bad = lb > true
        if not bad.any():
            return False
        self.count.violations += int(bad.sum())
        worst = float(ratio[bad].max())
        self.worst_ratio = worst if self.worst_ratio is None else max(self.worst_ratio, worst)
        new = SAFETY / self.worst_ratio if math.isfinite(self.worst_ratio) else 0.0
        if new < self.scale:
            self.scale = new
            return True
        return False

    def ratios(self) -> np.ndarray:
        """bound / true over the evaluated (feasible) edges checked so far."""
        return np.concatenate(self._ratios) if self._ratios else np.zeros(0)

    def record(self, evaluation: str = "lazy") -> dict:
        """The result.json fields of docs/design.md §4g."""
        r = self.ratios()
        r = r[np.isfinite(r)]
        return {
            "rounds": self.count.rounds,
            "bound_median_ratio": float(np.median(r)) if r.size else None,
            "bound_violations": self.count.violations,
            "bound_worst_ratio": self.worst_ratio,
            "bound_scale": self.scale,
            "simulated": self.count.simulated,
            "reused": self.reused,
            "refused": self.count.refused,
            "simulate_seconds": self.count.simulate_seconds,
            "pairs_checked": self.count.pairs_checked,
            "collided": self.count.collided,
            "check_seconds": self.count.check_seconds,
            "bound_seconds": self.bound_seconds,
            "bound": self.bound.describe() if hasattr(self.bound, "describe") else {},
        }

    def save(self, path) -> None:
        """Write the roadmap with what was evaluated (refused edges dropped, NaN where not
        evaluated) so a later query reuses it (docs/design.md §4f)."""
        self.roadmap.without_edges(self.refused).save(path)


class CostView:
    """The costs one search sees on a :class:`LazyEdges`: ``kind`` "energy" (J) or
    "length" (rad), edges blocked by obstacles found later (∞), hazard penalties."""

    def __init__(self, lazy: LazyEdges, kind: str = "energy") -> None:
        if kind not in ("energy", "length"):
            raise ValueError(f"kind must be 'energy' or 'length', got {kind!r}")
        self.lazy = lazy
        self.kind = kind
        self.blocked = np.zeros(lazy.roadmap.num_edges, dtype=bool)
        self.penalty: dict[int, tuple[float, float]] = {}

    def costs(self, ids: np.ndarray | None = None) -> np.ndarray:
        """Current planning costs of the edges ``ids`` (all by default)."""
        from .hazards import penalised_cost

        lz = self.lazy
        ids = np.arange(lz.roadmap.num_edges) if ids is None else np.asarray(ids, np.int64)
        c = lz.energy_costs(ids) if self.kind == "energy" else lz.length_costs(ids)
        c[self.blocked[ids]] = math.inf
        if self.penalty:
            for j, e in enumerate(ids.tolist()):
                if e in self.penalty:
                    c[j] = penalised_cost(float(c[j]), *self.penalty[e])
        return c

    def graph(self) -> Graph:
        """A search graph on the current costs."""
        rm = self.lazy.roadmap
        return Graph.from_arrays(rm.num_nodes, rm.src, rm.dst, self.costs())

    def heuristic(self, landmark: int) -> LandmarkHeuristic:
        """The focused search's heuristic (docs/design.md §5d): distances from ``landmark``
        (the start) on the current costs — bounds where not evaluated — by one compiled
        Dijkstra (``scipy.sparse.csgraph``)."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        rm = self.lazy.roadmap
        c = self.costs()
        ok = np.isfinite(c)
        # built from (data, (i, j)): an explicit zero cost stays an edge for csgraph
        G = csr_matrix((c[ok], (rm.src[ok], rm.dst[ok])), shape=(rm.num_nodes, rm.num_nodes))
        return LandmarkHeuristic(dijkstra(G, indices=landmark))

    def planner(self, planner_cls, start: int, goal: int, *, focused: bool = True) -> Planner:
        """A planner on the current costs, focused by :meth:`heuristic` from ``start``
        when ``focused`` and the planner takes one — not Dijkstra (:meth:`settle` rebuilds it
        after the bounds are rescaled)."""
        from ..search import Dijkstra

        # Dijkstra is the unfocused search by definition (a heuristic makes it A*)
        use = focused and not issubclass(planner_cls, Dijkstra)
        h = self.heuristic(start) if use else None
        return planner_cls(self.graph(), start, goal, heuristic=h)

    def _push(self, planner: Planner, ids: np.ndarray) -> None:
        rm = self.lazy.roadmap
        if ids.size:
            planner.update_edges((rm.src[ids], rm.dst[ids], self.costs(ids)))

    def block(self, planner: Planner, pairs) -> int:
        """Block (∞) both directions of the undirected node ``pairs`` in this view and in
        ``planner``, evaluated or not; returns how many directed edges."""
        ids = self.lazy.pair_ids(pairs)
        self.blocked[ids] = True
        self._push(planner, ids)
        return int(ids.size)

    def penalise(self, planner: Planner, pairs, penalty: float, floor: float) -> None:
        """Cost both directions of ``pairs`` ``penalised_cost(cost, penalty, floor)`` from
        now on (also once evaluated)."""
        ids = self.lazy.pair_ids(pairs)
        for e in ids.tolist():
            self.penalty[e] = (float(penalty), float(floor))
        self._push(planner, ids)

    def settle(self, planner: Planner) -> Path:
        """The LazySP loop: plan, simulate the path's unknown edges in one batch, enter
        their costs in one ``update_edges`` (all unevaluated ones after a bound violation),
        repair; until the path's edges are all known. Raises NoPathError like plan().
        With ``lazy.progress``, a "lazy search" bar counts this loop's rounds and shows
        the edges simulated so far (by every search on these edges)."""
        lz = self.lazy
        rm = lz.roadmap
        self.planner_used = planner
        with bar(None, f"lazy search ({self.kind})", unit=" rounds",
                 enabled=lz.progress) as rounds:
            while True:
                path = planner.plan()
                ids = lz.edge_ids(path.nodes)
                todo = ids[~lz.known[ids]]
                if todo.size == 0:
                    self.planner_used = planner
                    return path
                lz.count.rounds += 1
                # LazySP on collision too: certify the path's unchecked edges first; blocked
                # ones leave in one update and the planner repairs before any simulation
                blocked = lz.certify(todo)
                checked = (f"{2 * lz.count.pairs_checked} edge checks, "
                           if lz.count.pairs_checked else "")
                if blocked.size:
                    self._push(planner, blocked)
                    rounds.set_postfix_str(f"{checked}{lz.count.simulated} edges simulated",
                                           refresh=False)
                    rounds.update(1)
                    continue
                rounds.set_postfix_str(
                    f"{checked}{lz.count.simulated} edges simulated (+{todo.size})")
                rescaled = lz.evaluate(todo)
                rounds.set_postfix_str(f"{checked}{lz.count.simulated} edges simulated",
                                       refresh=False)
                rounds.update(1)
                if rescaled and self.kind == "energy":
                    if isinstance(planner.heuristic, LandmarkHeuristic):
                        # lower bounds dropped: the heuristic may overestimate now, so
                        # the focused search starts again on the new costs (§5d)
                        planner = self._refocus(planner)
                        continue
                    todo = np.union1d(todo, np.flatnonzero(~rm.evaluated & ~lz.refused))
                self._push(planner, todo)

    def _refocus(self, old: Planner) -> Planner:
        """A new focused planner from ``old``'s start on the current costs; the work done
        so far stays in its statistics."""
        new = self.planner(type(old), old.start, old.goal)
        new.stats = old.stats.copy()
        new.stats_mark = old.stats_mark.copy()
        self.planner_used = new
        return new


def lazy_plan(lazy: LazyEdges, planner_cls, kind: str = "energy", *,
              focused: bool = False) -> tuple[Path, Planner]:
    """One lazy search from the roadmap's start to its goal: (path, planner); ``focused``:
    with the bound-distance heuristic (:meth:`CostView.heuristic`)."""
    view = CostView(lazy, kind)
    p = view.planner(planner_cls, lazy.roadmap.start, lazy.roadmap.goal, focused=focused)
    path = view.settle(p)
    return path, view.planner_used
