"""D* Lite (Koenig & Likhachev 2002, optimized version) and MPD* Lite (paper 000 §3).

Both planners share one search core that runs from the goal towards the start
over predecessor edges, with priorities

    key(s) = [min(g, rhs)(s) + h(s_start, s) + km ;  min(g, rhs)(s)]

and ``km += h(s_last, s_start)`` once after the robot moved, before the next
batch of edge changes is processed (or before the next ``plan()``).

MPD* Lite (000 §3, Fig. 6, the "Store" function): every time ``rhs(u)`` is
(re)computed, the minimising successor is stored as ``u``'s pointer, and the
path is read by following pointers from the start. D* Lite reads the path by
g-gradient: at each node the successor minimising ``cost + g``. The search core
is identical for both, so a comparison measures only path extraction, which is
the one difference the paper claims (000 §5).

Implementation notes (pitfalls of public implementations, docs/design.md §5):

* Zero-cost edges. Classic D* Lite assumes costs > 0: with a zero-cost cycle
  two nodes can end up consistent while supporting each other with a stale
  value. Here path values are compared lexicographically as (cost, hops), so
  every edge is strictly positive in that order and the D* Lite proofs apply;
  the cost component is the exact float cost, and among equal-cost paths the
  one with fewest edges is preferred. This also covers float absorption
  (``c + g == g`` for tiny positive ``c``).
* No float-equality tests on recomputed costs: the "was this edge the support
  of rhs(u)?" test of D* Lite is done on the stored pointer (``ptr[u] == v``),
  which exists in both planners.
* For a changed directed edge ``u -> v`` it is ``rhs(u)`` that is updated.
* ``math.inf`` is infinity (no sentinel), and a node with infinite value has
  hop count 0 so that all unreachable values compare equal.
* The loop runs while ``top_key < key(start)`` or start is inconsistent (keys
  compared as tuples); the priority queue is ``heapq`` with lazy deletion: the
  current entry of a node is the very tuple stored in ``qkey[node]`` (identity).
  Without a heuristic ``km`` stays 0, so a current entry's key is exact and the
  "key grew, reinsert" test is made only with a heuristic.

Speed (measured by bench/search.py and bench/queues.py). Values live in Python
lists indexed by node id; the graph's CSR lists (ptr / neighbour / cost) are read
by index, ``for j in range(a, b)``, which in CPython is much cheaper than
``zip(nbr[a:b], cost[a:b], strict=True)`` (two slices, and the keyword sends every
``zip`` call down a slow path). ``update_edge`` writes the cost itself for plain
int ids and a float cost (``Graph.set_cost`` inlined; other inputs go through it)
and computes the queue key inline; MPD* Lite follows and sums its path in one
pass. Keys and sums use the same expressions in the same order everywhere, so
the results are bit-identical to the straightforward code.
"""

from __future__ import annotations

import math
import operator
from bisect import bisect_left
from heapq import heappop, heappush, heapreplace

import numpy as np

from mpd_pin.errors import NoPathError
from mpd_pin.search.base import Heuristic, Path, Planner, SearchInvariantError
from mpd_pin.search.graph import Graph

__all__ = ["DStarLite", "MPDStarLite"]

_INF = math.inf


