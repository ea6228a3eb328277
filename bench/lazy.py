"""Lazy vs eager energy roadmaps (docs/design.md §4g, §5f); prints ratios measured in one run.

1. For case1–4, the Panda scenario and an 800-node planar 3-link roadmap (case1's scene
   with ``num_nodes = 798``): the fraction of directed edges simulated, LazySP rounds,
   time to plan (roadmap + search: sampling, neighbours, collision checks, then either
   every edge energy and one MPD* Lite search, or the bounds and the lazy loop), the
   bound's median tightness and violations, and whether the optimum is the eager one
   (same node path and total E⁺ within 1e-9 relative). Targets: equal optimum everywhere;
   ≤ 5 % of the edges simulated and ≥ 3× faster on the 800-node roadmap.
2. The repair after an obstacle appears near the robot on a 10k-node kNN graph (points in
   [0,1]³, k = 10, cost = length × U(1, 2), as bench/search.py): every edge into or out of
   the nodes nearest the path's third node is blocked (≥ 170 directed edges), then
   MPD* Lite repairs — with one batched ``update_edges`` and, for reference, with single
   ``update_edge`` calls — against ``networkx.astar_path`` from scratch with the
   Euclidean heuristic. Target: ≥ 20× faster. Best of ``--repeats``.

Run:  python bench/lazy.py            (about a minute; the eager Panda roadmap dominates)
      python bench/lazy.py --skip-panda --repeats 5
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import networkx as nx
import numpy as np
from scipy.spatial import cKDTree

from common import random_geometric_arrays, summary, target
from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost
from mpd_pin.planning.lazy import LazyEdges, lazy_plan
from mpd_pin.planning.roadmap import build_roadmap
from mpd_pin.search import Graph, MPDStarLite


# ------------------------------------------------------------------ section 1
def scenario(name: str, num_nodes: int | None = None):
    scn = parse_energy_scenario(load_scenario_data(builtin_scenarios()[name]))
    if num_nodes is not None:
        scn = replace(scn, options=replace(scn.options, num_nodes=num_nodes))
    return scn


def eager_run(scn):
    """(seconds, roadmap, path) of an eager plan: build with energies, one search."""
    drive = scn.drive()
    t0 = time.perf_counter()
    cost = EnergyCost(drive, scn.options.dt)
    rm = build_roadmap(cost, CollisionChecker(scn.arm, scn.world), scn.start, scn.goal,
                       scn.options, show_progress=False)
    path = MPDStarLite(rm.graph(), rm.start, rm.goal).plan()
    return time.perf_counter() - t0, rm, path


def lazy_run(scn):
    """(seconds, roadmap, path, LazyEdges) of a lazy plan: build without energies, the
    bounds, the LazySP loop."""
    drive = scn.drive()
    t0 = time.perf_counter()
    cost = EnergyCost(drive, scn.options.dt)
    rm = build_roadmap(cost, CollisionChecker(scn.arm, scn.world), scn.start, scn.goal,
                       scn.options, show_progress=False, evaluate=False)
    lz = LazyEdges(rm, cost, scn.options)
    path, _ = lazy_plan(lz, MPDStarLite)
    return time.perf_counter() - t0, rm, path, lz


def section_roadmaps(skip_panda: bool) -> None:
    print("\n== 1. Lazy vs eager on the built-in scenarios and an 800-node planar roadmap ==")
    cases = [("case1", None), ("case2", None), ("case3", None), ("case4", None)]
    if not skip_panda:
        cases.append(("panda", None))
    cases.append(("case1", 798))
    print(f"{'roadmap':>14} {'nodes':>5} {'edges':>6} | {'simulated':>14} {'rounds':>6} | "
          f"{'eager s':>8} {'lazy s':>7} {'speed-up':>8} | {'bound med':>9} {'viol':>4} | "
          f"{'same optimum':>12}")
    for name, n in cases:
        scn = scenario(name, n)
        te, rme, pe = eager_run(scn)
        tl, rml, pl, lz = lazy_run(scn)
        ee = float(rme.path_energy(pe.nodes).sum())
        el = float(rml.path_energy(pl.nodes).sum())
        rel = abs(el - ee) / ee
        same = pl.nodes == pe.nodes and rel <= 1e-9
        frac = lz.edges_evaluated / rml.num_edges
        rec = lz.record()
        label = name if n is None else f"{name} n={n + 2}"
        print(f"{label:>14} {rml.num_nodes:>5} {rml.num_edges:>6} | "
              f"{lz.edges_evaluated:>5} ({100 * frac:5.2f}%) {rec['rounds']:>6} | "
              f"{te:8.2f} {tl:7.2f} {te / tl:7.1f}x | {rec['bound_median_ratio']:9.3f} "
              f"{rec['bound_violations']:>4} | {'yes' if same else 'NO'} (rel {rel:.0e})")
        target(f"{label}: lazy optimum == eager optimum (path, E+ within 1e-9)", same,
               f"{len(pl.nodes)} nodes, {el:.6g} J vs {ee:.6g} J")
        if n is not None:
            target(f"{label}: <= 5 % of the edges simulated", frac <= 0.05,
                   f"{lz.edges_evaluated} of {rml.num_edges} = {100 * frac:.2f} %")
            target(f"{label}: time to plan >= 3x faster than eager", te / tl >= 3.0,
                   f"{tl:.2f} s vs {te:.2f} s = {te / tl:.1f}x")
            t = rml.timings
            print(f"   lazy {label}: sampling {t['sampling']:.3f} s, neighbours "
                  f"{t['neighbours']:.3f} s, collision checks {t['edge_checks']:.3f} s, "
                  f"bounds {lz.bound_seconds:.3f} s, simulation "
                  f"{lz.count.simulate_seconds:.3f} s; eager edge energies "
                  f"{rme.timings['edge_energies']:.2f} s")


# ------------------------------------------------------------------ section 2
def obstacle_near(g: Graph, pts: np.ndarray, node: int, protect: set[int], want: int):
    """Directed edges into/out of the nodes nearest ``node``'s point, ≥ ``want`` of them."""
    order = cKDTree(pts).query(pts[node], k=60)[1]
    edges: list[tuple[int, int]] = []
    for m in order.tolist():
        if m in protect:
            continue
        edges += [(int(u), m) for u in g.predecessors(m)]
        edges += [(m, int(v)) for v in g.successors(m)]
        if len(set(edges)) >= want:
            break
    return sorted(set(edges))


