"""The motion step of a run: from the roadmap path to what the arm runs (docs/design.md §9f).

After the plan (:mod:`mpd_pin.app.plan`) and the shortest-path comparison,
:func:`make_motion` builds the returned motion under the scenario's ``[motion]``:

* ``refine = false`` with ``execution = "stop"`` (the paper's scenarios): the roadmap
  path itself, stop-and-go, with the roadmap's own energies — nothing is simulated again,
  so these energies are bit-identical to the roadmap optimum;
* otherwise the candidates — the energy optimum and the shortest path (refine), or the
  optimum alone (no refine), and with a ``max_duration`` the shortest path shortcut for
  time (:func:`~mpd_pin.motion.shortcut.time_shortcut`, priced as it is) — go through
  :func:`~mpd_pin.motion.refine.refine_candidates`; the comparison's shortest path is
  refined and priced the same way;
* hidden obstacles (execution with sensing and repair): the travelled roadmap path,
  stop-and-go — the repairs happen at nodes, where the arm is at rest, and a shortcut
  would need obstacles that are only sensed on the way (``note`` says so).

With hazards of positive clearance, every new segment and curve is certified against
the clearance bands too.

With ``[motion] max_duration`` (or a query's ``max_duration``) and no candidate within it,
the run still has an answer, a planning outcome rather than bad input: the fastest motion
found (the candidate and execution with the least fastest feasible duration,
``MotionEnergy.fastest``, priced again at that duration), flagged infeasible
(``RunMotion.failure`` says why; the planner raises
:class:`~mpd_pin.errors.NoMotionWithinDuration` with its plan). Without a cap, no
candidate feasible at any duration is the same kind of outcome (:func:`_none_feasible`).

``RunMotion.energy_duration`` is result.json ``energy_duration``: the energy–time fronts
of the motion returned and of every candidate (:mod:`mpd_pin.motion.front`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamics.supply import supply_power
from ..motion.energy import STOP_RULE, MotionEnergy, check_waypoints, trajectory_energy
from ..motion.front import energy_duration_record
from ..motion.refine import NoFeasibleMotion, RefinedMotion, refine_candidates
from ..motion.series import motion_series
from ..motion.shortcut import time_shortcut
from .config import ConfigError
from .plan import PlanResult, Setup, path_length
from .scenario import EnergyScenario
from .verify import Verification

__all__ = ["RunMotion", "make_motion", "roadmap_motion", "fastest_duration",
           "no_motion_message"]

OPTIMUM, SHORTEST = "energy optimum", "shortest path"
#: The candidate for a cycle time: the shortest path shortcut for time (docs/design.md §9f).
QUICKEST = "shortest path, shortcut for time"


@dataclass
class RunMotion:
    """The returned motion, its time series (:func:`~mpd_pin.motion.series.motion_series`),
    the refinement (None when the roadmap path is returned as it is), the shortest path
    refined the same way (None likewise) and a note on how it was made; ``fastest`` (s):
    the fastest feasible motion of the returned geometry (``MotionEnergy.fastest``; with no
    motion within ``max_duration``, the fastest one found over the candidates; None: the
    motion's own duration); ``failure``: empty when the motion is the answer, else why
    there is none within ``max_duration`` (one line, the motion then being the fastest one
    found, infeasible); ``energy_duration``: result.json ``energy_duration`` (the
    energy–time fronts, :func:`~mpd_pin.motion.front.energy_duration_record`)."""

    energy: MotionEnergy
    series: dict[str, np.ndarray]
    refined: RefinedMotion | None
    shortest: MotionEnergy | None
    note: str
    fastest: float | None = None
    failure: str = ""
    energy_duration: dict[str, Any] | None = None

    @property
    def fastest_duration(self) -> float:
        """``fastest`` (s), or the motion's own duration when no candidate gave one."""
        return float(self.energy.duration if self.fastest is None else self.fastest)

    def check(self) -> Verification:
        """The motion as a :class:`~mpd_pin.app.verify.Verification` (for files and plots):
        E⁺ per joint from its series and its difference from the priced energy."""
        series = dict(self.series)
        recomputed = series["energy_t"][-1]
        ref = self.energy.energy_per_joint
        diff = float(np.max(np.abs(recomputed - ref) / np.maximum(np.abs(ref), 1e-300)))
        return Verification(series=series, energy_per_joint=recomputed,
                            max_relative_difference=diff,
                            bus_energy=series["bus_energy_t"][-1], supply=self.energy.supply)

    def record(self) -> dict[str, Any]:
        """``motion`` of result.json (docs/design.md §9d)."""
        m = self.energy
        t, V, i = self.series["t"], self.series["V"], self.series["i"]
        sampled = np.trapezoid(np.maximum(V * i, 0.0), t, axis=0) if len(t) > 1 else 0 * V[0]
        drawn = (float(np.trapezoid(supply_power(m.supply, V * i), t)) if len(t) > 1
                 else 0.0)  # the sampled supply energy (= Σ sampled per joint, §3i)
        total = float(m.total_energy)
        out = {
            **m.to_dict(),
            "node_times": self.series["node_times"],
            "trajectory_energy_per_joint": sampled,
            "trajectory_relative_difference": (
                abs(drawn - total) / abs(total) if total != 0 else 0.0),
            "note": self.note,
            "fastest_duration": self.fastest_duration,
            "duration_rule": m.duration_rule or STOP_RULE,
        }
        if self.refined is not None:
            out["refinement"] = self.refined.record()
            if self.refined.optimization is not None:
                out["optimization"] = self.refined.optimization
        return out


def roadmap_motion(drive, setup: Setup, plan: PlanResult, check: Verification) -> MotionEnergy:
    """The roadmap path of ``plan`` as a stop-and-go :class:`MotionEnergy` with the
    roadmap's own energies and durations (nothing simulated)."""
    roadmap = setup.roadmap
    path = list(plan.path)
    ids = roadmap.edge_ids(path) if len(path) > 1 else np.zeros(0, dtype=np.int64)
    W = roadmap.nodes[path]
    if drive.arm.continuous_joints and len(path) > 1:
        W = check_waypoints(drive, W)
    T = np.asarray(roadmap.durations, float)[ids]
    m = max(len(path) - 1, 0)
    energy = np.asarray(plan.energy, dtype=float)
    bus = roadmap.path_bus(path) if roadmap.bus is not None else np.zeros(2)
    total = path_supply_energy(roadmap, path, energy)
    duration = float(T.sum())
    return MotionEnergy("stop", W, energy, total, duration, 0.0, 0.0, 0.0,
                        True, max(m - 1, 0), [(k, k + 1) for k in range(m)], T,
                        energy_by_execution={"stop": total}, fastest=duration,
                        velocity_fastest=duration, longest=duration,
                        duration_rule="the roadmap path as it is: " + STOP_RULE,
                        bus_energy=bus, supply=drive.supply)


def path_supply_energy(roadmap, path: list[int], energy: np.ndarray) -> float:
    """The supply energy (J) of a roadmap node path whose E⁺ per joint is ``energy``:
    their sum with a supply per joint (the paper), else the bus's (docs/design.md §3i)."""
    if roadmap.supply.is_default:
        return float(np.sum(energy))  # the sum of ``energy`` as given, bit for bit
    return roadmap.path_supply_energy(path)


def _checker(scn: EnergyScenario, setup: Setup):
    """The checker new segments are certified with: the planning checker, enforcing the
    hazards' clearance when any has one."""
    if any(h.clearance > 0 for h in setup.world.hazards):
        checker = setup.checker.copy()
        checker.set_hazard_clearance(True)
        return checker
    return setup.checker


def fastest_duration(motions: dict[str, MotionEnergy]) -> float | None:
    """The least ``MotionEnergy.fastest`` (s: the fastest feasible duration of each
    execution and geometry) over ``motions`` (each one and its ``.alternative``): over the
    feasible ones, or over all when none is; None when there are none."""
    pool = [m for m0 in motions.values() for m in (m0, m0.alternative)
            if m is not None and m.fastest > 0 and math.isfinite(m.fastest)]
    good = [m.fastest for m in pool if m.feasible]
    if good or pool:
        return float(min(good or [m.fastest for m in pool]))
    return None


def no_motion_message(max_duration: float, motion: MotionEnergy) -> str:
    """The one line of a run with no motion within ``max_duration`` (s); ``motion``: the
    fastest one found (priced at its fastest duration)."""
    if motion.duration > max_duration + 1e-9:
        return (f"no motion within max_duration {max_duration:g} s: the fastest motion found "
                f"takes {motion.duration:.3f} s")
    return (f"no feasible motion within max_duration {max_duration:g} s: the fastest motion "
            f"found, {motion.duration:.3f} s, is infeasible ({motion.reason})")


def _over(motion: MotionEnergy, max_duration: float) -> MotionEnergy:
    """``motion`` flagged infeasible, its reason saying it takes longer than
    ``max_duration`` (s) when it does."""
    over = (f"takes {motion.duration:.3f} s > max_duration {max_duration:g} s"
            if motion.duration > max_duration + 1e-9 else "")
    reason = "; ".join(filter(None, [over, "" if motion.feasible else motion.reason]))
    return dataclasses.replace(motion, feasible=False, reason=reason or motion.reason)


def _fastest_feasible(drive, W: np.ndarray, execution: str, options, checker,
                      fastest: float) -> MotionEnergy | None:
    """The motion through ``W`` under ``execution`` at its fastest feasible duration
    ``fastest`` (s, ``MotionEnergy.fastest``: "stop", its roadmap timing; "nonstop", each
    piece's fastest feasible stretch, docs/design.md §9c), priced with that as
    ``max_duration``; None when it is not feasible (effort limits, collision)."""
    m = trajectory_energy(drive, W, execution, options=options, checker=checker,
                          max_duration=float(fastest))
    return m if m.feasible else None


def _fastest_found(scn: EnergyScenario, drive, checker, exc: NoFeasibleMotion,
                   refined_note: str, started: tuple[float, float]) -> RunMotion:
    """No candidate within ``[motion] max_duration``: the fastest feasible motion found
    (over the candidates and both executions, each at its ``MotionEnergy.fastest``,
    :func:`_fastest_feasible`), as an infeasible :class:`RunMotion` whose ``failure`` names
    its duration. When no candidate is feasible at any duration, the one with the least
    lower bound, priced at that bound (infeasible, its reason saying why)."""
    opts = scn.motion
    cap = float(opts.max_duration)
    pool = [(name, m) for name, m0 in exc.motions.items() for m in (m0, m0.alternative)
            if m is not None and m.fastest > 0 and math.isfinite(m.fastest)]
    if not pool:  # nothing was priced: every candidate failed its own refinement
        raise ConfigError(f"motion.max_duration: {cap:g} s: {exc}") from None
    pool.sort(key=lambda item: item[1].fastest)  # stable: ties keep the preferred candidate
    found: tuple[str, MotionEnergy] | None = None
    for name, m in pool:
        if found is not None and m.fastest >= found[1].duration:
            break  # it cannot be faster than the one found
        execution = m.execution if m.execution in ("stop", "nonstop") else "nonstop"
        fast = _fastest_feasible(drive, m.waypoints, execution, scn.options, checker,
                                 m.fastest)
        if fast is not None and (found is None or fast.duration < found[1].duration):
            found = (name, fast)
    if found is None:  # infeasible at any duration: priced at its lower bound
        name, m = pool[0]
        execution = m.execution if m.execution in ("stop", "nonstop") else "nonstop"
        found = (name, trajectory_energy(drive, m.waypoints, execution, options=scn.options,
                                         checker=checker, max_duration=float(m.fastest)))
    name, fast = found
    fast.duration_rule = ("the fastest feasible motion found (no candidate within "
                          "max_duration): " + (fast.duration_rule or STOP_RULE))
    refined = RefinedMotion(fast, name, exc.candidates, time.perf_counter() - started[0],
                            time.process_time() - started[1], dict(exc.motions))
    series = motion_series(drive, fast, scn.options.dt)
    if fast.feasible and fast.duration <= cap + 1e-9:  # found within the cap after all
        note = (f"the fastest motion found ({fast.execution}, from the {name}; "
                f"{refined_note})")
        return RunMotion(fast, series, refined, None, note, fastest=float(fast.duration),
                         energy_duration=energy_duration_record(name, fast, exc.motions, cap))
    motion = _over(fast, cap)
    refined.motion = motion
    note = (f"no motion within max_duration {cap:g} s: the fastest one found "
            f"({fast.execution}, from the {name}; {refined_note}), at its fastest duration")
    return RunMotion(motion, series, refined, None, note, fastest=float(motion.duration),
                     failure=no_motion_message(cap, motion),
                     energy_duration=energy_duration_record(name, motion, exc.motions, cap))


def _none_feasible(scn: EnergyScenario, setup: Setup, plan: PlanResult, check: Verification,
                   exc: NoFeasibleMotion, started: tuple[float, float]) -> RunMotion:
    """No candidate gives a feasible motion at any duration (no ``max_duration``): a planning
    outcome, not bad input. The answer is the preferred candidate's motion as priced (the
    first of ``exc.motions``; the roadmap path with the roadmap's energies when every
    candidate failed its own refinement), flagged infeasible, ``failure`` saying why (the
    planner raises :class:`~mpd_pin.errors.NoMotionWithinDuration` with its plan, and
    ``mpd-pin run`` exits with status 3, result.json ``"feasible": false``)."""
    drive = setup.drive
    if exc.motions:
        name, m = next(iter(exc.motions.items()))
    else:
        name, m = OPTIMUM, roadmap_motion(drive, setup, plan, check)
    m = dataclasses.replace(m, feasible=False, reason=m.reason or str(exc))
    failure = f"no feasible motion at any duration: {exc}"
    refined = RefinedMotion(m, name, exc.candidates, time.perf_counter() - started[0],
                            time.process_time() - started[1], dict(exc.motions))
    note = f"no feasible motion: the {name} as priced, infeasible"
    return RunMotion(m, motion_series(drive, m, scn.options.dt), refined, None, note,
                     failure=failure, energy_duration=energy_duration_record(
                         name, m, dict(exc.motions) or {name: m}, None))


def make_motion(scn: EnergyScenario, setup: Setup, plan: PlanResult, check: Verification,
                shortest: PlanResult | None, *, show_progress: bool = False) -> RunMotion:
    """The returned motion of a run (module docstring); ``show_progress``: a bar over the
    candidates on stderr. With no candidate within ``[motion] max_duration`` the
    :class:`RunMotion` is the fastest one found, infeasible, ``failure`` saying why."""
    opts = scn.motion
    drive, roadmap = setup.drive, setup.roadmap
    if plan.execution is not None or (not opts.refine and opts.execution == "stop") or len(
            plan.path) < 2:
        note = "the roadmap path, stop-and-go, with the roadmap's energies"
        if plan.execution is not None and (opts.refine or opts.execution != "stop"):
            note += (" (obstacles sensed on the way: the arm is at rest at each node where it "
                     "may repair, so the travelled path is neither shortcut nor run non-stop)")
        energy = roadmap_motion(drive, setup, plan, check)
        failure = ""  # its one execution, timed by the roadmap: its duration is its fastest
        if opts.max_duration is not None and energy.duration > opts.max_duration + 1e-9:
            energy = _over(energy, float(opts.max_duration))
            failure = no_motion_message(float(opts.max_duration), energy)
        return RunMotion(energy, check.series, None, None, note, fastest=energy.duration,
                         failure=failure, energy_duration=energy_duration_record(
                             OPTIMUM, energy, {OPTIMUM: energy}, opts.max_duration))
    checker = _checker(scn, setup)
    cands = {OPTIMUM: roadmap.nodes[plan.path]}
    if opts.refine and shortest is not None and list(shortest.path) != list(plan.path):
        cands[SHORTEST] = roadmap.nodes[shortest.path]
    if opts.refine and opts.alternatives:
        taken = [list(plan.path)] + ([list(shortest.path)] if shortest is not None else [])
        for k, path in enumerate(certified_alternatives(setup, taken, opts.alternatives,
                                                        drive.arm)):
            cands[f"alternative {k + 1}"] = roadmap.nodes[path]
    detours = frozenset(n for n in cands if n.startswith("alternative"))
    w0, c0 = time.perf_counter(), time.process_time()
    fixed = frozenset()
    if opts.refine and opts.max_duration is not None:  # a cycle time: the quickest geometry
        path = shortest.path if shortest is not None else plan.path
        W = check_waypoints(drive, roadmap.nodes[path])
        cands[QUICKEST] = time_shortcut(W, checker, scn.options, drive.arm.model.velocityLimit)
        fixed = frozenset({QUICKEST})
    how = "shortcut where the energy drops, " if opts.refine else ""
    many = f"{len(cands)} candidate{'s' if len(cands) > 1 else ''}"
    try:
        refined = refine_candidates(drive, checker, scn.options, cands, opts, optional=detours,
                                    progress=show_progress, fixed=fixed)
    except NoFeasibleMotion as exc:
        if opts.max_duration is None:
            return _none_feasible(scn, setup, plan, check, exc, (w0, c0))
        return _fastest_found(scn, drive, checker, exc, f"{how}{opts.execution} execution, "
                              f"{many}", (w0, c0))
    short_motion = None
    if shortest is not None:
        # one refinement (issue 34): the shortest path is one of the candidates, so its
        # motion is the one refined there (None when its refinement failed: not again)
        short_motion = refined.by_name.get(SHORTEST)
        if SHORTEST not in cands:
            if list(shortest.path) == list(plan.path):
                short_motion = refined.by_name[OPTIMUM]
            else:  # not refined (refine off): priced the same way
                try:
                    short_motion = refine_candidates(
                        drive, checker, scn.options, {SHORTEST: roadmap.nodes[shortest.path]},
                        opts, progress=show_progress,
                    ).motion
                except NoFeasibleMotion:
                    if opts.max_duration is None:
                        raise
                    short_motion = None  # none within the cap: nothing to compare with
        if opts.max_duration is not None and short_motion is not None and (
                not short_motion.feasible):
            short_motion = None  # none within the cap: nothing to compare with
    note = f"{how}{opts.execution} execution; from the {refined.candidate} ({many})"
    opt = refined.optimization
    if opt is not None and not opt.get("kept_seed", True):  # docs/design.md §9g
        note = (f"{how}{opts.execution} execution; the {opt['seed']} ({many}) optimised as a "
                f"whole at its duration")
    series = motion_series(drive, refined.motion, scn.options.dt)
    m = refined.motion
    return RunMotion(m, series, refined, short_motion, note,
                     fastest=float(m.fastest) if m.fastest > 0 else None,
                     energy_duration=energy_duration_record(
                         refined.candidate, m, refined.by_name, opts.max_duration))


def alternative_paths(roadmap, taken: list[list[int]], count: int, arm,
                      refused: np.ndarray | None = None) -> list[list[int]]:
    """Up to ``count`` roadmap paths from start to goal that share no interior node with
    the paths ``taken`` nor with each other: each the shortest in joint space (scipy's
    Dijkstra on the edge lengths) once those nodes are removed — a detour in another
    homotopy class where the roadmap has one (docs/design.md §9f). Edges ``refused`` by a
    lazy roadmap (a mask) are left out."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    from .plan import edge_lengths

    n = roadmap.num_nodes
    length = edge_lengths(roadmap, arm)
    keep = np.ones(roadmap.num_edges, dtype=bool) if refused is None else ~refused
    banned = {v for p in taken for v in p[1:-1]}
    out: list[list[int]] = []
    for _ in range(count):
        ok = keep & ~np.isin(roadmap.src, list(banned)) & ~np.isin(roadmap.dst, list(banned))
        if not ok.any():
            break
        G = csr_matrix((length[ok] + 1e-12, (roadmap.src[ok], roadmap.dst[ok])), shape=(n, n))
        dist, pred = dijkstra(G, indices=roadmap.start, return_predecessors=True)
        if not np.isfinite(dist[roadmap.goal]):
            break
        path = [int(roadmap.goal)]
        while path[-1] != roadmap.start:
            path.append(int(pred[path[-1]]))
        path.reverse()
        if len(path) < 3:  # the direct edge: nothing new to offer
            break
        out.append(path)
        banned |= set(path[1:-1])
    return out


def certified_alternatives(setup: Setup, taken: list[list[int]], count: int,
                           arm) -> list[list[int]]:
    """:func:`alternative_paths` whose edges are collision-checked: on a lazily checked
    roadmap (docs/design.md §4g) the detours' unchecked edges are certified, and while one
    is blocked (then refused) the detours are searched again — each round refuses at least
    one edge, so this ends."""
    lazy = setup.lazy
    refused = lazy.refused if lazy is not None else None
    while True:
        paths = alternative_paths(setup.roadmap, taken, count, arm, refused)
        if lazy is None or not paths:
            return paths
        ids = np.concatenate([lazy.edge_ids(p) for p in paths])
        if not lazy.certify(ids).size:
            return paths


def roadmap_path_record(setup: Setup, plan: PlanResult, arm) -> dict[str, Any]:
    """``roadmap_path`` of result.json: the MPD* Lite path behind the motion."""
    return {
        "nodes": [int(n) for n in plan.path],
        "configurations": setup.roadmap.nodes[plan.path],
        "length_rad": path_length(setup.roadmap, plan.path, arm),
        "energy_per_joint": plan.energy,
        "total_energy": path_supply_energy(setup.roadmap, plan.path, plan.energy),
    }