# The two expansions of ComputeShortestPath (optimized D* Lite, Koenig & Likhachev 2002),
# called by _DStarLiteCore._compute_shortest_path once per expanded node: the "g(u) > rhs(u)"
# case (_expand_over) and the "else" case, g(u) < rhs(u) (_expand_under). ``ctx`` is the
# tuple that method builds once per call (the live lists, start, km, the heuristic and its
# cache, the bound _recompute_rhs / _update_vertex); module-level functions unpacking one
# tuple cost less per call than methods reading a dozen attributes of self. Each returns its
# work as (edge evaluations, queue operations). _update_vertex and _recompute_rhs are inlined
# with the same expressions in the same order, so the keys and values are bit-identical.
def _expand_over(u: int, ru: float, rhu: int, ctx: tuple) -> tuple[int, int]:
    """Over-consistent ``u`` (rhs < g): g(u) = rhs(u), then every predecessor's rhs is
    relaxed through ``u`` and stored with ``u`` as its pointer (000 Fig. 6) where better."""
    (pptr, psrc, pcost, _, _, _, g, gh, rhs, rh, ptr, qkey, heap, start, km, hc, hfun,
     recompute, update_vertex) = ctx  # fmt: skip
    a, b = pptr[u], pptr[u + 1]
    n_ev = b - a
    n_q = 0
    g[u] = ru
    gh[u] = rhu
    nh = rhu + 1
    for j in range(a, b):
        s = psrc[j]
        t = pcost[j] + ru
        r = rhs[s]
        if t < r or (t == r and nh < rh[s]):
            # better support through u (the goal's (0, 0) is never beaten)
            rhs[s] = t
            rh[s] = nh
            ptr[s] = u
            gsv = g[s]
            ghs = gh[s]
            if gsv == t and ghs == nh:
                qkey[s] = None
                continue
            if t < gsv or (t == gsv and nh < ghs):
                mc, mh = t, nh
            else:
                mc, mh = gsv, ghs
            if hc is None:
                k = (mc + km, mh, mc, s)
            else:
                hv = hc[s]
                if hv is None:
                    hv = hc[s] = hfun(start, s)
                k = (mc + hv + km, mh, mc, s)
            qkey[s] = k
            heappush(heap, k)
            n_q += 1
        elif t == r and ptr[s] == u and nh != rh[s]:
            # same cost, more hops through u (float absorption): re-derive
            n_ev += recompute(s)
            n_q += update_vertex(s)
    return n_ev, n_q


def _expand_under(u: int, ctx: tuple) -> tuple[int, int]:
    """Under-consistent ``u`` (g < rhs): g(u) = inf, then the rhs of every predecessor
    whose pointer is ``u`` is recomputed over its successors, and ``u`` is re-queued."""
    (pptr, psrc, _, sptr, sdst, scost, g, gh, rhs, rh, ptr, qkey, heap, start, km, hc, hfun,
     _, update_vertex) = ctx  # fmt: skip
    a, b = pptr[u], pptr[u + 1]
    n_ev = b - a
    n_q = 0
    g[u] = _INF
    gh[u] = 0
    for s in psrc[a:b]:
        if ptr[s] != u:
            continue
        # rhs(s) was supported by u's old g: _recompute_rhs(s) inlined
        a2, b2 = sptr[s], sptr[s + 1]
        n_ev += b2 - a2
        best = _INF
        bh = 0
        bp = -1
        for j in range(a2, b2):
            v = sdst[j]
            t = scost[j] + g[v]
            if t < best:
                best = t
                bh = gh[v] + 1
                bp = v
            elif t == best and bp >= 0 and gh[v] + 1 < bh:
                bh = gh[v] + 1
                bp = v
        rhs[s] = best
        rh[s] = bh
        ptr[s] = bp
        # _update_vertex(s) inlined
        gsv = g[s]
        ghs = gh[s]
        if gsv == best and ghs == bh:
            qkey[s] = None
            continue
        if best < gsv or (best == gsv and bh < ghs):
            mc, mh = best, bh
        else:
            mc, mh = gsv, ghs
        if hc is None:
            k = (mc + km, mh, mc, s)
        else:
            hv = hc[s]
            if hv is None:
                hv = hc[s] = hfun(start, s)
            k = (mc + hv + km, mh, mc, s)
        qkey[s] = k
        heappush(heap, k)
        n_q += 1
    n_q += update_vertex(u)
    return n_ev, n_q


