"""A Panda query in a second (issue 34, item 7; docs/design.md §7c): CPU per phase of a first
query and of a later query on the same planner, against OMPL RRTConnect + shortcut on the
same queries. Prints the numbers of one run.

Queries: random collision-free start/goal pairs whose straight joint-space segment collides
(``bench/ompl_peer.py``), on the built-in Panda scene with ``sized`` motors and the
scenario's 150-node roadmap. For query k, a fresh :class:`mpd_pin.EnergyPlanner` plans it
(the **first query**: the roadmap is built around it), then the same planner plans query
k + 1 (a **later query**: the roadmap, its collision checks and simulated energies reused,
docs/design.md §4i). CPU is ``time.process_time`` of this process (all threads) around
``planner.plan``, and per phase from the plan's ``cpu_seconds_per_phase``. OMPL: the
CPU of ``ompl_waypoints`` (RRTConnect 0.1 s cap + reduceVertices + partialShortcutPath,
with mpd_pin's collision checker), which is what a user would run instead; pricing OMPL's
path is not counted. The verify step is off, as in a run by default (``[run] verify``).

Targets (issue 34): first query median ≤ 1.0 CPU-s, including the trajectory
optimisation; a later query ≤ 0.5 CPU-s; mpd_pin / OMPL ≤ 10×.

Run:  pip install -e ".[bench]" && python bench/query_speed.py [--queries 10] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from common import summary, target
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.planner import EnergyPlanner
from mpd_pin.dynamics.sizing import sized_motors
from mpd_pin.errors import NoMotionWithinDuration, NoPathError

PHASES = ("roadmap", "search", "verification", "comparison", "refinement")
FIRST_TARGET, LATER_TARGET, RATIO_TARGET = 1.0, 0.5, 10.0


def _plan(planner: EnergyPlanner, start, goal) -> tuple[float, dict | None, str]:
    """(CPU s, cpu_seconds_per_phase or None, outcome) of one query."""
    c0 = time.process_time()
    try:
        plan = planner.plan(start, goal)
        outcome = f"{plan.total_energy:7.2f} J"
    except NoPathError:
        return time.process_time() - c0, None, "no path"
    except NoMotionWithinDuration as exc:
        plan, outcome = exc.plan, "no motion"
    cpu = time.process_time() - c0
    return cpu, plan.to_dict()["cpu_seconds_per_phase"], outcome


def _row(label: str, cpu: float, phases: dict | None, outcome: str) -> str:
    parts = " ".join(f"{(phases or {}).get(p, float('nan')):6.2f}" for p in PHASES)
    return f"{label:>8} {cpu:7.2f} | {parts} | {outcome}"


def main() -> None:
    from ompl_peer import ompl_waypoints, random_queries

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--queries", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    scn = load_scenario("panda")
    scn = replace(scn, motor=sized_motors(scn.arm))
    queries = random_queries(scn, args.queries + 1, args.seed)
    print(f"panda: {args.queries} queries (sized motors, {scn.options.num_nodes} roadmap "
          f"nodes), CPU s")
    print(f"{'query':>8} {'total':>7} | " + " ".join(f"{p[:6]:>6}" for p in PHASES)
          + " | energy")
    first, later, ompl, ratios = [], [], [], []
    for k in range(args.queries):
        planner = EnergyPlanner.from_scenario(scn, show_progress=False)
        cpu1, ph1, out1 = _plan(planner, *queries[k])
        cpu2, ph2, out2 = _plan(planner, *queries[k + 1])
        c0 = time.process_time()
        peer = ompl_waypoints(scn, *queries[k], seed=args.seed + k)
        c_ompl = time.process_time() - c0
        print(_row(f"{k} first", cpu1, ph1, out1))
        print(_row(f"{k} later", cpu2, ph2, out2))
        print(f"{'':>8} OMPL RRTConnect + shortcut: {c_ompl:.3f} CPU s "
              f"({'solved' if peer['solved'] else 'not solved'}); mpd_pin / OMPL "
              f"{cpu1 / max(c_ompl, 1e-9):5.1f}×")
        if ph1 is not None:
            first.append(cpu1)
            if peer["solved"]:
                ompl.append(c_ompl)
                ratios.append(cpu1 / max(c_ompl, 1e-9))
        if ph2 is not None:
            later.append(cpu2)
    print()
    med = float(np.median(first)) if first else float("nan")
    target(f"first Panda query, median ≤ {FIRST_TARGET:g} CPU s", med <= FIRST_TARGET,
           f"median {med:.2f} s, max {max(first, default=float('nan')):.2f} s over "
           f"{len(first)} queries")
    med2 = float(np.median(later)) if later else float("nan")
    target(f"later query on the same planner, median ≤ {LATER_TARGET:g} CPU s",
           med2 <= LATER_TARGET, f"median {med2:.2f} s, max "
           f"{max(later, default=float('nan')):.2f} s")
    r = float(np.median(ratios)) if ratios else float("nan")
    target(f"against OMPL RRTConnect + shortcut, median ratio ≤ {RATIO_TARGET:g}×",
           r <= RATIO_TARGET, f"median {r:.1f}×, OMPL median "
           f"{float(np.median(ompl)) if ompl else float('nan'):.3f} CPU s")
    summary(t0)


if __name__ == "__main__":
    main()
