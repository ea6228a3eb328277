"""Benchmark of mpd_pin.search (MPD* Lite, D* Lite, A*, Dijkstra); prints, asserts only costs.

1. Table 6 of paper 000 redone on random geometric graphs (points in [0,1]^3
   standing in for roadmaps, k nearest neighbours, directed edges both ways,
   cost = Euclidean length * U(1, 2)): time and expansions per planner next to
   the paper's MATLAB seconds.
1b. The same on real energy roadmaps of 91, 182 and 273 nodes built with
   ``build_roadmap`` (3-link arm, PAPER_MOTOR behind a 9:1 gear, kp 40, kd 4,
   one box obstacle, seeded; T = 0.5 s, dt = 0.01 s so the build takes about a
   second), start and goal on either side of the obstacle: initial plan, and a
   repair after blocking every edge of the path's second node ahead of the robot.
2. Scaling on 1k / 10k / 100k-node graphs: initial plan of each planner vs
   networkx.dijkstra_path on the same graph.
3. Replanning: edges blocked near the robot (start) and, separately, near the
   goal; MPD* Lite repair vs networkx.astar_path from scratch (costs asserted
   equal).
4. Priority queue: heapq with lazy deletion vs a pure-Python indexed heap.

Run:  PYTHONPATH=. python bench/search.py            (about a minute)
      PYTHONPATH=. python bench/search.py --sizes 1000 10000   (skip 100k)
Every graph goes through ``planner_graph(n, src, dst, cost)``; section 1b passes
a real roadmap's arrays (tails, heads, energies in J) through it.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import networkx as nx
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra as sp_dijkstra
from scipy.spatial import cKDTree

from mpd_pin.search import (
    AStar,
    Dijkstra,
    DStarLite,
    Graph,
    MPDStarLite,
    Path,
    Planner,
    SearchStats,
)

# Paper 000, Table 6: (nodes, best-path length, MPD* Lite s, D* Lite s, A* s), MATLAB.
PAPER_TABLE6 = [
    (91, 3, 0.125, 0.348, 0.094),
    (91, 7, 0.344, 1.553, 0.891),
    (91, 10, 1.031, 8.564, 78.125),
    (182, 13, 1.063, 9.678, 593.218),
    (273, 21, 3.047, 40.849, 2450.375),
]


# ------------------------------------------------------------------ graphs
def random_geometric_arrays(
    n: int, k: int = 10, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points in [0,1]^3, k-NN edges in both directions, cost = length * U(1, 2).

    Returns ``(points, src, dst, cost)``; a pair listed from both ends appears
    twice and :class:`Graph` keeps the cheaper one.
    """
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3))
    _, nbr = cKDTree(pts).query(pts, k + 1)
    src = np.repeat(np.arange(n), k)
    dst = nbr[:, 1:].ravel()
    src, dst = np.concatenate([src, dst]), np.concatenate([dst, src])
    cost = np.linalg.norm(pts[src] - pts[dst], axis=1) * rng.uniform(1.0, 2.0, src.size)
    return pts, src, dst, cost


def planner_graph(n: int, src: np.ndarray, dst: np.ndarray, cost: np.ndarray) -> Graph:
    """The benchmarked graph from tails, heads and costs (a roadmap plugs in here)."""
    return Graph.from_arrays(n, src, dst, cost)


def to_networkx(g: Graph) -> nx.DiGraph:
    """The same graph for networkx (finite edges only), weight attribute ``weight``."""
    G = nx.DiGraph()
    G.add_nodes_from(range(g.num_nodes))
    s, d, c = g.to_arrays()
    keep = np.isfinite(c)
    G.add_weighted_edges_from(
        zip(s[keep].tolist(), d[keep].tolist(), c[keep].tolist(), strict=True)
    )
    return G


def euclid(points: np.ndarray) -> Callable[[int, int], float]:
    """h(a, b) = |p_a - p_b|: admissible and consistent since every cost >= edge length."""
    P = points.tolist()
    dist = math.dist
    return lambda a, b: dist(P[a], P[b])


def path_cost(g: Graph, nodes: list[int]) -> float:
    total = 0.0
    for u, v in zip(nodes[:-1], nodes[1:], strict=True):
        total += g.cost(u, v)
    return total


