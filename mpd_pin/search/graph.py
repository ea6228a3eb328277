"""Directed graph with mutable, non-negative edge costs in CSR form.

The graph knows nothing about search algorithms (networkx style): it stores the
edges once, sorted by tail (successor CSR) and once more sorted by head
(predecessor CSR, needed by D* Lite which searches from the goal), and lets the
cost of an existing edge be changed. Costs are floats ``>= 0`` in whatever unit
the caller uses (joules for energy roadmaps); ``math.inf`` marks a blocked edge.

The structure (which edges exist) is fixed at construction; only costs change.
An edge that may appear later should be created with cost ``math.inf``.

Parallel edges ``u -> v`` given more than once are merged into one edge that
keeps the minimum cost (the only one a shortest-path search could use);
:attr:`Graph.num_merged_parallel_edges` says how many were dropped. Self-loops
are allowed (they never lie on a shortest path).
"""

from __future__ import annotations

import math
import operator
from bisect import bisect_left
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

__all__ = ["Adjacency", "Graph"]

#: Batches up to this size are looked up edge by edge (bisect), larger ones with numpy.
_SMALL_BATCH = 48


class Adjacency(NamedTuple):
    """Read-only view of one CSR direction of a :class:`Graph`, for planners' hot loops.

    The edges of node ``u`` are ``nbr[ptr[u]:ptr[u + 1]]`` (heads for the successor view,
    tails for the predecessor view, ascending) with costs ``cost[ptr[u]:ptr[u + 1]]``. The
    lists are the graph's own storage, not copies (list indexing is ~3x faster than numpy
    indexing in pure-Python loops): **read them, never write them**. Costs change only
    through :meth:`Graph.set_cost` (planners: ``update_edge``), and a view taken earlier
    sees the change, because both cost orders are updated in place."""

    ptr: list[int]
    nbr: list[int]
    cost: list[float]


def _check_cost(cost: float, what: str) -> float:
    """Return ``cost`` as a float, rejecting NaN and negative values."""
    try:
        c = float(cost)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: cost must be a number, got {cost!r}") from None
    if math.isnan(c):
        raise ValueError(f"{what}: cost is NaN; costs must be >= 0 (math.inf = blocked)")
    if c < 0.0:
        raise ValueError(f"{what}: cost {c!r} is negative; costs must be >= 0 (math.inf = blocked)")
    return c + 0.0  # turns -0.0 into 0.0


