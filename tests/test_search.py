"""Deterministic tests of mpd_pin.search: Graph, MPD* Lite, D* Lite, A*, Dijkstra.

References are independent: hand-computed small cases, networkx and
scipy.sparse.csgraph shortest paths. Random property tests are in
test_search_properties.py.
"""

from __future__ import annotations

import ast
import math
import pathlib

import networkx as nx
import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra as sp_dijkstra
from scipy.spatial import cKDTree

import mpd_pin.errors
from mpd_pin.search import (
    AStar,
    Dijkstra,
    DStarLite,
    Graph,
    MPDStarLite,
    NoPathError,
    Path,
    SearchInvariantError,
    SearchStats,
)

PLANNERS = (MPDStarLite, DStarLite, AStar, Dijkstra)
INCREMENTAL = (MPDStarLite, DStarLite)
INF = math.inf


def _make(P, graph, start, goal, heuristic=None):
    return P(graph, start, goal, heuristic=None if P is Dijkstra else heuristic)


def _path_sum(graph: Graph, nodes: list[int]) -> float:
    total = 0.0
    for u, v in zip(nodes[:-1], nodes[1:], strict=True):
        total += graph.cost(u, v)
    return total


def _grid(w: int, h: int, cost_fn) -> tuple[int, list[tuple[int, int, float]], list]:
    """4-connected grid, both directions; cost_fn(i, j) gives the cost of i -> j."""
    pos = [(i % w, i // w) for i in range(w * h)]
    edges = []
    for i, (x, y) in enumerate(pos):
        for dx, dy in ((1, 0), (0, 1)):
            if x + dx < w and y + dy < h:
                j = (y + dy) * w + x + dx
                edges += [(i, j, cost_fn(i, j)), (j, i, cost_fn(j, i))]
    return w * h, edges, pos


# ---------------------------------------------------------------- Graph
def test_graph_csr_queries_and_set_cost() -> None:
    g = Graph(4, [(0, 1, 1.5), (0, 2, 2.0), (2, 1, 0.0), (1, 3, INF), (3, 3, 1.0)])
    assert g.num_nodes == 4 and g.num_edges == 5
    assert g.successors(0).tolist() == [1, 2]
    assert g.predecessors(1).tolist() == [0, 2]
    assert g.predecessors(3).tolist() == [1, 3]
    assert g.successor_costs(0).tolist() == [1.5, 2.0]
    assert g.cost(2, 1) == 0.0 and g.cost(1, 3) == INF
    assert g.has_edge(0, 2) and not g.has_edge(2, 0)
    g.set_cost(1, 3, 4.0)
    assert g.cost(1, 3) == 4.0
    src, dst, cost = g.to_arrays()
    assert list(zip(src.tolist(), dst.tolist(), cost.tolist(), strict=True)) == [
        (0, 1, 1.5),
        (0, 2, 2.0),
        (1, 3, 4.0),
        (2, 1, 0.0),
        (3, 3, 1.0),
    ]
    with pytest.raises(ValueError):
        g.successors(0)[0] = 3  # read-only view


def test_graph_copy_is_independent() -> None:
    g = Graph(2, [(0, 1, 1.0)])
    h = g.copy()
    h.set_cost(0, 1, 7.0)
    assert g.cost(0, 1) == 1.0 and h.cost(0, 1) == 7.0


def test_parallel_edges_keep_minimum_cost() -> None:
    g = Graph(3, [(0, 1, 5.0), (0, 1, 2.0), (0, 1, INF), (1, 2, 1.0)])
    assert g.num_edges == 2 and g.num_merged_parallel_edges == 2
    assert g.cost(0, 1) == 2.0
    assert MPDStarLite(g, 0, 2).plan().cost == 3.0


def test_from_arrays_matches_constructor() -> None:
    rng = np.random.default_rng(0)
    n, m = 50, 300
    src = rng.integers(0, n, m)
    dst = rng.integers(0, n, m)
    cost = rng.uniform(0, 3, m)
    a = Graph.from_arrays(n, src, dst, cost)
    b = Graph(n, zip(src.tolist(), dst.tolist(), cost.tolist(), strict=True))
    for x, y in zip(a.to_arrays(), b.to_arrays(), strict=True):
        np.testing.assert_array_equal(x, y)
    for v in range(n):
        np.testing.assert_array_equal(a.predecessors(v), b.predecessors(v))


def test_empty_graph_and_isolated_nodes() -> None:
    g = Graph(3, [])
    assert g.num_edges == 0
    for P in PLANNERS:
        with pytest.raises(NoPathError):
            _make(P, g, 0, 2).plan()
        assert _make(P, g, 1, 1).plan() == Path([1], 0.0)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1, []), "num_nodes must be >= 0"),
        ((2, [(0, 1, -1.0)]), r"edge #0 \(0 -> 1\): cost -1.0 is negative"),
        ((2, [(0, 1, -INF)]), "is negative"),
        ((2, [(0, 1, 1.0), (1, 0, math.nan)]), r"edge #1 \(1 -> 0\): cost is NaN"),
        ((2, [(0, 2, 1.0)]), r"edge #0 \(0 -> 2\): node 2 out of range \[0, 1\]"),
        ((2, [(-1, 0, 1.0)]), "node -1 out of range"),
        ((2, [(0, 1)]), r"edge #0 must be a \(u, v, cost\) triple"),
        ((2, [(0, 1, "abc")]), "cost must be a number"),
    ],
)
def test_graph_rejects_bad_input(args, match) -> None:
    with pytest.raises(ValueError, match=match):
        Graph(*args)


