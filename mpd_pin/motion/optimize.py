"""Trajectory optimisation at a fixed duration, then certification (docs/design.md §9g).

A motion of duration T is one clamped quintic B-spline in time, q(t) = Σ_i c_i N_i(t/T),
with ``n_c`` control points per joint on uniform knots; the first three and the last three
control points are the start and the goal, so q̇ = q̈ = 0 at both ends and the motion
leaves and joins the holding state as every other motion does. The free control points
x minimise the perfect-tracking supply energy (the screen of §9e/§9c, paper 000 eq. 2)

    E(x) = ∫₀ᵀ Σ_k s(V_ff,k i_ff,k) dt          (a supply per joint; s ≈ max(·, 0))
    E(x) = ∫₀ᵀ s(P) − η s(−P) dt, P = Σ_k V_ff,k i_ff,k     (a shared bus, §3i)

by Simpson's rule, with s a softplus of sharpness ``sharpness``/P_scale, subject to

* signed distance d_p(q(t_s)) ≥ margin_p + ``margin`` for every pair p the checker
  enforces (obstacles, self-collision, hazards with their clearance) at collision
  samples t_s, the pairs within ``activation`` of it (re-chosen each round);
* |q̇| ≤ ``velocity_fraction`` · v_lim at the energy samples where the seed comes within
  half the limit (linear in x);
* |τ_ff| ≤ ``effort_fraction`` · τ_lim at the energy samples where the seed comes within
  half the limit;
* the joint range on the control points themselves (bounds; convex hull again).

Gradients are analytic: q, q̇, q̈, q⃛ are linear in x through the basis matrices;
``pin.computeRNEADerivatives`` gives ∂τ/∂q, ∂τ/∂q̇ and M = ∂τ/∂q̈; the L·τ̇ term of V_ff
differentiates through d/dt of ∂τ/∂x along the sample grid (second order); distances
through the witness points (:mod:`mpd_pin.collision.distance`). The solver is scipy's
SLSQP (design §9g says why). The result is certified by the Bernstein boxes of §9c and
simulated with the RK4 of §3; it is kept only when certified, within the limits (its
simulated joint positions within each joint's range too) and cheaper *simulated* than its
seed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits

from ..collision.distance import PairDistances
from ..dynamics.motor import Drive
from ..dynamics.supply import supply_energy
from .certify import first_failure
from .nonstop import fastest_by_velocity, simulate_nonstop, snap_steps
from .outcome import MotionEnergy, check_waypoints, limit_reasons, range_reason
from .problem import OptimizeSettings, Problem, fit_curve, spline_curve
from .screen import joint_limits
from .spline import ViaSpline, unit_knots, via_spline

__all__ = ["OptimizeSettings", "OptimizedMotion", "price_curve", "optimize_curve",
           "optimize_motion", "optimize_seeds", "spline_curve", "fit_curve", "seed_curve"]

@dataclass
class OptimizedMotion:
    """The outcome of one optimisation: the motion (None when the seed is kept), and the
    record of ``motion.optimization`` (docs/design.md §9g)."""

    motion: MotionEnergy | None
    record: dict[str, Any] = field(default_factory=dict)
    #: the solved curve (also when it was not certified or priced: a screening solve)
    curve: ViaSpline | None = None


# ----------------------------------------------------------------------------- solve
#: A screened optimum whose screen energy lies more than this fraction above the cheapest
#: seed's simulated energy is not finished (:func:`optimize_seeds`): the screen and the
#: simulation agree to a fraction of this (§9e), and such a solve rose from an infeasible
#: start (an ``ur10_limited`` query: 169 → 335 J against a 166 J seed).
PROMISING = 0.05

#: What :func:`optimize_curve` does after its solve (its ``stage``).
STAGES = ("price", "certify", "screen")

#: The solver message of a solve stopped by ``OptimizeSettings.cpu_limit``.
CPU_LIMIT = "CPU limit reached"

#: A row below −this (m for distances, rad/s, N·m) makes an iterate infeasible for
#: :func:`_solve`'s record of the cheapest feasible one.
FEASIBLE = 1e-4


#: The solver message of a solve stopped after a round that rose and left the rows.
DIVERGED = "a round rose and left the rows"


def _worst_row(cons: list[dict], z: np.ndarray) -> float:
    """The smallest row of the constraints ``cons`` at ``z`` (m, rad/s or N·m; inf: none)."""
    return min((float(np.min(c["fun"](z), initial=np.inf)) for c in cons), default=np.inf)


def _solve(prob: Problem, x: np.ndarray, settings: OptimizeSettings,
           deadline: float = np.inf, iterations: int = 10**9) -> tuple[np.ndarray, dict]:
    """Rounds of SLSQP from ``x``. Each round adds the (sample, pair) rows, velocity and
    effort rows its start point comes near; the solve ends when a round converges and its
    end point adds no collision row, or after ``iterations`` SLSQP iterations in all (or
    past the CPU time ``deadline``), or after a round that rose in energy and ended further
    outside its rows than it started (:data:`DIVERGED`). Returns the last iterate and
    counters."""
    iters, status, msg = 0, 0, ""
    best: list = [np.inf, None]  # energy, iterate
    for _ in range(max(1, int(settings.rounds))):
        added = (prob.choose_pairs(x) + prob.choose_effort_rows(x)
                 + prob.choose_velocity_rows(x))
        if iters and status == 0 and not added:
            break
        A, b = prob.velocity()
        cons = []
        if len(b):
            cons.append({"type": "ineq", "fun": lambda z, A=A, b=b: A @ z + b,
                         "jac": lambda z, A=A: A})
        if any(len(a) for a in prob.active):
            cons.append({"type": "ineq", "fun": prob.collision, "jac": prob.collision_jac})
        if len(prob.effort_rows):
            cons.append({"type": "ineq", "fun": prob.effort, "jac": prob.effort_jac})
        scale = max(abs(prob.energy(x)), 1e-9)

        def keep(z, cons=cons, inside=True):  # the cheapest iterate within every row so far
            if inside and time.process_time() > deadline:
                raise StopIteration  # SLSQP stops and returns its current iterate
            # within the effort limit at every sample, not only at the round's rows: a
            # sample below half the limit at the round's start (no row) can end above it
            worst = min(_worst_row(cons, z), -prob.effort_excess(z))
            if worst >= -FEASIBLE and prob.energy(z) < best[0]:
                best[:] = [prob.energy(z), np.array(z, float)]

        if time.process_time() > deadline:
            status, msg = 9, CPU_LIMIT
            break
        if iters >= iterations:
            status, msg = 9, "iteration budget used up"
            break
        keep(x, inside=False)
        x_start = x
        e_start, w_start = prob.energy(x), _worst_row(cons, x)
        res = minimize(lambda z, k=scale: prob.energy(z) / k, x,
                       jac=lambda z, k=scale: prob.energy_grad(z) / k, method="SLSQP",
                       bounds=prob.bounds(), constraints=cons, callback=keep,
                       options={"maxiter": int(min(settings.max_iterations,
                                                   iterations - iters)),
                                "ftol": float(settings.tolerance)})
        iters += int(res.nit)
        status, msg = int(res.status), str(res.message)
        x = np.asarray(res.x, float)
        keep(x, inside=False)
        if status not in (0, 9) and best[1] is not None:
            # SLSQP's subproblem failed ("more than 3n iterations in LSQ subproblem",
            # "positive directional derivative"): its last iterate can be far worse than
            # where it started; go on from the cheapest iterate within every row instead
            x = best[1].copy()
        elif prob.energy(x) > e_start and _worst_row(cons, x) < min(w_start, -FEASIBLE):
            # the round rose and went further outside the rows than it started: SLSQP
            # lost its way (an UR5 continuation round ended 2.5× above its start, 0.21 m
            # inside an obstacle and 4.9 rad/s over a limit; the next took 2.4 CPU-s at
            # 60 ms an iteration and ended as far outside)
            status, msg, x = 9, DIVERGED, x_start  # better on both counts than its end
            break
    info = {"iterations": iters, "solver_status": status, "solver_message": msg}
    if best[1] is not None and status != 0:  # stopped early: its last iterate may be outside
        x = best[1]
    return x, info


def seed_curve(drive: Drive, motion: MotionEnergy) -> ViaSpline:
    """The curve an optimisation starts from (docs/design.md §9g): an optimised motion's
    own spline; else the non-stop spline through all of ``motion``'s waypoints (a
    stop-and-go motion's polyline, or a non-stop motion's pieces, joined without stops)."""
    if motion.curve is not None:
        return motion.curve
    vlim, _ = joint_limits(drive)
    W = motion.waypoints
    return via_spline(W, unit_knots(W, vlim))


def _control_points(settings: OptimizeSettings, via: int) -> int:
    if settings.control_points:
        return max(int(settings.control_points), 8)
    return int(np.clip(12 + 2 * via, 16, 24))


def optimize_curve(
    drive: Drive,
    checker: Any,
    seed: ViaSpline,
    duration: float,
    options: Any,
    *,
    settings: OptimizeSettings | None = None,
    seed_motion: MotionEnergy | None = None,
    distances: Any = None,
    stage: str = "price",
) -> OptimizedMotion:
    """Optimise the motion of duration ``duration`` (s, on the dt grid) seeded by the curve
    ``seed`` (stretched to that duration) and keep it when it is certified free by
    ``checker`` (None: no obstacles), within the velocity, effort and arrival limits of
    ``options`` (:class:`~mpd_pin.planning.roadmap.RoadmapOptions`) and cheaper than
    ``seed_motion`` when simulated (docs/design.md §9g). ``distances``: a
    :class:`~mpd_pin.collision.distance.PairDistances` of ``checker`` to reuse.
    ``stage``: "price" (all of the above), "certify" (solved again where the certificate
    fails, as for "price", but not simulated: ``.motion`` stays None, ``.curve`` and
    ``record["certified"]`` say what was found) or "screen" (one solve: its curve and
    screen energy ``record["screen_energy_out"]`` (J) only, neither certified nor
    simulated).
    Never raises for a failed solve: the seed is kept and the record says why."""
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {', '.join(STAGES)}, got {stage!r}")
    settings = settings or OptimizeSettings()
    w0, c0 = time.perf_counter(), time.process_time()
    dt = float(options.dt)
    T = float(snap_steps(duration, dt))
    q0, q1 = seed.waypoints[0], seed.waypoints[-1]
    if seed.optimised and not settings.control_points:  # a restart: its own polygon
        n_c = int(seed.spline.c.shape[0])
    else:
        n_c = _control_points(settings, seed.waypoints.shape[0] - 2)
    stretch = seed.unit_duration

    def seed_q(tau):
        return seed.spline(np.clip(tau, 0.0, 1.0) * stretch)

    C0 = fit_curve(seed_q, n_c, q0, q1)
    if checker is not None and distances is None:
        distances = PairDistances(checker)
    with threadpool_limits(1):  # small dense algebra: a second BLAS thread only spins
        return _optimize(drive, checker, T, options, settings, seed_motion, distances,
                         C0, n_c, w0, c0, stage)


def _optimize(drive, checker, T, options, settings, seed_motion, distances, C0, n_c,
              w0, c0, stage="price") -> OptimizedMotion:
    """The body of :func:`optimize_curve` (BLAS on one thread)."""
    rec: dict[str, Any] = {"duration": T, "control_points": n_c,
                           "seed_energy": None if seed_motion is None
                           else float(seed_motion.total_energy)}
    prob = Problem(drive, distances, C0, T, settings)
    x0 = prob.x0()
    P0 = prob.dynamics(x0)["P"]
    prob.beta = settings.sharpness / max(float(np.max(np.abs(P0))), 1e-9)
    rec["screen_energy_in"] = prob.energy(x0)
    kept = None
    x = x0
    for attempt in range(int(settings.retries) + 1):
        used = rec.get("iterations", 0)
        if attempt and (used >= settings.budget
                        or time.process_time() > c0 + settings.cpu_limit):
            rec["why"] = rec.get("why", "") + (f"; iteration budget ({settings.budget}) used up"
                                               if used >= settings.budget else
                                               f"; CPU limit ({settings.cpu_limit:g} s) reached")
            break
        if attempt and prob.energy(x) > rec["screen_energy_in"]:
            x = x0  # a failed solve that ended above its seed: again from the seed
        try:
            x, info = _solve(prob, x, settings, deadline=c0 + settings.cpu_limit,
                             iterations=int(settings.budget) - used)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
            rec.update(kept_seed=True, why=f"solver failed: {exc}")
            break
        info["iterations"] += rec.get("iterations", 0)
        rec.update(info)
        rec["screen_energy_out"] = prob.energy(x)
        curve = spline_curve(prob.knots, prob.C(x), T)
        if stage == "screen":
            rec.update(seconds=time.perf_counter() - w0, cpu_seconds=time.process_time() - c0,
                       margin=settings.margin, screened=True)
            return OptimizedMotion(None, rec, curve)
        if (prob.effort_excess(x) > FEASIBLE and rec["iterations"] < settings.budget
                and prob.choose_effort_rows(x)):  # over the limit where it had no row
            rec["certified"] = False
            rec["why"] = "over the effort limit at energy samples without an effort row"
            continue
        fast = 0
        if options.velocity_limits:  # over a limit between the energy samples: rows there
            fast = prob.add_velocity_samples(x)
            rec["velocity_rows_added"] = rec.get("velocity_rows_added", 0) + fast
        if checker is not None:
            fail = _sampled_failure(checker, curve)
            # collision samples where it came too close between them, for the next solve
            added = prob.add_samples(x)
            rec["samples_added"] = rec.get("samples_added", 0) + added
            if fail is None and not added:
                fail = first_failure(checker, curve, options.resolution)
            elif fail is None:
                fail = -1.0  # closer than the margin between samples: solve again first
            if fail is not None:
                rec["certified"] = False
                rec["why"] = ("not certified free" + (f" at t = {fail:.3f} s" if fail >= 0
                                                      else " (closer than the margin between "
                                                      "the collision samples)"))
                continue
        if fast:  # solve again with the new rows
            rec["certified"] = False
            rec["why"] = "over a velocity limit between the energy samples"
            continue
        rec["certified"] = True
        rec.pop("why", None)
        if stage == "price":
            kept = _price(drive, curve, T, options)
        break
    rec.update(seconds=time.perf_counter() - w0, cpu_seconds=time.process_time() - c0,
               margin=settings.margin)
    if stage == "certify" and rec.get("certified"):
        return OptimizedMotion(None, rec, curve)
    if kept is None:
        rec.setdefault("why", "no certified optimum")
        rec["kept_seed"] = True
        return OptimizedMotion(None, rec, curve)
    return _judge(kept, seed_motion, rec, curve)


def _judge(kept: MotionEnergy, seed_motion: MotionEnergy | None, rec: dict[str, Any],
           curve: ViaSpline) -> OptimizedMotion:
    """Keep the certified, simulated optimum ``kept`` when it is feasible and cheaper than
    ``seed_motion``; else the seed, ``rec`` saying why."""
    rec["energy"] = float(kept.total_energy)
    if not kept.feasible:
        rec.update(kept_seed=True, why=f"the optimum is infeasible when simulated: "
                   f"{kept.reason}")
        return OptimizedMotion(None, rec, curve)
    if seed_motion is not None and seed_motion.feasible and (
            kept.total_energy >= seed_motion.total_energy):
        rec.update(kept_seed=True, why="no less energy than the seed when simulated")
        return OptimizedMotion(None, rec, curve)
    rec["kept_seed"] = False
    return OptimizedMotion(kept, rec, curve)


def price_curve(drive: Drive, curve: ViaSpline, options: Any,
                seed_motion: MotionEnergy | None = None) -> OptimizedMotion:
    """A certified curve simulated at its duration (RK4, §3) and kept when feasible and
    cheaper than ``seed_motion`` (docs/design.md §9g)."""
    w0, c0 = time.perf_counter(), time.process_time()
    rec: dict[str, Any] = {"duration": float(curve.unit_duration),
                           "control_points": int(curve.spline.c.shape[0]), "certified": True}
    kept = _price(drive, curve, float(curve.unit_duration), options)
    rec.update(cpu_seconds=time.process_time() - c0, seconds=time.perf_counter() - w0)
    return _judge(kept, seed_motion, rec, curve)


def optimize_seeds(
    drive: Drive,
    checker: Any,
    seeds: list[tuple[str, ViaSpline, float, MotionEnergy | None]],
    options: Any,
    settings: OptimizeSettings | None = None,
    distances: Any = None,
    on_seed: Any = None,
) -> tuple[str | None, OptimizedMotion]:
    """Optimise from several seeds (name, curve, duration s, its simulated motion or None),
    spending the solves where they pay (docs/design.md §9g): each seed gets a screening
    solve of ``settings.screen`` SLSQP iterations on its own spline (neither certified nor
    simulated); the one of least screen energy (a solve whose QP subproblem failed after
    those that did not) goes on to convergence on its own control polygon (fresh SLSQP
    models, ``settings.budget`` iterations), then is solved once more on a finer spline
    (``settings.polish_points`` more control points per joint, ``settings.polish``
    iterations), certified and simulated — and while such a solve gained more than
    ``settings.refine_gain`` of its screen energy, once more on ``polish_points`` more
    (at most ``settings.refinements`` times, each kept only when certified and cheaper
    simulated); when the first finer solve is not kept, the
    converged coarse curve is certified and simulated instead; when neither is kept, or
    the result is no cheaper than the cheapest seed, the seed of next least screen energy
    is finished the same way. A seed whose screen energy lies more than :data:`PROMISING`
    above the cheapest seed's simulated energy is not finished. Returns the seed's name
    (None: no optimum kept) and the outcome (``.motion`` None: the seed is kept,
    ``record["why"]`` says why; ``record["runs"]``: the screening solves,
    ``record["solves"]``: the finishing ones). ``on_seed(name)`` is called after each
    seed's screening solve."""
    settings = settings or OptimizeSettings()
    if distances is None and checker is not None:
        distances = PairDistances(checker)
    c0 = time.process_time()
    runs, screened = [], []
    for name, curve, T, me in seeds:
        out = optimize_curve(drive, checker, curve, T, options, seed_motion=me,
                             settings=replace(settings, budget=int(settings.screen)),
                             distances=distances, stage="screen")
        runs.append({"seed": name, "seed_execution": None if me is None else me.execution,
                     **out.record})
        energy = out.record.get("screen_energy_out", np.nan)
        if out.curve is not None and math.isfinite(energy):
            # a solve whose QP subproblem failed (or that met the CPU guard) ranks after the
            # healthy ones: on the Panda's shared bus such a seed screened cheapest, then
            # spent the 6 s CPU guard on an uncertifiable continuation (SLSQP at 150 ms
            # an iteration)
            failed = (out.record.get("solver_status") not in (0, 9)
                      or out.record.get("solver_message") == CPU_LIMIT)
            screened.append((failed, energy, len(screened), name, out.curve, me))
        if on_seed is not None:
            on_seed(name)
    if not screened:
        why = "; ".join(f"{r['seed']}: {r.get('why', 'no solve')}" for r in runs)
        return None, OptimizedMotion(None, {"kept_seed": True, "why": why, "runs": runs,
                                            "cpu_seconds": time.process_time() - c0})
    # the motion to beat: the cheapest seed's (J, simulated); a screened optimum more than
    # PROMISING above it is not finished (its start broke the rows, and the solve rose)
    known = [me.total_energy for *_, me in seeds if me is not None and me.feasible]
    bar = min(known) if known else math.inf
    solves: list[dict[str, Any]] = []
    out, name = OptimizedMotion(None, {"kept_seed": True}), None
    for _, energy, _, name, coarse, me in sorted(screened):  # the next when one fails
        if energy > bar + PROMISING * abs(bar):
            continue
        out = _finish(drive, checker, coarse, options, settings, me, distances, solves, name)
        if out.motion is not None and out.motion.total_energy < bar:
            break
        if out.motion is not None:  # cheaper than its seed, not than the cheapest seed
            why = (f"{out.motion.total_energy:.6g} J, no less than the cheapest seed's "
                   f"{bar:.6g} J")
            out.record.update(kept_seed=True, why=why)
            solves[-1].update(kept_seed=True, why=why)
            out = OptimizedMotion(None, out.record, out.curve)
    if not solves:
        out.record["why"] = (f"no screened optimum within {PROMISING:.0%} of the cheapest "
                             f"seed's {bar:.6g} J")
    rec = {**out.record, "seed": name, "solves": solves, "runs": runs,
           "cpu_seconds": time.process_time() - c0}
    return (name if out.motion is not None else None), OptimizedMotion(out.motion, rec,
                                                                       out.curve)


