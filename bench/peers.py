"""mpd_pin's motion against OMPL RRTConnect + shortcutting, on the same energy model
(docs/design.md §9). Prints ratios measured in one run.

For each query — random collision-free start/goal pairs whose straight joint-space segment
collides (``bench/ompl_peer.py``), on the built-in Panda scene (``sized`` motors) and the
UR5 scene (``sized``) — it runs:

* mpd_pin as ``mpd-pin run`` does: roadmap, MPD* Lite search, the shortest path for the
  comparison, then the motion (candidates shortcut and priced, ``execution = "auto"``);
* OMPL 2.0 RRTConnect (0.1 s) + ``reduceVertices``/``partialShortcutPath``, with mpd_pin's
  collision checker as its validity checker; its waypoints priced by
  ``mpd_pin.trajectory_energy`` stop-and-go and non-stop, with the same roadmap timing
  rule, limits, dt and checker. OMPL's best is the cheaper feasible of the two.

Two policies: (a) each motion within its own timing (non-stop may take as long as the
same waypoints stop-and-go); (b) mpd_pin's motion held to OMPL's stop-and-go duration
(``max_duration``), so it cannot win by moving slower than the peer's stop-and-go motion.
Both durations are printed. Targets (issue "motions"): median ≥ 10 % less energy than
OMPL's best; less than OMPL stop-and-go on every query; plan + refinement ≤ 2× the plan.

Run:  pip install -e ".[bench]" && python bench/peers.py [--panda 5] [--ur5 3] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.motion_step import make_motion
from mpd_pin.app.plan import plan_path, plan_shortest, prepare
from mpd_pin.app.verify import verify_path
from mpd_pin.dynamics.sizing import sized_motors
from mpd_pin.errors import NoPathError
from mpd_pin.motion import trajectory_energy


def mpd_side(scn, start, goal, max_duration=None):
    """mpd_pin's motion for one query: (motion, plan CPU s, refinement CPU s, roadmap E⁺)."""
    scn = replace(scn, start=np.asarray(start, float), goal=np.asarray(goal, float))
    if max_duration is not None:
        scn = replace(scn, motion=replace(scn.motion, max_duration=float(max_duration)))
    c0 = time.process_time()
    setup = prepare(scn, show_progress=False)
    plan = plan_path(scn, setup)
    short = plan_shortest(scn, setup)
    c1 = time.process_time()
    check = verify_path(setup.drive, setup.roadmap, plan.path, scn.options.dt, plan.energy) \
        if not scn.motion.refine else None
    motion = make_motion(scn, setup, plan, check, short)
    c2 = time.process_time()
    return motion, setup, c1 - c0, c2 - c1, float(plan.energy.sum())


def _fmt(m) -> str:
    if m is None or not m.feasible:
        return "   infeasible     "
    return f"{m.total_energy:7.2f} J {m.duration:5.2f} s"


def run(name: str, n: int, seed: int) -> list[dict]:
    from ompl_peer import ompl_waypoints, random_queries

    scn = load_scenario(name)
    scn = replace(scn, motor=sized_motors(scn.arm))
    rows = []
    print(f"\n{name}: {n} queries (sized motors)")
    print(f"{'q':>2} | {'roadmap':>9} | {'mpd_pin motion':>26} | {'OMPL stop':>17} | "
          f"{'OMPL nonstop':>17} | {'vs best':>7} {'vs stop':>7} | {'(b) held':>17} "
          f"{'vs best':>7} | plan s  refine s  OMPL s")
    for q, (start, goal) in enumerate(random_queries(scn, n, seed)):
        try:
            motion, setup, t_plan, t_ref, e_road = mpd_side(scn, start, goal)
        except NoPathError as exc:
            print(f"{q:2d} | mpd_pin: no path ({exc})")
            continue
        peer = ompl_waypoints(scn, start, goal, seed=seed + q, checker=setup.checker)
        if not peer["solved"]:
            print(f"{q:2d} | OMPL: not solved")
            continue
        W = peer["waypoints"]
        stop = trajectory_energy(setup.drive, W, "stop", options=scn.options,
                                 checker=setup.checker)
        non = trajectory_energy(setup.drive, W, "nonstop", options=scn.options,
                                checker=setup.checker)
        best = min((m for m in (stop, non) if m.feasible), key=lambda m: m.total_energy,
                   default=None)
        me = motion.energy
        try:
            held, _, _, _, _ = mpd_side(scn, start, goal, max_duration=stop.duration)
            hm = held.energy
        except ConfigError:  # no motion of mpd_pin's fits in OMPL's stop-and-go duration
            hm = None
        ref = best.total_energy if best is not None else float("nan")
        row = {
            "query": q, "roadmap": e_road, "motion": me.total_energy,
            "motion_execution": me.execution, "motion_duration": me.duration,
            "ompl_stop": stop.total_energy if stop.feasible else float("nan"),
            "ompl_stop_duration": stop.duration, "ompl_best": ref,
            "ompl_nonstop": non.total_energy if non.feasible else float("nan"),
            "held": hm.total_energy if hm else float("nan"),
            "held_duration": hm.duration if hm else float("nan"),
            "plan_cpu": t_plan, "refine_cpu": t_ref, "ompl_seconds": peer["plan_seconds"],
            "ompl_certified": bool(all(peer["certified"])),
        }
        row["saved_vs_best"] = 100 * (1 - me.total_energy / ref)
        row["saved_vs_stop"] = 100 * (1 - me.total_energy / row["ompl_stop"])
        row["held_saved_vs_best"] = 100 * (1 - row["held"] / ref)
        rows.append(row)
        cert = "" if row["ompl_certified"] else "  (OMPL path not certified free)"
        print(f"{q:2d} | {e_road:7.2f} J | {me.execution:>7} {_fmt(me)} | {_fmt(stop)} | "
              f"{_fmt(non)} | {row['saved_vs_best']:6.1f}% {row['saved_vs_stop']:6.1f}% | "
              f"{_fmt(hm)} {row['held_saved_vs_best']:6.1f}% | {t_plan:6.2f}  {t_ref:7.2f}  "
              f"{peer['plan_seconds']:6.3f}{cert}")
    return rows


def summary(rows: list[dict]) -> None:
    if not rows:
        return
    med = np.median([r["saved_vs_best"] for r in rows])
    held_rows = [r["held_saved_vs_best"] for r in rows if np.isfinite(r["held"])]
    held = np.median(held_rows) if held_rows else float("nan")
    wins_stop = sum(r["saved_vs_stop"] > 0 for r in rows)
    ratio = np.median([(r["plan_cpu"] + r["refine_cpu"]) / r["plan_cpu"] for r in rows])
    print(f"\nmedian energy saved against OMPL's best execution: {med:.1f} % (target ≥ 10 %)")
    print(f"  held to OMPL's stop-and-go duration: {held:.1f} % on the {len(held_rows)} "
          "queries where a motion fits in it")
    print(f"less than OMPL stop-and-go on {wins_stop} of {len(rows)} queries (target: all)")
    print(f"(plan + refinement) / plan, CPU, median: {ratio:.2f} (target ≤ 2)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panda", type=int, default=5)
    ap.add_argument("--ur5", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rows = run("panda", args.panda, args.seed) if args.panda else []
    summary(rows)
    rows_u = run("ur5", args.ur5, args.seed) if args.ur5 else []
    summary(rows_u)
    if rows and rows_u:
        print("\nall queries:")
        summary(rows + rows_u)


if __name__ == "__main__":
    main()
