"""A* (Hart, Nilsson & Raphael 1968) and Dijkstra: forward best-first search.

They search from the start to the goal and, after any edge change or start
move, search again from scratch: the non-incremental baselines of paper 000
(Table 6). Priority queue: ``heapq`` with lazy deletion (an entry whose g is
larger than the node's current g is skipped). Entries are ``(f, g, node)``.
A node is re-expanded if a cheaper g is found later, so the result stays
optimal even for a heuristic that is admissible but only approximately
consistent; with a consistent one each node is expanded at most once.
"""

from __future__ import annotations

import math
from heapq import heappop, heappush

from mpd_pin.errors import NoPathError
from mpd_pin.search.base import Heuristic, Path, Planner, SearchInvariantError
from mpd_pin.search.graph import Graph

__all__ = ["AStar", "Dijkstra"]

_INF = math.inf


class _BestFirst(Planner):
    """Forward search from the start; the cached path is reused until something changes."""

    def __init__(
        self, graph: Graph, start: int, goal: int, heuristic: Heuristic | None = None
    ) -> None:
        super().__init__(graph, start, goal, heuristic)
        self._path: Path | None = None

    def update_edge(self, u: int, v: int, cost: float) -> None:
        """Set the cost of edge ``u -> v`` (``math.inf`` = blocked); next plan() re-searches."""
        self.graph.set_cost(u, v, cost)
        self._path = None

    def move_start(self, node: int) -> None:
        """Plan from ``node`` from now on (next plan() re-searches)."""
        node = self.graph.check_node(node, "start")
        if node != self._start:
            self._start = node
            self._path = None

    def plan(self) -> Path:
        """Cheapest path start -> goal, searched from scratch if anything changed."""
        if self._path is None:
            try:
                self._path = self._search()
            finally:
                self._close_plan_stats()
        else:
            self._close_plan_stats()
        return self._path

    def _search(self) -> Path:
        gr = self.graph
        sptr, sdst, scost = gr.successor_view
        n = gr.num_nodes
        start, goal = self._start, self.goal
        hfun = self.heuristic
        g = [_INF] * n
        parent = [-1] * n
        g[start] = 0.0
        if hfun is None:
            heap = [(0.0, 0.0, start)]
        else:
            heap = [(hfun(start, goal), 0.0, start)]
        n_exp = n_ev = 0
        n_q = 1
        found = False
        while heap:
            _, gu, u = heappop(heap)
            n_q += 1
            if gu > g[u]:
                continue  # stale entry
            if u == goal:
                found = True
                break
            n_exp += 1
            a, b = sptr[u], sptr[u + 1]
            n_ev += b - a
            if hfun is None:
                for j in range(a, b):  # index loop: cheaper than zip(..., strict=True)
                    v = sdst[j]
                    ng = gu + scost[j]
                    if ng < g[v]:
                        g[v] = ng
                        parent[v] = u
                        heappush(heap, (ng, ng, v))
                        n_q += 1
            else:
                for j in range(a, b):
                    v = sdst[j]
                    ng = gu + scost[j]
                    if ng < g[v]:
                        g[v] = ng
                        parent[v] = u
                        heappush(heap, (ng + hfun(v, goal), ng, v))
                        n_q += 1
        self._add_work(n_exp, n_ev, n_q)
        if not found:
            raise NoPathError(f"no path from node {start} to node {goal}")
        nodes = [goal]
        s = goal
        while s != start:
            s = parent[s]
            nodes.append(s)
            if s < 0 or len(nodes) > n:
                raise SearchInvariantError(
                    f"{type(self).__name__}: parent chain from goal {goal} does not reach "
                    f"start {start}"
                )
        nodes.reverse()
        return self._path_from_nodes(nodes)


class AStar(_BestFirst):
    """A*: forward search ordered by g + h(node, goal); ``heuristic=None`` is Dijkstra order."""


class Dijkstra(_BestFirst):
    """Dijkstra's algorithm (A* without heuristic); ``heuristic`` must be None."""

    def __init__(
        self, graph: Graph, start: int, goal: int, heuristic: Heuristic | None = None
    ) -> None:
        if heuristic is not None:
            raise ValueError("Dijkstra takes no heuristic (heuristic must be None); use AStar")
        super().__init__(graph, start, goal, None)