def test_graph_rejects_non_integer_nodes() -> None:
    with pytest.raises(TypeError, match="must be an integer"):
        Graph(2, [(0.0, 1, 1.0)])


@pytest.mark.parametrize(
    ("arrays", "match"),
    [
        (([0], [1, 0], [1.0]), "same length"),
        (([0], [2], [1.0]), r"dst\[0\] = 2 is out of range \[0, 1\]"),
        (([0, -3], [1, 1], [1.0, 1.0]), r"src\[1\] = -3 is out of range"),
        (([0, 1], [1, 0], [1.0, -0.5]), r"edge #1 \(1 -> 0\) has cost -0.5"),
        (([0], [1], [math.nan]), "has cost nan"),
        (([0.0], [1], [1.0]), "src must hold integer node ids"),
        (([[0]], [[1]], [[1.0]]), "must be 1-D"),
    ],
)
def test_from_arrays_rejects_bad_input(arrays, match) -> None:
    src, dst, cost = (np.asarray(a) for a in arrays)
    with pytest.raises(ValueError, match=match):
        Graph.from_arrays(2, src, dst, cost)


def test_set_cost_and_cost_reject_bad_input() -> None:
    g = Graph(3, [(0, 1, 1.0)])
    with pytest.raises(ValueError, match=r"edge 0 -> 1: cost -2.0 is negative"):
        g.set_cost(0, 1, -2.0)
    with pytest.raises(ValueError, match="NaN"):
        g.set_cost(0, 1, math.nan)
    with pytest.raises(ValueError, match=r"edge head 5 is out of range \[0, 2\]"):
        g.set_cost(0, 5, 1.0)
    with pytest.raises(KeyError, match="no edge 1 -> 0"):
        g.cost(1, 0)
    with pytest.raises(KeyError, match="no edge 0 -> 2"):
        g.set_cost(0, 2, 1.0)
    assert g.cost(0, 1) == 1.0


@pytest.mark.parametrize("P", PLANNERS)
def test_planners_reject_bad_input(P) -> None:
    g = Graph(3, [(0, 1, 1.0), (1, 2, 1.0)])
    with pytest.raises(ValueError, match=r"start 3 is out of range \[0, 2\]"):
        P(g, 3, 2)
    with pytest.raises(ValueError, match=r"goal -1 is out of range \[0, 2\]"):
        P(g, 0, -1)
    with pytest.raises(TypeError, match="graph must be a mpd_pin.search.Graph"):
        P(nx.DiGraph(), 0, 2)
    p = P(g, 0, 2)
    with pytest.raises(ValueError, match=r"start 7 is out of range"):
        p.move_start(7)
    with pytest.raises(ValueError, match="negative"):
        p.update_edge(0, 1, -1.0)
    with pytest.raises(KeyError, match="no edge 2 -> 0"):
        p.update_edge(2, 0, 1.0)
    assert p.plan() == Path([0, 1, 2], 2.0)  # failed updates left the planner intact


