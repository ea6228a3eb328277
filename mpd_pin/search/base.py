"""What every planner shares: the result type, the work counters and the interface.

All planners answer the same questions on a :class:`~mpd_pin.search.graph.Graph`:
``plan()`` returns the cheapest :class:`Path` from the current start to the goal
(or raises :class:`~mpd_pin.errors.NoPathError`), ``update_edge`` changes one
edge cost, ``move_start`` moves the robot. Heuristics are callables
``h(a, b) -> float``; ``None`` means zero, the default for energy costs.

A heuristic must be *admissible* (``h(a, b) <= d(a, b)``, the true cheapest
cost from ``a`` to ``b``), satisfy ``h(a, a) == 0`` and the triangle inequality
``h(a, c) <= h(a, b) + h(b, c)``. Together these make it consistent in both
directions (forward for A*, from the start for D* Lite's keys), which every
planner here relies on for optimality. A Euclidean distance is such a bound for
costs that are at least the length of the edge; for energy a plain joint-space
distance is *not* a lower bound, so the default stays zero (docs/design.md §5).
Values must be finite and ``>= 0``, and they should hold in floating point too
(shrink a tight bound by a relative 1e-12 if in doubt).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from bisect import bisect_left
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from mpd_pin.errors import MpdPinError
from mpd_pin.search.graph import Graph

__all__ = ["Heuristic", "Path", "Planner", "SearchInvariantError", "SearchStats"]

Heuristic = Callable[[int, int], float]


def _plain(x):
    """numpy scalars as Python ints/floats (``update_edge`` refuses numpy floats as ids)."""
    return x.item() if hasattr(x, "item") else x


class SearchInvariantError(MpdPinError, RuntimeError):
    """A planner's internal state is inconsistent (a bug, or an inconsistent heuristic).

    Raised, for example, when following MPD* Lite's stored pointers would loop.
    """


@dataclass(frozen=True)
class Path:
    """A path from start to goal: node ids (start first) and its cost.

    ``cost`` is the sum of the edge costs in path order (left to right, plain
    float addition, as networkx sums), in the graph's cost unit (J for energy).
    """

    nodes: list[int]
    cost: float

    def __len__(self) -> int:
        return len(self.nodes)

    @property
    def edges(self) -> list[tuple[int, int]]:
        """Consecutive node pairs ``(u, v)`` of the path."""
        return list(zip(self.nodes[:-1], self.nodes[1:], strict=True))


@dataclass
class SearchStats:
    """Work counters of a planner.

    ``expansions``: nodes taken off the priority queue and processed;
    ``edge_evaluations``: edge costs read while searching or extracting the path;
    ``queue_operations``: heap pushes and pops (stale entries included).
    ``planner.stats`` is cumulative; ``planner.last_stats`` is the work done since
    the previous ``plan()`` returned, up to the end of the latest one (so it
    includes the repair work of the ``update_edge`` calls in between).
    """

    expansions: int = 0
    edge_evaluations: int = 0
    queue_operations: int = 0

    def copy(self) -> SearchStats:
        """An independent copy."""
        return SearchStats(self.expansions, self.edge_evaluations, self.queue_operations)

    def __add__(self, other: SearchStats) -> SearchStats:
        return SearchStats(
            self.expansions + other.expansions,
            self.edge_evaluations + other.edge_evaluations,
            self.queue_operations + other.queue_operations,
        )

    def __sub__(self, other: SearchStats) -> SearchStats:
        return SearchStats(
            self.expansions - other.expansions,
            self.edge_evaluations - other.edge_evaluations,
            self.queue_operations - other.queue_operations,
        )


class Planner(ABC):
    """Common interface of MPDStarLite, DStarLite, AStar and Dijkstra.

    Parameters: ``graph`` (the planner reads it live; change costs through
    :meth:`update_edge` so incremental planners learn about it), ``start`` and
    ``goal`` node ids, ``heuristic(a, b)`` (see module docstring) or ``None``.
    """

    def __init__(
        self, graph: Graph, start: int, goal: int, heuristic: Heuristic | None = None
    ) -> None:
        if not isinstance(graph, Graph):
            raise TypeError(f"graph must be a mpd_pin.search.Graph, got {type(graph).__name__}")
        if heuristic is not None and not callable(heuristic):
            raise TypeError(
                f"heuristic must be callable h(a, b) -> float or None, got {heuristic!r}"
            )
        self.graph = graph
        #: the graph's live CSR storage (read-only by contract, see Graph.successor_view)
        self._succ = graph.successor_view
        self._start = graph.check_node(start, "start")
        self.goal = graph.check_node(goal, "goal")
        self.heuristic = heuristic
        self.stats = SearchStats()
        self.last_stats = SearchStats()
        self.stats_mark = SearchStats()

    @property
    def start(self) -> int:
        """Current start node (where the robot is)."""
        return self._start

    @abstractmethod
    def plan(self) -> Path:
        """Cheapest path from the current start to the goal; NoPathError if none."""

    @abstractmethod
    def update_edge(self, u: int, v: int, cost: float) -> None:
        """Set the cost of the existing directed edge ``u -> v`` (``math.inf`` = blocked)."""

    @abstractmethod
    def move_start(self, node: int) -> None:
        """The robot advanced: plan from ``node`` from now on."""

    def update_edges(self, changes: Iterable[tuple[int, int, float]] | tuple) -> None:
        """Apply several ``(u, v, cost)`` changes as one batch (docs/design.md §5f).

        ``changes``: an iterable of triples, or a tuple of three equal-length numpy arrays
        ``(u, v, cost)``. The incremental planners override this with one vectorised
        look-up and one rhs repair per changed tail; here it is ``update_edge`` in turn.
        """
        if isinstance(changes, tuple) and len(changes) == 3 and isinstance(changes[0], np.ndarray):
            changes = zip(*(list(map(_plain, a)) for a in changes), strict=True)
        for u, v, c in changes:
            self.update_edge(u, v, c)

    def _add_work(self, expansions: int, edge_evaluations: int, queue_operations: int) -> None:
        st = self.stats
        st.expansions += expansions
        st.edge_evaluations += edge_evaluations
        st.queue_operations += queue_operations

    def _close_plan_stats(self) -> None:
        self.last_stats = self.stats - self.stats_mark
        self.stats_mark = self.stats.copy()

    def _path_from_nodes(self, nodes: list[int]) -> Path:
        """Build a Path, summing edge costs left to right; checks each edge is finite."""
        sptr, sdst, scost = self._succ
        inf = math.inf
        total = 0.0
        u = nodes[0]
        for v in nodes[1:]:
            hi = sptr[u + 1]
            k = bisect_left(sdst, v, sptr[u], hi)
            if k == hi or sdst[k] != v or scost[k] == inf:
                raise SearchInvariantError(
                    f"{type(self).__name__}: extracted path uses edge {u} -> {v}, "
                    "which is missing or blocked"
                )
            total += scost[k]
            u = v
        return Path(nodes=nodes, cost=total)
