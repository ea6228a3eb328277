"""From roadmap paths to the returned motion: candidates, shortcuts, execution (docs/design.md §9f).

The roadmap's energy optimum is optimal only among stop-and-go paths on its sampled
graph. :func:`refine_candidates` takes several certified paths — the energy optimum, the
shortest path, alternatives — shortens each where the simulated energy drops
(:func:`~mpd_pin.motion.shortcut.shortcut_path`), prices each with the chosen execution
(:func:`~mpd_pin.motion.energy.trajectory_energy`) and returns the cheapest feasible
motion, with a record of every candidate.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.supply import PER_JOINT
from ..progress import bar as progress_bar
from .energy import EXECUTIONS, MotionEnergy, stretch_front, trajectory_energy
from .optimize import optimize_seeds, seed_curve
from .outcome import waypoint_array
from .relax import relax_path
from .shortcut import shortcut_path

__all__ = ["MotionOptions", "NoFeasibleMotion", "RefinedMotion", "choose_seeds",
           "refine_candidates"]


class NoFeasibleMotion(ValueError):
    """No candidate gave a feasible motion; ``fastest`` (s) is the shortest duration any
    candidate's execution allows (what ``max_duration`` would need to be at least);
    ``motions``: the candidates priced (name → :class:`MotionEnergy`, each infeasible, the
    other execution in ``.alternative``), in order of preference; ``candidates``: their
    records (as ``RefinedMotion.candidates``)."""

    def __init__(self, message: str, fastest: float,
                 motions: dict[str, MotionEnergy] | None = None,
                 candidates: list[dict[str, Any]] | None = None) -> None:
        super().__init__(message)
        self.fastest = fastest
        self.motions = dict(motions or {})
        self.candidates = list(candidates or [])


@dataclass(frozen=True)
class MotionOptions:
    """How the returned motion is made (``[motion]`` of a scenario).

    execution: "auto" (the cheaper feasible of stop-and-go and non-stop), "stop" or
    "nonstop"; refine: shortcut the candidates where energy drops (False: the roadmap
    path as it is); max_duration: the longest motion allowed (s; None: no limit);
    interior: points inside each segment a shortcut may start or end at; max_rounds:
    shortcut rounds per candidate; seed: of the via-point relaxation (reproducible);
    alternatives: extra roadmap paths refined besides the energy optimum and the shortest
    path (node-disjoint detours, docs/design.md §9f); optimize: optimise the best
    candidates' motions as a whole at their duration (docs/design.md §9g); seeds: how many
    candidates (the cheapest first) seed an optimisation.
    """

    execution: str = "auto"
    refine: bool = True
    max_duration: float | None = None
    interior: int = 3
    max_rounds: int = 2
    seed: int = 0
    alternatives: int = 1
    optimize: bool = True
    seeds: int = 3

    def __post_init__(self) -> None:
        if self.execution not in EXECUTIONS:
            raise ValueError(f"execution must be one of {', '.join(EXECUTIONS)}, "
                             f"got {self.execution!r}")
        if self.max_duration is not None and not (
            isinstance(self.max_duration, (int, float)) and math.isfinite(self.max_duration)
            and self.max_duration > 0
        ):
            raise ValueError(f"max_duration must be a number > 0 (s), got {self.max_duration!r}")
        if int(self.interior) != self.interior or self.interior < 0:
            raise ValueError(f"interior must be a non-negative integer, got {self.interior!r}")
        if int(self.alternatives) != self.alternatives or self.alternatives < 0:
            raise ValueError(f"alternatives must be a non-negative integer, "
                             f"got {self.alternatives!r}")
        if int(self.seeds) != self.seeds or self.seeds < 1:
            raise ValueError(f"seeds must be a positive integer, got {self.seeds!r}")
        if int(self.max_rounds) != self.max_rounds or self.max_rounds < 1:
            raise ValueError(f"max_rounds must be a positive integer, got {self.max_rounds!r}")


@dataclass
class RefinedMotion:
    """The returned motion (``motion``), the name of the candidate it came from, one record
    per candidate, and the CPU and wall seconds the refinement took."""

    motion: MotionEnergy
    candidate: str
    candidates: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    by_name: dict[str, MotionEnergy] = field(default_factory=dict)
    #: ``motion.optimization`` of result.json (None: not optimised, docs/design.md §9g)
    optimization: dict[str, Any] | None = None

    def record(self) -> dict[str, Any]:
        """``motion.refinement`` of result.json."""
        return {"candidate": self.candidate, "candidates": self.candidates,
                "seconds": self.seconds, "cpu_seconds": self.cpu_seconds}


#: An optional candidate (a detour) whose shortcut costs more than this factor times the
#: best shortcut so far is not refined further (its relaxation and pricing are skipped).
PRUNE = 1.1


class _Pruned(Exception):
    """An optional candidate left after its shortcut (see :data:`PRUNE`)."""


def _refine_one(drive: Drive, W: np.ndarray, checker: Any, options: Any,
                motion: MotionOptions, memo: dict, rec: dict[str, Any],
                bar: float = np.inf, stage=None) -> np.ndarray:
    """One candidate's pipeline (docs/design.md §9e): shortcut, relax the via points,
    shortcut again; its stop-and-go E⁺ (J) after each step go into ``rec``. Raises
    :class:`_Pruned` when the shortcut's E⁺ is above ``bar`` (J). ``stage(name)``, if
    given, is told each step as it starts."""
    stage = stage or (lambda name: None)
    stage("shortcut")
    sc = shortcut_path(drive, W, checker, options, interior=motion.interior,
                       max_rounds=motion.max_rounds, memo=memo)
    rec.update(stop_energy_in=sc.initial_energy, stop_energy_shortcut=sc.total_energy)
    if sc.total_energy > bar:
        raise _Pruned
    stage("relaxation")
    rx = relax_path(drive, sc.waypoints, checker, options, seed=motion.seed, memo=memo)
    stage("second shortcut")
    sc2 = shortcut_path(drive, rx.waypoints, checker, options, interior=motion.interior,
                        max_rounds=1, memo=memo)
    rec.update(stop_energy_in=sc.initial_energy, stop_energy_shortcut=sc.total_energy,
               stop_energy_relaxed=rx.total_energy, stop_energy_out=sc2.total_energy,
               shortcut_rounds=sc.rounds + sc2.rounds, via_points_moved=rx.moves,
               pairs_checked=sc.pairs_checked + sc2.pairs_checked,
               edges_simulated=sc.edges_simulated + rx.edges_simulated + sc2.edges_simulated)
    return sc2.waypoints


def refine_candidates(
    drive: Drive,
    checker: Any,
    options: Any,
    candidates: dict[str, np.ndarray],
    motion: MotionOptions | None = None,
    optional: frozenset[str] = frozenset(),
    progress: bool = False,
    fixed: frozenset[str] = frozenset(),
) -> RefinedMotion:
    """The cheapest feasible motion over ``candidates`` (name → certified waypoints (m+1, nq)
    rad, in order of preference on ties; continuous joints may come wrapped, as roadmap
    nodes are: they are unwrapped first, docs/design.md §1d) under ``motion``;
    ``options``: the roadmap's :class:`~mpd_pin.planning.roadmap.RoadmapOptions` (timing,
    limits, dt, resolution);
    ``checker`` certifies every new segment and non-stop curve. Candidates named in
    ``optional`` (detours; list them last) stop after their shortcut when it costs more
    than :data:`PRUNE` times the best shortcut before them. ValueError when no candidate
    gives a feasible motion (its reasons in the message). ``progress``: a "refinement"
    bar over the candidates on stderr, naming the candidate and the step under way.
    Candidates named in ``fixed`` are priced as given, without the energy refinement (the
    shortest path shortcut for time, a candidate for a cycle time: docs/design.md §9f).

    With a supply other than the paper's (docs/design.md §3i) every candidate is refined
    twice: for the energy drawn from that supply, and for the per-joint E⁺ (named
    "NAME (refined per joint)"); both are priced on the drive's supply. The local search
    of a refinement can stop in different minima under the two objectives (measured on the
    Panda at η = 0.6: 41.8 J refined for the bus, 39.5 J refined per joint), and this way
    the motion planned for the bus never costs more on it than the one planned per joint.
    Simulated edges are shared between the two (the memo), since the supply prices a
    motion without changing it."""
    motion = motion or MotionOptions()
    w0, c0 = time.perf_counter(), time.process_time()
    memo: dict = {}
    records, by_name = [], {}
    jobs = [(name, W, drive, "supply") for name, W in candidates.items()]
    if motion.refine and not drive.supply.is_default:
        per_joint = dataclasses.replace(drive, supply=PER_JOINT)
        jobs += [(f"{name} (refined per joint)", W, per_joint, "per_joint")
                 for name, W in candidates.items() if name not in fixed]
        optional = optional | {f"{n} (refined per joint)" for n in optional}
    with progress_bar(len(jobs), "refinement", unit="candidate", enabled=progress,
                      iterable=jobs) as shown:
        for name, W, refining, objective in shown:  # the bar advances per candidate
            # a roadmap path holds its nodes wrapped to [−π, π): continuous joints unwrapped
            # (§1d), so that the shortcut and the relaxation price every segment the
            # shorter way round, as the roadmap did (a Bravo 7 path across the seam was
            # refused: "no feasible sequence through the path's own segments")
            W = waypoint_array(drive, W)
            rec: dict[str, Any] = {"name": name, "waypoints_in": int(W.shape[0])}
            if objective != "supply":
                rec["objective"] = objective
            if motion.refine and W.shape[0] > 2 and name not in fixed:
                bar = np.inf
                if name in optional:  # against the best shortcut of the same objective
                    done = [r["stop_energy_shortcut"] for r in records
                            if "stop_energy_shortcut" in r
                            and r.get("objective", "supply") == objective]
                    bar = PRUNE * min(done, default=np.inf)
                try:
                    W = _refine_one(refining, W, checker, options, motion, memo, rec, bar,
                                    stage=lambda step, n=name: shown.set_postfix_str(
                                        f"{n}: {step}"))
                except _Pruned:
                    rec.update(feasible=False, reason=f"pruned: its shortcut costs more than "
                               f"{PRUNE:g}× the best before it")
                    records.append(rec)
                    continue
                except ValueError as exc:  # no feasible sequence through its own segments
                    rec.update(feasible=False, reason=str(exc))
                    records.append(rec)
                    continue
            shown.set_postfix_str(f"{name}: pricing ({motion.execution})")
            me = trajectory_energy(drive, W, motion.execution, options=options,
                                   checker=checker, max_duration=motion.max_duration,
                                   memo=memo)
            rec.update(waypoints=int(me.waypoints.shape[0]), execution=me.execution,
                       total_energy=me.total_energy, duration=me.duration,
                       feasible=me.feasible, energy_by_execution=dict(me.energy_by_execution))
            if not me.feasible:
                rec["reason"] = me.reason
            records.append(rec)
            by_name[name] = me
    feasible = [n for n, m in by_name.items() if m.feasible]
    if not feasible:
        why = "; ".join(f"{r['name']}: {r.get('reason', '')}" for r in records)
        fastest = min((min(m.fastest, m.alternative.fastest if m.alternative else np.inf)
                       for m in by_name.values()), default=np.inf)
        raise NoFeasibleMotion(f"no feasible motion among the candidates ({why})", fastest,
                               motions=by_name, candidates=records)
    best = min(feasible, key=lambda n: by_name[n].total_energy)
    optimization = None
    if motion.optimize and motion.execution != "stop":  # an optimum runs non-stop (§9g)
        with progress_bar(min(len(feasible), motion.seeds), "optimisation", unit="seed",
                          enabled=progress) as shown:
            best, optimization = _optimize_best(drive, checker, options, motion, by_name,
                                                feasible, best, shown)
    return RefinedMotion(by_name[best], best, records, time.perf_counter() - w0,
                         time.process_time() - c0, by_name, optimization)


#: Candidates costing more than this factor times the cheapest seed no optimisation: each
#: costs 0.5–4 CPU-s (bench/optimize.py), and the budget goes to the likelier winners.
SEED_FACTOR = 1.4

#: Name of the optimised motion in ``RefinedMotion.by_name`` (its seed is named apart).
OPTIMIZED = "optimised"


def choose_seeds(energies: dict[str, float], count: int) -> list[str]:
    """The candidates that seed the optimisation (docs/design.md §9g): the ``count``
    cheapest of ``energies`` (name → J), cheapest first, within SEED_FACTOR of the
    cheapest, measured as (SEED_FACTOR − 1)·|cheapest| above it: with regeneration an
    energy can be ≤ 0 (§3i), where SEED_FACTOR × cheapest would exclude them all."""
    order = sorted(energies, key=energies.__getitem__)
    cheapest = energies[order[0]]
    bar = cheapest + (SEED_FACTOR - 1.0) * abs(cheapest)
    return [n for n in order if energies[n] <= bar][: int(count)]


def _optimize_best(drive: Drive, checker: Any, options: Any, motion: MotionOptions,
                   by_name: dict[str, MotionEnergy], feasible: list[str], best: str,
                   shown) -> tuple[str, dict[str, Any]]:
    """Optimise from the ``motion.seeds`` cheapest feasible candidates at their own duration
    (docs/design.md §9g; a stop-and-go candidate seeded by the spline through its
    polyline; :func:`~mpd_pin.motion.optimize.optimize_seeds`); the certified, simulated
    result, when it beats its seed, becomes ``by_name[OPTIMIZED]``. Returns the winner's
    name and ``motion.optimization``."""
    order = choose_seeds({n: by_name[n].total_energy for n in feasible}, motion.seeds)
    seeds = [(n, seed_curve(drive, by_name[n]), by_name[n].duration, by_name[n])
             for n in order]
    shown.set_postfix_str(order[0])
    name, out = optimize_seeds(drive, checker, seeds, options,
                               on_seed=lambda n: (shown.set_postfix_str(n), shown.update(1)))
    rec = dict(out.record)
    if out.motion is None:
        rec.update(kept_seed=True, seed=best, energy_before=by_name[best].total_energy,
                   energy_after=by_name[best].total_energy)
        return best, rec
    m = out.motion
    m.alternative = by_name[name]
    _stretch_front(drive, options, motion, m, by_name[name], name)
    by_name[OPTIMIZED] = m
    rec.update(kept_seed=False, seed=name, energy_before=by_name[name].total_energy,
               energy_after=m.total_energy, iterations=int(rec.get("iterations", 0)),
               certified=bool(rec.get("certified", True)))
    return OPTIMIZED, rec


def _stretch_front(drive: Drive, options: Any, motion: MotionOptions, m: MotionEnergy,
                   seed: MotionEnergy, name: str) -> None:
    """Give the optimised motion ``m`` its own energy–time front (docs/design.md §9c): the
    fastest feasible stretch of its curve, the screen from there to the longer of its
    duration and its seed's longest (within ``max_duration``), and its two ends simulated
    besides its own duration; and its duration rule (its seed's duration)."""

    longest = max(float(seed.longest or seed.duration), float(m.duration))
    if motion.max_duration is not None:
        longest = max(min(longest, float(motion.max_duration)), float(m.duration))
    p = stretch_front(drive, m.curve, options, longest, points=2,
                      include=(float(m.duration),))
    m.fastest = float(min(p.lower(), m.duration))
    m.velocity_fastest = float(p.t_velocity)
    m.longest = float(p.hi)
    m.ideal_curve = list(p.ideal)
    m.duration_curve = p.simulated()
    m.duration_rule = (f"the duration of its seed, the {name} ({seed.execution}: "
                       f"{seed.duration_rule or 'its own timing'}), optimised at that duration")
