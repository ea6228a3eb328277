"""What the trajectory optimisation at a fixed duration buys (docs/design.md §9g), against
OMPL RRTConnect + shortcutting priced and optimised the same way. Prints one run's numbers.

Queries: random collision-free start/goal pairs whose straight joint-space segment collides
(``bench/ompl_peer.py``'s ``random_queries``), on the built-in Panda scene and the UR5 scene,
both with ``sized`` motors (as ``bench/peers.py``). For each query it runs:

1. mpd_pin as ``mpd-pin run`` does (roadmap, MPD* Lite, the shortest path for the
   comparison, then the motion), once with ``MotionOptions(optimize=False)`` (the refined
   candidates only, the previous behaviour) and once with the default (the best candidates
   optimised as a whole at their duration); the same roadmap and paths feed both. Printed:
   energy (J), duration (s) and execution of each, the optimisation's CPU seconds (the sum
   of ``RefinedMotion.optimization``: every seed run and the polish solve) and the % less
   energy.
2. The expert's pipeline: OMPL 2.0 RRTConnect (0.1 s) + ``reduceVertices`` /
   ``partialShortcutPath`` (mpd_pin's checker as validity checker), its waypoints run
   through ``mp.optimize_motion`` at T, the duration of mpd_pin's optimised motion; and the
   same waypoints priced by ``trajectory_energy`` stop-and-go and non-stop with
   ``max_duration = T``, OMPL's best being the cheaper feasible of the two. mpd_pin's
   optimised motion against both (% less energy; negative: mpd_pin costs more).
3. A restart check: ``optimize_curve`` seeded with mpd_pin's returned optimised motion
   (``seed_curve(drive, motion)``, same duration, ``seed_motion=motion``) and how much less
   it still finds (≈ 0 % when the optimisation stopped at a local optimum). This is a
   restart of the same optimiser (same objective, constraints and solver), not an
   independent one: it cannot reveal an optimum the method itself cannot reach. The
   restart chooses its number of control points from the seed's breakpoints (an optimised
   curve of n_c points has n_c − 6 interior ones), so it may solve with more than the
   first solve had (column ``n_c``: first → restart); column ``same n_c`` is the same
   restart held to the first solve's n_c (information only; the targets use the former).

4. An independent optimisation seeded with the returned motion at its duration
   (``independent``: scipy trust-constr on a spline of 8 more control points per joint,
   checked at 4,000 samples and simulated): how much less it finds (0 when nothing better).

5. The issue's own peer: OMPL's path (the non-stop spline through its waypoints) through
   that same independent optimisation at T, on as many control points as the check of 4
   (``OMPL + independent optimisation``), and mpd_pin's motion against it.

Targets (issue 31): the optimisation ≤ 1 CPU-s per Panda query (median); median ≥ 40 %
less energy than OMPL's best at equal duration; never more than 3 % above OMPL's path
through an independent optimisation (5: the issue's words), and no worse in the median; the
same two against OMPL's path through mpd_pin's own optimisation (2: a stronger peer, which
on half the queries ends at the same optimum); the restart finds ≤ 2 % less in
the median and ≤ 5 % on any query; so does the independent optimisation, on Panda queries.

Run:  pip install -e ".[bench]" && python bench/optimize.py [--panda 6] [--ur5 3] [--seed 0]
      (5–15 minutes with the defaults on 2 shared cores)
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import numpy as np

import mpd_pin as mp
from common import summary, target
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.motion_step import make_motion
from mpd_pin.app.plan import plan_path, plan_shortest, prepare
from mpd_pin.dynamics.sizing import sized_motors
from mpd_pin.errors import NoPathError
from mpd_pin.motion import trajectory_energy
from mpd_pin.motion.optimize import OptimizeSettings, optimize_curve, seed_curve
from mpd_pin.motion.screen import joint_limits
from mpd_pin.motion.spline import unit_knots, via_spline

NAN = float("nan")


def _less(e: float, ref: float) -> float:
    """% less energy of ``e`` than ``ref`` (nan when either is missing)."""
    if not (math.isfinite(e) and math.isfinite(ref)) or ref == 0:
        return NAN
    return 100.0 * (1.0 - e / ref)


def _e(m) -> float:
    return float(m.total_energy) if m is not None and m.feasible else NAN


def _fmt(m, width: int = 7) -> str:
    if m is None or not m.feasible:
        return f"{'infeasible':>{width + 10}}"
    return f"{m.total_energy:{width}.2f} J {m.duration:5.2f} s"


def _exec(m) -> str:
    if m is None:
        return "-"
    return "optim" if m.curve is not None else m.execution


def _nc(m) -> str:
    """Control points per joint of an optimised motion's curve ('-' when not optimised)."""
    if m is None or m.curve is None:
        return "-"
    return str(int(m.curve.spline.c.shape[0]))


