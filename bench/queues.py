"""The planners' hot-loop choices: the priority queue and the adjacency loop.

1. Priority queue: heapq with lazy deletion vs a pure-Python indexed heap
   (decrease-key through a positions array).
2. Adjacency loop over a node's CSR slice: ``for j in range(a, b)`` indexing the
   head and cost lists (what the planners do) vs ``zip(heads[a:b], costs[a:b],
   strict=True)`` (what they did before: two slices, and a keyword argument that
   makes every ``zip`` call take CPython's slow construction path).

All variants run the same Dijkstra from the low corner to the high corner of a
random geometric graph (points in [0,1]^3, k nearest neighbours, directed edges
both ways, cost = Euclidean length * U(1, 2); the graphs of ``bench/search.py``,
sections 2 and 3). Prints, measured in this run, the best time of each and the
ratios; asserts that all find the same cost.

Run:  PYTHONPATH=. python bench/queues.py [--sizes 1000 10000 100000] [--k 10]
"""

from __future__ import annotations

import argparse
import math
from functools import partial
from heapq import heappop, heappush

import numpy as np

from common import best_of, random_geometric_arrays
from mpd_pin.search import Graph


def dijkstra_lazy(g: Graph, s: int, t: int) -> float:
    """Cost of the cheapest s -> t path: heapq, stale entries skipped when popped."""
    sptr, sdst, scost = g.successor_view
    dist = [math.inf] * g.num_nodes
    dist[s] = 0.0
    heap = [(0.0, s)]
    while heap:
        d, u = heappop(heap)
        if d > dist[u]:
            continue
        if u == t:
            return d
        for j in range(sptr[u], sptr[u + 1]):
            v = sdst[j]
            nd = d + scost[j]
            if nd < dist[v]:
                dist[v] = nd
                heappush(heap, (nd, v))
    return math.inf


def dijkstra_lazy_zip(g: Graph, s: int, t: int) -> float:
    """:func:`dijkstra_lazy` with the adjacency read by ``zip`` of two slices."""
    sptr, sdst, scost = g.successor_view
    dist = [math.inf] * g.num_nodes
    dist[s] = 0.0
    heap = [(0.0, s)]
    while heap:
        d, u = heappop(heap)
        if d > dist[u]:
            continue
        if u == t:
            return d
        a, b = sptr[u], sptr[u + 1]
        for v, c in zip(sdst[a:b], scost[a:b], strict=True):
            nd = d + c
            if nd < dist[v]:
                dist[v] = nd
                heappush(heap, (nd, v))
    return math.inf


def dijkstra_indexed(g: Graph, s: int, t: int) -> float:
    """Same loop with a binary heap that supports decrease-key (positions array)."""
    sptr, sdst, scost = g.successor_view
    n = g.num_nodes
    dist = [math.inf] * n
    pos = [-1] * n  # index in heap, -1 = not in heap
    heap: list[int] = []

    def sift_up(i: int) -> None:
        x = heap[i]
        dx = dist[x]
        while i:
            j = (i - 1) >> 1
            y = heap[j]
            if dist[y] <= dx:
                break
            heap[i] = y
            pos[y] = i
            i = j
        heap[i] = x
        pos[x] = i

    def pop_min() -> int:
        top = heap[0]
        last = heap.pop()
        pos[top] = -2  # done
        if heap:
            size = len(heap)
            i = 0
            dl = dist[last]
            while True:
                c = 2 * i + 1
                if c >= size:
                    break
                if c + 1 < size and dist[heap[c + 1]] < dist[heap[c]]:
                    c += 1
                if dist[heap[c]] >= dl:
                    break
                heap[i] = heap[c]
                pos[heap[i]] = i
                i = c
            heap[i] = last
            pos[last] = i
        return top

    dist[s] = 0.0
    heap.append(s)
    pos[s] = 0
    while heap:
        u = pop_min()
        if u == t:
            return dist[u]
        d = dist[u]
        for j in range(sptr[u], sptr[u + 1]):
            v = sdst[j]
            nd = d + scost[j]
            if nd < dist[v]:
                dist[v] = nd
                if pos[v] == -1:
                    heap.append(v)
                    pos[v] = len(heap) - 1
                sift_up(pos[v])
    return math.inf


def queues(sizes: list[int], k: int) -> None:
    """Print, per graph size, the best time of each variant (best of 5; of 1 above 10k
    nodes), the three measured round-robin so that load from other processes hits all."""
    print("== Hot-loop choices: heapq + lazy deletion vs pure-Python indexed heap;")
    print("   index loop vs zip(strict=True) of two slices (both with heapq) ==")
    variants = (
        ("heapq lazy", dijkstra_lazy),
        ("indexed heap", dijkstra_indexed),
        ("heapq lazy, zip", dijkstra_lazy_zip),
    )
    for n in sizes:
        pts, src, dst, cost = random_geometric_arrays(n, k, seed=1)
        g = Graph.from_arrays(n, src, dst, cost)
        s, t = int(np.argmin(pts.sum(1))), int(np.argmax(pts.sum(1)))
        best = dict.fromkeys((name for name, _ in variants), math.inf)
        found = set()
        for _ in range(5 if n <= 10_000 else 1):
            for name, fn in variants:
                dt, c = best_of(partial(fn, g, s, t), 1)
                best[name] = min(best[name], dt)
                found.add(c)
        assert len(found) == 1, found
        a, b, z = best["heapq lazy"], best["indexed heap"], best["heapq lazy, zip"]
        print(
            f"{n:>7} nodes: heapq lazy {a:.4f} s, indexed heap {b:.4f} s "
            f"(indexed / heapq = {b / a:.2f}); zip loop {z:.4f} s (zip / index = {z / a:.2f})"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    ap.add_argument("--k", type=int, default=10, help="nearest neighbours per node")
    args = ap.parse_args()
    queues(args.sizes, args.k)


if __name__ == "__main__":
    main()