class _DStarLiteCore(Planner):
    """Incremental search from the goal shared by :class:`MPDStarLite` and :class:`DStarLite`."""

    def __init__(
        self, graph: Graph, start: int, goal: int, heuristic: Heuristic | None = None
    ) -> None:
        super().__init__(graph, start, goal, heuristic)
        n = graph.num_nodes
        # the graph's live successor CSR lists, bound once (read-only by contract)
        self._sptr, self._sdst, self._scost = self._succ
        # update_edge writes both cost orders itself (Graph.set_cost inlined): the graph's
        # predecessor-order costs and edge-id map, also live lists never replaced
        self._pcost = graph.predecessor_view.cost
        self._e2p = graph._e2p
        self._g: list[float] = [_INF] * n
        self._gh: list[int] = [0] * n  # hop count of g (0 when g is inf)
        self._rhs: list[float] = [_INF] * n
        self._rh: list[int] = [0] * n  # hop count of rhs
        self._ptr: list[int] = [-1] * n  # MPD* Lite's stored minimising successor
        self._qkey: list[tuple | None] = [None] * n  # current heap entry (lazy deletion)
        self._heap: list[tuple] = []
        self._km = 0.0
        self._s_last = self._start
        self._hcache: list[float | None] | None = None if heuristic is None else [None] * n
        goal_ = self.goal
        self._rhs[goal_] = 0.0
        self._update_vertex(goal_)

    # --------------------------------------------------------------- internals
    def _update_vertex(self, s: int) -> int:
        """Put ``s`` in the queue iff inconsistent; returns the number of heap pushes.

        Its heap entry is ``(k1, hops, k2, s)`` with ``k2, hops = min(g, rhs)(s)`` as
        (cost, hops) and ``k1 = k2 + h(start, s) + km`` (``k2 + km`` without a heuristic).
        The hot loops inline this with the same expressions in the same order, so a key
        is bit-identical wherever it is computed."""
        g, r = self._g[s], self._rhs[s]
        gh, rh = self._gh[s], self._rh[s]
        if g == r and gh == rh:
            self._qkey[s] = None
            return 0
        if r < g or (r == g and rh < gh):
            mc, mh = r, rh
        else:
            mc, mh = g, gh
        hc = self._hcache
        if hc is None:
            k = (mc + self._km, mh, mc, s)
        else:
            hv = hc[s]
            if hv is None:
                hv = hc[s] = self.heuristic(self._start, s)
            k = (mc + hv + self._km, mh, mc, s)
        self._qkey[s] = k
        heappush(self._heap, k)
        return 1

    def _recompute_rhs(self, s: int) -> int:
        """rhs(s) = min over successors of (cost + g), storing the argmin (000 Fig. 6).

        Returns the number of edge costs read.
        """
        g, gh = self._g, self._gh
        a, b = self._sptr[s], self._sptr[s + 1]
        sdst, scost = self._sdst, self._scost
        best = _INF
        bh = 0
        bp = -1
        for j in range(a, b):  # index loop: cheaper than zip(..., strict=True) of two slices
            v = sdst[j]
            t = scost[j] + g[v]
            if t < best:
                best = t
                bh = gh[v] + 1
                bp = v
            elif t == best and bp >= 0 and gh[v] + 1 < bh:
                bh = gh[v] + 1
                bp = v
        self._rhs[s] = best
        self._rh[s] = bh
        self._ptr[s] = bp
        return b - a

    def _sync_start(self) -> None:
        """``km += h(s_last, s_start)`` once after the start moved (D* Lite, Fig. 4)."""
        if self._start == self._s_last:
            return
        if self.heuristic is not None:
            dk = self.heuristic(self._s_last, self._start)
            if not (0.0 <= dk < _INF):
                raise ValueError(
                    f"heuristic({self._s_last}, {self._start}) = {dk!r}; "
                    "heuristic values must be finite and >= 0"
                )
            self._km += dk
            self._hcache = [None] * self.graph.num_nodes
        self._s_last = self._start

    def _compute_shortest_path(self) -> None:
        """ComputeShortestPath of optimized D* Lite, with pointer bookkeeping.

        This is the queue loop (stale entries, termination, reinsertion of a grown key);
        an expanded node is handled by :func:`_expand_over` or :func:`_expand_under`."""
        g, gh, rhs, rh = self._g, self._gh, self._rhs, self._rh
        qkey, heap = self._qkey, self._heap
        start = self._start
        km = self._km
        hc = self._hcache
        hfun = self.heuristic
        pptr, psrc, pcost = self.graph.predecessor_view
        sptr, sdst, scost, ptr = self._sptr, self._sdst, self._scost, self._ptr
        # what the two expansions read, in the order they unpack it, bound once per call
        # (km and the heuristic cache do not change during a call)
        ctx = (pptr, psrc, pcost, sptr, sdst, scost, g, gh, rhs, rh, ptr, qkey, heap, start, km,
               hc, hfun, self._recompute_rhs, self._update_vertex)  # fmt: skip
        expand_over, expand_under = _expand_over, _expand_under
        n_exp = n_ev = n_q = 0
        while True:
            # drop stale heap entries (lazy deletion)
            while heap:
                top = heap[0]
                u = top[3]
                if qkey[u] is top:
                    break
                heappop(heap)
                n_q += 1
            else:
                break  # queue empty: every node is consistent
            gs = g[start]
            if gs == rhs[start] and gh[start] == rh[start]:
                # start consistent: stop once top_key >= key(start); -1 makes equal keys stop
                if not top < (gs + km, gh[start], gs, -1):
                    break
            gu, ru, ghu, rhu = g[u], rhs[u], gh[u], rh[u]
            over = ru < gu or (ru == gu and rhu < ghu)
            # Without a heuristic km stays 0 and a current entry's key is exact (every change
            # of g/rhs re-queues the node), so only keys with a heuristic can have grown.
            if hc is not None:
                if over:
                    mc, mh = ru, rhu
                else:
                    mc, mh = gu, ghu
                hv = hc[u]
                if hv is None:
                    hv = hc[u] = hfun(start, u)
                knew = (mc + hv + km, mh, mc, u)
                if top < knew:  # key grew since insertion (km changed): reinsert
                    qkey[u] = knew
                    heapreplace(heap, knew)
                    n_q += 1
                    continue
            heappop(heap)
            n_q += 1
            qkey[u] = None
            n_exp += 1
            if over:
                ev, q = expand_over(u, ru, rhu, ctx)
            else:
                ev, q = expand_under(u, ctx)
            n_ev += ev
            n_q += q
        self._add_work(n_exp, n_ev, n_q)

    # -------------------------------------------------------------- interface
    def update_edge(self, u: int, v: int, cost: float) -> None:
        """Set the cost of edge ``u -> v`` and repair ``rhs(u)``, the tail's value.

        Costs: >= 0, ``math.inf`` = blocked. The work is done here and in the
        next :meth:`plan` (which processes the queue).
        """
        if self._start != self._s_last:
            self._sync_start()
        # Graph.set_cost inlined for the common case: plain int ids, the edge found among u's
        # successors, a float cost >= 0 (NaN fails the comparison). Anything else goes
        # through set_cost, which validates and raises its errors.
        k = -1
        if type(u) is int and type(v) is int and type(cost) is float and cost >= 0.0:
            sptr = self._sptr
            if 0 <= u < len(sptr) - 1:
                sdst = self._sdst
                hi = sptr[u + 1]
                k = bisect_left(sdst, v, sptr[u], hi)
                if k == hi or sdst[k] != v:
                    k = -1  # no such edge (or v out of range): set_cost raises
        if k >= 0:
            c = cost + 0.0  # turns -0.0 into 0.0
            self._scost[k] = c
            self._pcost[self._e2p[k]] = c
        else:
            k = self.graph.set_cost(u, v, cost)  # validates; k indexes the successor view
            c = self._scost[k]
            u = int(u)
            v = int(v)
        if u == self.goal:
            return
        g, rhs = self._g, self._rhs
        t = c + g[v]
        r = rhs[u]
        if t < r or (t == r and self._gh[v] + 1 < self._rh[u]):
            rhs[u] = r = t
            self._rh[u] = nh = self._gh[v] + 1
            self._ptr[u] = v
            n_ev = 1
        elif self._ptr[u] == v:
            n_ev = 1 + self._recompute_rhs(u)
            r = rhs[u]
            nh = self._rh[u]
        else:
            return  # not the support of rhs(u) and not better: nothing changes
        st = self.stats
        st.edge_evaluations += n_ev
        # _update_vertex(u) inlined; (r, nh) is now (rhs, rh)(u)
        gu, ghu = g[u], self._gh[u]
        if gu == r and ghu == nh:
            self._qkey[u] = None
            return
        if r < gu or (r == gu and nh < ghu):
            mc, mh = r, nh
        else:
            mc, mh = gu, ghu
        hc = self._hcache
        if hc is None:
            key = (mc + self._km, mh, mc, u)
        else:
            hv = hc[u]
            if hv is None:
                hv = hc[u] = self.heuristic(self._start, u)
            key = (mc + hv + self._km, mh, mc, u)
        self._qkey[u] = key
        heappush(self._heap, key)
        st.queue_operations += 1

    def update_edges(self, changes) -> None:
        """Set the costs of many edges, then repair each changed tail's rhs once
        (docs/design.md §5f). ``changes``: an iterable of ``(u, v, cost)`` triples, or a
        tuple of three numpy arrays ``(u, v, cost)``. Equivalent to calling :meth:`update_edge`
        for each in turn (same values; among exactly equal-cost alternatives the stored
        pointer may differ), but the edge look-up and validation are vectorised and a tail
        with several changed edges is queued once. All costs are validated before any
        changes."""
        if isinstance(changes, tuple) and len(changes) == 3 and isinstance(changes[0], np.ndarray):
            us, vs, cs = (np.asarray(a).tolist() for a in changes)
        else:
            triples = list(changes)
            us = [operator.index(t[0]) for t in triples]
            vs = [operator.index(t[1]) for t in triples]
            cs = [t[2] for t in triples]
        if not us:
            return
        self._sync_start()
        ks = self.graph.set_costs(us, vs, cs)
        scost, sdst = self._succ.cost, self._succ.nbr
        g, gh, rhs, rh, ptr = self._g, self._gh, self._rhs, self._rh, self._ptr
        goal = self.goal
        # per tail: does its support change (full recompute), else the best improvement
        best: dict[int, tuple[float, int, int] | None] = {}
        for u, k in zip(us, ks, strict=True):
            if u == goal:
                continue
            v = sdst[k]
            cur = best.get(u, 0)
            if cur is None:
                continue  # already marked for a full recompute
            if ptr[u] == v:
                best[u] = None
                continue
            t = scost[k] + g[v]
            nh = gh[v] + 1
            if cur == 0 or t < cur[0] or (t == cur[0] and nh < cur[1]):
                best[u] = (t, nh, v)
        n_ev = n_q = 0
        for u, cand in best.items():
            if cand is None:
                n_ev += self._recompute_rhs(u)
            else:
                t, nh, v = cand
                r = rhs[u]
                if not (t < r or (t == r and nh < rh[u])):
                    continue
                rhs[u] = t
                rh[u] = nh
                ptr[u] = v
            n_q += self._update_vertex(u)
        self._add_work(0, n_ev + len(us), n_q)

    def move_start(self, node: int) -> None:
        """The robot is now at ``node``; ``km`` is updated before the next repair."""
        self._start = self.graph.check_node(node, "start")

    def plan(self) -> Path:
        """Repair (or, the first time, compute) the solution and return the path."""
        if self._start != self._s_last:
            self._sync_start()
        self._compute_shortest_path()
        start = self._start
        if self._g[start] == _INF:
            self._close_plan_stats()
            raise NoPathError(f"no path from node {start} to node {self.goal}")
        path = self._extract_path()
        self._close_plan_stats()
        return path

    def _extract(self) -> list[int]:
        raise NotImplementedError

    def _extract_path(self) -> Path:
        """The path from the start: :meth:`_extract`, then summed by ``_path_from_nodes``."""
        return self._path_from_nodes(self._extract())

    def _loop_error(self, nodes: list[int]) -> SearchInvariantError:
        return SearchInvariantError(
            f"{type(self).__name__}: path extraction from {self._start} did not reach goal "
            f"{self.goal} within {self.graph.num_nodes} steps (loop: ...{nodes[-5:]}); "
            "the heuristic may be inconsistent"
        )

    def rhs(self, node: int) -> float:
        """Current one-step look-ahead value rhs(node) (cost units; inf if unknown/unreachable)."""
        return self._rhs[self.graph.check_node(node)]

    def g(self, node: int) -> float:
        """Current g(node): cost-to-goal estimate (inf if not yet known)."""
        return self._g[self.graph.check_node(node)]