def _repair_times(g0, pts, s, t, blocked, repeats):
    """Best-of times (s) of the batched and the single-call repair, and networkx's."""
    U = np.array([u for u, _ in blocked])
    V = np.array([v for _, v in blocked])
    C = np.full(U.size, math.inf)
    times, out = {}, {}
    for mode in ("update_edges", "update_edge"):
        best = math.inf
        for _ in range(repeats):
            p = MPDStarLite(g0.copy(), s, t)
            p.plan()
            t0 = time.perf_counter()
            if mode == "update_edges":
                p.update_edges((U, V, C))
            else:
                for u, v in blocked:
                    p.update_edge(u, v, math.inf)
            path = p.plan()
            best = min(best, time.perf_counter() - t0)
        times[mode], out[mode] = best, (path.cost, p.last_stats.expansions)
    G = nx.DiGraph()
    ss, dd, cc = g0.to_arrays()
    G.add_weighted_edges_from(zip(ss.tolist(), dd.tolist(), cc.tolist(), strict=True))
    G.remove_edges_from(blocked)
    P = pts.tolist()

    def h(a, b):
        return math.dist(P[a], P[b])

    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        ref = nx.astar_path(G, s, t, heuristic=h)
        best = min(best, time.perf_counter() - t0)
    ref_cost = nx.path_weight(G, ref, "weight")
    for mode, (cost, _) in out.items():
        assert abs(cost - ref_cost) <= 1e-12 * ref_cost, (mode, cost, ref_cost)
    return times, best, out["update_edges"][1]


def section_repair(repeats: int) -> None:
    print("\n== 2. Repair after an obstacle appears near the robot (10k-node kNN graph) ==")
    n = 10_000
    pts, src, dst, cost = random_geometric_arrays(n, 10, seed=1)
    g0 = Graph.from_arrays(n, src, dst, cost)
    s, t = int(np.argmin(pts.sum(1))), int(np.argmax(pts.sum(1)))
    first = MPDStarLite(g0.copy(), s, t).plan().nodes
    print(f"   obstacle around path node k (k = 2..6 from the robot), >= 170 directed edges "
          f"blocked; best of {repeats}; costs asserted equal to networkx's")
    print(f"   {'k':>2} {'blocked':>7} {'expanded':>8} | {'update_edges':>12} "
          f"{'update_edge':>11} | {'nx.astar eucl':>13} | {'speed-up':>8}")
    ups = []
    for k in range(2, 7):
        blocked = obstacle_near(g0, pts, first[k], {s, t}, want=170)
        times, nx_t, exp = _repair_times(g0, pts, s, t, blocked, repeats)
        up = nx_t / times["update_edges"]
        ups.append(up)
        print(f"   {k:>2} {len(blocked):>7} {exp:>8} | {times['update_edges'] * 1e3:9.3f} ms "
              f"{times['update_edge'] * 1e3:8.3f} ms | {nx_t * 1e3:10.2f} ms | {up:7.1f}x")
    med = float(np.median(ups))
    target("repair near the robot >= 20x faster than networkx.astar_path (Euclidean), median",
           med >= 20.0, f"median {med:.1f}x, min {min(ups):.1f}x over 5 placements")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5, help="best of this many (section 2)")
    ap.add_argument("--skip-panda", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    section_roadmaps(args.skip_panda)
    section_repair(args.repeats)
    summary(t0)


if __name__ == "__main__":
    main()
