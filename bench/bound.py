"""The lazy planner's lower bound of E⁺ (docs/design.md §4g), ``per_joint`` vs ``sum`` mode.

1. Tightness on real roadmap edges: for each scenario, ``--edges`` directed edges of its
   lazy roadmap drawn at random (seed 0), simulated (``edge_outcomes``), the feasible ones
   kept; per mode: median and 5 % quantile of bound / true E⁺, the share of bounds under
   1 mJ, the largest ratio and the violations (bound > true). Scenarios: quickstart, ur5
   and the Panda scenario with ``sized`` motors (``panda-sized``), the recommended motors;
   the Panda as shipped (a servo that saturates on some edges) and the paper's case1–4.
   Target: median ≥ 0.5 on the sized motors, no violation.
2. The lazy loop per mode against the eager optimum (every edge simulated once, MPD* Lite
   on the feasible ones): simulated edges, LazySP rounds, seconds of the bounds and of the
   loop (simulation included), the eager simulation time, the same node path and E⁺.
   ``--large N`` adds case1's scene with N nodes, lazy only (no eager reference: the two
   modes must agree).

Run:  python bench/bound.py                   (a few minutes on 2 shared cores)
      python bench/bound.py --edges 100 --skip-panda --large 10000
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

import mpd_pin as mp
from common import summary, target
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.plan import prepare
from mpd_pin.dynamics.bound import EnergyBound
from mpd_pin.dynamics.simulate import edge_outcomes
from mpd_pin.planning.lazy import LazyEdges, evaluate_edges, lazy_plan
from mpd_pin.planning.roadmap import feasibility
from mpd_pin.search import Graph, MPDStarLite

SIZED = ("quickstart", "ur5", "panda-sized")


def scenario(name: str, num_nodes: int | None = None):
    """A built-in scenario; ``panda-sized``: the Panda scenario with ``sized`` motors."""
    scn = load_scenario("panda" if name == "panda-sized" else name)
    if name == "panda-sized":
        scn = replace(scn, motor=mp.sized_motors(scn.arm))
    if num_nodes is not None:
        scn = replace(scn, options=replace(scn.options, num_nodes=num_nodes))
    # every edge collision-checked first: the eager reference simulates every edge
    return replace(scn, evaluation="lazy", collision="eager")


def bounds(drive, opts) -> dict[str, EnergyBound]:
    tol = opts.arrival_tolerance
    return {mode: EnergyBound(drive, arrival_tolerance=tol, mode=mode)
            for mode in ("per_joint", "sum")}


# ------------------------------------------------------------------ section 1
def section_tightness(names: list[str], edges: int) -> None:
    print(f"\n== 1. bound / true E+ on {edges} random edges of each lazy roadmap ==")
    print(f"{'scenario':>12} {'mode':>9} {'edges':>5} | {'median':>6} {'p05':>6} {'max':>6} "
          f"{'<1 mJ':>6} {'viol':>4}")
    for name in names:
        scn = scenario(name)
        setup = prepare(scn, show_progress=False)
        rm, lz, drive = setup.roadmap, setup.lazy, setup.drive
        rng = np.random.default_rng(0)
        ids = rng.choice(rm.num_edges, size=min(edges, rm.num_edges), replace=False)
        Q0, Q1, T = rm.nodes[rm.src[ids]], lz._Q1[ids], rm.durations[ids]
        out = edge_outcomes(drive, Q0, Q1, T, scn.options.dt)
        over, missed = feasibility(out, scn.options, drive.arm.model)
        ok = ~(over | missed)
        true = out.energy[ok].sum(axis=1)
        for mode, b in bounds(drive, scn.options).items():
            lb = b(Q0[ok], Q1[ok], T[ok])
            r = lb / true
            print(f"{name:>12} {mode:>9} {ok.sum():>5} | {np.median(r):6.3f} "
                  f"{np.quantile(r, 0.05):6.3f} {r.max():6.4f} {np.mean(lb < 1e-3):6.2f} "
                  f"{int((lb > true).sum()):>4}")
            if mode == "per_joint":
                target(f"{name}: no violation", not (lb > true).any(), f"max {r.max():.4f}")
                if name in SIZED:
                    target(f"{name}: median bound/true >= 0.5", np.median(r) >= 0.5,
                           f"{np.median(r):.3f}")


# ------------------------------------------------------------------ section 2
def _fresh(rm):
    """A copy of a lazy roadmap with nothing evaluated."""
    copy = rm.without_edges(np.zeros(rm.num_edges, dtype=bool))
    copy.energy[:] = np.nan
    return copy


def section_lazy(names: list[str], large: int | None) -> None:
    print("\n== 2. the lazy loop per mode vs the eager optimum ==")
    print(f"{'scenario':>16} {'edges':>6} {'mode':>9} | {'simulated':>9} {'rounds':>6} "
          f"{'bound s':>7} {'loop s':>7} | {'eager s':>7} | {'median':>6} {'viol':>4} | same")
    runs = [(n, None) for n in names] + ([("case1", large)] if large else [])
    for name, n in runs:
        scn = scenario(name, n)
        setup = prepare(scn, show_progress=False)
        base, cost, opts = setup.roadmap, setup.cost, scn.options
        ref = None
        eager_s = float("nan")
        if n is None:  # the eager optimum: every edge simulated, MPD* Lite on the feasible
            full = _fresh(base)
            t0 = time.perf_counter()
            refused = evaluate_edges(cost, full, np.arange(full.num_edges), opts)
            ok = ~refused
            g = Graph.from_arrays(full.num_nodes, full.src[ok], full.dst[ok],
                                  full.energy[ok].sum(axis=1))
            path = MPDStarLite(g, full.start, full.goal).plan()
            eager_s = time.perf_counter() - t0
            ref = (path.nodes, float(full.path_energy(path.nodes).sum()))
        label = name if n is None else f"{name} n={n}"
        found = {}
        for mode, b in bounds(setup.drive, opts).items():
            rm = _fresh(base)
            t0 = time.perf_counter()
            lz = LazyEdges(rm, cost, opts, bound=b)
            t1 = time.perf_counter()
            path, _ = lazy_plan(lz, MPDStarLite)
            t2 = time.perf_counter()
            rec = lz.record()
            energy = float(rm.path_energy(path.nodes).sum())
            found[mode] = (path.nodes, energy)
            same = "-" if ref is None else (
                "yes" if path.nodes == ref[0] and abs(energy - ref[1]) <= 1e-9 * ref[1]
                else f"NO ({energy:.6g} vs {ref[1]:.6g} J)")
            print(f"{label:>16} {rm.num_edges:>6} {mode:>9} | {lz.edges_evaluated:>9} "
                  f"{rec['rounds']:>6} {t1 - t0:7.2f} {t2 - t1:7.2f} | {eager_s:7.2f} | "
                  f"{rec['bound_median_ratio']:6.3f} {rec['bound_violations']:>4} | {same}")
            if ref is not None:
                target(f"{label} {mode}: lazy optimum == eager optimum", same == "yes",
                       f"{energy:.6g} J")
        if ref is None:  # no eager reference: the two modes against each other
            (pa, ea), (pb, eb) = found["per_joint"], found["sum"]
            target(f"{label}: the same path and E+ with both modes",
                   pa == pb and abs(ea - eb) <= 1e-9 * eb, f"{ea:.6g} J vs {eb:.6g} J")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--edges", type=int, default=200, help="edges per roadmap (section 1)")
    ap.add_argument("--skip-panda", action="store_true", help="leave out panda, panda-sized")
    ap.add_argument("--large", type=int, default=None,
                    help="also case1's scene with this many nodes, lazy only (section 2)")
    args = ap.parse_args()
    names = ["quickstart", "ur5", "panda-sized", "panda", "case1", "case2", "case3", "case4"]
    if args.skip_panda:
        names = [n for n in names if not n.startswith("panda")]
    t0 = time.perf_counter()
    section_tightness(names, args.edges)
    section_lazy([n for n in names if n in (*SIZED, "case1")], args.large)
    summary(t0)


if __name__ == "__main__":
    main()
