"""The cycle time is the input (issue 32; docs/design.md §9c): mpd_pin held to a duration D
against OMPL's path priced at the same D. Prints the numbers of one run.

For each query — random collision-free start/goal pairs whose straight joint-space segment
collides (``bench/ompl_peer.py``), on the built-in Panda scene and the UR5 scene (``sized``
motors) — it plans OMPL 2.0 RRTConnect (0.1 s) + shortcut with mpd_pin's collision checker
and prices its waypoints non-stop (``trajectory_energy(..., "nonstop")``): T₀, the fastest
feasible non-stop duration of OMPL's path (the fastest uniform stretch of its spline within
the velocity, effort and arrival limits). Then at D = f·T₀, f ∈ {1.25, 1.5, 2, 3}:

* OMPL: its waypoints priced by ``trajectory_energy(auto, max_duration=D)`` (the cheaper
  feasible of stop-and-go and non-stop within D);
* mpd_pin: the run's motion (roadmap, MPD* Lite, the shortest path, candidates refined,
  priced and optimised, as ``mpd-pin run`` does) with ``[motion] max_duration = D``. A
  refusal is a run with no motion within D (exit 3 of ``mpd-pin run``).

It also prints, per query, the fastest durations: T₀ and the TOPP-RA time-optimal duration
along the same spline (``mpd_pin.motion.topp``, a lower bound for any time law along that
geometry), and mpd_pin's uncapped motion with its ``motion.fastest_duration`` and TOPP-RA's.

Targets (issue 32): no refusal at any D that OMPL's path meets; a median of ≥ 30 % less
energy than OMPL's path at the same D, at every f.

Run:  pip install -e ".[bench]" && python bench/cycle_time.py [--panda 4] [--ur5 3] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from common import summary, target
from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.motion_step import make_motion
from mpd_pin.app.plan import plan_path, plan_shortest, prepare
from mpd_pin.dynamics.sizing import sized_motors
from mpd_pin.errors import NoPathError
from mpd_pin.motion import trajectory_energy
from mpd_pin.motion.screen import joint_limits
from mpd_pin.motion.spline import unit_knots, via_spline
from mpd_pin.motion.topp import time_optimal_duration

FACTORS = (1.25, 1.5, 2.0, 3.0)


def mpd_side(scn, start, goal):
    """The roadmap, MPD* Lite plan and shortest path of one query, made once (as
    :func:`peers.mpd_side` makes them), and a function D ↦ (the run's ``RunMotion`` with
    ``[motion] max_duration = D`` (None: uncapped), or None when it raised; CPU s)."""
    scn = replace(scn, start=np.asarray(start, float), goal=np.asarray(goal, float))
    setup = prepare(scn, show_progress=False)
    plan = plan_path(scn, setup)
    short = plan_shortest(scn, setup)

    def motion(D):
        capped = replace(scn, motion=replace(scn.motion, max_duration=D))
        c0 = time.process_time()
        try:
            got = make_motion(capped, setup, plan, None, short)
        except (ConfigError, ValueError) as exc:
            print(f"     mpd_pin at D = {D}: {type(exc).__name__}: {exc}")
            got = None
        return got, time.process_time() - c0

    return setup, motion


def _topp(drive, motion, options) -> float | None:
    """TOPP-RA's time-optimal duration along the geometry of a non-stop motion (its
    optimised curve, or the splines of its pieces between stops, summed); None for a
    stop-and-go motion or when TOPP-RA finds none."""
    if motion.execution != "nonstop":
        return None
    if motion.curve is not None:
        return time_optimal_duration(drive, motion.curve, options)
    vlim, _ = joint_limits(drive)
    total = 0.0
    for i, j in motion.pieces:
        W = motion.waypoints[i : j + 1]
        t = time_optimal_duration(drive, via_spline(W, unit_knots(W, vlim)), options)
        if t is None:
            return None
        total += t
    return total


def _fmt(m) -> str:
    if m is None or not m.feasible:
        return f"{'refused' if m is None else 'infeasible':>24}"
    ex = "non" if m.execution == "nonstop" else m.execution
    return f"{m.total_energy:7.2f} J {ex:>4} {m.duration:5.2f} s"


def run(name: str, n: int, seed: int) -> list[dict]:
    from ompl_peer import ompl_waypoints, random_queries

    scn = load_scenario(name)
    scn = replace(scn, motor=sized_motors(scn.arm))
    rows = []
    print(f"\n{name}: {n} queries (sized motors), D = f × T₀ (T₀: OMPL's path, fastest "
          "non-stop)")
    for q, (start, goal) in enumerate(random_queries(scn, n, seed)):
        t0 = time.perf_counter()
        try:
            setup, motion = mpd_side(scn, start, goal)
        except NoPathError as exc:
            print(f"{q:2d} | mpd_pin: no path ({exc})")
            continue
        drive, checker = setup.drive, setup.checker
        peer = ompl_waypoints(scn, start, goal, seed=seed + q, checker=checker)
        if not peer["solved"]:
            print(f"{q:2d} | OMPL: not solved")
            continue
        W = peer["waypoints"]
        non = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
        T0 = float(non.fastest)
        topp0 = _topp(drive, non, scn.options)
        Ds = [f * T0 for f in FACTORS]
        mine = {D: motion(D) for D in (None, *Ds)}
        free, _ = mine[None]
        fm = free.energy if free is not None else None
        topp1 = _topp(drive, fm, scn.options) if fm is not None else None
        print(f"{q:2d} | OMPL: {len(W)} waypoints, T₀ = {T0:.3f} s (velocity bound "
              f"{non.velocity_fastest:.3f} s, TOPP-RA {topp0 or float('nan'):.3f} s), "
              f"{len(non.pieces)} piece(s)")
        if fm is not None:
            src = free.refined.candidate if free.refined else "roadmap path"
            print(f"   | mpd_pin uncapped: {_fmt(fm)}, fastest {free.fastest_duration:.3f} s "
                  f"(velocity bound {fm.velocity_fastest:.3f} s, TOPP-RA "
                  f"{topp1 or float('nan'):.3f} s), from the {src}")
        print(f"   | {'f':>4} {'D s':>6} | {'OMPL at D':>24} | {'mpd_pin at D':>24} | "
              f"{'less':>6} | mpd fastest  CPU s")
        for f, D in zip(FACTORS, Ds, strict=True):
            peer_m = trajectory_energy(drive, W, "auto", options=scn.options, checker=checker,
                                       max_duration=D)
            got, cpu = mine[D]
            refused = got is None or bool(got.failure)
            mm = None if refused else got.energy
            saved = (100 * (1 - mm.total_energy / peer_m.total_energy)
                     if mm is not None and peer_m.feasible else float("nan"))
            fastest = got.fastest_duration if got is not None else float("nan")
            why = f"  refused: {got.failure}" if got is not None and got.failure else ""
            print(f"   | {f:4.2f} {D:6.3f} | {_fmt(peer_m if peer_m.feasible else None)} | "
                  f"{_fmt(mm)} | {saved:5.1f}% | {fastest:7.3f}  {cpu:6.2f}{why}")
            rows.append({"arm": name, "query": q, "f": f, "D": D,
                         "ompl_feasible": bool(peer_m.feasible),
                         "ompl": peer_m.total_energy if peer_m.feasible else float("nan"),
                         "refused": refused, "mpd": mm.total_energy if mm else float("nan"),
                         "mpd_duration": mm.duration if mm else float("nan"),
                         "saved": saved, "T0": T0, "topp_ompl": topp0,
                         "mpd_fastest": fastest, "cpu": cpu})
        print(f"   | ({time.perf_counter() - t0:.1f} s wall for the query)")
    return rows


def report(rows: list[dict], label: str) -> None:
    if not rows:
        return
    print(f"\n{label}:")
    bad = [r for r in rows if r["ompl_feasible"] and r["refused"]]
    refused = sum(r["refused"] for r in rows)
    target("no refusal at any D OMPL's path meets", not bad,
           f"{len(bad)} of {sum(r['ompl_feasible'] for r in rows)} (q, D) refused; "
           f"{refused} refusals in all")
    ok = True
    parts = []
    for f in FACTORS:
        s = [r["saved"] for r in rows if r["f"] == f and np.isfinite(r["saved"])]
        med = float(np.median(s)) if s else float("nan")
        ok &= bool(s) and med >= 30.0
        parts.append(f"f={f:g}: {med:.1f} % (n={len(s)}, {min(s, default=np.nan):.1f}–"
                     f"{max(s, default=np.nan):.1f})")
    target("median ≥ 30 % less energy than OMPL's path at the same D, at every f", ok,
           "; ".join(parts))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panda", type=int, default=4)
    ap.add_argument("--ur5", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows = run("panda", args.panda, args.seed) if args.panda else []
    rows_u = run("ur5", args.ur5, args.seed) if args.ur5 else []
    report(rows, "panda")
    report(rows_u, "ur5")
    if rows and rows_u:
        report(rows + rows_u, "all queries")
    summary(t0)


if __name__ == "__main__":
    main()