def test_heuristic_validation() -> None:
    g = Graph(3, [(0, 1, 1.0), (1, 2, 1.0)])
    with pytest.raises(ValueError, match="Dijkstra takes no heuristic"):
        Dijkstra(g, 0, 2, heuristic=lambda a, b: 0.0)
    with pytest.raises(TypeError, match="heuristic must be callable"):
        AStar(g, 0, 2, heuristic=3.0)
    p = MPDStarLite(g, 0, 2, heuristic=lambda a, b: -1.0 if a != b else 0.0)
    p.plan()
    p.move_start(1)
    with pytest.raises(ValueError, match=r"heuristic\(0, 1\) = -1.0"):
        p.plan()


def test_no_path_error_is_the_package_error() -> None:
    assert NoPathError is mpd_pin.errors.NoPathError
    assert issubclass(SearchInvariantError, mpd_pin.errors.MpdPinError)


# --------------------------------------------------------- small exact cases
@pytest.mark.parametrize("P", PLANNERS)
def test_hand_checked_small_graph_with_changes(P) -> None:
    #   0 -1-> 1 -1-> 3 ; 0 -4-> 2 -1-> 3 ; 1 -0-> 2 ; 3 -1-> 0
    g = Graph(4, [(0, 1, 1.0), (1, 3, 1.0), (0, 2, 4.0), (2, 3, 1.0), (1, 2, 0.0), (3, 0, 1.0)])
    p = P(g, 0, 3)
    assert p.plan() == Path([0, 1, 3], 2.0)
    p.update_edge(1, 3, INF)  # the tail (1) must be repaired
    assert p.plan() == Path([0, 1, 2, 3], 2.0)
    p.update_edge(1, 2, 3.0)
    assert p.plan() == Path([0, 2, 3], 5.0)
    p.update_edge(0, 2, INF)
    assert p.plan() == Path([0, 1, 2, 3], 5.0)
    p.move_start(2)
    assert p.plan() == Path([2, 3], 1.0)
    p.update_edge(2, 3, INF)
    with pytest.raises(NoPathError, match="no path from node 2 to node 3"):
        p.plan()
    p.update_edge(1, 3, 0.5)
    with pytest.raises(NoPathError):
        p.plan()  # 2 has no way to 1
    p.update_edge(2, 3, 2.0)
    assert p.plan() == Path([2, 3], 2.0)


@pytest.mark.parametrize("P", INCREMENTAL)
def test_zero_cost_cycle_does_not_fool_incremental_search(P) -> None:
    """Two nodes joined by zero-cost edges must not keep supporting each other.

    Classic D* Lite (costs > 0 assumed) ends here with g(0) = g(1) = 5 and a
    pointer cycle 0 -> 1 -> 0 although the cheapest cost is 6.
    """
    g = Graph(3, [(0, 1, 0.0), (1, 0, 0.0), (0, 2, 5.0), (1, 2, 5.0)])
    p = P(g, 0, 2)
    assert p.plan() == Path([0, 2], 5.0)
    p.update_edge(0, 2, 6.0)
    assert p.plan() == Path([0, 1, 2], 5.0)
    p.update_edge(1, 2, 7.0)
    assert p.plan() == Path([0, 2], 6.0)
    p.update_edge(0, 2, INF)
    assert p.plan() == Path([0, 1, 2], 7.0)
    p.update_edge(1, 2, INF)
    with pytest.raises(NoPathError):
        p.plan()