def hop_matrix(g: Graph) -> np.ndarray:
    """Edges on the cheapest path for every (start, goal) pair (-1 if unreachable)."""
    n = g.num_nodes
    s, d, c = g.to_arrays()
    m = csr_matrix((c, (s, d)), shape=(n, n))
    _, pred = sp_dijkstra(m, return_predecessors=True)
    hops = np.full((n, n), -1, dtype=np.int64)
    np.fill_diagonal(hops, 0)
    rows = np.arange(n)[:, None].repeat(n, 1)
    for _ in range(n):  # hops[s, t] = hops[s, pred[s, t]] + 1, to a fixed point
        p = pred
        ok = (p >= 0) & (hops < 0)
        if not ok.any():
            break
        prev = hops[rows[ok], p[ok]]
        hops[ok] = np.where(prev >= 0, prev + 1, -1)
    return hops


# ----------------------------------------------------------------- timing
def timed_plan(
    make: Callable[[Graph, int, int], Planner], g: Graph, s: int, t: int, repeats: int
) -> tuple[float, Planner]:
    """Best-of-``repeats`` wall time of ``make(g, s, t)`` and its first plan() (s)."""
    best = math.inf
    planner = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        p = make(g, s, t)
        p.plan()
        dt = time.perf_counter() - t0
        if dt < best:
            best, planner = dt, p
    return best, planner


def planners_for(points: np.ndarray) -> dict[str, Callable[[Graph, int, int], Planner]]:
    h = euclid(points)
    return {
        "MPD* Lite": lambda g, s, t: MPDStarLite(g, s, t),
        "D* Lite": lambda g, s, t: DStarLite(g, s, t),
        "A* h=0": lambda g, s, t: AStar(g, s, t),
        "A* euclid": lambda g, s, t: AStar(g, s, t, heuristic=h),
        "MPD* euclid": lambda g, s, t: MPDStarLite(g, s, t, heuristic=h),
        "Dijkstra": lambda g, s, t: Dijkstra(g, s, t),
    }


# --------------------------------------------------------------- section 1
def table6(repeats: int) -> None:
    print("\n== 1. Table 6 of paper 000 on random geometric graphs ([0,1]^3, k=10) ==")
    print(f"   times: ours in ms (best of {repeats}, construction + first plan), paper in s")
    names = ["MPD* Lite", "D* Lite", "A* h=0", "A* euclid"]
    head = f"{'scen':>4} {'nodes':>5} {'edges':>5} {'path':>9} | " + " | ".join(
        f"{nm:>17}" for nm in names
    )
    print(head + " | extraction || paper MPD*/D*/A* (s)")
    print(
        f"{'':>4} {'':>5} {'':>5} {'ours/ppr':>9} | "
        + " | ".join(f"{'ms':>8} {'exp':>8}" for _ in names)
        + f" | {'D*-MPD*':>10} ||"
    )
    by_n: dict[int, tuple] = {}
    for i, (n, hops_paper, t_mpd, t_d, t_a) in enumerate(PAPER_TABLE6, 1):
        if n not in by_n:
            pts, src, dst, cost = random_geometric_arrays(n, 10, seed=n)
            g = planner_graph(n, src, dst, cost)
            by_n[n] = (pts, g, hop_matrix(g))
        pts, g, hops = by_n[n]
        # the (start, goal) pair whose cheapest path has the paper's number of nodes
        # (nodes = edges + 1), or the longest available; ties: farthest apart
        target = hops_paper - 1
        cand = np.argwhere(hops == min(target, hops.max()))
        far = np.linalg.norm(pts[cand[:, 0]] - pts[cand[:, 1]], axis=1)
        s, t = (int(x) for x in cand[np.argmax(far)])
        makers = planners_for(pts)
        cells = []
        costs = []
        evals = {}
        for nm in names:
            dt, p = timed_plan(makers[nm], g, s, t, repeats)
            evals[nm] = p.stats.edge_evaluations
            path = p.plan()
            costs.append(path.cost)
            cells.append(f"{dt * 1e3:8.3f} {p.stats.expansions:8d}")
        assert all(math.isclose(c, costs[0], rel_tol=1e-12) for c in costs), costs
        extra = evals["D* Lite"] - evals["MPD* Lite"]
        print(
            f"{i:>4} {n:>5} {g.num_edges:>5} {len(path.nodes):>4}/{hops_paper:<4} | "
            + " | ".join(cells)
            + f" | {extra:>4d} evals || {t_mpd:.3f} / {t_d:.3f} / {t_a:.3f}"
        )
    print("   path = nodes on the best path (ours / paper); exp = expansions; extraction =")
    print("   edge costs D* Lite reads to follow the g-gradient that MPD* Lite's pointers save.")
    print("   The paper's roadmaps are not available: compare magnitudes and ranking only.")


# -------------------------------------------------------------- section 1b
#: Start and goal of the real roadmaps (rad): the hand on either side of the wall.
REAL_START = np.array([0.6, 0.3, 0.2])
REAL_GOAL = np.array([2.4, -0.3, -0.2])
REAL_SIZES = (91, 182, 273)


