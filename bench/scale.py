"""Large roadmaps on the Panda scene (issue "scale"; docs/design.md §4g); one run, printed.

For 300, 1k, 3k and 10k sampled nodes on the built-in Panda scene with ``sized`` motors
and lazy energies: CPU seconds of every phase of roadmap + search (sampling, neighbours,
edge checks, bounds, the lazy loop), the edges checked and simulated, the rounds, and the
optimum — with lazy collision checks (the default) and, up to ``--eager-max`` nodes, with
every edge checked first. Targets: the 10k roadmap + search in ≤ 10 CPU-s; the lazy
optimum equal to the eager one.

Run:  python bench/scale.py                 (a few minutes)
      python bench/scale.py --nodes 300 1000 --eager-max 1000
"""

from __future__ import annotations

import argparse
import time

import mpd_pin as mp
from mpd_pin.app.plan import plan_path, prepare
from mpd_pin.app.planner import configure

TARGET_CPU = 10.0  # CPU-s for roadmap + search at 10k nodes


def panda(nodes: int, collision: str):
    scn = mp.load_scenario("panda")
    from dataclasses import replace

    scn = replace(scn, motor=mp.sized_motors(scn.arm))
    return configure(scn, num_nodes=nodes, collision=collision, evaluation="lazy")


def run(nodes: int, collision: str) -> dict:
    scn = panda(nodes, collision)
    c0, w0 = time.process_time(), time.perf_counter()
    setup = prepare(scn, show_progress=False)
    c1 = time.process_time()
    result = plan_path(scn, setup)
    c2, w2 = time.process_time(), time.perf_counter()
    lz, rm = setup.lazy, setup.roadmap
    pairs = rm.pairs_checked + lz.count.pairs_checked
    return {
        "nodes": rm.num_nodes, "edges": rm.num_edges, "checked": 2 * pairs,
        "simulated": lz.count.simulated, "rounds": lz.count.rounds,
        "roadmap_cpu": c1 - c0, "search_cpu": c2 - c1, "total_cpu": c2 - c0,
        "wall": w2 - w0, "timings": dict(rm.timings), "bounds": lz.bound_seconds,
        "simulate": lz.count.simulate_seconds, "check": lz.count.check_seconds,
        "energy": float(result.energy.sum()), "path": list(result.path),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[300, 1000, 3000, 10000])
    ap.add_argument("--eager-max", type=int, default=3000,
                    help="largest roadmap also run with eager collision checks")
    args = ap.parse_args()
    head = (f"{'nodes':>6} {'check':>6} {'edges':>7} {'checked':>8} {'simul.':>6} "
            f"{'rounds':>6} {'sample':>7} {'knn':>6} {'checks':>7} {'bounds':>7} "
            f"{'loop':>7} {'(sim)':>6} {'CPU-s':>7} {'wall':>6} {'E (J)':>9}")
    print(head)
    for n in args.nodes:
        for collision in ("lazy", "eager"):
            if collision == "eager" and n > args.eager_max:
                continue
            r = run(n, collision)
            t = r["timings"]
            checks = t.get("edge_checks", 0.0) + r["check"]
            print(f"{r['nodes']:>6} {collision:>6} {r['edges']:>7} {r['checked']:>8} "
                  f"{r['simulated']:>6} {r['rounds']:>6} {t.get('sampling', 0):7.2f} "
                  f"{t.get('neighbours', 0):6.2f} {checks:7.2f} {r['bounds']:7.2f} "
                  f"{r['search_cpu']:7.2f} {r['simulate']:6.2f} {r['total_cpu']:7.2f} "
                  f"{r['wall']:6.1f} "
                  f"{r['energy']:9.4f}", flush=True)
            if collision == "lazy":
                lazy_r = r
            elif r["energy"] != lazy_r["energy"] or r["path"] != lazy_r["path"]:
                print(f"   MISMATCH: eager checks give {r['energy']} J over {r['path']}, "
                      f"lazy {lazy_r['energy']} J over {lazy_r['path']}")
        if n >= 10000:
            ok = lazy_r["total_cpu"] <= TARGET_CPU
            print(f"   target {'MET' if ok else 'MISSED'}: {n} nodes roadmap + search "
                  f"{lazy_r['total_cpu']:.1f} CPU-s (target <= {TARGET_CPU:g}; ratio "
                  f"{lazy_r['total_cpu'] / TARGET_CPU:.2f})")


if __name__ == "__main__":
    main()