@pytest.mark.parametrize("P", PLANNERS)
def test_all_zero_costs_prefer_fewest_edges(P) -> None:
    n = 6
    edges = [(i, j, 0.0) for i in range(n) for j in range(n) if i != j and abs(i - j) <= 2]
    p = P(Graph(n, edges), 0, n - 1)
    path = p.plan()
    assert path.cost == 0.0 and path.nodes[0] == 0 and path.nodes[-1] == n - 1
    if P in INCREMENTAL:  # ties broken by hop count
        assert len(path.nodes) == 4


@pytest.mark.parametrize("P", INCREMENTAL)
def test_km_is_accumulated_after_a_move(P) -> None:
    """Regression found by search: without ``km += h(s_last, s_start)`` this gives 8, not 7."""
    n, edges, pos = _grid(12, 11, lambda i, j: 2.0 if (i, j) == (41, 53) else 1.0)

    def h(a: int, b: int) -> float:
        return float(abs(pos[a][0] - pos[b][0]) + abs(pos[a][1] - pos[b][1]))

    g = Graph(n, edges)
    p = P(g, 54, 36, heuristic=h)
    assert p.plan().cost == 7.0
    p.move_start(41)
    p.update_edge(41, 40, INF)
    ref = nx.DiGraph()
    ref.add_weighted_edges_from((u, v, c) for u, v, c in zip(*g.to_arrays(), strict=True))
    ref.remove_edge(41, 40)
    assert nx.dijkstra_path_length(ref, 41, 36) == 7.0
    assert p.plan().cost == 7.0


def test_mpd_pointers_and_values_are_exposed() -> None:
    g = Graph(3, [(0, 1, 1.0), (1, 2, 2.0), (0, 2, 5.0)])
    p = MPDStarLite(g, 0, 2)
    p.plan()
    assert [p.pointer(0), p.pointer(1), p.pointer(2)] == [1, 2, None]
    assert p.g(0) == p.rhs(0) == 3.0 and p.g(2) == 0.0


def test_pointer_loop_raises_a_clear_internal_error() -> None:
    g = Graph(3, [(0, 1, 1.0), (1, 0, 1.0), (1, 2, 1.0)])
    p = MPDStarLite(g, 0, 2)
    p.plan()
    p._ptr[1] = 0  # corrupt the state on purpose
    p._ptr[0] = 1
    with pytest.raises(SearchInvariantError, match="did not reach goal 2"):
        p._extract()


# ----------------------------------------------------------- stats and work
def test_stats_cumulative_and_per_plan() -> None:
    n, edges, _ = _grid(8, 8, lambda i, j: 1.0 + (i * 7 + j) % 3)
    for P in PLANNERS:
        p = P(Graph(n, edges), 0, n - 1)
        total = SearchStats()
        p.plan()
        assert p.last_stats.expansions > 0 and p.last_stats.edge_evaluations > 0
        assert p.last_stats.queue_operations > 0
        total = total + p.last_stats
        p.update_edge(0, 1, INF)
        p.plan()
        total = total + p.last_stats
        assert total == p.stats
        p.plan()  # nothing changed: no search
        assert p.last_stats.expansions == 0


def test_incremental_repair_beats_replanning_from_scratch() -> None:
    """Blocking an edge next to the robot: the repair expands fewer nodes than a new search."""
    rng = np.random.default_rng(1)
    w = h = 60
    n, edges, _ = _grid(w, h, lambda i, j: float(rng.integers(1, 10)))
    start, goal = 0, n - 1
    for P in INCREMENTAL:
        g = Graph(n, edges)
        p = P(g, start, goal)
        first = p.plan()
        full = p.last_stats.expansions
        u, v = first.nodes[0], first.nodes[1]
        p.update_edge(u, v, INF)
        repaired = p.plan()
        fresh = P(g.copy(), start, goal)
        again = fresh.plan()
        assert repaired.cost == again.cost == nx.dijkstra_path_length(_nx(g), start, goal)
        assert p.last_stats.expansions < fresh.last_stats.expansions
        assert p.last_stats.expansions < full / 20, (p.last_stats, full)