class Graph:
    """Directed graph on nodes ``0 .. num_nodes-1`` with mutable edge costs.

    ``Graph(n, edges)`` takes an iterable of ``(u, v, cost)`` triples;
    :meth:`from_arrays` builds the same from numpy arrays (fast, for 1M edges).
    Nodes out of range and NaN or negative costs raise :class:`ValueError`.

    Storage: numpy CSR arrays (``succ_ptr``/``succ_dst`` and
    ``pred_ptr``/``pred_src``) plus mirrors as Python lists, which is what the
    pure-Python planners read in their hot loops (indexing a list is ~3x faster
    than indexing a numpy array). Costs live in two lists, one in successor
    order and one in predecessor order, kept identical by :meth:`set_cost`, so a
    cost read anywhere is bit-identical to the one stored.
    """

    __slots__ = (
        "_n",
        "_m",
        "_merged",
        "_succ_ptr_arr",
        "_succ_dst_arr",
        "_pred_ptr_arr",
        "_pred_src_arr",
        "_sptr",
        "_sdst",
        "_scost",
        "_pptr",
        "_psrc",
        "_pcost",
        "_e2p",
        "_keys",
    )

    def __init__(self, num_nodes: int, edges: Iterable[tuple[int, int, float]] = ()) -> None:
        n = _check_num_nodes(num_nodes)
        src: list[int] = []
        dst: list[int] = []
        cost: list[float] = []
        for k, e in enumerate(edges):
            try:
                u, v, c = e
            except (TypeError, ValueError):
                raise ValueError(f"edge #{k} must be a (u, v, cost) triple, got {e!r}") from None
            u = _as_node_id(u, f"edge #{k} tail")
            v = _as_node_id(v, f"edge #{k} head")
            for w in (u, v):
                if not 0 <= w < n:
                    raise ValueError(
                        f"edge #{k} ({u} -> {v}): node {w} out of range [0, {n - 1}]"
                        if n
                        else f"edge #{k} ({u} -> {v}): the graph has no nodes"
                    )
            src.append(u)
            dst.append(v)
            cost.append(_check_cost(c, f"edge #{k} ({u} -> {v})"))
        self._build(
            n,
            np.asarray(src, dtype=np.int64),
            np.asarray(dst, dtype=np.int64),
            np.asarray(cost, dtype=np.float64),
        )

    @classmethod
    def from_arrays(
        cls,
        num_nodes: int,
        src: np.ndarray,
        dst: np.ndarray,
        cost: np.ndarray,
    ) -> Graph:
        """Build from three 1-D arrays of equal length: tails, heads, costs (>= 0, inf ok)."""
        n = _check_num_nodes(num_nodes)
        s = np.asarray(src)
        d = np.asarray(dst)
        c = np.asarray(cost)
        for name, a in (("src", s), ("dst", d), ("cost", c)):
            if a.ndim != 1:
                raise ValueError(f"{name} must be 1-D, got shape {a.shape}")
        if not (len(s) == len(d) == len(c)):
            raise ValueError(
                f"src, dst and cost must have the same length, got {len(s)}, {len(d)}, {len(c)}"
            )
        for name, a in (("src", s), ("dst", d)):
            if len(a) and a.dtype.kind not in "iu":
                raise ValueError(f"{name} must hold integer node ids, got dtype {a.dtype}")
        if len(c) and c.dtype.kind not in "iuf":
            raise ValueError(f"cost must be numeric, got dtype {c.dtype}")
        s = s.astype(np.int64, copy=False)
        d = d.astype(np.int64, copy=False)
        c = c.astype(np.float64, copy=True)
        for name, a in (("src", s), ("dst", d)):
            bad = np.flatnonzero((a < 0) | (a >= n))
            if bad.size:
                k = int(bad[0])
                raise ValueError(
                    f"{name}[{k}] = {int(a[k])} is out of range [0, {n - 1}] "
                    f"({bad.size} node id(s) out of range)"
                )
        bad = np.flatnonzero(np.isnan(c) | (c < 0))
        if bad.size:
            k = int(bad[0])
            raise ValueError(
                f"edge #{k} ({int(s[k])} -> {int(d[k])}) has cost {float(c[k])!r}; "
                "costs must be >= 0 and not NaN (math.inf = blocked)"
            )
        g = cls.__new__(cls)
        g._build(n, s, d, c)
        return g

    def _build(self, n: int, src: np.ndarray, dst: np.ndarray, cost: np.ndarray) -> None:
        cost = cost + 0.0  # -0.0 -> 0.0
        m_in = len(src)
        order = np.lexsort((dst, src))  # by tail, then head
        s, d, c = src[order], dst[order], cost[order]
        if m_in:
            first = np.empty(m_in, dtype=bool)
            first[0] = True
            first[1:] = (s[1:] != s[:-1]) | (d[1:] != d[:-1])
            starts = np.flatnonzero(first)
            c = np.minimum.reduceat(c, starts)
            s, d = s[starts], d[starts]
        m = len(s)
        sptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(s, minlength=n), out=sptr[1:])
        porder = np.lexsort((s, d))  # by head, then tail; porder[j] = edge id
        pptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(d, minlength=n), out=pptr[1:])
        e2p = np.empty(m, dtype=np.int64)
        e2p[porder] = np.arange(m, dtype=np.int64)

        self._n = n
        self._m = m
        self._merged = m_in - m
        self._succ_ptr_arr = _readonly(sptr)
        self._succ_dst_arr = _readonly(d)
        self._pred_ptr_arr = _readonly(pptr)
        self._pred_src_arr = _readonly(s[porder])
        self._sptr = sptr.tolist()
        self._sdst = d.tolist()
        self._scost = c.tolist()
        self._pptr = pptr.tolist()
        self._psrc = self._pred_src_arr.tolist()
        self._pcost = c[porder].tolist()
        self._e2p = e2p.tolist()
        self._keys = _readonly(s * n + d) if m else np.zeros(0, dtype=np.int64)

    # ------------------------------------------------------------------ queries
    @property
    def num_nodes(self) -> int:
        """Number of nodes."""
        return self._n

    @property
    def num_edges(self) -> int:
        """Number of distinct directed edges (after merging parallel edges)."""
        return self._m

    @property
    def num_merged_parallel_edges(self) -> int:
        """How many parallel duplicates were dropped at construction (min cost kept)."""
        return self._merged

    def check_node(self, node: int, what: str = "node") -> int:
        """Return ``node`` as an int, or raise ValueError if it is not in ``[0, num_nodes)``."""
        u = _as_node_id(node, what)
        if not 0 <= u < self._n:
            if self._n == 0:
                raise ValueError(f"{what} {u} is out of range: the graph has no nodes")
            raise ValueError(f"{what} {u} is out of range [0, {self._n - 1}]")
        return u

    def successors(self, u: int) -> np.ndarray:
        """Heads of the edges leaving ``u`` (read-only int array, ascending)."""
        u = self.check_node(u)
        return self._succ_dst_arr[self._sptr[u] : self._sptr[u + 1]]

    def predecessors(self, v: int) -> np.ndarray:
        """Tails of the edges entering ``v`` (read-only int array, ascending)."""
        v = self.check_node(v)
        return self._pred_src_arr[self._pptr[v] : self._pptr[v + 1]]

    def successor_costs(self, u: int) -> np.ndarray:
        """Costs of the edges leaving ``u``, aligned with :meth:`successors` (a copy)."""
        u = self.check_node(u)
        return np.array(self._scost[self._sptr[u] : self._sptr[u + 1]], dtype=np.float64)

    @property
    def successor_view(self) -> Adjacency:
        """Edges by tail: ``(ptr, heads, costs)``, shared and live (see :class:`Adjacency`)."""
        return Adjacency(self._sptr, self._sdst, self._scost)

    @property
    def predecessor_view(self) -> Adjacency:
        """Edges by head: ``(ptr, tails, costs)``, shared and live (see :class:`Adjacency`)."""
        return Adjacency(self._pptr, self._psrc, self._pcost)

    def _edge_id(self, u: int, v: int) -> int:
        u = self.check_node(u, "edge tail")
        v = self.check_node(v, "edge head")
        lo, hi = self._sptr[u], self._sptr[u + 1]
        k = bisect_left(self._sdst, v, lo, hi)
        if k == hi or self._sdst[k] != v:
            raise KeyError(f"no edge {u} -> {v} in the graph")
        return k

    def has_edge(self, u: int, v: int) -> bool:
        """True if the directed edge ``u -> v`` exists (whatever its cost, inf included)."""
        try:
            self._edge_id(u, v)
        except KeyError:
            return False
        return True

    def cost(self, u: int, v: int) -> float:
        """Cost of edge ``u -> v`` (KeyError if the edge does not exist)."""
        return self._scost[self._edge_id(u, v)]

    def set_cost(self, u: int, v: int, cost: float) -> int:
        """Change the cost of the existing edge ``u -> v`` (``math.inf`` = blocked).

        Returns the edge's index in :attr:`successor_view`. Planners holding this graph are
        *not* notified: use ``planner.update_edge``.
        """
        # fast path (replanning calls this once per changed edge): plain ints in range and
        # a float >= 0 (NaN fails the comparison); anything else takes the checked path
        n = self._n
        if type(u) is int and type(v) is int and 0 <= u < n and 0 <= v < n:
            sptr, sdst = self._sptr, self._sdst
            hi = sptr[u + 1]
            k = bisect_left(sdst, v, sptr[u], hi)
            if k == hi or sdst[k] != v:
                raise KeyError(f"no edge {u} -> {v} in the graph")
        else:
            k = self._edge_id(u, v)
        if type(cost) is float and cost >= 0.0:
            c = cost + 0.0  # turns -0.0 into 0.0
        else:
            c = _check_cost(cost, f"edge {u} -> {v}")
        self._scost[k] = c
        self._pcost[self._e2p[k]] = c
        return k

    def edge_indices(self, u, v) -> list[int]:
        """Indices in :attr:`successor_view` of the edges ``u[i] -> v[i]`` (sequences or
        arrays of node ids; KeyError naming the first missing edge, ValueError for a node
        id out of range). Small batches bisect the lists, large ones use numpy."""
        n = self._n
        if len(u) != len(v):
            raise ValueError(f"u and v must have the same length, got {len(u)} and {len(v)}")
        if len(u) <= _SMALL_BATCH:
            ul = u.tolist() if isinstance(u, np.ndarray) else list(u)
            vl = v.tolist() if isinstance(v, np.ndarray) else list(v)
            sptr, sdst = self._sptr, self._sdst
            out = []
            for a, b in zip(ul, vl, strict=True):
                if not (0 <= a < n and 0 <= b < n):
                    raise ValueError(f"edge {a} -> {b}: node out of range [0, {n - 1}]")
                lo, hi = sptr[a], sptr[a + 1]
                k = bisect_left(sdst, b, lo, hi)
                if k == hi or sdst[k] != b:
                    raise KeyError(f"no edge {a} -> {b} in the graph")
                out.append(k)
            return out
        ua = np.asarray(u, dtype=np.int64).ravel()
        va = np.asarray(v, dtype=np.int64).ravel()
        bad = (ua < 0) | (ua >= n) | (va < 0) | (va >= n)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"edge {int(ua[k])} -> {int(va[k])}: node out of range [0, {n - 1}]")
        # edges are sorted by (tail, head), so tail * n + head is sorted too
        keys = self._keys
        want = ua * n + va
        k = np.searchsorted(keys, want)
        k_clip = np.minimum(k, max(keys.size - 1, 0))
        miss = (k >= keys.size) | (keys[k_clip] != want) if keys.size else np.ones(ua.size, bool)
        if miss.any():
            j = int(np.flatnonzero(miss)[0])
            raise KeyError(f"no edge {int(ua[j])} -> {int(va[j])} in the graph")
        return k.tolist()

    def set_costs(self, u, v, cost) -> list[int]:
        """Change the costs of the existing edges ``u[i] -> v[i]`` at once (``math.inf`` =
        blocked; NaN or negative refused before anything changes). Returns their indices in
        :attr:`successor_view`. Planners are not notified: use ``planner.update_edges``."""
        ks = self.edge_indices(u, v)
        cl = cost.tolist() if isinstance(cost, np.ndarray) else [float(c) for c in cost]
        if len(cl) != len(ks):
            raise ValueError(f"{len(ks)} edges but {len(cl)} costs")
        for j, c in enumerate(cl):
            if not c >= 0.0:  # NaN or negative
                _check_cost(c, f"edge {u[j]} -> {v[j]}")
        scost, pcost, e2p = self._scost, self._pcost, self._e2p
        for kk, cc in zip(ks, cl, strict=True):
            cc += 0.0  # -0.0 -> 0.0
            scost[kk] = cc
            pcost[e2p[kk]] = cc
        return ks

    def to_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Current ``(src, dst, cost)`` arrays, one row per distinct edge, sorted by tail."""
        src = np.repeat(np.arange(self._n, dtype=np.int64), np.diff(self._succ_ptr_arr))
        return src, self._succ_dst_arr.copy(), np.array(self._scost, dtype=np.float64)

    def copy(self) -> Graph:
        """Independent copy (costs can then be changed separately)."""
        g = Graph.__new__(Graph)
        for name in Graph.__slots__:
            setattr(g, name, getattr(self, name))
        g._scost = list(self._scost)
        g._pcost = list(self._pcost)
        return g

    def __repr__(self) -> str:
        return f"Graph(num_nodes={self._n}, num_edges={self._m})"


def _check_num_nodes(num_nodes: int) -> int:
    n = _as_node_id(num_nodes, "num_nodes")
    if n < 0:
        raise ValueError(f"num_nodes must be >= 0, got {n}")
    return n


def _as_node_id(x: object, what: str) -> int:
    if isinstance(x, bool | float | np.floating):
        raise TypeError(f"{what} must be an integer, got {x!r}")
    try:
        return operator.index(x)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(f"{what} must be an integer, got {x!r}") from None


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a
