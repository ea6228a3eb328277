"""Later queries on a built roadmap: their start and goal joined to it (docs/design.md §4i).

A roadmap is built once, around its first query (start = node 0, goal = node 1, exactly
as :func:`~mpd_pin.planning.roadmap.build_roadmap` builds it, so a first query plans the
same path as a one-shot run). A later query (start′, goal′) reuses every node, edge,
collision check and simulated energy: :func:`add_query` appends start′ and goal′ as nodes
(or finds them among the nodes, within :data:`SAME_NODE` rad), joins each new node to
its ``k`` nearest neighbours — and each node that now has a new node among its ``k``
nearest to that node, as a build with the new nodes would — checks those edges for
collision, times them, and either simulates them (eager) or leaves them unevaluated
(lazy, NaN energies). Only the new edges cost anything.
"""

from __future__ import annotations

import hashlib
import time

import numpy as np

from ..dynamics.cost import EnergyCost
from ..progress import tqdm_class
from .options import RoadmapOptions
from .roadmap import candidate_edges, check_endpoint, cost_edges, free_pairs, neighbour_pairs
from .roadmap_data import EDGE_COUNTS, Roadmap
from .supply_costs import attach_supply

__all__ = ["add_query", "SAME_NODE"]

#: A query configuration within this distance (rad, every joint) of a roadmap node is
#: that node.
SAME_NODE = 1e-9


def _node_id(nodes: np.ndarray, q: np.ndarray) -> int | None:
    hit = np.flatnonzero(np.all(np.abs(nodes - q) <= SAME_NODE, axis=1))
    return int(hit[0]) if hit.size else None


def add_query(
    roadmap: Roadmap,
    cost: EnergyCost,
    checker,
    start,
    goal,
    options: RoadmapOptions,
    *,
    evaluate: bool,
    check_edges: bool = True,
    show_progress: bool = False,
) -> Roadmap:
    """A copy of ``roadmap`` whose ``start`` and ``goal`` are the configurations ``start``
    and ``goal`` (rad), appended as nodes when they are not nodes already and joined as in
    the module docstring. Existing edges keep their energies (NaN rows stay unevaluated);
    new edges are simulated when ``evaluate`` (the infeasible ones refused and counted in
    ``edge_counts``), else NaN. With ``check_edges=False`` (lazy collision checking, not
    with ``evaluate``) the new edges are left unchecked. ValueError (one line) when start
    or goal is outside the joint limits or in collision."""
    arm = cost.drive.arm
    start = check_endpoint(arm, checker, start, "start")
    goal = check_endpoint(arm, checker, goal, "goal")
    t0 = time.perf_counter()
    nodes = np.asarray(roadmap.nodes, dtype=float)
    n_old = nodes.shape[0]
    ids = []
    for q in (start, goal):
        found = _node_id(nodes, q)
        if found is None:
            nodes = np.vstack([nodes, q[None, :]])
            found = nodes.shape[0] - 1
        ids.append(found)
    src, dst = np.asarray(roadmap.src), np.asarray(roadmap.dst)
    durations, energy = np.asarray(roadmap.durations), np.asarray(roadmap.energy, float)
    bus = None if roadmap.bus is None else np.asarray(roadmap.bus, float)
    counts = {k: int(roadmap.edge_counts.get(k, 0)) for k in EDGE_COUNTS}
    checked = roadmap.checked
    pairs_checked = 0
    if nodes.shape[0] > n_old:
        pairs = neighbour_pairs(nodes, options.k, arm.continuous_mask)
        pairs = pairs[pairs.max(axis=1) >= n_old]  # the pairs among old nodes exist already
        pairs_checked = len(pairs) if check_edges else 0
        if check_edges:
            pairs = free_pairs(checker, nodes, pairs, options.resolution)
        if evaluate:
            new = cost_edges(cost, nodes, pairs, options, tqdm_class(show_progress), show_progress)
        else:
            new = candidate_edges(nodes, pairs, options, arm)
        src, dst = np.concatenate([src, new[0]]), np.concatenate([dst, new[1]])
        durations = np.concatenate([durations, new[2]])
        energy = np.concatenate([energy, np.asarray(new[3], float)])
        if bus is not None:
            bus = np.concatenate([bus, np.asarray(new[5], float)])
        for k in EDGE_COUNTS:
            counts[k] += int(new[4].get(k, 0))
        if not check_edges or checked is not None:
            old = roadmap.checked_mask
            checked = np.concatenate([old, np.full(new[0].size, check_edges)])
    digest = hashlib.sha256(roadmap.key.encode())
    digest.update(np.ascontiguousarray(nodes[n_old:], dtype=float).tobytes())
    digest.update(np.array(ids, dtype=np.int64).tobytes())
    timings = {"query_nodes": time.perf_counter() - t0}
    extended = Roadmap(nodes=nodes, start=ids[0], goal=ids[1], src=src, dst=dst,
                       durations=durations, energy=np.array(energy, dtype=float),
                       key=digest.hexdigest(), timings=timings, edge_counts=counts,
                       checked=None if checked is None else np.asarray(checked, dtype=bool),
                       pairs_checked=pairs_checked,
                       bus=None if bus is None else np.array(bus, dtype=float))
    return attach_supply(extended, cost.drive)