def _finish(drive: Drive, checker: Any, coarse: ViaSpline, options: Any,
            settings: OptimizeSettings, me: MotionEnergy | None, distances: Any,
            solves: list[dict[str, Any]], name: str) -> OptimizedMotion:
    """One screened seed finished (:func:`optimize_seeds`): on to convergence on its own
    polygon (a restart) and certified, then on the finer spline, certified and simulated;
    else the certified coarse curve simulated; nothing when the coarse curve is not
    certified. Each solve's record goes into ``solves``."""
    T = float(coarse.unit_duration)
    more = optimize_curve(drive, checker, coarse, T, options, seed_motion=me,
                          distances=distances, stage="certify", settings=settings)
    solves.append({"seed": name, **more.record})
    if not more.record.get("certified"):  # the finer solve would start where it failed
        return OptimizedMotion(None, more.record, more.curve)
    coarse = more.curve or coarse
    n_c = int(coarse.spline.c.shape[0]) + int(settings.polish_points)
    out = _polish(drive, checker, coarse, T, options, settings, me, distances, n_c)
    solves.append({"seed": name, **out.record})
    if out.motion is None:  # the certified coarse curve
        out = price_curve(drive, coarse, options, me)
        solves.append({"seed": name, **out.record})
        return out
    for _ in range(int(settings.refinements)):
        if _gain(out.record) <= settings.refine_gain:
            break
        n_c += int(settings.polish_points)
        finer = _polish(drive, checker, out.curve, T, options, settings, out.motion,
                        distances, n_c)
        solves.append({"seed": name, **finer.record})
        if finer.motion is None:  # not kept: the last certified level stays
            break
        out = finer
    return out