class MPDStarLite(_DStarLiteCore):
    """MPD* Lite (paper 000 §3, Fig. 6): D* Lite reading the path from stored pointers.

    ``MPDStarLite(graph, start, goal, heuristic=None)``; see :class:`~mpd_pin.search.base.Planner`.
    """

    def pointer(self, node: int) -> int | None:
        """Stored minimising successor of ``node`` (None if rhs(node) is inf or node is goal)."""
        p = self._ptr[self.graph.check_node(node)]
        return None if p < 0 else p

    def _extract(self) -> list[int]:
        ptr = self._ptr
        goal = self.goal
        s = self._start
        nodes = [s]
        limit = self.graph.num_nodes
        while s != goal:
            s = ptr[s]
            if s < 0:
                raise SearchInvariantError(
                    f"MPDStarLite: node {nodes[-1]} on the path from {self._start} has no "
                    "stored pointer"
                )
            nodes.append(s)
            if len(nodes) > limit:
                raise self._loop_error(nodes)
        return nodes

    def _extract_path(self) -> Path:
        """Follow the pointers and sum the edge costs left to right in one pass.

        The same nodes and the same float sum as ``_path_from_nodes(_extract())``; on any
        inconsistency it falls back to those two, which raise the error."""
        ptr = self._ptr
        sptr, sdst, scost = self._sptr, self._sdst, self._scost
        goal = self.goal
        s = self._start
        nodes = [s]
        append = nodes.append
        left = self.graph.num_nodes  # steps allowed before it must be a loop
        total = 0.0
        while s != goal:
            v = ptr[s]
            left -= 1
            if v < 0 or left <= 0:
                return self._path_from_nodes(self._extract())
            hi = sptr[s + 1]
            k = bisect_left(sdst, v, sptr[s], hi)
            if k == hi or sdst[k] != v or scost[k] == _INF:
                return self._path_from_nodes(self._extract())
            total += scost[k]
            append(v)
            s = v
        return Path(nodes=nodes, cost=total)


class DStarLite(_DStarLiteCore):
    """D* Lite (Koenig & Likhachev 2002): path by g-gradient, argmin of cost + g.

    ``DStarLite(graph, start, goal, heuristic=None)``; see :class:`~mpd_pin.search.base.Planner`.
    """

    def _extract(self) -> list[int]:
        gr = self.graph
        sptr, sdst, scost = gr.successor_view
        g, gh = self._g, self._gh
        goal = self.goal
        s = self._start
        nodes = [s]
        limit = gr.num_nodes
        n_ev = 0
        while s != goal:
            a, b = sptr[s], sptr[s + 1]
            n_ev += b - a
            best = _INF
            bh = 0
            bp = -1
            for j in range(a, b):
                v = sdst[j]
                t = scost[j] + g[v]
                if t < best or (t == best and bp >= 0 and gh[v] + 1 < bh):
                    best = t
                    bh = gh[v] + 1
                    bp = v
            if bp < 0:
                raise SearchInvariantError(
                    f"DStarLite: node {s} on the path from {self._start} has no successor "
                    "with finite cost + g"
                )
            s = bp
            nodes.append(s)
            if len(nodes) > limit:
                raise self._loop_error(nodes)
        self._add_work(0, n_ev, 0)
        return nodes