def _why(record: dict | None) -> str:
    """Why an optimisation record kept its seed ('' when it did not)."""
    if not record or not record.get("kept_seed"):
        return ""
    return str(record.get("why", "kept the seed"))


def independent(drive, checker, motion, options, samples: int = 4000):
    """An independent trajectory optimisation seeded with ``motion`` at its duration, in
    the way of the prototype of ../shared/DESIGN.md §2: L-BFGS-B (where mpd_pin uses
    SLSQP) on a quadratic penalty of every violated row (distances scaled by the 1 cm
    margin, velocities and efforts by their limits, weight 1e3), on a finer B-spline (8
    control points more per joint, the returned curve fitted in least squares), with the
    same energy model. Its optimum is checked at ``samples`` evenly spaced times for
    collision (the issue's outside measurement) and simulated by mpd_pin's RK4 and
    controller; returns its energy (J), or nan when it is not free or not within the
    limits."""
    if motion is None or not motion.feasible or motion.curve is None:
        return NAN
    return independent_curve(drive, checker, motion.curve, float(motion.duration),
                             int(motion.curve.spline.c.shape[0]) + 8, options, samples)


def independent_curve(drive, checker, curve, T: float, n_c: int, options,
                      samples: int = 4000) -> float:
    """:func:`independent` seeded with any ``curve`` (a :class:`ViaSpline`, stretched to
    ``T`` s) on ``n_c`` control points per joint: its energy (J), or nan."""
    from scipy.optimize import minimize

    from mpd_pin.collision.distance import PairDistances
    from mpd_pin.motion.optimize import _price
    from mpd_pin.motion.problem import OptimizeSettings, Problem, fit_curve, spline_curve

    C0 = fit_curve(lambda tau: curve.spline(np.clip(tau, 0, 1) * curve.unit_duration), n_c,
                   curve.waypoints[0], curve.waypoints[-1])
    settings = OptimizeSettings()
    prob = Problem(drive, PairDistances(checker), C0, T, settings)
    x = prob.x0()
    prob.beta = 200.0 / max(float(np.max(np.abs(prob.dynamics(x)["P"]))), 1e-9)
    scale = prob.energy(x)
    lo, hi = np.array(prob.bounds()).T
    mu = 1e3
    for _ in range(3):  # rows chosen where each pass starts, as the prototype re-linearised
        prob.choose_pairs(x)
        prob.choose_velocity_rows(x)
        prob.choose_effort_rows(x)
        A, b = prob.velocity()
        s_v = np.concatenate([settings.velocity_fraction * prob.vlim[prob.velocity_rows[:, 1]]] * 2)
        s_e = np.concatenate([settings.effort_fraction * prob.elim[prob.effort_rows[:, 1]]] * 2)

        def f(z, A=A, b=b, s_v=s_v, s_e=s_e):
            parts = [((A @ z + b) / s_v, A / s_v[:, None]) if len(b) else None,
                     (prob.collision(z) / settings.margin,
                      prob.collision_jac(z) / settings.margin)
                     if any(len(a) for a in prob.active) else None,
                     (prob.effort(z) / s_e, prob.effort_jac(z) / s_e[:, None])
                     if len(prob.effort_rows) else None]
            val, grad = prob.energy(z) / scale, prob.energy_grad(z) / scale
            for part in parts:
                if part is None:
                    continue
                g, J = part
                neg = np.minimum(g, 0.0)
                val += mu * float(neg @ neg)
                grad = grad + 2.0 * mu * (neg @ J)
            return val, grad

        res = minimize(f, x, jac=True, method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True)),
                       options={"maxiter": 300})
        x = res.x
    out = spline_curve(prob.knots, prob.C(x), T)
    t = np.linspace(0.0, out.unit_duration, samples)
    if not checker.is_free_batch(out.spline(t)).all():
        return NAN
    priced = _price(drive, out, T, options)
    return float(priced.total_energy) if priced.feasible else NAN