def energy_roadmap(num_total: int, seed: int = 0):
    """A real energy roadmap of ``num_total`` nodes (start and goal included).

    3-link arm, PAPER_MOTOR with gear ratio 9, kp 40 V/rad, kd 4 V·s/rad,
    feed-forward on; one box "wall" of 0.3 m x 0.4 m centred at (0, 0.9) m in the
    x–z plane; k = 10 neighbours; fixed edge duration T = 0.5 s, RK4 dt = 0.01 s.
    Returns ``(roadmap, build_seconds)``.
    """
    import mpd_pin as mp
    from mpd_pin.collision import CollisionChecker
    from mpd_pin.roadmap import EnergyCost, RoadmapOptions, build_roadmap
    from mpd_pin.world import Box, World

    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(9.0), kp=40.0, kd=4.0)
    world = World((Box.planar((0.0, 0.9), 0.3, 0.4, name="wall"),))
    options = RoadmapOptions(num_nodes=num_total - 2, k=10, seed=seed, duration=0.5, dt=0.01)
    t0 = time.perf_counter()
    roadmap = build_roadmap(
        EnergyCost(drive, options.dt),
        CollisionChecker(arm, world),
        REAL_START,
        REAL_GOAL,
        options,
        show_progress=False,
    )
    return roadmap, time.perf_counter() - t0


def paper_row(n: int, path_nodes: int) -> tuple:
    """The Table 6 row with ``n`` nodes whose best path length is closest to ours."""
    rows = [r for r in PAPER_TABLE6 if r[0] == n]
    return min(rows, key=lambda r: abs(r[1] - path_nodes))


def timed_repair(
    make: Callable[[Graph, int, int], Planner],
    g0: Graph,
    s: int,
    t: int,
    blocked: list[tuple[int, int]],
    repeats: int,
) -> tuple[float, Path, SearchStats]:
    """Best-of-``repeats`` time of blocking ``blocked`` (update_edge to inf) and plan() again.

    Each repeat starts from a fresh planner on a copy of ``g0`` whose first plan is
    not timed. Returns the time (s), the repaired path and the repair's own work
    (``last_stats`` right after the repairing plan()).
    """
    best = math.inf
    result = None
    for _ in range(repeats):
        p = make(g0.copy(), s, t)
        p.plan()
        t0 = time.perf_counter()
        for u, v in blocked:
            p.update_edge(u, v, math.inf)
        path = p.plan()
        dt = time.perf_counter() - t0
        if dt < best:
            best, result = dt, (path, p.last_stats.copy())
    return best, *result


def real_table6(repeats: int, sizes: tuple[int, ...] = REAL_SIZES) -> None:
    print("\n== 1b. Table 6 of paper 000 on real energy roadmaps (3-link arm, costs = E+ in J) ==")
    print("   PAPER_MOTOR gear 9, kp 40, kd 4, one box obstacle, k=10, seed 0, T=0.5 s, dt=0.01 s")
    print(f"   times: ours in ms (best of {repeats}), paper in s (MATLAB, its own roadmaps)")
    print("   plan = construction + first plan; repair = block every in/out edge of the path's")
    print("   second node ahead of the robot (update_edge to inf) + plan(); A* and Dijkstra")
    print("   search again from scratch, the D* Lites repair incrementally")
    names = ["MPD* Lite", "D* Lite", "A* h=0", "Dijkstra"]
    makers: dict[str, Callable[[Graph, int, int], Planner]] = {
        "MPD* Lite": MPDStarLite,
        "D* Lite": DStarLite,
        "A* h=0": AStar,
        "Dijkstra": Dijkstra,
    }
    print(
        f"{'nodes':>5} {'edges':>5} {'build':>6} {'path':>9} {'':>6} | "
        + " | ".join(f"{nm:>15}" for nm in names)
        + " || paper MPD*/D*/A* (s)"
    )
    print(
        f"{'':>5} {'':>5} {'s':>6} {'ours/ppr':>9} {'':>6} | "
        + " | ".join(f"{'ms':>7} {'exp':>7}" for _ in names)
        + " ||"
    )
    for n in sizes:
        rm, build_s = energy_roadmap(n, seed=0)
        g = planner_graph(rm.num_nodes, rm.src, rm.dst, rm.cost)
        s, t = rm.start, rm.goal
        first_cells, rep_cells, costs, rep_costs = [], [], [], []
        path = None
        for nm in names:
            dt, p = timed_plan(makers[nm], g, s, t, repeats)
            path = p.plan()
            costs.append(path.cost)
            first_cells.append(f"{dt * 1e3:7.3f} {p.stats.expansions:7d}")
        assert all(math.isclose(c, costs[0], rel_tol=1e-12) for c in costs), costs
        node = path.nodes[min(2, len(path.nodes) - 2)]
        blocked = [(int(u), node) for u in g.predecessors(node)]
        blocked += [(node, int(v)) for v in g.successors(node)]
        for nm in names:
            dt, rpath, work = timed_repair(makers[nm], g, s, t, blocked, repeats)
            rep_costs.append(rpath.cost)
            rep_cells.append(f"{dt * 1e3:7.3f} {work.expansions:7d}")
        assert all(math.isclose(c, rep_costs[0], rel_tol=1e-12) for c in rep_costs), rep_costs
        assert rep_costs[0] >= costs[0]
        pn, hops_paper, t_mpd, t_d, t_a = paper_row(n, len(path.nodes))
        print(
            f"{n:>5} {rm.num_edges:>5} {build_s:6.2f} {len(path.nodes):>4}/{hops_paper:<4} "
            f"{'plan':>6} | " + " | ".join(first_cells) + f" || {t_mpd:.3f} / {t_d:.3f} / {t_a:.3f}"
        )
        print(
            f"{'':>5} {'':>5} {'':>6} {'':>9} {'repair':>6} | "
            + " | ".join(rep_cells)
            + f" || blocked {len(blocked)} edges of node {node};"
            f" cost {costs[0]:.4g} -> {rep_costs[0]:.4g} J"
        )
    print("   path = nodes on the best path (ours / the paper row of that size with the closest")
    print("   length); exp = expansions (repair: the repair's own work, planner.last_stats).")


