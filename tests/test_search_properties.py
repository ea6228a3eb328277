"""Property tests of the four planners against networkx on random changing graphs.

Random directed graphs (<= 60 nodes, zero-cost edges, self-loops) go through
random sequences of steps: cost increases, decreases, blocks (inf), unblocks and
re-sets, each of a random edge or of an edge of MPD* Lite's current path;
batches of several such changes (applied with ``update_edges`` before one
``plan()``); and start moves. Half of the scenarios then walk the robot to the
goal with changes interleaved. A start move advances the robot one node along
the path MPD* Lite itself returned after the previous step (the planner's own
current path, refreshed after every operation, as a robot executing it would),
not along a reference path. After *every* step (one change, one batch or one
move) each planner's ``plan()`` is checked: its path is a path of finite edges
in the current graph from the current start to the goal, ``path.cost`` equals
the left-to-right sum of those edges' costs exactly (``==``), and that cost
equals ``networkx.dijkstra_path_length`` on the current graph — or every
planner raises ``NoPathError`` when networkx finds no path. MPD* Lite's stored
pointers must form an acyclic chain from the start to the goal equal to its path.

Exactness. For integer costs and dyadic costs (multiples of 1/8, bounded) every
partial sum is exactly representable, so each planner's cost is compared with
networkx's using ``==``. For general floats exact equality is not attainable:
float addition is not associative, and the planners rank candidate paths by
sums taken in different orders (networkx and A*/Dijkstra accumulate
``dist[u] + w`` from the start, the D* Lites accumulate cost-to-goal from the
goal). When two different paths have real costs within a few ulps of each
other, each planner picks the one that is smaller in its own summation order,
and the two left-to-right sums then differ in the last bits although both paths
are optimal up to rounding. (The same path always gives the same ``path.cost``:
it is re-summed left to right, as networkx does.) There the comparison is
``math.isclose(cost, ref, rel_tol=1e-12, abs_tol=0)``. With non-negative terms a
sum of at most 60 edges is within 59 * 2**-53 (about 7e-15) relative of its real
value, so two optimal paths' sums differ by less than about 1.4e-14 relative;
1e-12 leaves a factor of ~70 above that. A genuinely suboptimal path closer than
1e-12 relative would go unnoticed here; the exact integer and dyadic tests,
which run the same scenarios, leave no such slack.

Part of the examples use an admissible, consistent heuristic
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
CHANGES = ("inc", "dec", "block", "unblock", "set")

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
    # "tight": most edges cost exactly their lower bound, so the heuristic is exact on
    # many paths, the search stays narrow and leaves stale queue entries behind, where
    # D* Lite's km bookkeeping after start moves matters
    tight = use_h and draw(st.booleans())
    extra = st.one_of(st.just(0.0), st.just(0.0), st.just(0.0), cost) if tight else cost
    costs = {(u, v): _l1(pos[u], pos[v]) + draw(extra) for u, v in pairs}
    blocked = draw(st.lists(st.sampled_from(pairs), max_size=3)) if pairs else []
    for e in blocked:
        costs[e] = INF
    # (kind, edge index, amount); a negative index picks an edge of the current path
    # (an obstacle appearing right where the robot is about to go)
    change = st.tuples(st.sampled_from(CHANGES), st.integers(-(10**6), 10**6), cost)
    move = st.just(("move", 0, 0.0))
    batch = st.lists(change, min_size=2, max_size=4).map(lambda cs: ("batch", cs, 0.0))
    # one_of picks a branch uniformly: a step is a move 2/5 of the time
    ops = draw(st.lists(st.one_of(change, move, move, batch), max_size=16))
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
        # half of the scenarios end with the robot walking to the goal (changes interleaved)
        "walk": draw(st.none() | st.lists(st.one_of(change, batch), max_size=6)),
    }


def _reference(n: int, costs: dict) -> nx.DiGraph:
    G = nx.DiGraph()
    G.add_nodes_from(range(n))
    G.add_weighted_edges_from((u, v, c) for (u, v), c in costs.items() if c < INF)
    return G


def _check(planners, costs: dict, n: int, start: int, goal: int, exact: bool) -> list | None:
    """Check every planner's plan() against networkx; return MPD* Lite's path (None: no path)."""
    G = _reference(n, costs)
    try:
        ref_cost = nx.dijkstra_path_length(G, start, goal)
    except nx.NetworkXNoPath:
        ref_cost = None
    event("no path" if ref_cost is None else "path")
    current = None
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
            current = list(nodes)
    return current


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

    def new_cost(kind: str, e, amount: float) -> float:
        old = costs[e]
        if kind == "inc":
            return old + amount
        if kind == "dec":
            return lb(e) + amount if old == INF else max(lb(e), old - amount)
        if kind == "block":
            return INF
        if kind == "unblock":
            return lb(e) + amount if old == INF else old
        return lb(e) + amount  # "set"

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
    # MPD* Lite's own current path, refreshed by the check after every operation
    current = _check(planners, costs, n, start, goal, exact)
    moves = 0

    def step(kind: str, arg, amount: float) -> None:
        nonlocal start, current, moves
        if kind == "move":
            # the robot advances one node along the path MPD* Lite just returned
            if current is None or len(current) < 2:
                event("move skipped (no path or at goal)")
            else:
                start = current[1]
                moves += 1
                for p in planners:
                    p.move_start(start)
        elif keys:
            batch = arg if kind == "batch" else [(kind, arg, amount)]
            changes = []
            on_path = [] if current is None else list(zip(current[:-1], current[1:], strict=True))
            for k, idx, amt in batch:
                e = on_path[idx % len(on_path)] if idx < 0 and on_path else keys[idx % len(keys)]
                costs[e] = new_cost(k, e, amt)
                changes.append((e[0], e[1], costs[e]))
            if kind == "batch":
                event("batch of changes")
            for p in planners:
                if kind == "batch":
                    p.update_edges(changes)
                else:
                    p.update_edge(*changes[0])
        current = _check(planners, costs, n, start, goal, exact)

    for op in sc["ops"]:
        step(*op)
    if sc["walk"] is not None:
        # then walk to the goal, one change after each move while they last
        walk = list(sc["walk"])
        for _ in range(4 * n):
            if current is None or len(current) < 2:
                break
            step("move", 0, 0.0)
            if walk:
                step(*walk.pop(0))
        else:
            raise AssertionError(f"the robot did not reach the goal in {4 * n} moves")
        event("walked to the goal" if current is not None else "walk cut off (no path)")
    event(f"start moved {min(moves, 4)}{'+' if moves >= 4 else ''} times")


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