def mpd_motions(scn, start, goal):
    """mpd_pin's motions without and with the optimisation, from one roadmap and plan."""
    scn = replace(scn, start=np.asarray(start, float), goal=np.asarray(goal, float))
    c0 = time.process_time()
    setup = prepare(scn, show_progress=False)
    plan = plan_path(scn, setup)
    short = plan_shortest(scn, setup)
    c1 = time.process_time()
    plain = make_motion(replace(scn, motion=replace(scn.motion, optimize=False)), setup, plan,
                        None, short)
    c2 = time.process_time()
    opt = make_motion(scn, setup, plan, None, short)
    c3 = time.process_time()
    return setup, plain, opt, {"plan": c1 - c0, "plain": c2 - c1, "opt": c3 - c2}


def run(name: str, n: int, seed: int) -> list[dict]:
    from ompl_peer import ompl_waypoints, random_queries

    scn = load_scenario(name)
    scn = replace(scn, motor=sized_motors(scn.arm))
    rows: list[dict] = []
    print(f"\n{name}: {n} queries (sized motors, seed {seed})")
    print(f"{'q':>2} | {'mpd_pin optimize=False':>25} | {'mpd_pin optimised':>25} "
          f"{'less':>6} {'CPU/runs':>7} n_c | {'OMPL best at T':>25} | {'OMPL + optimise':>17} "
          f"{'CPU':>5} n_c | {'vs best':>7} {'vs OMPL+opt':>11} | {'restart':>7} {'CPU':>5} "
          f"{'n_c':>7} {'same n_c':>7} | "
          f"plan s")
    for q, (start, goal) in enumerate(random_queries(scn, n, seed)):
        notes: list[str] = []
        try:
            setup, plain, opt, cpu = mpd_motions(scn, start, goal)
        except NoPathError as exc:
            print(f"{q:2d} | mpd_pin: no path ({exc})")
            continue
        drive, checker = setup.drive, setup.checker
        m0, m1 = plain.energy, opt.energy
        if plain.failure or opt.failure:
            notes.append(f"mpd_pin failure: {plain.failure or opt.failure}")
        orec = opt.refined.optimization if opt.refined is not None else None
        opt_cpu = float(orec["cpu_seconds"]) if orec else NAN
        n_runs = len(orec["runs"]) if orec else 0
        if orec:
            for r in orec["runs"]:
                if r.get("kept_seed"):
                    notes.append(f"optimisation of {r['seed']} kept its seed: {r.get('why')}")
                if r.get("solver_status", 0) != 0:
                    notes.append(f"optimisation of {r['seed']}: SLSQP status "
                                 f"{r['solver_status']} ({r.get('solver_message')}) after "
                                 f"{r.get('iterations')} iterations, {r['cpu_seconds']:.2f} "
                                 "CPU-s")
                if r.get("samples_added"):
                    notes.append(f"optimisation of {r['seed']}: {r['samples_added']} collision "
                                 "samples added after a failed check")
            if orec.get("kept_seed"):
                notes.append("no optimum kept: the returned motion is a refined candidate")
        # the optimised run's candidates should be the plain run's: same roadmap, same seed
        if plain.refined is not None and opt.refined is not None:
            same = opt.refined.by_name.get(plain.refined.candidate)
            if same is None or not math.isclose(same.total_energy, m0.total_energy,
                                                rel_tol=1e-9):
                notes.append("the optimised run's candidates differ from the plain run's")
        T = float(m1.duration)

        peer = ompl_waypoints(scn, start, goal, seed=seed + q, checker=checker)
        best = oo = None
        oo_cpu = oi = NAN
        if not peer["solved"]:
            notes.append("OMPL: not solved")
        else:
            W = peer["waypoints"]
            if not all(peer["certified"]):
                notes.append("OMPL path not certified free (a segment fails our check)")
            stop = trajectory_energy(drive, W, "stop", options=scn.options, checker=checker,
                                     max_duration=T)
            non = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker,
                                    max_duration=T)
            best = min((m for m in (stop, non) if m.feasible), key=lambda m: m.total_energy,
                       default=None)
            if best is None:
                notes.append(f"OMPL: neither stop ({stop.reason}) nor nonstop ({non.reason}) "
                             f"feasible within {T:.2f} s")
            try:
                oo = mp.optimize_motion(drive, setup.world, W, duration=T, options=scn.options,
                                        checker=checker)
                oo_cpu = float(oo.optimization.get("cpu_seconds", NAN))
                if _why(oo.optimization):
                    notes.append(f"OMPL + optimise kept its seed: {_why(oo.optimization)}")
                if not oo.feasible:
                    notes.append(f"OMPL + optimise infeasible: {oo.reason}")
            except ValueError as exc:
                notes.append(f"OMPL + optimise: {exc}")
            # the issue's own peer: OMPL's path through an independent optimisation at T,
            # on as many control points as the independent check of mpd_pin's motion
            vlim = joint_limits(drive)[0]
            n_ind = (int(m1.curve.spline.c.shape[0]) if m1.curve is not None else 24) + 8
            oi = independent_curve(drive, checker, via_spline(W, unit_knots(W, vlim)), T,
                                   n_ind, scn.options)

        c_ind = time.process_time()
        ind = independent(drive, checker, m1, scn.options)
        ind_cpu = time.process_time() - c_ind
        rs = optimize_curve(drive, checker, seed_curve(drive, m1), T, scn.options,
                            seed_motion=m1)
        rs_e = float(rs.motion.total_energy) if rs.motion is not None else float(m1.total_energy)
        # the restart picks its control points from the seed's breakpoints: an optimised
        # curve of n_c points has n_c − 6 interior ones, so it may get more than the first
        # solve had; the same restart at the winner's n_c tells the two apart
        win = next((r for r in orec["runs"] if r["seed"] == orec.get("seed")), None) \
            if orec and not orec.get("kept_seed") else None
        nc0, nc1 = (win or {}).get("control_points"), rs.record.get("control_points")
        rs_same_e = rs_e
        if nc0 is not None and nc0 != nc1:
            rs2 = optimize_curve(drive, checker, seed_curve(drive, m1), T, scn.options,
                                 seed_motion=m1,
                                 settings=OptimizeSettings(control_points=int(nc0)))
            rs_same_e = float((rs2.motion or m1).total_energy)
        if rs.motion is None and "no less energy" not in _why(rs.record):
            notes.append(f"restart kept its seed: {_why(rs.record)}")
        if rs.motion is not None and rs_e < 0.98 * m1.total_energy:
            notes.append(f"restart: {rs.record.get('iterations')} iterations, SLSQP status "
                         f"{rs.record.get('solver_status')} ({rs.record.get('solver_message')})")

        row = {
            "arm": name, "query": q, "plain": _e(m0), "plain_duration": m0.duration,
            "opt": _e(m1), "opt_duration": T, "opt_cpu": opt_cpu,
            "ompl_best": _e(best), "ompl_opt": _e(oo), "ompl_opt_cpu": oo_cpu,
            "opt_runs": n_runs, "restart": rs_e,
            "restart_cpu": float(rs.record.get("cpu_seconds", NAN)),
            "restart_nc": f"{nc0 or '-'}→{nc1}", "restart_same": rs_same_e,
            "plan_cpu": cpu["plan"], "motion_cpu": cpu["opt"],
            "independent": ind, "independent_cpu": ind_cpu,
        }
        row["less_opt"] = _less(row["opt"], row["plain"])
        row["vs_best"] = _less(row["opt"], row["ompl_best"])
        row["vs_ompl_opt"] = _less(row["opt"], row["ompl_opt"])
        row["ompl_ind"] = oi
        row["vs_ompl_ind"] = _less(row["opt"], oi)
        row["restart_less"] = _less(rs_e, row["opt"])
        row["restart_same_less"] = _less(rs_same_e, row["opt"])
        # the independent optimiser: % less than mpd_pin (0 when it found nothing better)
        row["independent_less"] = max(_less(ind, row["opt"]), 0.0) if math.isfinite(ind) \
            else 0.0
        rows.append(row)
        print(f"{q:2d} | {_exec(m0):>7} {_fmt(m0)} | {_exec(m1):>7} {_fmt(m1)} "
              f"{row['less_opt']:5.1f}% {opt_cpu:5.2f}/{n_runs} {_nc(m1):>3} | {_exec(best):>7} "
              f"{_fmt(best)} | "
              f"{_fmt(oo)} {oo_cpu:5.2f} {_nc(oo):>3} | {row['vs_best']:6.1f}% "
              f"{row['vs_ompl_opt']:10.2f}% | "
              f"{row['restart_less']:6.2f}% {row['restart_cpu']:5.2f} {row['restart_nc']:>7} "
              f"{row['restart_same_less']:6.2f}% | {cpu['plan']:6.2f} | independent "
              f"{row['independent_less']:5.2f}% less ({ind_cpu:.1f} s)")
        print(f"{'':>2}   OMPL + independent optimisation: "
              f"{oi:7.2f} J ({row['vs_ompl_ind']:.2f} % less for mpd_pin)"
              if math.isfinite(oi) else f"{'':>2}   OMPL + independent optimisation: "
              "not free or not within the limits")
        for note in notes:
            print(f"   ! {note}")
    return rows


