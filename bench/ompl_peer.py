"""OMPL peer for the benchmarks: random hard queries and RRTConnect waypoints (OMPL 2.0.1).

Imported by the other bench scripts as ``ompl_peer`` (``bench/`` is on ``sys.path`` when
they run as ``python bench/<name>.py``); needs the ``bench`` extra (``ompl>=2.0``).

OMPL 2.0.1 nanobind bindings, calls that work (there is no ``ob.ScopedState`` and
``ob.State`` has no constructor):

* ``space = ob.RealVectorStateSpace(nq)``; ``b = ob.RealVectorBounds(nq)``,
  ``b.setLow(i, lo)``, ``b.setHigh(i, hi)``, ``space.setBounds(b)``;
* ``s = space.allocState()`` (a ``RealVectorStateType``, values uninitialised),
  ``s[i] = x``; ``s[:nq]`` is a list of floats, also for the states handed to the
  validity callback; ``s[i]`` is not bounds-checked (``s[nq]`` reads garbage);
* ``ss = og.SimpleSetup(space)``; ``ss.setStateValidityChecker(callable)`` takes a
  plain Python callable ``State -> bool``; ``ss.setStartAndGoalStates(s, g)``;
  ``ss.setPlanner(og.RRTConnect(si))``; ``ss.solve(seconds)`` returns a ``PlannerStatus``
  (truthy also for approximate solutions: compare with
  ``ob.PlannerStatus.EXACT_SOLUTION`` or use ``ss.haveExactSolutionPath()``);
* ``p = ss.getSolutionPath()`` (``og.PathGeometric``): ``p.getStates()``, ``p.length()``;
  ``ps = og.PathSimplifier(si)``: ``ps.reduceVertices(p)``, ``ps.partialShortcutPath(p)``,
  ``ps.simplifyMax(p)`` modify ``p`` in place;
* ``ou.setLogLevel(ou.LOG_WARN)`` silences the Debug/Info lines.

Objects left in module globals of a script make nanobind print "leaked instances"
at exit; keep them inside functions.

Seeding: ``ou.RNG.setSeed(s)`` reseeds OMPL's global seed generator, from which every
``RNG`` constructed later (planner, samplers, simplifier) draws its seed. After the
first RNG exists OMPL logs an error ("Random number generation already started ...")
but reseeds anyway (measured with 2.0.1: the same query with the same seed gives the
same path whatever ran before, in one process). So :func:`ompl_waypoints` reseeds
before building its ``SimpleSetup``, with the log muted for that call. Runs repeat
exactly only while RRTConnect stops on its first solution before ``time_limit``; seed 0
is not allowed by OMPL, so ``seed + 1`` is used.

Measured 2026-12-03, 2-core machine (``PYTHONPATH=. python bench/ompl_peer.py``),
RRTConnect, 0.05 rad validity resolution, reduceVertices + partialShortcutPath
(certified: all segments pass our continuous check; rerun: same seed, same waypoints)
::

    panda: 5 queries (seed 0), RRTConnect 0.1 s, shortcut
    query solved wayp  length  seconds certified
        0   True    4   5.002   0.0122 True  (3/3 segments; rerun same: True)
        1   True    3   8.877   0.0225 True  (2/2 segments; rerun same: True)
        2   True    8  10.829   0.0156 True  (7/7 segments; rerun same: True)
        3   True    3   7.860   0.0149 True  (2/2 segments; rerun same: True)
        4   True    4   9.923   0.0277 True  (3/3 segments; rerun same: True)
    ur5: 3 queries (seed 0), RRTConnect 0.1 s, shortcut
    query solved wayp  length  seconds certified
        0   True    4  11.550   0.0195 True  (3/3 segments; rerun same: True)
        1  False    0     nan   0.1010 -     (0/0 segments; rerun same: True)
        2   True    3  11.412   0.0052 True  (2/2 segments; rerun same: True)
    solved paths with a segment failing the certified check: 0/7

Seconds vary with machine load (another job shared the 2 cores); lengths and waypoints
repeat across runs. UR5 query 1 is not solved in 20 s either: most likely no path exists
(the table splits the joint space). A larger sample (25 queries each, seed 1,
``time_limit=1``): Panda 25/25 solved; paths with a segment failing the certified check:
1 with "none", 1 with "shortcut", 4 with "simplifyMax"; UR5 21/25 solved, 0 failing
paths. Every failing segment really collides with the wall (hand or link 6; the
discrete check at 0.0005 rad finds it): OMPL's 0.05 rad steps step over the contact.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from mpd_pin.collision import CollisionChecker

ou.setLogLevel(ou.LOG_WARN)

SIMPLIFY = ("shortcut", "simplifyMax", "none")


def _limits(scn: Any) -> tuple[np.ndarray, np.ndarray]:
    model = scn.arm.model
    return np.asarray(model.lowerPositionLimit, float), np.asarray(model.upperPositionLimit, float)


def moving_clearance(checker: CollisionChecker) -> Callable[[np.ndarray], float]:
    """``q ↦`` smallest signed distance (m) from the moving links to known obstacles, hazards.

    Unlike ``checker.clearance`` it skips geometry fixed to the universe (the base): the
    UR5 base sits 7 mm above its table, so ``clearance(q) > 0.02`` never holds there.
    """
    gm, model = checker.geom_model, checker.model
    groups = {**checker.obstacle_pairs, **checker.hazard_pairs}
    objs = gm.geometryObjects
    pairs = [k for name in checker.known_obstacles for k in groups[name]
             if max(objs[gm.collisionPairs[k].first].parentJoint,
                    objs[gm.collisionPairs[k].second].parentJoint) > 0]
    gd, data = gm.createData(), model.createData()

    def clearance(q: np.ndarray) -> float:
        pin.updateGeometryPlacements(model, data, gm, gd, np.asarray(q, float))
        return min((pin.computeDistance(gm, gd, k).min_distance for k in pairs), default=np.inf)

    return clearance


def random_queries(
    scn: Any,
    n: int,
    seed: int,
    *,
    min_clearance: float = 0.02,
    min_spread: float = 1.0,
    resolution: float = 0.05,
    one_turn: bool = True,
    checker: CollisionChecker | None = None,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` (start, goal) pairs (rad) drawn uniformly inside the joint limits.

    Both ends are collision-free with clearance > ``min_clearance`` (m, from the moving
    links to the known obstacles and hazards: :func:`moving_clearance`), differ by at
    least ``min_spread`` rad in some joint, and the straight segment between them is not
    certified free at ``resolution`` rad. ``one_turn``: a joint with more than a turn of
    range is sampled in the turn (2π) centred in its limits; the UR5's ±2π joints otherwise
    give many infeasible pairs (the table splits the shoulder-lift range into components
    with the same poses a turn apart). Deterministic for ``seed``.
    """
    checker = checker if checker is not None else CollisionChecker(scn.arm, scn.world)
    lo, hi = _limits(scn)
    if one_turn:
        mid = (lo + hi) / 2
        lo, hi = np.maximum(lo, mid - np.pi), np.minimum(hi, mid + np.pi)
    rng = np.random.default_rng(seed)
    clearance = moving_clearance(checker)

    def ok(q: np.ndarray) -> bool:
        return checker.is_free(q) and clearance(q) > min_clearance

    out: list[tuple[np.ndarray, np.ndarray]] = []
    while len(out) < n:
        q0, q1 = rng.uniform(lo, hi), rng.uniform(lo, hi)
        if np.max(np.abs(q1 - q0)) < min_spread or not (ok(q0) and ok(q1)):
            continue
        if not checker.edges_free(q0[None], q1[None], resolution)[0]:
            out.append((q0, q1))
    return out