def _nx(g: Graph) -> nx.DiGraph:
    G = nx.DiGraph()
    G.add_nodes_from(range(g.num_nodes))
    src, dst, cost = g.to_arrays()
    G.add_weighted_edges_from(
        (u, v, c)
        for u, v, c in zip(src.tolist(), dst.tolist(), cost.tolist(), strict=True)
        if c < INF
    )
    return G


# ------------------------------------------------- larger graphs vs scipy
def _geometric(n: int, k: int, seed: int):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3))
    _, nbr = cKDTree(pts).query(pts, k + 1)
    src = np.repeat(np.arange(n), k)
    dst = nbr[:, 1:].ravel()
    src, dst = np.concatenate([src, dst]), np.concatenate([dst, src])
    cost = np.linalg.norm(pts[src] - pts[dst], axis=1) * rng.uniform(1, 2, src.size)
    return pts, Graph.from_arrays(n, src, dst, cost)


def _scipy_dist(g: Graph, start: int) -> np.ndarray:
    src, dst, cost = g.to_arrays()
    keep = np.isfinite(cost)
    # csgraph treats explicit zeros as missing edges: no zero costs in this graph
    assert np.all(cost[keep] > 0)
    m = csr_matrix((cost[keep], (src[keep], dst[keep])), shape=(g.num_nodes, g.num_nodes))
    return sp_dijkstra(m, indices=start)


