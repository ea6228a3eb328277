"""Property tests of the four planners against networkx on random changing graphs.

Random directed graphs (<= 60 nodes, zero-cost edges, self-loops) go through
random sequences of cost increases, decreases, blocks (inf), unblocks and start
moves along the current shortest path. After each step every planner's path is
checked against ``networkx.dijkstra_path_length`` on the current graph: exactly
for integer and dyadic costs (sums are exact), to 1e-12 relative for general
floats. Part of the examples use an admissible, consistent heuristic
(costs >= |pos[u] - pos[v]|, h = |pos[a] - pos[b]|).
"""

from __future__ import annotations

import math

import networkx as nx
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mpd_pin.errors import NoPathError
from mpd_pin.search import AStar, Dijkstra, DStarLite, Graph, MPDStarLite

PLANNERS = (MPDStarLite, DStarLite, AStar, Dijkstra)
INF = math.inf
OPS = ("inc", "dec", "block", "unblock", "set", "move", "move")

INT_COST = st.integers(0, 6).map(float)
DYADIC_COST = st.integers(0, 80).map(lambda k: k / 8.0)
FLOAT_COST = st.floats(0.0, 10.0, allow_nan=False, allow_infinity=False)


def _l1(p: tuple[int, int], q: tuple[int, int]) -> float:
    return float(abs(p[0] - q[0]) + abs(p[1] - q[1]))


