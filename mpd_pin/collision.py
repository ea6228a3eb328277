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
plus one copy of the data into the thread pool (no model rebuild, ~µs per pool
entry). Distances use two more ``GeometryData`` of the same model, one with only
the obstacle pairs active and one with only the hazard pairs.

Exactness and tolerances
------------------------
Every collision request has ``security_margin = 0``: a pair collides exactly
when the geometries overlap (touching counts as collision). The only extra
margin is the hazards' ``clearance`` when it is enforced
(:meth:`CollisionChecker.set_hazard_clearance`). ``distance_upper_bound`` is set
to the margin so GJK stops as soon as it proves separation (a 1.5–2× speed-up
that does not change the boolean answer).

Coal handles the links' cylinders with GJK/EPA on the exact support function
(coal 3 inflates a cylinder's support point by a relative 1e-10 only in the
degenerate directions exactly along or across its axis, i.e. ≤ 1e-11 m here),
so the answer is exact up to the GJK tolerance ``gjk_tolerance = 1e-6``:
configurations whose true signed distance lies within about 1e-6 m of contact
may be reported either way. We keep that tolerance (tighter values cost time
and cannot beat floating-point kinematics anyway); the tests compare with an
exact 2-D geometry and count the disagreements, all within 1e-6 m of contact.
Use a positive ``margin`` for a conservative checker.

Backends (measured on the shared 2-core machine, ``bench/collision.py``)
------------------------------------------------------------------------
3-link arm + 2 obstacles, configurations per second: loop of
``pin.computeCollisions`` over pairs ≈ 2.8–3.8e5; loop over a naive
broad-phase manager ≈ 1.3–4.6e5; ``computeCollisionsInParallel`` with a
``GeometryPool`` ≈ 6.0e5 (1 thread) / 2.8–8.1e5 (2 threads); with a
``BroadPhaseManagerPool`` (dynamic AABB tree) ≈ 3.7–6.1e5 (1 thread) /
3.4–9.8e5 (2 threads). Panda (mesh links) + 2 boxes: loop of pairs ≈ 1.3–1.6e4;
naive broad-phase loop ≈ 3.3–8.2e4; ``GeometryPool`` ≈ 0.9–1.7e4 / 1.4–2.6e4;
``BroadPhaseManagerPool`` ≈ 3.9–7.5e4 / 3.2–12e4. (The sweep-and-prune manager
disagreed with the exact pairs on the planar arm, so it is not used.) Chosen:
single queries go through a naive broad-phase manager (AABB culling, then the
exact narrow phase), batches through ``computeCollisionsInParallel`` on a
``BroadPhaseManagerPool`` — the fastest or within noise of it on both arms.

Thread safety: a checker owns its Pinocchio ``Data``/``GeometryData`` and thread
pool; do not call one checker from several Python threads at once (use
:meth:`CollisionChecker.copy` per thread). The batch methods are parallel inside.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from .arm import Arm
from .world import Hazard, World, geometry_object

__all__ = ["CollisionChecker", "edge_configurations", "GJK_TOLERANCE"]

#: GJK tolerance of the collision requests (Coal's default is 1e-6; 1e-9 costs no
#: measurable time here and shrinks the band of undecided near-contact configurations).
GJK_TOLERANCE = 1e-9


def _bisection_order(n: int) -> np.ndarray:
    """Indices 0..n with both ends first, then midpoints coarse to fine (for early exit)."""
    if n <= 1:
        return np.arange(n + 1)
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
    return np.array(order)


def edge_configurations(q0: np.ndarray, q1: np.ndarray, resolution: float) -> np.ndarray:
    """Configurations checked along the straight joint-space edge q0 → q1, both ends included.

    ``n = ceil(max_k |q1_k − q0_k| / resolution)`` equal steps (at least one), so
    no joint moves more than ``resolution`` (rad, or m for prismatic joints)
    between consecutive checks. Returns an (n + 1, nq) array in path order.
    """
    d = float(np.max(np.abs(q1 - q0))) if q0.size else 0.0
    n = max(1, math.ceil(d / resolution - 1e-9))
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
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
        Security margin (m) for obstacle and self-collision pairs; 0 = exact.
    num_threads:
        Threads for the batch queries (default: number of CPUs).
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
        self._manager = pin.BroadPhaseManager_NaiveCollisionManager(
            self.model, self.geom_model, self.geom_data
        )
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
            margins[idx] = self._clearance[name] if self._hazard_clearance else 0.0
        return active, margins, dist, haz

    def _sync(self, force: bool = False) -> None:
        """Bring pair activation and margins in line with the world (cheap when unchanged)."""
        if not force and self._synced_version == self.world.version:
            return
        active, margins, dist, haz = self._pair_state()
        if force or not (
            np.array_equal(active, self._active) and np.array_equal(margins, self._margins)
        ):
            for k in range(self._npairs):
                req = self.geom_data.collisionRequests[k]
                req.security_margin = float(margins[k])
                # Run EPA when GJK is inconclusive: without it (Pinocchio's default
                # enable_contact=False) shallow penetrations of the link cylinders, up to
                # ~2e-4 m in our tests, were reported as free.
                req.enable_contact = True
                req.gjk_tolerance = GJK_TOLERANCE
                # GJK may stop once separation beyond the margin is proven.
                req.distance_upper_bound = float(margins[k]) + 1e-9
                if active[k]:
                    self.geom_data.activateCollisionPair(k)
                else:
                    self.geom_data.deactivateCollisionPair(k)
            for data, flags in ((self._dist_data, dist), (self._hazard_data, haz)):
                for k in range(self._npairs):
                    if flags[k]:
                        data.activateCollisionPair(k)
                    else:
                        data.deactivateCollisionPair(k)
            self._pool.update(self.geom_data)
            self._active, self._margins = active, margins
        self._dist_idx = [int(k) for k in np.flatnonzero(dist)]
        self._haz_idx = [int(k) for k in np.flatnonzero(haz)]
        self._haz_clear_of = {
            k: self._clearance[n] for n, idx in self.hazard_pairs.items() for k in idx
        }
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
        )

    # ---------------------------------------------------------------- input
    def _q(self, q: Any, what: str = "q") -> np.ndarray:
        return self.arm.check_configuration(q, what)

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
    def is_free(self, q: Any) -> bool:
        """True if configuration ``q`` is collision-free (obstacles, hazards, self)."""
        q = self._q(q)
        self._sync()
        return not pin.computeCollisions(self.model, self.data, self._manager, q, True)

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
            if pin.computeCollisions(self.model, self.data, self._manager, Q[i], True):
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
        trajectories = pin.StdVec_MatrixXs()
        for k in range(K):
            Q = edge_configurations(Q0[k], Q1[k], r)
            trajectories.append(np.asfortranarray(Q[_bisection_order(len(Q) - 1)].T))
        res = pin.computeCollisionsInParallel(self.num_threads, self._pool, trajectories, True)
        return np.array([not np.any(np.asarray(v, dtype=bool)) for v in res], dtype=bool)

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
