"""The energy of any path: stop-and-go or non-stop execution (docs/design.md §9a–§9c).

:func:`trajectory_energy` prices a list of joint-space waypoints with the same motor,
controller, current model and RK4 as the roadmap edges (paper 000 eq. 2: E⁺ = Σ_k ∫
max(V_k i_k, 0) dt):

* ``"stop"`` — each segment is a rest-to-rest quintic edge timed by the roadmap's rule
  (:meth:`~mpd_pin.planning.roadmap.RoadmapOptions.timing`): exactly what the roadmap
  charges for the same edges (the same batched integrator, the same durations);
* ``"nonstop"`` — one quintic spline in time through the via points
  (:mod:`mpd_pin.motion.spline`), simulated in one piece and stretched uniformly, its
  duration chosen for the least energy from its fastest feasible stretch (within the
  velocity, effort and arrival limits, simulated: :class:`_Piece`) to the longer of 3×
  that and the stop-and-go duration (and within ``max_duration``): slow motions pay
  holding current and friction, fast ones copper loss. Where the curve is not certified free
  (with a ``checker``) the motion keeps a stop at the via point nearest the failure and is
  two non-stop pieces, down to single straight edges (which the stop mode certifies);
* ``"auto"`` — both, and the cheaper feasible one is returned.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.simulate import EdgeOutcomes, edge_outcomes
from ..dynamics.supply import supply_energy
from .certify import certified_pieces
from .nonstop import fastest_by_velocity, nonstop_tables, simulate_nonstop, snap_steps
from .outcome import (
    EXECUTIONS,
    PRICINGS,
    MotionEnergy,
    check_waypoints,
    joint_range,
    limit_reasons,
    waypoint_array,
)
from .screen import effort_bound, ideal_nonstop, joint_limits
from .spline import ViaSpline, unit_knots, via_spline
from .timed import timed_energy

__all__ = ["EXECUTIONS", "PRICINGS", "MotionEnergy", "trajectory_energy", "check_waypoints",
           "nonstop_tables", "simulate_nonstop", "snap_steps", "fastest_by_velocity",
           "waypoint_array", "limit_reasons", "cached_outcomes", "stretch_front"]

#: Durations of a non-stop piece screened by perfect-tracking energy (the best is simulated;
#: its neighbours, then all, only while none simulated is feasible).
SCREEN_GRID = 24

#: The longest non-stop duration tried, as a multiple of the fastest one allowed.
STRETCH = 3.0


# ----------------------------------------------------------------------------- stop
def cached_outcomes(drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray, dt: float,
              memo: dict | None) -> EdgeOutcomes:
    """:func:`edge_outcomes` of the edges, reusing rows kept in ``memo`` (keyed by the
    endpoints', duration's and step's bytes; rows never mix in a batch, so a row is the
    same whichever batch computed it) and keeping the new ones there."""
    if memo is None:
        return edge_outcomes(drive, Q0, Q1, T, dt)
    keys = [a.tobytes() + b.tobytes() + np.float64(t).tobytes() + np.float64(dt).tobytes()
            for a, b, t in zip(Q0, Q1, T, strict=True)]
    new = np.array([("outcome", k) not in memo for k in keys], dtype=bool)
    if new.any():
        out = edge_outcomes(drive, Q0[new], Q1[new], T[new], dt)
        for r, k in enumerate(np.flatnonzero(new)):
            memo["outcome", keys[k]] = tuple(getattr(out, f.name)[r] for f in
                                             fields(EdgeOutcomes))
    rows = [memo["outcome", k] for k in keys]
    return EdgeOutcomes(*(np.array([r[i] for r in rows]) for i in range(len(rows[0]))))


def _stop(drive: Drive, W: np.ndarray, dt: float, options, checker, effort_on: bool,
          memo: dict | None = None) -> MotionEnergy:
    """Rest-to-rest quintic edges between consecutive waypoints, roadmap timing."""
    Q0, Q1 = W[:-1], W[1:]
    vlim, elim = joint_limits(drive)
    T, _ = options.timing(Q0, Q1, drive.arm.model.velocityLimit)
    out = cached_outcomes(drive, Q0, Q1, T, dt, memo)
    energy = out.energy.sum(axis=0)
    bus = out.bus_energy.sum(axis=0)
    total = float(supply_energy(drive.supply, energy, bus))
    vel = float(np.max(1.875 * np.abs(Q1 - Q0) / T[:, None] / vlim))
    eff = float(np.max(out.peak_torque / elim))
    err = float(np.max(np.abs(out.end_error)))
    reasons = limit_reasons(options, eff, err, vel, "a waypoint", effort_on=effort_on)
    if checker is not None:
        free = checker.edges_free(Q0, Q1, options.resolution)
        if not free.all():
            k = int(np.flatnonzero(~free)[0])
            reasons.append(f"the segment from waypoint {k + 1} to {k + 2} (counting from 1) "
                           "is not collision-free")
    m = W.shape[0] - 1
    colliding = checker is not None and not free.all()
    return MotionEnergy("stop", W, energy, total, float(T.sum()), err, vel, eff,
                        not reasons, m - 1, [(i, i + 1) for i in range(m)], T,
                        "; ".join(reasons), fastest=float(T.sum()),
                        velocity_fastest=float(T.sum()), longest=float(T.sum()),
                        duration_rule=STOP_RULE, colliding=colliding,
                        bus_energy=bus, supply=drive.supply)


#: The fastest feasible stretch of a non-stop piece is found to this share of its duration
#: (or one RK4 step, whichever is more): simulated feasible there, infeasible that much
#: shorter (docs/design.md §9c).
FASTEST_TOLERANCE = 0.005

#: Rounds of simulations (each of at most 3 durations) the fastest-stretch search may take.
FASTEST_ROUNDS = 10

#: How a non-stop piece's duration is chosen (result.json ``motion.duration_rule``), and a
#: stop-and-go motion's.
NONSTOP_RULE = "least simulated energy over [fastest, max(3 × fastest, stop-and-go duration)]"
CAPPED_RULE = "least simulated energy over [fastest, max_duration]"
STOP_RULE = "roadmap timing (stop-and-go: each segment timed by the roadmap's duration rule)"

class _Piece:
    """One non-stop piece (docs/design.md §9c): its spline stretched uniformly, the bounds
    on its duration, and every duration simulated (``rows``, by duration on the dt grid)."""

    def __init__(self, drive: Drive, vs: ViaSpline, dt: float, options, effort_on: bool):
        self.drive, self.vs, self.dt = drive, vs, float(dt)
        self.options, self.effort_on = options, bool(effort_on)
        vlim, self.elim = joint_limits(drive)
        self.ratio = vs.peak_speed_ratio(vlim) * 1.002 if options.velocity_limits else 0.0
        #: the velocity limits' bound (s, on the dt grid, not below min_duration)
        self.t_velocity = float(snap_steps(max(self.ratio * vs.unit_duration,
                                          options.min_duration), dt))
        #: the perfect-tracking effort bound (s, :func:`effort_bound`; 0 without limits)
        self.t_effort = effort_bound(drive, vs) if effort_on else 0.0
        self.rows: dict[float, dict] = {}
        #: the duration range of the last search (s), and its end without max_duration
        self.lo = self.hi = self.rule_hi = self.t_velocity
        self.ideal: list[tuple[float, float]] = []
        self._fastest: float | None = None
        self._searched = False

    @property
    def bound(self) -> float:
        """The perfect-tracking lower bound (s): the larger of the velocity and effort
        bounds (the velocity bound where holding the arm exceeds an effort limit)."""
        te = self.t_effort if math.isfinite(self.t_effort) else 0.0
        return float(snap_steps(max(self.t_velocity, te), self.dt))

    def run(self, Ts) -> None:
        """Simulate the durations ``Ts`` (s, snapped to the dt grid) not simulated yet."""
        Ts = np.unique(snap_steps(Ts, self.dt))
        Ts = Ts[[float(x) not in self.rows for x in Ts]]
        if not Ts.size:
            return
        drive, options = self.drive, self.options
        E, _, err, _, peak, B = simulate_nonstop(drive, self.vs, Ts, self.dt)
        for k, T in enumerate(Ts.tolist()):
            eff = float(np.max(peak[k] / self.elim))
            e = float(np.max(np.abs(err[k])))
            ok = (not self.effort_on or eff <= 1.0 + 1e-12) and e <= options.arrival_tolerance
            total = float(supply_energy(drive.supply, E[k], B[k]))
            self.rows[T] = {"energy": E[k].copy(), "bus": B[k].copy(), "total": total,
                            "end_error": e, "effort": eff, "ok": ok,
                            "velocity": self.ratio / 1.002 * self.vs.unit_duration / T}

    def _violation(self, T: float) -> float:
        """How far the simulation at T is from feasible: the larger of its effort ratio
        (when enforced) and its end error over the arrival tolerance (≤ 1: feasible)."""
        r = self.rows[T]
        v = r["end_error"] / self.options.arrival_tolerance
        return max(v, r["effort"]) if self.effort_on else v

    def _guess(self, lo: float | None, hi: float | None) -> float:
        """Where the violation crosses 1 (s): log-linear in log T between the infeasible
        ``lo`` and the feasible ``hi``, else from the one given (violation ∝ T⁻²)."""
        if lo is not None and hi is not None:
            vl, vh = self._violation(lo), self._violation(hi)
            if vl > 1.0 and vh > 0.0 and vl > vh:
                f = math.log(vl) / (math.log(vl) - math.log(vh))
                return math.exp(math.log(lo) + f * (math.log(hi) - math.log(lo)))
            return 0.5 * (lo + hi)
        T = hi if hi is not None else lo
        v = self._violation(T)
        return T * math.sqrt(v) if v > 0.0 else T

    def fastest(self) -> float | None:
        """The fastest uniform stretch (s, on the dt grid) that is simulated feasible, to
        :data:`FASTEST_TOLERANCE` (infeasible that much shorter, or it is the velocity
        bound); None when none is found up to :data:`STRETCH` times the bound. Starts at
        :attr:`bound` and moves by the violation of the durations simulated."""
        if self._searched:
            return self._fastest
        self._searched = True
        if not math.isfinite(self.t_effort):
            return None  # holding the arm still exceeds an effort limit
        t_v, t0 = self.t_velocity, self.bound
        self.run([t0])
        for _ in range(FASTEST_ROUNDS):
            ok = sorted(T for T, r in self.rows.items() if r["ok"])
            if not ok:  # longer: from the longest infeasible one
                top = max(self.rows)
                if top >= STRETCH * t0:
                    break
                tol = max(FASTEST_TOLERANCE * top, self.dt)
                T = min(max(self._guess(top, None), top + tol), 1.5 * top)
                props = [T, T + 2 * tol]
            else:
                hi = ok[0]
                if hi <= t_v + 1e-9:
                    break  # the velocity limits bind
                tol = max(FASTEST_TOLERANCE * hi, self.dt)
                below = [T for T, r in self.rows.items() if not r["ok"] and T < hi]
                lo = max(below) if below else None
                if lo is not None and hi - lo <= tol + 1e-9:
                    break
                T = self._guess(lo, hi)
                if lo is None:  # shorter: from the shortest feasible one
                    T = max(min(T, hi - tol), 0.7 * hi)
                    props = [T - tol / 2, T + tol / 2]
                else:
                    T = min(max(T, lo + tol / 2), hi - tol / 2)
                    props = [T - tol / 2, T + tol / 2]
            props = np.maximum(snap_steps(props, self.dt), t_v)
            props = [float(x) for x in np.unique(props) if float(x) not in self.rows]
            if not props:
                ok = sorted(T for T, r in self.rows.items() if r["ok"])
                below = [T for T, r in self.rows.items()
                         if not r["ok"] and ok and T < ok[0]]
                if not ok or not below:
                    break
                mid = float(snap_steps(0.5 * (max(below) + ok[0]), self.dt))
                if mid in self.rows:
                    break
                props = [mid]
            self.run(props)
        ok = [T for T, r in self.rows.items() if r["ok"]]
        self._fastest = min(ok) if ok else None
        return self._fastest

    def lower(self) -> float:
        """The shortest duration searched (s): :meth:`fastest`, or :attr:`bound` when no
        stretch is feasible."""
        fast = self.fastest()
        return self.bound if fast is None else fast

    def search(self, t_max: float | None, t_budget: float = 0.0) -> tuple[float, dict | None]:
        """Best duration (s) and its outcome row (None when ``t_max`` is below the
        fastest; ``ok`` False when no duration is feasible). Durations from the fastest
        feasible stretch to the longer of :data:`STRETCH` times that and ``t_budget`` (s,
        the stop-and-go duration of the same waypoints), capped by ``t_max``: screened by
        perfect-tracking energy, the best simulated, its neighbours only if it is not
        feasible, the whole grid only if none of them is."""
        dt, rows = self.dt, self.rows
        t_lo = self.lower()
        t_hi = self.rule_hi = max(STRETCH * t_lo, t_lo + 4 * dt, t_budget)
        if t_max is not None:
            t_hi = min(t_hi, t_max)
        self.lo, self.hi = t_lo, max(t_hi, t_lo)
        if t_hi < t_lo - 1e-12:
            self.hi, self.ideal = t_lo, []
            return t_lo, None
        grid = snap_steps(np.geomspace(t_lo, t_hi, SCREEN_GRID) if t_hi > t_lo
                     else np.array([t_lo]), dt)
        # with the durations simulated already (the fastest stretch's search), so that the
        # screen has a value at every simulated point of the range
        grid = np.unique(np.concatenate([grid, [T for T in rows
                                                if t_lo - 1e-9 <= T <= t_hi + 1e-9]]))
        grid = grid[grid <= max(t_hi, t_lo) + 1e-9]
        e_ideal, peak_ideal = ideal_nonstop(self.drive, self.vs, grid)
        fits = (np.all(peak_ideal <= self.elim, axis=1) if self.effort_on
                else np.ones(grid.size, dtype=bool))
        fits |= np.array([rows.get(float(T), {}).get("ok", False) for T in grid])
        order = np.argsort(np.where(fits, e_ideal, np.inf), kind="stable")

        def found() -> bool:
            return any(r["ok"] and T <= t_hi + 1e-9 for T, r in rows.items())

        self.run(grid[order[:1]])  # the screen's best
        if not found():  # then its neighbours, then the whole grid
            i = int(order[0])
            self.run(grid[max(i - 1, 0): i + 2])
        if not found():
            self.run(grid)
        self.ideal = _ideal_curve(grid, e_ideal)
        ok = [T for T, r in rows.items() if r["ok"] and t_lo - 1e-9 <= T <= t_hi + 1e-9]
        if not ok:
            inside = [T for T in rows if T <= t_hi + 1e-9] or list(rows)
            T = max(inside)
            return T, dict(rows[T], ok=False)
        best = min(ok, key=lambda T: rows[T]["total"])
        return best, dict(rows[best])

    def simulated(self) -> list[tuple[float, float]]:
        """(duration, E⁺) of the feasible durations simulated within the last search's
        range, sorted; all durations simulated when none is feasible."""
        ok = sorted((T, r["total"]) for T, r in self.rows.items()
                    if r["ok"] and self.lo - 1e-9 <= T <= self.hi + 1e-9)
        return ok or sorted((T, r["total"]) for T, r in self.rows.items())


def stretch_front(drive: Drive, vs: ViaSpline, options, longest: float, *,
                  points: int = 4, include: tuple[float, ...] = ()) -> _Piece:
    """The energy–time front of the one-piece curve ``vs`` stretched uniformly (docs/design.md
    §9c): its fastest feasible stretch, the perfect-tracking screen from there to
    ``longest`` (s) and ``points`` simulated durations (geometric) plus ``include`` (s).
    Returns the :class:`_Piece` (``lower()``, ``t_velocity``, ``ideal``, ``simulated()``)."""
    p = _Piece(drive, vs, float(options.dt), options, bool(options.effort_limits))
    t_lo = p.lower()
    hi = max(float(longest), t_lo, *include)
    p.run(np.concatenate([np.geomspace(t_lo, hi, points) if hi > t_lo else [t_lo],
                          np.asarray(include, dtype=float)]))
    p.search(hi, hi)  # the screen over [fastest, hi], at the points simulated too
    return p


def _ideal_curve(grid: np.ndarray, energy: np.ndarray) -> list[tuple[float, float]]:
    return [(float(T), float(e)) for T, e in zip(grid, energy, strict=True)]


def _nonstop(drive: Drive, W: np.ndarray, dt: float, options, checker, max_duration,
             effort_on: bool, stop: MotionEnergy | None) -> MotionEnergy:
    vlim, _ = joint_limits(drive)
    if stop is not None and stop.colliding:
        parts = [(0, W.shape[0] - 1)]  # the polyline itself collides: nothing to certify
    else:
        parts = certified_pieces(W, checker, options.resolution, vlim,
                                 limits=joint_range(drive.arm))
    energy = np.zeros(drive.nq)
    bus = np.zeros(2)
    durations, reasons = [], []
    err = vel = eff = 0.0
    runs = [_Piece(drive, via_spline(W[i : j + 1], unit_knots(W[i : j + 1], vlim)), dt,
                   options, effort_on) for i, j in parts]
    lows = [p.lower() for p in runs]  # each piece's fastest feasible stretch (s)
    for (i, j), p, low in zip(parts, runs, lows, strict=True):
        share = None
        if max_duration is not None:  # each piece's share: in proportion to its fastest
            share = max_duration * low / sum(lows)
        budget = 0.0 if stop is None else float(np.sum(stop.piece_durations[i:j]))
        T, row = p.search(share, budget)
        if row is None:
            reasons.append(f"no duration within max_duration (the fastest piece {i}–{j} "
                           f"needs {T:.3f} s)")
            durations.append(T)
            continue
        if not row["ok"]:
            reasons.append(f"piece {i}–{j}: no feasible duration (effort {row['effort']:.3g}×, "
                           f"end error {row['end_error']:.3g} rad)")
        energy += row["energy"]
        bus += row["bus"]
        durations.append(T)
        err, vel, eff = max(err, row["end_error"]), max(vel, row["velocity"]), max(
            eff, row["effort"])
    if stop is not None and stop.colliding:
        reasons.append(stop.reason)
    stops = len(parts) - 1
    total = float(supply_energy(drive.supply, energy, bus))
    feasible = not reasons
    if len(runs) == 1:
        curve, ideal = runs[0].simulated(), runs[0].ideal
    else:  # the screen of the pieces at shares of a total, the motion itself simulated
        ideal = _split_screen(drive, runs, lows)
        curve = [(float(np.sum(durations)), total)] if feasible else []
    return MotionEnergy("nonstop", W, energy, total, float(np.sum(durations)),
                        err, vel, eff, feasible, stops, parts, np.asarray(durations),
                        "; ".join(reasons), duration_curve=curve, ideal_curve=ideal,
                        fastest=float(sum(lows)),
                        velocity_fastest=float(sum(p.t_velocity for p in runs)),
                        longest=float(sum(p.hi for p in runs)),
                        duration_rule=_nonstop_rule(runs, max_duration),
                        bus_energy=bus, supply=drive.supply)


def _nonstop_rule(runs: list[_Piece], max_duration: float | None) -> str:
    """``duration_rule`` of a non-stop motion whose pieces were searched as ``runs``."""
    capped = max_duration is not None and any(p.hi < p.rule_hi - 1e-9 for p in runs)
    rule = CAPPED_RULE if capped else NONSTOP_RULE
    if max_duration is not None and not capped:
        rule += " (max_duration not reached)"
    if len(runs) > 1:
        rule += (f", per piece between the {len(runs) - 1} stops (max_duration shared in "
                 "proportion to the pieces' fastest durations)")
    return rule


def _split_screen(drive: Drive, runs: list[_Piece], lows: list[float]
                  ) -> list[tuple[float, float]]:
    """The perfect-tracking screen (duration, E) of a motion of several non-stop pieces,
    each at its share of the total (in proportion to its fastest, as ``max_duration`` is
    shared), from the sum of their fastest to the sum of their longest durations."""
    lo, hi = float(sum(lows)), float(sum(p.hi for p in runs))
    grid = np.geomspace(lo, hi, SCREEN_GRID) if hi > lo else np.array([lo])
    total = np.zeros(grid.size)
    parts = []
    for p, low in zip(runs, lows, strict=True):  # shares rounded down to the dt grid
        T = np.maximum(np.floor(grid * low / lo / p.dt + 1e-9) * p.dt, low)
        e, _ = ideal_nonstop(drive, p.vs, T)
        parts.append(T)
        total += e
    durations = np.sum(parts, axis=0)
    return _ideal_curve(durations, total)


# ----------------------------------------------------------------------------- public
def trajectory_energy(
    drive: Drive,
    waypoints: Any,
    execution: str = "auto",
    *,
    dt: float | None = None,
    options: Any = None,
    checker: Any = None,
    max_duration: float | None = None,
    memo: dict | None = None,
    times: Any = None,
) -> MotionEnergy:
    """E⁺ (J) of the arm running through ``waypoints`` ((m+1, nq) rad; docs/design.md §9a).

    ``execution``: "stop" (rest-to-rest quintic edges timed by the roadmap rule of
    ``options``, a :class:`~mpd_pin.planning.roadmap.RoadmapOptions`; the roadmap's own
    edge energies), "nonstop" (one quintic spline in time through the via points, its
    duration (s) chosen for the least E⁺ from its fastest feasible stretch, within
    ``max_duration``; docs/design.md §9c),
    or "auto" (both; the cheaper feasible one, the other in ``.alternative``). ``dt``: RK4
    step (s; default ``options.dt``). With a collision ``checker`` the motion is certified
    free (straight edges for stop; the spline's curve for non-stop, which keeps a stop
    where its curve is not free). ``memo`` (a dict) reuses stop-and-go edges simulated
    before with it. "timed" (with ``times``, (m+1,) s from 0, strictly increasing): the
    trajectory as given, :func:`mpd_pin.motion.timed.timed_energy`. ValueError for bad
    waypoints or times, an unknown execution, or ``times`` without "timed" or the reverse.
    """
    from ..planning.roadmap import RoadmapOptions

    if execution not in PRICINGS:
        raise ValueError(f"execution must be one of {', '.join(PRICINGS)}, got {execution!r}")
    if (times is None) == (execution == "timed"):
        raise ValueError("execution 'timed' needs times (s, one per waypoint)" if times is None
                         else f"times are for execution 'timed', not {execution!r}")
    options = options or RoadmapOptions()
    dt = float(options.dt if dt is None else dt)
    if max_duration is not None and not (math.isfinite(max_duration) and max_duration > 0):
        raise ValueError(f"max_duration must be a number > 0 (s), got {max_duration!r}")
    if execution == "timed":
        return timed_energy(drive, waypoints, times, dt=dt, options=options, checker=checker,
                            max_duration=max_duration)
    W = check_waypoints(drive, waypoints)
    effort_on = bool(options.effort_limits)
    stop = _stop(drive, W, dt, options, checker, effort_on, memo)
    if max_duration is not None and stop.duration > max_duration + 1e-9:
        stop.feasible = False
        stop.reason = "; ".join(filter(None, [stop.reason, f"takes {stop.duration:.3f} s > "
                                              f"max_duration {max_duration:g} s"]))
    if execution == "stop":
        stop.energy_by_execution = {"stop": _feasible_energy(stop)}
        return stop
    non = _nonstop(drive, W, dt, options, checker, max_duration, effort_on, stop)
    by = {"stop": _feasible_energy(stop), "nonstop": _feasible_energy(non)}
    stop.energy_by_execution = non.energy_by_execution = by
    if execution == "nonstop":
        non.alternative = stop
        return non
    best, other = (non, stop) if _better(non, stop) else (stop, non)
    best.alternative = other
    return best


def _feasible_energy(m: MotionEnergy) -> float | None:
    return m.total_energy if m.feasible else None


def _better(a: MotionEnergy, b: MotionEnergy) -> bool:
    """Whether ``a`` is preferred: feasible first, then less energy."""
    if a.feasible != b.feasible:
        return a.feasible
    return a.total_energy < b.total_energy