@st.composite
def scenarios(draw, cost: st.SearchStrategy[float]) -> dict:
    """A random graph, start, goal, optional positions for a heuristic, and operations.

    Two families: arbitrary random digraphs (dense or sparse, self-loops allowed)
    and grids with 4/8-neighbour moves (long paths, where the heuristic and the
    km bookkeeping matter). With positions, every cost is >= the L1 distance of
    its endpoints, so h(a, b) = L1(pos[a], pos[b]) is admissible and consistent.
    """
    if draw(st.booleans()):
        n = draw(st.integers(2, 60))
        node = st.integers(0, n - 1)
        pairs = draw(st.lists(st.tuples(node, node), min_size=n, max_size=5 * n, unique=True))
        coord = st.tuples(st.integers(0, 6), st.integers(0, 6))
        pos = draw(st.lists(coord, min_size=n, max_size=n))
    else:
        w = draw(st.integers(1, 10))
        rows = draw(st.integers(2, 60 // w))
        n = w * rows
        node = st.integers(0, n - 1)
        pos = [(i % w, i // w) for i in range(n)]
        steps = [(1, 0), (0, 1)] + ([(1, 1), (1, -1)] if draw(st.booleans()) else [])
        pairs = []
        for i, (x, y) in enumerate(pos):
            for dx, dy in steps:
                if 0 <= x + dx < w and 0 <= y + dy < rows:
                    j = (y + dy) * w + x + dx
                    pairs += [(i, j), (j, i)]
    use_h = draw(st.booleans())
    if not use_h:
        pos = [(0, 0)] * n
    costs = {(u, v): _l1(pos[u], pos[v]) + draw(cost) for u, v in pairs}
    blocked = draw(st.lists(st.sampled_from(pairs), max_size=3)) if pairs else []
    for e in blocked:
        costs[e] = INF
    ops = draw(
        st.lists(
            st.tuples(st.sampled_from(OPS), st.integers(0, 10**6), cost, st.booleans()),
            max_size=14,
        )
    )
    start = draw(node)
    # start == goal now and then; otherwise a different node
    goal = start if draw(st.integers(0, 15)) == 0 else (start + draw(st.integers(1, n - 1))) % n
    return {
        "n": n,
        "costs": costs,
        "pos": pos if use_h else None,
        "start": start,
        "goal": goal,
        "ops": ops,
        "shared": draw(st.booleans()),
    }


def _reference(n: int, costs: dict) -> nx.DiGraph:
    G = nx.DiGraph()
    G.add_nodes_from(range(n))
    G.add_weighted_edges_from((u, v, c) for (u, v), c in costs.items() if c < INF)
    return G


def _check(planners, costs: dict, n: int, start: int, goal: int, exact: bool) -> list | None:
    """Check every planner against networkx; return the reference path (or None)."""
    G = _reference(n, costs)
    try:
        ref_cost = nx.dijkstra_path_length(G, start, goal)
        ref_path = nx.dijkstra_path(G, start, goal)
    except nx.NetworkXNoPath:
        ref_cost = ref_path = None
    event("no path" if ref_path is None else f"path of {min(len(ref_path), 6)}+ nodes")
    for p in planners:
        assert p.start == start
        if ref_cost is None:
            with pytest.raises(NoPathError):
                p.plan()
            continue
        path = p.plan()
        nodes = path.nodes
        assert nodes[0] == start and nodes[-1] == goal, (type(p).__name__, nodes)
        total = 0.0
        for u, v in zip(nodes[:-1], nodes[1:], strict=True):
            c = costs.get((u, v))
            assert c is not None and c < INF, f"{type(p).__name__}: {u}->{v} not an edge"
            total += c
        assert path.cost == total
        if exact:
            assert path.cost == ref_cost, (type(p).__name__, path.cost, ref_cost)
        else:
            assert math.isclose(path.cost, ref_cost, rel_tol=1e-12, abs_tol=0.0), (
                type(p).__name__,
                path.cost,
                ref_cost,
            )
        if isinstance(p, MPDStarLite):
            _check_pointer_chain(p, costs, start, goal, nodes)
    return ref_path


def _check_pointer_chain(p: MPDStarLite, costs: dict, start: int, goal: int, nodes) -> None:
    """The stored pointers from start form an acyclic chain of finite edges to the goal."""
    chain = [start]
    seen = {start}
    s = start
    while s != goal:
        nxt = p.pointer(s)
        assert nxt is not None, f"pointer chain breaks at {s}"
        assert costs.get((s, nxt), INF) < INF
        assert nxt not in seen, f"pointer cycle through {nxt}: {chain}"
        seen.add(nxt)
        chain.append(nxt)
        s = nxt
    assert p.pointer(goal) is None
    assert chain == nodes


def _run(sc: dict, exact: bool) -> None:
    n, costs, pos = sc["n"], dict(sc["costs"]), sc["pos"]
    start, goal = sc["start"], sc["goal"]
    keys = sorted(costs)

    def lb(e):
        return 0.0 if pos is None else _l1(pos[e[0]], pos[e[1]])

    heuristic = None if pos is None else (lambda a, b: _l1(pos[a], pos[b]))
    event("zero heuristic" if heuristic is None else "L1 heuristic")
    edges = [(u, v, c) for (u, v), c in costs.items()]
    if sc["shared"]:
        shared = Graph(n, edges)
        graphs = [shared] * len(PLANNERS)
    else:
        graphs = [Graph(n, edges) for _ in PLANNERS]
    planners = [
        P(gr, start, goal, heuristic=None if P is Dijkstra else heuristic)
        for P, gr in zip(PLANNERS, graphs, strict=True)
    ]
    ref_path = _check(planners, costs, n, start, goal, exact)
    for kind, idx, amount, check_now in sc["ops"]:
        if kind == "move":
            if ref_path is None or len(ref_path) < 2:
                continue
            start = ref_path[min(1 + idx % 3, len(ref_path) - 1)]
            event("start moved")
            for p in planners:
                p.move_start(start)
        else:
            if not keys:
                continue
            e = keys[idx % len(keys)]
            old = costs[e]
            if kind == "inc":
                new = old + amount
            elif kind == "dec":
                new = lb(e) + amount if old == INF else max(lb(e), old - amount)
            elif kind == "block":
                new = INF
            elif kind == "unblock":
                new = lb(e) + amount if old == INF else old
            else:
                new = lb(e) + amount
            costs[e] = new
            for p in planners:
                p.update_edge(e[0], e[1], new)
        if check_now:
            ref_path = _check(planners, costs, n, start, goal, exact)
    _check(planners, costs, n, start, goal, exact)


_SETTINGS = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
}


@settings(max_examples=500, **_SETTINGS)
@given(scenarios(INT_COST))
def test_integer_costs_match_networkx_exactly(sc: dict) -> None:
    _run(sc, exact=True)


@settings(max_examples=300, **_SETTINGS)
@given(scenarios(DYADIC_COST))
def test_dyadic_costs_match_networkx_exactly(sc: dict) -> None:
    _run(sc, exact=True)


@settings(max_examples=200, **_SETTINGS)
@given(scenarios(FLOAT_COST))
def test_general_float_costs_match_networkx(sc: dict) -> None:
    _run(sc, exact=False)
