"""Pick-and-place cycles (issue 33; docs/design.md §8c): one cycle time shared across legs.
Prints the numbers of one run.

The built-in ``pick_place`` scenario: the Panda cell (table, wall, bin; ``sized`` motors),
home → pick → place carrying a 2 kg part → home, dwells of 0.5 s (grasp) and 0.3 s
(release). The legs' fastest motions f_k come from a first ``plan_cycle`` with a long cycle
time; then at cycle_time = 1.5 × (Σ f_k + Σ dwell) it compares

* the allocation: ``EnergyPlanner.plan_cycle(legs, start=, cycle_time=)`` (the dynamic
  programme on each leg's energy–time front, each leg planned within its share);
* an equal split: each leg planned with ``max_duration`` = (cycle_time − Σ dwell)/K;
* a split proportional to the fastest durations: ``max_duration`` = f_k/Σf × (cycle_time −
  Σ dwell);
* OMPL's legs at the allocation's durations: RRTConnect + shortcut (``bench/ompl_peer.py``)
  with the leg's collision checker (the part attached on the carrying leg), its waypoints
  priced by ``trajectory_energy(drive_k, W, "auto", max_duration=T_k)`` with the leg's
  drive (``drive.with_payload(part)`` on the carrying leg), T_k the allocation's share of
  the leg (its cap), and again with T_k the duration of the allocation's leg motion.

Every strategy pays the same dwells (the same poses and payloads), added to its total. It
also prints the CPU seconds per cycle: the allocation's ``plan_cycle`` on a planner whose
roadmap is built (``Cycle.seconds``), and the first one that built it.

Targets (issue 33): the allocation never above the proportional split; below OMPL's legs.

Run:  pip install -e ".[bench]" && python bench/cycle.py [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from common import summary, target
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.planner import EnergyPlanner
from mpd_pin.collision import CollisionChecker
from mpd_pin.errors import NoMotionWithinDuration
from mpd_pin.motion import trajectory_energy


def split_energy(planner, legs, starts, caps) -> tuple[list, float]:
    """Each leg planned with ``max_duration`` = its cap (s): (per leg (energy J, duration s)
    or None when refused, CPU s)."""
    c0 = time.process_time()
    out = []
    for leg, q0, cap in zip(legs, starts, caps, strict=True):
        try:
            p = planner.plan(q0, leg.goal, max_duration=cap, payload=leg.payload)
            out.append((p.total_energy, p.motion.duration))
        except NoMotionWithinDuration as exc:
            print(f"     refused at {cap:.3f} s: {exc}")
            out.append(None)
    return out, time.process_time() - c0


def ompl_legs(scn, legs, starts, caps, seed: int) -> list:
    """OMPL RRTConnect + shortcut per leg, priced at the leg's cap: (energy J, duration s)
    or None (unsolved or infeasible)."""
    from ompl_peer import ompl_waypoints

    out = []
    for k, (leg, q0, cap) in enumerate(zip(legs, starts, caps, strict=True)):
        drive = scn.drive().with_payload(leg.payload)
        checker = CollisionChecker(drive.arm, scn.world)
        peer = ompl_waypoints(scn, q0, leg.goal, seed=seed + k, checker=checker)
        if not peer["solved"]:
            print(f"     OMPL leg {k + 1}: not solved")
            out.append(None)
            continue
        m = trajectory_energy(drive, peer["waypoints"], "auto", options=scn.options,
                              checker=checker, max_duration=cap)
        print(f"     OMPL leg {k + 1}: {len(peer['waypoints'])} waypoints, "
              f"{m.execution} {m.duration:.3f} s, {m.total_energy:.2f} J"
              + ("" if m.feasible else f" (infeasible: {m.reason})"))
        out.append((m.total_energy, m.duration) if m.feasible else None)
    return out


def _total(rows, dwell_energy: float) -> float:
    return math.nan if any(r is None for r in rows) else sum(r[0] for r in rows) + dwell_energy


def _fmt(rows) -> str:
    return ", ".join("refused" if r is None else f"{r[0]:7.2f} J in {r[1]:.3f} s" for r in rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0, help="OMPL's seed")
    ap.add_argument("--factor", type=float, default=1.5,
                    help="cycle_time = factor × (Σ fastest + Σ dwell)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    scn = load_scenario("pick_place")
    legs = list(scn.cycle.legs)
    starts = [scn.start] + [leg.goal for leg in legs[:-1]]
    planner = EnergyPlanner.from_scenario(scn, show_progress=False)
    first = planner.plan_cycle(legs, start=scn.start, cycle_time=3600.0)
    fastest = first.allocation["fastest"]
    dwell = sum(leg.dwell for leg in legs)
    cycle_time = args.factor * (sum(fastest) + dwell)
    print(f"pick_place: {len(legs)} legs, fastest {', '.join(f'{f:.3f}' for f in fastest)} s,"
          f" dwells {dwell:g} s; cycle_time = {args.factor:g} × {sum(fastest) + dwell:.3f} = "
          f"{cycle_time:.3f} s")
    print(f"   first plan_cycle (builds the roadmap; cycle_time 3600 s): "
          f"{first.total_energy:.2f} J, CPU {first.seconds['cpu']:.1f} s")
    cycle = planner.plan_cycle(legs, start=scn.start, cycle_time=cycle_time)
    budget = cycle_time - dwell
    dwell_energy = cycle.dwell_energy
    alloc = [(leg.energy, leg.duration) for leg in cycle.legs]
    caps = [leg.max_duration for leg in cycle.legs]
    dt = scn.options.dt
    equal = [dt * math.floor(budget / len(legs) / dt) for _ in legs]
    prop = [dt * math.floor(f / sum(fastest) * budget / dt) for f in fastest]
    e_rows, e_cpu = split_energy(planner, legs, starts, equal)
    p_rows, p_cpu = split_energy(planner, legs, starts, prop)
    print("   OMPL within the allocation's shares (caps):")
    o_rows = ompl_legs(scn, legs, starts, caps, args.seed)
    durations = [leg.duration for leg in cycle.legs]
    print("   OMPL within the allocation's leg durations:")
    od_rows = ompl_legs(scn, legs, starts, durations, args.seed)
    totals = {"allocation": _total(alloc, dwell_energy), "equal": _total(e_rows, dwell_energy),
              "proportional": _total(p_rows, dwell_energy),
              "OMPL": _total(o_rows, dwell_energy),
              "OMPL (durations)": _total(od_rows, dwell_energy)}
    print(f"\n   dwell energy (every strategy): {dwell_energy:.2f} J")
    print(f"   {'split':<17} {'caps s':<26} {'cycle J':>8} | legs")
    for name, shares, rows in (("allocation", caps, alloc), ("equal", equal, e_rows),
                               ("proportional", prop, p_rows), ("OMPL", caps, o_rows),
                               ("OMPL (durations)", durations, od_rows)):
        print(f"   {name:<17} {', '.join(f'{c:.3f}' for c in shares):<26} "
              f"{totals[name]:8.2f} | {_fmt(rows)}")
    cpu = cycle.seconds["cpu"]
    print(f"\n   CPU per cycle: allocation {cpu:.1f} s ({cycle.seconds['plans']} leg plans, "
          f"roadmap built); equal split {e_cpu:.1f} s, proportional {p_cpu:.1f} s "
          f"({len(legs)} leg plans each)")
    print(f"   the cycle: {cycle.duration:.3f} s of {cycle_time:.3f} s "
          f"({cycle_time - cycle.duration:.3f} s idle)")
    a, p, o = totals["allocation"], totals["proportional"], totals["OMPL"]
    target("allocation never above the proportional split", not (a > p * (1 + 1e-9)),
           f"{a:.2f} J vs {p:.2f} J")
    target("allocation below OMPL's legs at the allocation's durations",
           bool(np.isfinite(o)) and a < o, f"{a:.2f} J vs {o:.2f} J"
           + (f" ({100 * (1 - a / o):.1f} % less)" if np.isfinite(o) else ""))
    summary(t0)


if __name__ == "__main__":
    main()