def _polish(drive: Drive, checker: Any, curve: ViaSpline, T: float, options: Any,
            settings: OptimizeSettings, me: MotionEnergy | None, distances: Any,
            n_c: int) -> OptimizedMotion:
    """The finer solve of :func:`_finish` on ``n_c`` control points per joint, seeded by
    ``curve``: ``settings.polish`` iterations in rounds of ``settings.polish_round`` at
    ``settings.polish_tolerance``; certified and simulated, kept when cheaper than ``me``."""
    budget = int(settings.polish)
    return optimize_curve(drive, checker, curve, T, options, seed_motion=me,
                          distances=distances,
                          settings=replace(settings, budget=budget,
                                           control_points=n_c,
                                           tolerance=float(settings.polish_tolerance),
                                           max_iterations=int(settings.polish_round),
                                           rounds=math.ceil(budget / settings.polish_round)))


def _gain(record: dict[str, Any]) -> float:
    """What a solve gained on its own screen: (E_in − E_out)/|E_in| (0 when unknown)."""
    e_in, e_out = record.get("screen_energy_in"), record.get("screen_energy_out")
    if e_in is None or e_out is None or not (math.isfinite(e_in) and math.isfinite(e_out)):
        return 0.0
    return (e_in - e_out) / max(abs(e_in), 1e-12)