# --------------------------------------------------------------- section 2
def scaling(sizes: list[int], graphs: dict) -> None:
    print("\n== 2. Scaling: initial plan, start/goal near opposite corners of the cube ==")
    names = ["MPD* Lite", "D* Lite", "A* h=0", "A* euclid", "MPD* euclid", "Dijkstra"]
    print(
        f"{'nodes':>7} {'edges':>8} {'nx.dijkstra_path':>16} | "
        + " | ".join(f"{nm:>11}" for nm in names)
        + " | MPD*/nx"
    )
    for n in sizes:
        pts, g, G, s, t = graphs[n]
        reps = 3 if n <= 10_000 else 2
        best_nx = math.inf
        for _ in range(reps):
            t0 = time.perf_counter()
            nx_path = nx.dijkstra_path(G, s, t)
            best_nx = min(best_nx, time.perf_counter() - t0)
        ref = path_cost(g, nx_path)
        makers = planners_for(pts)
        times = {}
        exps = {}
        for nm in names:
            dt, p = timed_plan(makers[nm], g, s, t, reps)
            c = p.plan().cost
            assert math.isclose(c, ref, rel_tol=1e-12), (nm, c, ref)
            times[nm] = dt
            exps[nm] = p.stats.expansions
        print(
            f"{n:>7} {g.num_edges:>8} {best_nx:>14.4f} s | "
            + " | ".join(f"{times[nm]:>9.4f} s" for nm in names)
            + f" | {times['MPD* Lite'] / best_nx:6.2f}x"
        )
        print(
            f"{'':>7} {'':>8} {'expansions':>16} | "
            + " | ".join(f"{exps[nm]:>11d}" for nm in names)
        )


