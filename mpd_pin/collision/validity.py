"""Configuration validity: collision of one configuration, batches and trajectories, distances.

docs/design.md §4. Plain functions over the Pinocchio model and data and a
:class:`QueryState` (which ``GeometryData``, broad-phase manager and thread pool a
query runs on); :class:`PoolLoader` keeps track of what each thread pool holds.
The ``GeometryData`` are preallocated by the checker and reused by every query.

Backends (bench/collision.py; shared 2-core machine under load ≈ 2, best of 3)
-----------------------------------------------------------------------------
Configurations per second, 3-link arm + 2 obstacles / Panda (mesh links) + 2 boxes:

* loop of ``pin.computeCollisions`` over the pairs: 2.4e5 / 1.6e4
* loop over a naive broad-phase manager: 2.8e5 / 7.5e4
* loop over a dynamic-AABB-tree manager: 1.2e5 / 5.2e4
* ``GeometryPool`` in parallel, 1 and 2 threads: 2.0e5, 2.4e5 / 1.6e4, 1.4e4
* ``BroadPhaseManagerPool`` in parallel, 1 and 2 threads: 2.9e5, 1.9e5 / 7.4e4, 6.3e4
* ``is_free`` in a loop (input checks included): 1.8e5 / 7.0e4

(Repeated runs vary by up to 2× with the machine's load; the sweep-and-prune
manager disagreed with the exact pairs on the planar arm and is not used.)
Chosen: single queries loop over the pairs for primitive-only arms and over a
naive broad-phase manager when the arm has meshes (``single_backend="auto"``);
batches use ``computeCollisionsInParallel`` on a ``BroadPhaseManagerPool``
(the only pool that is fast with meshes, on par for primitives). Revealing an
obstacle costs ~35 µs (planar) to ~160 µs (Panda); building a checker 0.5 ms /
3 ms (+ ~10 ms for the Panda's hull model on the first certified edge check).
Two threads did not pay on the loaded machine: pass ``num_threads`` to suit
yours.

Thread safety: a checker owns its Pinocchio ``Data``/``GeometryData`` and thread
pool; do not call one checker from several Python threads at once (use
:meth:`~mpd_pin.collision.CollisionChecker.copy` per thread). The batch methods
are parallel inside.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

__all__ = [
    "QueryState",
    "PoolLoader",
    "PARALLEL_MIN",
    "collides",
    "batch_collides",
    "trajectories_collide",
    "colliding_pairs",
    "min_distance",
    "hazard_margin",
    "distances",
]

#: Batches smaller than this run on one thread (see :meth:`PoolLoader.threads_for`).
PARALLEL_MIN = 32


class QueryState(NamedTuple):
    """What a collision query runs on: the requests and pair flags (``gd``), the
    single-query broad-phase manager (None: loop over the pairs), the thread pool and
    the geometry model ``gd`` belongs to; ``screen``, when given, a state with the same
    pairs and requests on geometry that contains this one's (convex hulls of its meshes):
    a configuration free there is free here, so only the screen's hits are queried here
    (docs/design.md §4b, "Hull screen")."""

    gd: pin.GeometryData
    manager: Any
    pool: Any
    gm: pin.GeometryModel
    screen: Any = None


class PoolLoader:
    """Thread pools and what they hold: a pool is updated (its threads get copies of a
    ``GeometryData``: requests and pair flags) only when it holds another one."""

    def __init__(self, num_threads: int) -> None:
        self.num_threads = int(num_threads)
        self._holds: dict[int, pin.GeometryData] = {}  # id(pool) -> data it holds copies of

    def load(self, pool: Any, gd: pin.GeometryData, force: bool = False) -> None:
        """Make ``pool`` hold copies of ``gd`` (``force``: ``gd`` changed in place)."""
        if force or self._holds.get(id(pool)) is not gd:
            pool.update(gd)  # copies gd's requests and pair flags into every thread
            self._holds[id(pool)] = gd

    def threads_for(self, n: int) -> int:
        """Threads for a batch of ``n`` queries."""
        # Small batches on one thread: on a loaded machine an OpenMP barrier waiting for
        # a descheduled thread cost ~10 ms per call (measured), far more than the work.
        return self.num_threads if n >= PARALLEL_MIN else 1


def collides(model: pin.Model, data: pin.Data, state: QueryState, q: np.ndarray) -> bool:
    """Whether configuration ``q`` collides under ``state`` (stops at the first pair)."""
    if state.screen is not None:
        if not collides(model, data, state.screen, q):
            return False
        state = state._replace(screen=None)
    if state.manager is None:
        return pin.computeCollisions(model, data, state.gm, state.gd, q, True)
    return pin.computeCollisions(model, data, state.manager, q, True)


def batch_collides(
    model: pin.Model,
    data: pin.Data,
    state: QueryState,
    Q: np.ndarray,
    pools: PoolLoader | None,
) -> np.ndarray:
    """Collision (K,) of each row of Q (K, nq) under ``state``: in parallel on the state's
    pool when ``pools`` is given, else one by one."""
    if state.screen is not None:
        hit = batch_collides(model, data, state.screen, Q, pools)
        if hit.any():
            hit[hit] = batch_collides(model, data, state._replace(screen=None),
                                      np.ascontiguousarray(Q[hit]), pools)
        return hit
    if pools is not None:
        pools.load(state.pool, state.gd)
        res = pin.computeCollisionsInParallel(
            pools.threads_for(Q.shape[0]), state.pool, np.asfortranarray(Q.T), True, False
        )
        return np.asarray(res, dtype=bool)
    return np.array([collides(model, data, state, q) for q in Q], dtype=bool)


def trajectories_collide(
    model: pin.Model,
    data: pin.Data,
    state: QueryState,
    trajectories: list[np.ndarray],
    pools: PoolLoader | None,
) -> list[np.ndarray]:
    """Per-configuration collision of each (n_i, nq) C-ordered trajectory under ``state``,
    stopping each trajectory at its first collision (later entries False); in parallel
    when ``pools`` is given."""
    if state.screen is not None:  # free on the screen up to its first hit: free here too
        first = trajectories_collide(model, data, state.screen, trajectories, pools)
        out = [np.zeros(len(T), dtype=bool) for T in trajectories]
        rest = [(t, int(np.argmax(r))) for t, r in enumerate(first) if r.any()]
        if rest:
            hits = trajectories_collide(model, data, state._replace(screen=None),
                                        [trajectories[t][f:] for t, f in rest], pools)
            for (t, f), r in zip(rest, hits, strict=True):
                out[t][f:] = r
        return out
    if pools is None:
        out = []
        for T in trajectories:
            r = np.zeros(len(T), dtype=bool)
            for j, q in enumerate(T):
                if collides(model, data, state, q):
                    r[j] = True
                    break
            out.append(r)
        return out
    pools.load(state.pool, state.gd)
    vec = pin.StdVec_MatrixXs()
    for T in trajectories:
        vec.append(T.T)  # (nq, n_i) Fortran view of a C-ordered block: no copy
    res = pin.computeCollisionsInParallel(
        pools.threads_for(sum(len(T) for T in trajectories)), state.pool, vec, True
    )
    return [np.asarray(v, dtype=bool) for v in res]


def colliding_pairs(
    model: pin.Model,
    data: pin.Data,
    gm: pin.GeometryModel,
    gd: pin.GeometryData,
    active: np.ndarray,
    q: np.ndarray,
) -> list[tuple[str, str]]:
    """Names of the active geometry pairs of ``gm`` in collision at ``q`` (all pairs checked)."""
    pin.computeCollisions(model, data, gm, gd, q, False)
    out = []
    for k in map(int, np.flatnonzero(active)):
        if gd.collisionResults[k].isCollision():
            cp = gm.collisionPairs[k]
            out.append((gm.geometryObjects[cp.first].name, gm.geometryObjects[cp.second].name))
    return out


def min_distance(
    model: pin.Model,
    data: pin.Data,
    gm: pin.GeometryModel,
    gd: pin.GeometryData,
    pairs: list[int],
    q: np.ndarray,
) -> float:
    """Smallest signed distance (m) over ``pairs`` at ``q`` (+inf if none), computed on the
    distance data ``gd`` (its active pairs)."""
    if not pairs:
        return math.inf
    pin.computeDistances(model, data, gm, gd, q)
    res = gd.distanceResults
    return min(res[k].min_distance for k in pairs)


def hazard_margin(
    model: pin.Model,
    data: pin.Data,
    gm: pin.GeometryModel,
    gd: pin.GeometryData,
    clearance_of: dict[int, float],
    pairs: list[int],
    q: np.ndarray,
) -> float:
    """min over ``pairs`` of (signed distance − ``clearance_of[pair]``) (m); +inf if none."""
    if not pairs:
        return math.inf
    pin.computeDistances(model, data, gm, gd, q)
    res = gd.distanceResults
    return float(min(res[k].min_distance - clearance_of[k] for k in pairs))


def distances(
    model: pin.Model,
    data: pin.Data,
    gm: pin.GeometryModel,
    groups: list[tuple[dict[str, list[int]], pin.GeometryData]],
    q: np.ndarray,
) -> dict[str, float]:
    """Signed distance (m) to each named group of pairs whose pairs are active in its
    distance data: ``groups`` lists (pairs by name, distance data)."""
    for _, gd in groups:
        pin.computeDistances(model, data, gm, gd, q)
    out: dict[str, float] = {}
    for pairs, gd in groups:
        for name, idx in pairs.items():
            if idx and gd.activeCollisionPairs[idx[0]]:
                out[name] = float(min(gd.distanceResults[k].min_distance for k in idx))
    return out
