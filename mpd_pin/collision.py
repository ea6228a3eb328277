"""Configuration and edge validity for an arm in a :class:`~mpd_pin.world.World` (DESIGN §4).

:class:`CollisionChecker` is an OMPL-style validity checker: it knows the arm
and the world but nothing about the planner. It builds ONE Pinocchio
``GeometryModel``: the arm's collision geometries, then every obstacle and
hazard of the world (hidden ones too) fixed to the universe joint. Its
collision pairs are

* arm geometry × obstacle, for every obstacle;
* arm geometry × hazard ("No Enter" zones are never entered);
* self-collision pairs: the arm's own pairs when it has some (example-robot-data
  robots come with their SRDF-filtered pairs), otherwise every pair of
  geometries on non-adjacent joints (planar arms: non-adjacent links; none for
  two links).

Hidden obstacles are in the model from the start; their pairs are simply
inactive in the ``GeometryData`` until revealed, so revealing is a flag flip
plus one copy of the data into the thread pool (no model rebuild: ~35 µs for a
planar arm, ~160 µs for the Panda). Distances use two more ``GeometryData`` of
the same model, one with only the obstacle pairs active and one with only the
hazard pairs.

Exactness and tolerances
------------------------
Every collision request has ``security_margin = 0``: a pair collides exactly
when the geometries overlap (touching counts as collision). The only extra
margin is the hazards' ``clearance`` when it is enforced
(:meth:`CollisionChecker.set_hazard_clearance`). ``distance_upper_bound`` is set
to the margin so GJK may stop as soon as it proves separation (it does not
change the boolean answer; no measurable speed-up here).

Coal's tolerance on the link cylinders: Coal 3 solves cylinder pairs with GJK
(+ EPA) on the exact support function (it inflates a cylinder's support point
by a relative 1e-10 only in the degenerate directions along or across its
axis, ≤ 1e-11 m here). Pinocchio's default requests, however, have
``enable_contact = False``: GJK alone then reported shallow penetrations (up to
~2e-4 m measured against the exact 2-D geometry) as free, when it converged on
a tiny positive distance instead of proving the origin inside. Every request
here sets ``enable_contact = True`` (EPA decides those cases) and
``gjk_tolerance = 1e-9`` (distance requests too: the default 1e-6 is relative
and gave ~1e-6 m distance errors). With that, configurations placed at known
signed distances from contact disagree with the exact geometry only when
|d| < 4e-7 m (tests/test_collision.py). EPA runs only on colliding pairs; it
costs ~1.7× in a batch of random planar configurations (no measurable cost on
the Panda). Use a positive ``margin`` for a conservative checker.

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
(the only pool that is fast with meshes, on par for primitives). Edges:
``edges_free`` passes each edge as one trajectory in bisection order with
per-trajectory early exit: 3.9e4 edges/s at 0.05 rad for the 3-link arm
(1.2× a loop of ``edge_free``, 1.9× one flat batch of all configurations),
1.2e4 edges/s for the Panda. Revealing an obstacle costs ~35 µs (planar) to
~160 µs (Panda); building a checker 0.5 ms / 3 ms. Two threads did not pay
on the loaded machine: pass ``num_threads`` to suit yours.

Thread safety: a checker owns its Pinocchio ``Data``/``GeometryData`` and thread
pool; do not call one checker from several Python threads at once (use
:meth:`CollisionChecker.copy` per thread). The batch methods are parallel inside.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Sequence
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from .arm import Arm
from .world import Hazard, World, geometry_object

__all__ = ["CollisionChecker", "edge_configurations", "GJK_TOLERANCE"]

#: GJK tolerance of the collision requests (Coal's default is 1e-6; 1e-9 costs no
#: measurable time here and shrinks the band of undecided near-contact configurations).
GJK_TOLERANCE = 1e-9


@functools.lru_cache(maxsize=1024)
def _bisection_order(n: int) -> np.ndarray:
    """Indices 0..n with both ends first, then midpoints coarse to fine (for early exit)."""
    if n <= 1:
        out = np.arange(n + 1)
        out.flags.writeable = False
        return out
    order = [0, n]
    intervals = [(0, n)]
    while intervals:
        nxt = []
        for a, b in intervals:
            if b - a > 1:
                m = (a + b) // 2
                order.append(m)
                nxt.append((a, m))
                nxt.append((m, b))
        intervals = nxt
    out = np.array(order)
    out.flags.writeable = False  # cached: shared between calls
    return out


def edge_configurations(q0: np.ndarray, q1: np.ndarray, resolution: float) -> np.ndarray:
    """Configurations checked along the straight joint-space edge q0 → q1, both ends included.

    ``n = ceil(max_k |q1_k − q0_k| / resolution)`` equal steps (at least one), so
    no joint moves more than ``resolution`` (rad, or m for prismatic joints)
    between consecutive checks. Returns an (n + 1, nq) array in path order.
    """
    d = float(np.max(np.abs(q1 - q0))) if q0.size else 0.0
    n = max(1, math.ceil(d / resolution - 1e-9))
    t = (np.arange(n + 1) / n)[:, None]
    return q0[None, :] + t * (q1 - q0)[None, :]


class CollisionChecker:
    """Validity checker for ``arm`` among the obstacles of ``world``.

    Parameters
    ----------
    arm:
        The arm (its ``collision_model`` supplies the link geometry).
    world:
        Obstacles and hazards; None for an empty world. The checker follows the
        world: obstacles revealed through ``world.reveal`` (or :meth:`reveal`)
        count from the next query on.
    include_hidden:
        Check against hidden obstacles too (ground truth) instead of only known ones.
    self_collision:
        None or True: self-collision pairs as described in the module docstring;
        False: none.
    hazard_clearance:
        If True, configurations closer than a hazard's ``clearance`` to it are
        invalid; if False (default) hazards only may not be entered.
    margin:
        Security margin (m) for every pair (obstacles, hazards, self); 0 = exact.
        An enforced hazard clearance larger than ``margin`` replaces it.
    num_threads:
        Threads for the batch queries (default: number of CPUs).
    single_backend:
        Single queries (:meth:`is_free`, :meth:`edge_free`): ``"pairs"`` loops over
        the collision pairs, ``"broadphase"`` culls them with AABBs first;
        ``"auto"`` picks broad phase when the arm has mesh geometry, else pairs.
    """

    def __init__(
        self,
        arm: Arm,
        world: World | None = None,
        *,
        include_hidden: bool = False,
        self_collision: bool | None = None,
        hazard_clearance: bool = False,
        margin: float = 0.0,
        num_threads: int | None = None,
        single_backend: str = "auto",
    ) -> None:
        if not isinstance(arm, Arm):
            raise ValueError(f"arm must be an mpd_pin.Arm, got {type(arm).__name__}")
        if world is None:
            world = World()
        if not isinstance(world, World):
            raise ValueError(f"world must be an mpd_pin.World, got {type(world).__name__}")
        margin = float(margin)
        if not math.isfinite(margin) or margin < 0.0:
            raise ValueError(f"margin must be finite and >= 0 (m), got {margin!r}")
        if num_threads is None:
            num_threads = os.cpu_count() or 1
        if int(num_threads) < 1:
            raise ValueError(f"num_threads must be >= 1, got {num_threads!r}")
        if single_backend not in ("auto", "pairs", "broadphase"):
            raise ValueError(
                f"single_backend must be 'auto', 'pairs' or 'broadphase', got {single_backend!r}"
            )
        self._single_backend = single_backend
        self.arm = arm
        self.world = world
        self.margin = margin
        self.num_threads = int(num_threads)
        self._include_hidden = bool(include_hidden)
        self._hazard_clearance = bool(hazard_clearance)
        self._self_collision = self_collision
        self._build()

    # ------------------------------------------------------------------ build
    def _build(self) -> None:
        arm, world = self.arm, self.world
        self.model: pin.Model = arm.model
        self.data: pin.Data = arm.model.createData()
        gm = pin.GeometryModel()
        arm_cm = arm.collision_model
        for go in arm_cm.geometryObjects:
            gm.addGeometryObject(pin.GeometryObject(go))
        n_arm = arm_cm.ngeoms
        self.arm_geometry_ids: list[int] = list(range(n_arm))

        # Self-collision pairs.
        self_pairs: list[tuple[int, int]] = []
        if self._self_collision is not False:
            if len(arm_cm.collisionPairs) > 0:
                self_pairs = [(cp.first, cp.second) for cp in arm_cm.collisionPairs]
            else:
                parents = list(arm.model.parents)
                for i in range(n_arm):
                    for j in range(i + 1, n_arm):
                        ji = arm_cm.geometryObjects[i].parentJoint
                        jj = arm_cm.geometryObjects[j].parentJoint
                        if ji == jj or parents[ji] == jj or parents[jj] == ji:
                            continue
                        self_pairs.append((i, j))

        # Obstacles and hazards: all of them, hidden ones included (pairs toggled later).
        self._geom_of: dict[str, int] = {}
        self._clearance: dict[str, float] = {}
        for item in world:
            if isinstance(item, Hazard):
                gid = gm.addGeometryObject(geometry_object(item.shape, f"hazard:{item.name}"))
                self._clearance[item.name] = item.clearance
            else:
                gid = gm.addGeometryObject(geometry_object(item, f"obstacle:{item.name}"))
            self._geom_of[item.name] = gid

        self.self_pairs: list[int] = []
        self.obstacle_pairs: dict[str, list[int]] = {}
        self.hazard_pairs: dict[str, list[int]] = {}
        k = 0
        for i, j in self_pairs:
            gm.addCollisionPair(pin.CollisionPair(i, j))
            self.self_pairs.append(k)
            k += 1
        for item in world:
            target = self.hazard_pairs if isinstance(item, Hazard) else self.obstacle_pairs
            target[item.name] = []
            for a in self.arm_geometry_ids:
                gm.addCollisionPair(pin.CollisionPair(a, self._geom_of[item.name]))
                target[item.name].append(k)
                k += 1
        self.geom_model: pin.GeometryModel = gm
        self.geom_data: pin.GeometryData = gm.createData()
        self._dist_data = gm.createData()
        self._hazard_data = gm.createData()
        self._npairs = k
        self._active = np.zeros(k, dtype=bool)
        self._margins = np.zeros(k)
        self._dist_flags = np.zeros(k, dtype=bool)
        self._haz_flags = np.zeros(k, dtype=bool)
        self._haz_clear_of = {
            k: self._clearance[n] for n, idx in self.hazard_pairs.items() for k in idx
        }
        self._manager = pin.BroadPhaseManager_NaiveCollisionManager(
            self.model, self.geom_model, self.geom_data
        )
        if self._single_backend == "auto":
            meshes = any(
                go.geometry.getObjectType() != coal.OT_GEOM for go in arm_cm.geometryObjects
            )
            self.single_backend = "broadphase" if meshes else "pairs"
        else:
            self.single_backend = self._single_backend
        self._pool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(
            self.model, self.geom_model, self.num_threads
        )
        # Valid placements before the pool's AABB trees are first updated (coal rejects the
        # uninitialised bounding volumes otherwise).
        for gd in (self._dist_data, self._hazard_data):
            for req in gd.distanceRequests:
                req.gjk_tolerance = GJK_TOLERANCE  # default 1e-6 (relative): ~1e-6 m errors
        q_ref = pin.neutral(self.model)
        for gd in (self.geom_data, self._dist_data, self._hazard_data):
            pin.updateGeometryPlacements(self.model, self.data, gm, gd, q_ref)
        self._synced_version = -1
        self._sync(force=True)

    def _pair_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Desired (collision active, margins, obstacle-distance active, hazard active)."""
        active = np.zeros(self._npairs, dtype=bool)
        margins = np.full(self._npairs, self.margin)
        dist = np.zeros(self._npairs, dtype=bool)
        haz = np.zeros(self._npairs, dtype=bool)
        active[self.self_pairs] = True
        for name, idx in self.obstacle_pairs.items():
            if self._include_hidden or self.world.is_known(name):
                active[idx] = True
                dist[idx] = True
        for name, idx in self.hazard_pairs.items():
            if self._include_hidden or self.world.is_known(name):
                active[idx] = True
                haz[idx] = True
            clearance = self._clearance[name] if self._hazard_clearance else 0.0
            margins[idx] = max(self.margin, clearance)
        return active, margins, dist, haz

    def _sync(self, force: bool = False) -> None:
        """Bring pair activation and margins in line with the world (cheap when unchanged).

        Only the pairs whose state changed are touched; the thread pool then gets
        one copy of the updated ``GeometryData``.
        """
        if not force and self._synced_version == self.world.version:
            return
        active, margins, dist, haz = self._pair_state()
        changed_margin = np.flatnonzero(margins != self._margins)
        changed_active = np.flatnonzero(active != self._active)
        if force:
            changed_margin = changed_active = np.arange(self._npairs)
        for k in map(int, changed_margin):
            req = self.geom_data.collisionRequests[k]
            req.security_margin = float(margins[k])
            # Run EPA when GJK is inconclusive: without it (Pinocchio's default
            # enable_contact=False) shallow penetrations of the link cylinders, up to
            # ~2e-4 m in our tests, were reported as free.
            req.enable_contact = True
            req.gjk_tolerance = GJK_TOLERANCE
            # GJK may stop once separation beyond the margin is proven.
            req.distance_upper_bound = float(margins[k]) + 1e-9
        for k in map(int, changed_active):
            if active[k]:
                self.geom_data.activateCollisionPair(k)
            else:
                self.geom_data.deactivateCollisionPair(k)
        for data, flags, old in (
            (self._dist_data, dist, self._dist_flags),
            (self._hazard_data, haz, self._haz_flags),
        ):
            todo = np.arange(self._npairs) if force else np.flatnonzero(flags != old)
            for k in map(int, todo):
                if flags[k]:
                    data.activateCollisionPair(k)
                else:
                    data.deactivateCollisionPair(k)
        if force or changed_margin.size or changed_active.size:
            self._pool.update(self.geom_data)
        self._active, self._margins = active, margins
        self._dist_flags, self._haz_flags = dist, haz
        self._dist_idx = [int(k) for k in np.flatnonzero(dist)]
        self._haz_idx = [int(k) for k in np.flatnonzero(haz)]
        self._synced_version = self.world.version

    # ------------------------------------------------------------- settings
    @property
    def include_hidden(self) -> bool:
        """Whether hidden (not yet revealed) obstacles are checked too."""
        return self._include_hidden

    def set_include_hidden(self, flag: bool) -> None:
        """Check against all obstacles (True) or only the known ones (False)."""
        self._include_hidden = bool(flag)
        self._sync(force=True)

    @property
    def hazard_clearance(self) -> bool:
        """Whether hazards' clearances are enforced by :meth:`is_free`."""
        return self._hazard_clearance

    def set_hazard_clearance(self, flag: bool) -> None:
        """Enforce (True) or ignore (False) the hazards' clearances in validity checks."""
        self._hazard_clearance = bool(flag)
        self._sync(force=True)

    def reveal(self, *names: str) -> list[str]:
        """Reveal hidden obstacles in the world (and here); returns the newly revealed names."""
        new = self.world.reveal(*names)
        self._sync()
        return new

    def copy(self) -> CollisionChecker:
        """An independent checker on the same arm and world (e.g. one per Python thread)."""
        return CollisionChecker(
            self.arm,
            self.world,
            include_hidden=self._include_hidden,
            self_collision=self._self_collision,
            hazard_clearance=self._hazard_clearance,
            margin=self.margin,
            num_threads=self.num_threads,
            single_backend=self._single_backend,
        )

    # ---------------------------------------------------------------- input
    def _q(self, q: Any, what: str = "q") -> np.ndarray:
        """``q`` as a float array of length nq, else ValueError (fast path of
        ``Arm.check_configuration``: a few µs matter at 10⁵ queries per second)."""
        try:
            arr = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be {self.arm.nq} numbers, got {q!r}") from None
        if arr.shape != (self.arm.nq,):
            raise ValueError(f"{what} must have {self.arm.nq} joint values, got shape {arr.shape}")
        if not all(map(math.isfinite, arr.tolist())):
            raise ValueError(f"{what} contains NaN or infinity: {arr.tolist()}")
        return arr

    def _batch(self, Q: Any, what: str = "Q") -> np.ndarray:
        try:
            arr = np.asarray(Q, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be a (K, {self.arm.nq}) array of numbers") from None
        if arr.ndim != 2 or arr.shape[1] != self.arm.nq:
            raise ValueError(f"{what} must have shape (K, {self.arm.nq}), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} contains NaN or infinity")
        return arr

    @staticmethod
    def _resolution(resolution: Any) -> float:
        try:
            r = float(resolution)
        except (TypeError, ValueError):
            raise ValueError(f"resolution must be a number (rad), got {resolution!r}") from None
        if not math.isfinite(r) or r <= 0.0:
            raise ValueError(f"resolution must be finite and > 0 (rad), got {resolution!r}")
        return r

    # -------------------------------------------------------------- queries
    def _collides(self, q: np.ndarray) -> bool:
        if self.single_backend == "pairs":
            return pin.computeCollisions(
                self.model, self.data, self.geom_model, self.geom_data, q, True
            )
        return pin.computeCollisions(self.model, self.data, self._manager, q, True)

    def is_free(self, q: Any) -> bool:
        """True if configuration ``q`` is collision-free (obstacles, hazards, self)."""
        q = self._q(q)
        self._sync()
        return not self._collides(q)

    def is_free_batch(self, Q: Any) -> np.ndarray:
        """Validity of each row of ``Q`` (K, nq) as a (K,) bool array (parallel)."""
        Q = self._batch(Q)
        self._sync()
        if Q.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        res = pin.computeCollisionsInParallel(
            self.num_threads, self._pool, np.asfortranarray(Q.T), True, False
        )
        return ~np.asarray(res, dtype=bool)

    def in_collision_pairs(self, q: Any) -> list[tuple[str, str]]:
        """Names of the geometry pairs in collision at ``q`` (diagnostics)."""
        q = self._q(q)
        self._sync()
        pin.computeCollisions(self.model, self.data, self.geom_model, self.geom_data, q, False)
        out = []
        for k in map(int, np.flatnonzero(self._active)):
            if self.geom_data.collisionResults[k].isCollision():
                cp = self.geom_model.collisionPairs[k]
                out.append(
                    (
                        self.geom_model.geometryObjects[cp.first].name,
                        self.geom_model.geometryObjects[cp.second].name,
                    )
                )
        return out

    def clearance(self, q: Any) -> float:
        """Signed minimum distance (m) from the arm to the known obstacles (negative: penetration).

        Self-collision and hazards are not included; +inf with no obstacles.
        For mesh geometry Coal reports penetrations as distances ≤ 0, not depths.
        """
        q = self._q(q)
        self._sync()
        if not self._dist_idx:
            return math.inf
        pin.computeDistances(self.model, self.data, self.geom_model, self._dist_data, q)
        res = self._dist_data.distanceResults
        return float(min(res[k].min_distance for k in self._dist_idx))

    def hazard_margin(self, q: Any) -> float:
        """min over known hazards of (distance to the hazard − its clearance) (m); +inf if none.

        Negative means closer than allowed (or inside the zone).
        """
        q = self._q(q)
        self._sync()
        if not self._haz_idx:
            return math.inf
        pin.computeDistances(self.model, self.data, self.geom_model, self._hazard_data, q)
        res = self._hazard_data.distanceResults
        return float(min(res[k].min_distance - self._haz_clear_of[k] for k in self._haz_idx))

    def distances(self, q: Any) -> dict[str, float]:
        """Signed distance (m) from the arm to each known obstacle and hazard, by name."""
        q = self._q(q)
        self._sync()
        out: dict[str, float] = {}
        pin.computeDistances(self.model, self.data, self.geom_model, self._dist_data, q)
        pin.computeDistances(self.model, self.data, self.geom_model, self._hazard_data, q)
        for pairs, data in ((self.obstacle_pairs, self._dist_data), (self.hazard_pairs,
                                                                     self._hazard_data)):
            for name, idx in pairs.items():
                if idx and data.activeCollisionPairs[idx[0]]:
                    out[name] = float(min(data.distanceResults[k].min_distance for k in idx))
        return out

    # ---------------------------------------------------------------- edges
    def edge_free(self, q0: Any, q1: Any, resolution: float) -> bool:
        """True if every configuration along q0 → q1 at joint-space ``resolution`` is free.

        See :func:`edge_configurations` (both ends included). Configurations are
        checked ends first, then by bisection, stopping at the first collision.
        Discrete checking: an obstacle thinner than the arm's sweep between two
        consecutive checks can be missed; choose ``resolution`` accordingly.
        """
        q0 = self._q(q0, "q0")
        q1 = self._q(q1, "q1")
        r = self._resolution(resolution)
        self._sync()
        Q = edge_configurations(q0, q1, r)
        for i in _bisection_order(len(Q) - 1):
            if self._collides(Q[i]):
                return False
        return True

    def edges_free(self, Q0: Any, Q1: Any, resolution: float) -> np.ndarray:
        """``edge_free`` for each row pair of ``Q0``, ``Q1`` (K, nq), as a (K,) bool array.

        All edges run in parallel on the broad-phase pool, each stopping at its
        first colliding configuration (ends first, then bisection).
        """
        Q0 = self._batch(Q0, "Q0")
        Q1 = self._batch(Q1, "Q1")
        if Q0.shape != Q1.shape:
            raise ValueError(f"Q0 and Q1 must have the same shape, got {Q0.shape} and {Q1.shape}")
        r = self._resolution(resolution)
        self._sync()
        K = Q0.shape[0]
        if K == 0:
            return np.zeros(0, dtype=bool)
        D = Q1 - Q0
        steps = np.maximum(1, np.ceil(np.abs(D).max(axis=1) / r - 1e-9).astype(np.int64))
        trajectories = pin.StdVec_MatrixXs()
        owner = np.empty(K, dtype=np.int64)  # edge index of each trajectory
        pos = 0
        for n in np.unique(steps):  # edges with the same step count, vectorised
            idx = np.flatnonzero(steps == n)
            t = (_bisection_order(int(n)) / n)[None, :, None]
            configs = Q0[idx, None, :] + t * D[idx, None, :]  # (k, n + 1, nq), C order
            for i in range(idx.size):
                trajectories.append(configs[i].T)  # (nq, n + 1), Fortran order: no copy
            owner[pos : pos + idx.size] = idx
            pos += idx.size
        res = pin.computeCollisionsInParallel(self.num_threads, self._pool, trajectories, True)
        out = np.empty(K, dtype=bool)
        for j, v in enumerate(res):
            out[owner[j]] = not any(v)
        return out

    # ----------------------------------------------------------------- info
    def __repr__(self) -> str:
        return (
            f"CollisionChecker(arm={self.arm.name!r}, obstacles={len(self.obstacle_pairs)}, "
            f"hazards={len(self.hazard_pairs)}, self_pairs={len(self.self_pairs)}, "
            f"include_hidden={self._include_hidden}, hazard_clearance={self._hazard_clearance})"
        )

    @property
    def known_obstacles(self) -> Sequence[str]:
        """Names of the obstacles and hazards currently checked."""
        return [
            n
            for n in [*self.obstacle_pairs, *self.hazard_pairs]
            if self._include_hidden or self.world.is_known(n)
        ]