def _sampled_failure(checker: Any, curve: ViaSpline, samples: int = 400) -> float | None:
    """The first of ``samples`` evenly spaced times (s) at which the curve collides, or None:
    a cheap test before the certificate, which is slow on a curve that collides."""
    t = np.linspace(0.0, curve.unit_duration, samples)
    hit = ~checker.is_free_batch(curve.spline(t))
    return float(t[np.argmax(hit)]) if hit.any() else None


def _price(drive: Drive, curve: ViaSpline, T: float, options) -> MotionEnergy:
    """Simulate the optimised curve at T (RK4, §3) and check it as a non-stop piece."""
    vlim, elim = joint_limits(drive)
    (E, _, err, _, peak, B), rec = simulate_nonstop(drive, curve, np.array([T]),
                                                    float(options.dt), record=True)
    vel = curve.peak_speed_ratio(vlim) * curve.unit_duration / T
    eff = float(np.max(peak[0] / elim))
    e = float(np.max(np.abs(err[0])))
    reasons = limit_reasons(options, eff, e, vel, "the goal")
    outside = range_reason(drive.arm, rec.q[:, 0])
    if outside:
        reasons.append(outside)
    total = float(supply_energy(drive.supply, E[0], B[0]))
    W = curve.waypoints
    m = W.shape[0] - 1
    return MotionEnergy("nonstop", W, E[0].copy(), total, T, e, float(vel), eff, not reasons,
                        0, [(0, m)], np.array([T]), "; ".join(reasons),
                        energy_by_execution={"nonstop": total if not reasons else None},
                        fastest=T if math.isfinite(T) else 0.0, bus_energy=B[0].copy(),
                        supply=drive.supply, curve=curve, recorded=rec)