def _med(values) -> float:
    v = [x for x in values if math.isfinite(x)]
    return float(np.median(v)) if v else NAN


def arm_summary(name: str, rows: list[dict]) -> None:
    if not rows:
        return
    print(f"\n{name} ({len(rows)} queries), medians: optimisation "
          f"{_med(r['less_opt'] for r in rows):.1f} % less than optimize=False, "
          f"{_med(r['opt_cpu'] for r in rows):.2f} CPU-s; vs OMPL's "
          f"best at T {_med(r['vs_best'] for r in rows):.1f} %; vs OMPL + optimise "
          f"{_med(r['vs_ompl_opt'] for r in rows):.1f} % (its CPU "
          f"{_med(r['ompl_opt_cpu'] for r in rows):.2f} s); restart "
          f"{_med(r['restart_less'] for r in rows):.2f} % less (at the first solve's n_c "
          f"{_med(r['restart_same_less'] for r in rows):.2f} %); plan CPU "
          f"{_med(r['plan_cpu'] for r in rows):.2f} s, motion step (optimised) CPU "
          f"{_med(r['motion_cpu'] for r in rows):.2f} s")


def targets(rows: list[dict]) -> None:
    print(f"\nall {len(rows)} queries:")
    panda = [r["opt_cpu"] for r in rows if r["arm"] == "panda" and math.isfinite(r["opt_cpu"])]
    med = _med(panda)
    target("optimisation ≤ 1 CPU-s per Panda query, median", math.isfinite(med) and med <= 1.0,
           f"median {med:.2f} CPU-s over {len(panda)} Panda queries, max "
           f"{max(panda, default=NAN):.2f}")

    vb = [r["vs_best"] for r in rows if math.isfinite(r["vs_best"])]
    med = _med(vb)
    target("median ≥ 40 % less energy than OMPL's best at equal duration",
           math.isfinite(med) and med >= 40.0,
           f"median {med:.1f} %, min {min(vb, default=NAN):.1f} % over {len(vb)} queries "
           f"with a feasible OMPL motion within T")

    vo = [r["vs_ompl_opt"] for r in rows if math.isfinite(r["vs_ompl_opt"])]
    worst = min(vo, default=NAN)
    target("never more than 3 % above OMPL + the same optimisation",
           bool(vo) and worst >= -3.0,
           f"worst query {-worst:+.1f} % energy against it (+: more) over {len(vo)} queries "
           f"with a feasible OMPL + optimise motion")
    med = _med(vo)
    target("no worse than OMPL + the same optimisation in the median",
           math.isfinite(med) and med >= 0.0, f"median {med:.2f} % less")

    vi = [r["vs_ompl_ind"] for r in rows if math.isfinite(r["vs_ompl_ind"])]
    worst, med = min(vi, default=NAN), _med(vi)
    target("never more than 3 % above OMPL + an independent optimisation (the issue's peer)",
           bool(vi) and worst >= -3.0,
           f"worst query {-worst:+.2f} % energy against it (+: more) over {len(vi)} queries "
           "where it ended free and within the limits")
    target("no worse than OMPL + an independent optimisation in the median",
           math.isfinite(med) and med >= 0.0, f"median {med:.2f} % less")

    rl = [r["restart_less"] for r in rows if math.isfinite(r["restart_less"])]
    med, top = _med(rl), max(rl, default=NAN)
    target("restart finds ≤ 2 % less in the median", math.isfinite(med) and med <= 2.0,
           f"median {med:.2f} %")
    target("restart finds ≤ 5 % less on any query", bool(rl) and top <= 5.0,
           f"max {top:.2f} % over {len(rl)} queries")
    il = [r["independent_less"] for r in rows if r["arm"] == "panda"]
    med, top = _med(il), max(il, default=NAN)
    target("an independent optimisation (L-BFGS-B penalty, finer spline) finds ≤ 2 % less on "
           "Panda queries in the median", math.isfinite(med) and med <= 2.0,
           f"median {med:.2f} %")
    target("... and ≤ 5 % on any Panda query", bool(il) and top <= 5.0,
           f"max {top:.2f} % over {len(il)} queries")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panda", type=int, default=6)
    ap.add_argument("--ur5", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows_p = run("panda", args.panda, args.seed) if args.panda else []
    rows_u = run("ur5", args.ur5, args.seed) if args.ur5 else []
    arm_summary("panda", rows_p)
    arm_summary("ur5", rows_u)
    rows = rows_p + rows_u
    if rows:
        targets(rows)
    summary(t0)


if __name__ == "__main__":
    main()