def _seed_ompl(seed: int) -> None:
    """Reseed OMPL's seed generator, muting the "already started" error it logs."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(seed) % 0xFFFFFFFF + 1)  # 0 is rejected by OMPL
    finally:
        ou.setLogLevel(level)


def ompl_waypoints(
    scn: Any,
    start: np.ndarray,
    goal: np.ndarray,
    *,
    seed: int,
    time_limit: float = 0.1,
    simplify: str = "shortcut",
    checker: CollisionChecker | None = None,
) -> dict[str, Any]:
    """Plan start → goal (rad) with OMPL RRTConnect, then simplify.

    Validity is ``checker.is_free`` at 0.05 rad steps (OMPL's discrete motion check).
    ``simplify``: ``"shortcut"`` (reduceVertices + partialShortcutPath), ``"simplifyMax"``
    or ``"none"``. Returns ``waypoints`` ((m, nq), start and goal included; (0, nq) if
    unsolved), ``plan_seconds`` (wall s of solve + simplify), ``solved`` (exact solution),
    ``certified`` (per segment, our continuous check at 0.05 rad) and ``length`` (rad,
    Euclidean in joint space; nan if unsolved).
    """
    if simplify not in SIMPLIFY:
        raise ValueError(f"simplify must be one of {SIMPLIFY}, got {simplify!r}")
    checker = checker if checker is not None else CollisionChecker(scn.arm, scn.world)
    lo, hi = _limits(scn)
    nq = lo.size
    _seed_ompl(seed)  # before any sampler of this query exists

    space = ob.RealVectorStateSpace(nq)
    bounds = ob.RealVectorBounds(nq)
    for i in range(nq):
        bounds.setLow(i, float(lo[i]))
        bounds.setHigh(i, float(hi[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(lambda s: checker.is_free(s[:nq]))
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(0.05 / space.getMaximumExtent())
    s0, s1 = space.allocState(), space.allocState()
    for i in range(nq):
        s0[i], s1[i] = float(start[i]), float(goal[i])
    ss.setStartAndGoalStates(s0, s1)
    ss.setPlanner(og.RRTConnect(si))

    t0 = time.perf_counter()
    solved = ss.solve(time_limit) == ob.PlannerStatus.EXACT_SOLUTION
    if solved:
        path = ss.getSolutionPath()
        ps = og.PathSimplifier(si)
        if simplify == "shortcut":
            ps.reduceVertices(path)
            ps.partialShortcutPath(path)
        elif simplify == "simplifyMax":
            ps.simplifyMax(path)
    seconds = time.perf_counter() - t0

    if not solved:
        return {"waypoints": np.zeros((0, nq)), "plan_seconds": seconds, "solved": False,
                "certified": [], "length": float("nan")}
    W = np.array([s[:nq] for s in path.getStates()], dtype=float)
    certified = [bool(c) for c in checker.edges_free(W[:-1], W[1:], 0.05)]
    length = float(np.linalg.norm(np.diff(W, axis=0), axis=1).sum())
    return {"waypoints": W, "plan_seconds": seconds, "solved": True,
            "certified": certified, "length": length}


def main() -> None:
    from mpd_pin.app.kinds import load_scenario

    failed = total = 0
    for name, n in (("panda", 5), ("ur5", 3)):
        scn = load_scenario(name)
        checker = CollisionChecker(scn.arm, scn.world)
        queries = random_queries(scn, n, seed=0, checker=checker)
        print(f"{name}: {n} queries (seed 0), RRTConnect 0.1 s, shortcut")
        print(f"{'query':>5} {'solved':>6} {'wayp':>4} {'length':>7} {'seconds':>8} certified")
        for k, (q0, q1) in enumerate(queries):
            r = ompl_waypoints(scn, q0, q1, seed=k, checker=checker)
            again = ompl_waypoints(scn, q0, q1, seed=k, checker=checker)
            same = np.array_equal(r["waypoints"], again["waypoints"])
            ok = all(r["certified"]) if r["solved"] else "-"
            total += r["solved"]
            failed += ok is False
            print(f"{k:>5} {r['solved']!s:>6} {len(r['waypoints']):>4} {r['length']:>7.3f} "
                  f"{r['plan_seconds']:>8.4f} {ok!s:<5} "
                  f"({sum(r['certified'])}/{len(r['certified'])} segments; rerun same: {same})")
    print(f"solved paths with a segment failing the certified check: {failed}/{total}")


if __name__ == "__main__":
    main()