# --------------------------------------------------------------- section 3
def replanning(sizes: list[int], graphs: dict, repeats: int) -> None:
    print("\n== 3. Replanning after an obstacle blocks one path node (all its in/out edges) ==")
    print("   MPD* Lite repair (update_edge calls + plan) vs searches from scratch")
    print(
        f"{'nodes':>7} {'where':>10} {'blocked':>7} | {'MPD* repair':>16} | "
        f"{'MPD* fresh':>16} | {'nx.astar h=0':>12} | {'nx.astar eucl':>13} | "
        f"{'speed-up vs nx h=0 / eucl':>25}"
    )
    for n in sizes:
        pts, g0, G, s, t = graphs[n]
        h = euclid(pts)
        first = MPDStarLite(g0.copy(), s, t).plan().nodes
        for where, idx in (("near robot", 2), ("near goal", len(first) - 3)):
            node = first[idx]
            blocked = [(int(u), node) for u in g0.predecessors(node)]
            blocked += [(node, int(v)) for v in g0.successors(node)]
            rep_t = math.inf
            for _ in range(repeats):
                p = MPDStarLite(g0.copy(), s, t)
                p.plan()
                t0 = time.perf_counter()
                for u, v in blocked:
                    p.update_edge(u, v, math.inf)
                path = p.plan()
                rep_t = min(rep_t, time.perf_counter() - t0)
            rep_exp = p.last_stats.expansions
            changed = p.graph
            fresh_t, fresh = timed_plan(MPDStarLite, changed, s, t, 1)
            removed = [(u, v, G[u][v]["weight"]) for u, v in blocked if G.has_edge(u, v)]
            G.remove_edges_from([(u, v) for u, v, _ in removed])
            try:
                t0 = time.perf_counter()
                p0 = nx.astar_path(G, s, t)
                nx0_t = time.perf_counter() - t0
                t0 = time.perf_counter()
                p1 = nx.astar_path(G, s, t, heuristic=h)
                nx1_t = time.perf_counter() - t0
            finally:
                G.add_weighted_edges_from(removed)
            c_ref = path_cost(changed, p0)
            for c in (path.cost, fresh.plan().cost, path_cost(changed, p1)):
                assert math.isclose(c, c_ref, rel_tol=1e-12), (where, c, c_ref)
            print(
                f"{n:>7} {where:>10} {len(blocked):>7} | "
                f"{rep_t * 1e3:8.2f} ms {rep_exp:>5d}e | "
                f"{fresh_t * 1e3:8.1f} ms {fresh.stats.expansions:>5d}e | "
                f"{nx0_t * 1e3:9.1f} ms | {nx1_t * 1e3:10.1f} ms | "
                f"{nx0_t / rep_t:10.1f}x / {nx1_t / rep_t:8.1f}x"
            )


# --------------------------------------------------------------- section 4
def _dijkstra_lazy(g: Graph, s: int, t: int) -> float:
    from heapq import heappop, heappush

    sptr, sdst, scost = g._sptr, g._sdst, g._scost
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


def _dijkstra_indexed(g: Graph, s: int, t: int) -> float:
    """Same loop with a binary heap that supports decrease-key (positions array)."""
    sptr, sdst, scost = g._sptr, g._sdst, g._scost
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
        a, b = sptr[u], sptr[u + 1]
        for v, c in zip(sdst[a:b], scost[a:b], strict=True):
            nd = d + c
            if nd < dist[v]:
                dist[v] = nd
                if pos[v] == -1:
                    heap.append(v)
                    pos[v] = len(heap) - 1
                sift_up(pos[v])
    return math.inf


def queues(sizes: list[int], graphs: dict) -> None:
    print("\n== 4. Priority queue: heapq + lazy deletion vs pure-Python indexed heap ==")
    for n in sizes:
        _, g, _, s, t = graphs[n]
        res = {}
        for name, fn in (("heapq lazy", _dijkstra_lazy), ("indexed heap", _dijkstra_indexed)):
            best = math.inf
            for _ in range(3 if n <= 10_000 else 1):
                t0 = time.perf_counter()
                d = fn(g, s, t)
                best = min(best, time.perf_counter() - t0)
            res[name] = (best, d)
        assert res["heapq lazy"][1] == res["indexed heap"][1]
        a, b = res["heapq lazy"][0], res["indexed heap"][0]
        print(
            f"{n:>7} nodes: heapq lazy {a:.4f} s, indexed heap {b:.4f} s "
            f"(indexed / heapq = {b / a:.2f})"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000])
    ap.add_argument("--k", type=int, default=10, help="nearest neighbours per node")
    ap.add_argument("--no-real", action="store_true", help="skip section 1b (real energy roadmaps)")
    args = ap.parse_args()
    t_all = time.perf_counter()
    table6(repeats=20)
    if not args.no_real:
        real_table6(repeats=20)
    graphs = {}
    for n in args.sizes:
        pts, src, dst, cost = random_geometric_arrays(n, args.k, seed=1)
        t0 = time.perf_counter()
        g = planner_graph(n, src, dst, cost)
        tb = time.perf_counter() - t0
        t0 = time.perf_counter()
        G = to_networkx(g)
        tnx = time.perf_counter() - t0
        s = int(np.argmin(pts.sum(1)))
        t = int(np.argmax(pts.sum(1)))
        graphs[n] = (pts, g, G, s, t)
        print(f"(graph {n}: Graph.from_arrays {tb:.2f} s, networkx DiGraph {tnx:.2f} s)")
    scaling(args.sizes, graphs)
    replanning(args.sizes, graphs, repeats=3)
    queues(args.sizes, graphs)
    print(f"\ntotal {time.perf_counter() - t_all:.1f} s")


if __name__ == "__main__":
    main()