def optimize_motion(
    drive: Drive,
    world: Any,
    waypoints: Any,
    duration: float,
    *,
    options: Any = None,
    checker: Any = None,
    settings: OptimizeSettings | None = None,
) -> MotionEnergy:
    """A locally energy-optimal, certified motion of ``duration`` (s) from any joint-space
    path ``waypoints`` ((m+1, nq) rad: OMPL, MoveIt, a teach pendant; docs/design.md §9g).

    The seed is the non-stop quintic spline through the waypoints (§9b) stretched to
    ``duration``; the optimum is kept when it is certified free in ``world`` (a
    :class:`~mpd_pin.World`; or pass a ``checker``), within the limits of ``options``
    (:class:`~mpd_pin.RoadmapOptions`: dt, resolution, limits) and cheaper simulated than
    the seed, else the seed's own motion at ``duration`` is returned. Either way a
    :class:`~mpd_pin.MotionEnergy` like :func:`~mpd_pin.trajectory_energy`'s, with
    ``.optimization`` saying what happened. ValueError (one line) for waypoints of the wrong
    shape, with NaN or in collision (naming the row, from 1), or a ``duration`` below the
    fastest the velocity limits allow the seed (naming that minimum)."""
    from ..collision import CollisionChecker
    from ..planning.roadmap import RoadmapOptions

    options = options or RoadmapOptions()
    W = check_waypoints(drive, waypoints)
    try:
        T = float(duration)
    except (TypeError, ValueError):
        raise ValueError(f"duration must be a number > 0 (s), got {duration!r}") from None
    if not (math.isfinite(T) and T > 0):
        raise ValueError(f"duration must be a number > 0 (s), got {duration!r}")
    if checker is None:
        checker = CollisionChecker(drive.arm, world)
    free = checker.is_free_batch(W)
    if not free.all():
        k = int(np.flatnonzero(~free)[0])
        raise ValueError(f"waypoint row {k + 1} (counting from 1) is in collision: "
                         f"{checker.describe_collision(W[k])}")
    vlim, _ = joint_limits(drive)
    seed = via_spline(W, unit_knots(W, vlim))
    t_min = fastest_by_velocity(seed, vlim, options, float(options.dt))
    T = float(snap_steps(T, float(options.dt)))
    if T < t_min - 1e-9:
        raise ValueError(f"duration {duration:g} s is below the fastest the velocity limits "
                         f"allow this path, {t_min:.3f} s")
    base = _price(drive, seed, T, options)
    fail = first_failure(checker, seed, options.resolution)
    if fail is not None:
        base.feasible = False
        base.reason = "; ".join(filter(None, [base.reason, "the spline through the waypoints "
                                              f"is not certified free at t = "
                                              f"{fail * T / seed.unit_duration:.3f} s"]))
    base.curve = base.recorded = None  # the seed is the spline through its waypoints
    base.fastest = t_min
    _, out = optimize_seeds(drive, checker, [("waypoints", seed, T, base)], options, settings)
    if out.motion is None:
        base.optimization = out.record
        return base
    out.motion.fastest = t_min
    out.motion.optimization = out.record
    out.motion.alternative = base
    return out.motion