def test_random_geometric_graph_with_replanning_matches_scipy() -> None:
    pts, g0 = _geometric(1500, 8, seed=3)
    start = int(np.argmin(pts.sum(1)))
    goal = int(np.argmax(pts.sum(1)))

    def h(a: int, b: int) -> float:  # cost >= euclidean length: admissible, consistent
        return float(np.linalg.norm(pts[a] - pts[b])) * (1 - 1e-12)

    planners = [
        _make(P, g0.copy(), start, goal, heuristic=hh)
        for P in PLANNERS
        for hh in ((None, h) if P is not Dijkstra else (None,))
    ]
    rng = np.random.default_rng(4)
    src, dst, _ = g0.to_arrays()
    for _step in range(6):
        g_now = planners[0].graph
        ref = _scipy_dist(g_now, start)[goal]
        paths = [p.plan() for p in planners]
        for p, path in zip(planners, paths, strict=True):
            assert path.nodes[0] == start and path.nodes[-1] == goal
            assert path.cost == _path_sum(g_now, path.nodes)
            assert math.isclose(path.cost, ref, rel_tol=1e-12), (type(p).__name__, path.cost, ref)
        # block the edges around a node of the current path, re-cost a few others
        mid = paths[0].nodes[len(paths[0].nodes) // 3]
        changes = [(int(u), mid, INF) for u in g0.predecessors(mid) if u != start]
        for e in rng.choice(len(src), 20, replace=False):
            old = g_now.cost(int(src[e]), int(dst[e]))
            if old < INF:
                changes.append((int(src[e]), int(dst[e]), old * float(rng.uniform(0.5, 2))))
        nxt = paths[0].nodes[1]
        for p in planners:
            p.update_edges(changes)
            p.move_start(nxt)
        start = nxt


# ------------------------------------------------------------------- imports
def test_search_package_imports_nothing_from_the_rest_of_mpd_pin() -> None:
    allowed_roots = {
        "__future__",
        "math",
        "heapq",
        "bisect",
        "operator",
        "abc",
        "collections",
        "dataclasses",
        "numpy",
        "typing",
    }
    pkg = pathlib.Path(mpd_pin.search.__file__).parent
    for f in sorted(pkg.glob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                ok = name.split(".")[0] in allowed_roots or name == "mpd_pin.errors"
                ok = ok or name.startswith("mpd_pin.search")
                assert ok, f"{f.name} imports {name}"


def test_search_runs_without_loading_pinocchio_or_coal() -> None:
    """A fresh interpreter plans with mpd_pin.search; Pinocchio and Coal stay unloaded."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from mpd_pin.search import Graph, MPDStarLite, DStarLite, AStar, Dijkstra\n"
        "from mpd_pin.errors import NoPathError\n"
        "import mpd_pin\n"
        "g = Graph(4, [(0, 1, 1.0), (1, 3, 1.0), (0, 2, 0.5), (2, 3, 2.0)])\n"
        "for P in (MPDStarLite, DStarLite, AStar, Dijkstra):\n"
        "    p = P(g.copy(), 0, 3)\n"
        "    assert p.plan().nodes == [0, 1, 3]\n"
        "    p.update_edge(1, 3, float('inf'))\n"
        "    assert p.plan().nodes == [0, 2, 3]\n"
        "assert mpd_pin.NoPathError is NoPathError\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('pinocchio', 'coal', 'hppfcl')]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    def run_ok(source: str) -> None:
        out = subprocess.run(
            [sys.executable, "-c", source], capture_output=True, text=True, timeout=120,
            check=False,
        )
        assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr

    run_ok(code)
    # The lazy top-level names still resolve (and then do load Pinocchio).
    code2 = (
        "import sys\n"
        "import mpd_pin as mp\n"
        "assert 'pinocchio' not in sys.modules\n"
        "assert set(mp.__all__) <= set(dir(mp))\n"
        "assert mp.Arm.__name__ == 'Arm' and mp.Drive.__name__ == 'Drive'\n"
        "assert 'pinocchio' in sys.modules\n"
        "for name in mp.__all__:\n"
        "    getattr(mp, name)\n"
        "try:\n"
        "    mp.no_such_name\n"
        "except AttributeError:\n"
        "    print('ok')\n"
    )
    run_ok(code2)


def test_adjacency_views_are_live_and_match_networkx() -> None:
    """The planners' read-only CSR views list exactly networkx's successors/predecessors
    with their costs, and see a set_cost made after the view was taken."""
    edges = [(0, 1, 2.0), (0, 2, 5.0), (1, 2, 1.0), (2, 0, 0.5), (3, 1, 4.0)]
    g = Graph(4, edges)
    ref = nx.DiGraph()
    ref.add_nodes_from(range(4))
    ref.add_weighted_edges_from(edges)
    succ, pred = g.successor_view, g.predecessor_view
    for u in range(4):
        a, b = succ.ptr[u], succ.ptr[u + 1]
        assert list(zip(succ.nbr[a:b], succ.cost[a:b], strict=True)) == sorted(
            (v, d["weight"]) for v, d in ref.succ[u].items())
        a, b = pred.ptr[u], pred.ptr[u + 1]
        assert list(zip(pred.nbr[a:b], pred.cost[a:b], strict=True)) == sorted(
            (w, d["weight"]) for w, d in ref.pred[u].items())
    k = g.set_cost(1, 2, 7.0)
    assert succ.nbr[k] == 2 and succ.cost[k] == 7.0
    j = pred.ptr[2] + pred.nbr[pred.ptr[2]:pred.ptr[3]].index(1)
    assert pred.cost[j] == 7.0


# ------------------------------------------ update_edge's inlined fast path
@pytest.mark.parametrize("P", INCREMENTAL)
def test_update_edge_fast_and_checked_paths_agree_with_networkx(P) -> None:
    """update_edge writes the cost itself for plain int ids and float costs (Graph.set_cost
    inlined) and goes through set_cost for anything else (numpy ids, int costs, -0.0):
    either way both cost orders of the graph hold the new cost, and the repaired path
    matches networkx's on the changed graph, blocked node after blocked node."""
    pts, g = _geometric(600, 6, seed=5)
    start, goal = int(np.argmin(pts.sum(1))), int(np.argmax(pts.sum(1)))
    p = P(g, start, goal)
    nodes = p.plan().nodes
    forms = [
        lambda u, v, c: (u, v, c),
        lambda u, v, c: (np.int64(u), np.int32(v), np.float64(c)),
        lambda u, v, c: (u, v, int(c) if c < INF else c),
    ]
    for step in range(4):
        node = nodes[min(2, len(nodes) - 2)]
        if node in (start, goal):
            break
        blocked = [(int(u), node) for u in g.predecessors(node)]
        blocked += [(node, int(v)) for v in g.successors(node)]
        for i, (u, v) in enumerate(blocked):
            p.update_edge(*forms[(i + step) % 3](u, v, INF))
        # re-cost a few finite edges too, as -0.0 and as int, through both paths
        u0, v0 = nodes[-2], nodes[-1]
        p.update_edge(u0, v0, -0.0 if step % 2 else 0.0)
        assert math.copysign(1.0, g.cost(u0, v0)) == 1.0
        u1, v1 = nodes[0], nodes[1]
        if (u1, v1) not in blocked:
            p.update_edge(*forms[step % 3](u1, v1, float(step + 1)))
        pred = g.predecessor_view
        for u, v in [*blocked, (u0, v0), (u1, v1)]:
            a, b = pred.ptr[v], pred.ptr[v + 1]
            assert pred.cost[a + pred.nbr[a:b].index(u)] == g.cost(u, v)
        G = _nx(g)
        try:
            ref = nx.dijkstra_path_length(G, start, goal)
        except nx.NetworkXNoPath:
            with pytest.raises(NoPathError):
                p.plan()
            break
        path = p.plan()
        assert path.cost == _path_sum(g, path.nodes)
        assert math.isclose(path.cost, ref, rel_tol=1e-12), (step, path.cost, ref)
        assert all(math.isfinite(g.cost(a, b)) for a, b in path.edges)
        nodes = path.nodes


@pytest.mark.parametrize("P", INCREMENTAL)
def test_update_edge_rejects_bad_input_like_set_cost(P) -> None:
    """Inputs the fast path does not take get set_cost's checks and messages, and a
    refused change leaves the planner as it was."""
    g = Graph(3, [(0, 1, 1.0), (1, 2, 1.0), (0, 2, 5.0)])
    p = P(g, 0, 2)
    assert p.plan() == Path([0, 1, 2], 2.0)
    with pytest.raises(ValueError, match=r"edge head 3 is out of range \[0, 2\]"):
        p.update_edge(0, 3, INF)
    with pytest.raises(ValueError, match=r"edge head -1 is out of range"):
        p.update_edge(0, -1, INF)
    with pytest.raises(ValueError, match=r"edge tail 7 is out of range"):
        p.update_edge(7, 1, INF)
    with pytest.raises(ValueError, match="NaN"):
        p.update_edge(0, 1, math.nan)
    with pytest.raises(ValueError, match="negative"):
        p.update_edge(0, 1, -INF)
    with pytest.raises(TypeError, match="must be an integer"):
        p.update_edge(True, 1, INF)
    with pytest.raises(TypeError, match="must be an integer"):
        p.update_edge(0, 1.0, INF)
    with pytest.raises(KeyError, match="no edge 2 -> 1"):
        p.update_edge(2, 1, 1.0)
    assert g.cost(0, 1) == 1.0
    assert p.plan() == Path([0, 1, 2], 2.0)


def test_mpd_one_pass_extraction_reports_corrupt_pointers() -> None:
    """MPD* Lite's path is read and summed in one pass; a broken pointer chain still gives
    the errors of the two-pass reading (no pointer, a loop, a blocked edge)."""
    g = Graph(4, [(0, 1, 1.0), (1, 0, 1.0), (1, 2, 1.0), (2, 3, 1.0), (0, 3, 9.0)])
    p = MPDStarLite(g, 0, 3)
    assert p.plan() == Path([0, 1, 2, 3], 3.0)
    assert p._extract_path() == p._path_from_nodes(p._extract())
    saved = list(p._ptr)
    p._ptr[1] = -1
    with pytest.raises(SearchInvariantError, match="node 1 on the path from 0 has no stored"):
        p._extract_path()
    p._ptr[:] = saved
    p._ptr[1] = 0
    with pytest.raises(SearchInvariantError, match="did not reach goal 3"):
        p._extract_path()
    p._ptr[:] = saved
    g.set_cost(1, 2, INF)  # behind the planner's back: the stored pointer uses it
    with pytest.raises(SearchInvariantError, match="edge 1 -> 2, which is missing or blocked"):
        p._extract_path()
