"""Configuration and edge validity for an arm in a World (docs/design.md §4).

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

Certified edges (the default of ``edge_free`` / ``edges_free``)
---------------------------------------------------------------
A discrete check at a fixed joint step misses overlaps thinner than the sweep
between two checks (~0.15 % of the random planar edges accepted at 0.05 rad
collide at 0.005 rad). The certified check proves the whole straight segment
q(t) = q0 + t (q1 − q0), t ∈ [0, 1], free; ``mode="discrete"`` (or
``edge_mode="discrete"``) keeps the old check for comparison.

*Bound.* For arm geometry g and a one-coordinate joint k on its kinematic path
(root → g's joint), with motion subspace (v_k, ω_k) in joint k's frame (unit ω
for a revolute joint, unit v for a prismatic one), every point x of g satisfies
|∂x/∂q_k| ≤ L[g, k] = |v_k| + |ω_k| ρ[g, k], where ρ[g, k] bounds |x − o_k|:
the norms of the joint-placement translations of the joints after k on the
path, plus |v_b| max|q_b| for prismatic joints b after k, plus the farthest
corner of g's local AABB placed in its joint's frame. Along the segment a
point's path is then no longer than Σ_k L[g, k] |Δq_k|. For pair p:

* arm geometry g × obstacle or hazard: W[p, k] = L[g, k] on g's path;
* self pair (g, h): the joints both paths share move both rigidly and do not
  change their distance; W[p, k] = L[g, k] on g's path only plus L[h, k] on
  h's path only (motion in the frame of their deepest common joint).

B_p(Δq) = W[p] · |Δq| bounds pair p's relative displacement
(:meth:`CollisionChecker.displacement_bounds`; tests compare it with forward
kinematics: measured path lengths reach up to 0.998 of it on the planar arms,
0.86 on the Panda).

*Certificate.* If pair p's clearance at the midpoint of a segment exceeds
margin_p + B_p/2, every configuration of the segment has clearance > margin_p
(each is within B_p/2 of the midpoint). Coal answers "clearance ≤ c?" as a
boolean collision query with ``security_margin = c`` (Pinocchio inflates the
broad-phase AABBs by the margin, so culling stays exact), far cheaper than
distances: no distance is ever computed. To batch these queries over edges
with one ``GeometryData`` per level, an edge's length is normalised,
λ = max_p (W[p] · |Δq|) / S_p with S_p = Σ_k W[p, k] (= the largest joint step
when all joints move alike), and the edge is cut into n = ⌈λ / resolution⌉
segments; a segment of normalised length ≤ h then has B_p ≤ S_p h for every
pair, and level h queries its midpoint with c_p = margin_p + S_p h / 2 +
CERTIFY_EPS (1e-6 m, above Coal's measured 4e-7 m error near contact).
``margin_p`` is the checker's ``margin`` (hazards: their clearance when
enforced). Level 0 checks each edge's midpoints ends-first-then-bisection with
early exit at the certification margins (an edge with no failure is accepted:
n queries, like the discrete check), an edge with a failure at the exact
margins (early exit: colliding edges end here), then its remaining midpoints.
Failed segments are bisected, h halves, and each half's midpoint is queried
at the new margins; a failed half is checked at the exact margins (a collision
rejects the edge). Below ``min_step`` (MIN_STEP = 1e-6, normalised rad) what
is left is "too close to call" and the edge is rejected: only edges whose
clearance above the margin somewhere is under about S_p · min_step + 1e-6 m
(≤ 6e-6 m for these arms) can be rejected although free. So ``resolution``
keeps its meaning as the (normalised) joint step between queries on an edge
far from everything; it changes the cost, not the guarantee: every accepted
edge is proven free at any value.

*Convex hulls.* Coal's mesh (BVH) queries slow down with the security margin
(Panda, margin 0.1 m: 6.3e3 vs 6.9e4 configurations/s at 0). Certification
queries therefore run on a second geometry model where each arm mesh whose
convex hull's volume is within 0.1 % of its own is replaced by that hull (all
nine Panda meshes: ≤ 0.03 %); GJK on a hull does not slow down (5.3e4/s at
0.1 m). The hull contains the mesh, so its clearance certifies the mesh; exact
checks stay on the meshes. A mesh that is not nearly convex is certified on
itself.

*Measured* (bench/collision.py, resolution 0.05 rad, best of 3, shared 2-core
machine at load ≈ 1; 1 thread / 2 threads; under load 4–5 all figures drop up
to 3×, the ratios stay within ~2–4.5×). 4000 random edges of the 3-link arm
among 2 obstacles: discrete 6.0e4 / 8.9e4 edges/s, certified 2.8e4 / 4.1e4
(2.2× the discrete time; per edge 6.8 certification + ≤ 1.9 exact queries).
500 random Panda edges among 2 boxes: discrete 9.5e3 / 1.0e4, certified
3.6e3 / 2.7e3 (2.7–3.7×; certifying on the meshes instead of the hulls: 1.1–2.1×
slower again, 4.5× under load). Roadmap-like edges (10 nearest neighbours among
free samples): 1.7–1.8× (planar), 2.3–2.8× (Panda). Resolutions 0.025 and 0.1
rad cost about the same. Acceptance, discrete vs certified: random edges 0.5570
vs 0.5567 (planar), 0.5840 vs 0.5820 (Panda); roadmap-like 0.9412 vs 0.9403 and
0.7017 vs 0.6970. Every edge the discrete check accepted and the certified one
rejected collides (found sampling at 1/20000 of the edge); no certified edge
collides at 1/100 of the resolution; no edge was too close to call. A loop of
single ``edge_free`` calls: 5–7e3 (planar) / 2.2–2.4e3 (Panda) certified
edges/s.

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
(the only pool that is fast with meshes, on par for primitives). Discrete
edges: ``edges_free(..., mode="discrete")`` passes each edge as one trajectory in
bisection order with per-trajectory early exit: 3.9e4 edges/s at 0.05 rad for
the 3-link arm (1.2× a loop of ``edge_free``, 1.9× one flat batch of all
configurations), 1.2e4 edges/s for the Panda (load ≈ 2; certified edges above).
Revealing an obstacle costs ~35 µs (planar) to ~160 µs (Panda); building a
checker 0.5 ms / 3 ms (+ ~10 ms for the Panda's hull model on the first
certified edge check). Two threads did not pay on the loaded machine: pass
``num_threads`` to suit yours.

Thread safety: a checker owns its Pinocchio ``Data``/``GeometryData`` and thread
pool; do not call one checker from several Python threads at once (use
:meth:`CollisionChecker.copy` per thread). The batch methods are parallel inside.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from collections.abc import Sequence
from typing import Any, NamedTuple

import coal
import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..world import Hazard, World, geometry_object

__all__ = [
    "CollisionChecker",
    "edge_configurations",
    "EDGE_MODES",
    "GJK_TOLERANCE",
    "CERTIFY_EPS",
    "MIN_STEP",
]

#: GJK tolerance of the collision requests (Coal's default is 1e-6; 1e-9 costs no
#: measurable time here and shrinks the band of undecided near-contact configurations).
GJK_TOLERANCE = 1e-9

#: Edge checks: "certified" (continuous, conservative; the default) or "discrete".
EDGE_MODES = ("certified", "discrete")

#: Extra clearance (m) every certificate demands beyond the bound, covering Coal's
#: distance error near contact (< 4e-7 m measured, see "Exactness" above).
CERTIFY_EPS = 1e-6

#: Default smallest segment (normalised joint step, rad) the certified check refines
#: to; an edge still undecided there is rejected ("too close to call").
MIN_STEP = 1e-6

_PARALLEL_MIN = 32  # batches smaller than this run on one thread (see _threads_for)
_HULL_VOLUME_TOL = 1e-3  # meshes within this relative volume of their hull certify on the hull


class _State(NamedTuple):
    """What a collision query runs on: requests, single-query manager, pool, geometry."""

    gd: pin.GeometryData
    manager: Any
    pool: Any
    gm: pin.GeometryModel


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
    edge_mode:
        Default of :meth:`edge_free` / :meth:`edges_free`: ``"certified"``
        (continuous, conservative: the whole straight segment is proven free) or
        ``"discrete"`` (configurations at a fixed joint step only).
    min_step:
        Smallest segment (normalised joint step, rad) the certified check refines to
        before rejecting an edge as too close to call.
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
        edge_mode: str = "certified",
        min_step: float = MIN_STEP,
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
        if edge_mode not in EDGE_MODES:
            raise ValueError(f"edge_mode must be one of {EDGE_MODES}, got {edge_mode!r}")
        min_step = float(min_step)
        if not math.isfinite(min_step) or min_step <= 0.0:
            raise ValueError(f"min_step must be finite and > 0 (rad), got {min_step!r}")
        self._single_backend = single_backend
        self.edge_mode = edge_mode
        self.min_step = min_step
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
        self._pool_gd: dict[int, pin.GeometryData] = {}  # id(pool) -> data it holds copies of
        self._levels: dict[tuple[float, bytes], _State] = {}
        self._normalised: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._cert: tuple[pin.GeometryModel, Any] | None = None  # built on first use
        self.certification_hulls: list[str] = []  # arm meshes certified on their convex hull
        self._setup_bounds()
        self.last_certify_stats: dict[str, int] = {}
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
            self._pool_gd[id(self._pool)] = self.geom_data
            self._levels.clear()  # certification margins derive from these pairs
            self._normalised.clear()
        self._active, self._margins = active, margins
        self._dist_flags, self._haz_flags = dist, haz
        self._dist_idx = [int(k) for k in np.flatnonzero(dist)]
        self._haz_idx = [int(k) for k in np.flatnonzero(haz)]
        self._synced_version = self.world.version

    # ------------------------------------------------------- motion bounds
    def _setup_bounds(self) -> None:
        """Per-geometry, per-joint lever arms for the displacement bound (module docstring).

        For arm geometry g and joint k on its kinematic path (root → g's joint),
        ``L[g, k] = |v_k| + |ω_k| · ρ[g, k]`` where (v_k, ω_k) is joint k's motion
        subspace in its own frame (unit ω for a revolute joint, unit v for a
        prismatic one) and ``ρ[g, k]`` bounds the distance from joint k's origin to
        any point of g: the norms of the joint placement translations below k on the
        path, plus ``|v_b| · |q_b|`` for every prismatic-like joint b below k, plus
        the farthest corner of g's local AABB placed in its joint's frame.
        """
        model, arm_cm = self.model, self.arm.collision_model
        nq, n_arm = model.nq, len(self.arm_geometry_ids)
        data = model.createData()
        pin.computeJointJacobians(model, data, pin.neutral(model))
        lin = np.zeros(model.njoints)
        ang = np.zeros(model.njoints)
        offset = np.zeros(model.njoints)
        col = np.full(model.njoints, -1)
        unsupported = []
        for j in range(1, model.njoints):
            if model.joints[j].nv != 1 or model.joints[j].nq != 1:
                unsupported.append(model.names[j])
                continue
            s_j = pin.getJointJacobian(model, data, j, pin.LOCAL)[:, model.idx_vs[j]]
            lin[j] = float(np.linalg.norm(s_j[:3]))
            ang[j] = float(np.linalg.norm(s_j[3:]))
            offset[j] = float(np.linalg.norm(model.jointPlacements[j].translation))
            col[j] = model.idx_qs[j]
        self._bound_unsupported = unsupported
        # L = A + M @ |q|max: A the configuration-independent part, M the prismatic terms.
        A = np.zeros((n_arm, nq))
        M = np.zeros((n_arm, nq, nq))
        on_path = np.zeros((n_arm, nq), dtype=bool)
        for g in range(n_arm):
            go = arm_cm.geometryObjects[g]
            geom = go.geometry
            box = geom.aabb_local
            if not np.all(np.isfinite(box.min_)) or np.any(box.min_ > box.max_):
                geom.computeLocalAABB()  # idempotent; normally done by the broad phase already
                box = geom.aabb_local
            lo, hi = np.asarray(box.min_), np.asarray(box.max_)
            corners = np.array([[(lo, hi)[b >> i & 1][i] for i in range(3)] for b in range(8)])
            placed = corners @ go.placement.rotation.T + go.placement.translation
            reach = float(np.linalg.norm(placed, axis=1).max())
            path = []
            j = go.parentJoint
            while j > 0:
                path.append(j)
                j = model.parents[j]
            path.reverse()
            for a, k in enumerate(path):
                if col[k] < 0:
                    continue
                below = path[a + 1 :]
                rho = reach + sum(offset[b] for b in below)
                A[g, col[k]] = lin[k] + ang[k] * rho
                on_path[g, col[k]] = True
                for b in below:
                    if lin[b] > 0 and col[b] >= 0:
                        M[g, col[k], col[b]] = ang[k] * lin[b]
        self._geom_A, self._geom_M = A, (M if np.any(M) else None)
        # Per pair: which joints move each side relative to the other.
        P = len(self.geom_model.collisionPairs)
        first = np.zeros(P, dtype=np.int64)
        second = np.zeros(P, dtype=np.int64)
        mask_a = np.zeros((P, nq))
        mask_b = np.zeros((P, nq))
        for k, cp in enumerate(self.geom_model.collisionPairs):
            a, b = int(cp.first), int(cp.second)
            if a >= n_arm:
                a, b = b, a
            first[k] = a
            if b < n_arm:  # self pair: the joints the two geometries share move both rigidly
                second[k] = b
                mask_a[k] = on_path[a] & ~on_path[b]
                mask_b[k] = on_path[b] & ~on_path[a]
            else:  # arm geometry × fixed obstacle or hazard
                mask_a[k] = on_path[a]
        self._pair_first, self._pair_second = first, second
        self._pair_mask_a, self._pair_mask_b = mask_a, mask_b
        self._W_const = None
        if self._geom_M is None:
            self._W_const = self._pair_weights(np.zeros(nq))

    def _pair_weights(self, qabs: np.ndarray) -> np.ndarray:
        """(P, nq) matrix W: pair p's geometries move relative to each other by at most
        ``W[p] · |Δq|`` along a straight segment whose prismatic coordinates stay
        within ``qabs`` in absolute value."""
        if self._geom_M is None and self._W_const is not None:
            return self._W_const
        L = self._geom_A if self._geom_M is None else self._geom_A + self._geom_M @ qabs
        return L[self._pair_first] * self._pair_mask_a + L[self._pair_second] * self._pair_mask_b

    def _qabs(self, *Qs: np.ndarray) -> np.ndarray:
        """Largest |q| per coordinate over the given configurations (prismatic terms only)."""
        if self._geom_M is None:
            return np.zeros(self.model.nq)
        return np.max([np.abs(Q).max(axis=0) for Q in Qs if Q.size], axis=0)

    def displacement_bounds(self, q0: Any, q1: Any) -> np.ndarray:
        """Bound (m) on the relative motion of each collision pair along q0 → q1, shape (P,).

        Every point of the pair's arm geometry moves (for self pairs: relative to the
        other geometry) along a path no longer than this while the joints move along
        the straight segment. Pair k is ``geom_model.collisionPairs[k]``.
        """
        q0 = self._q(q0, "q0")
        q1 = self._q(q1, "q1")
        self._require_bounds()
        return self._pair_weights(self._qabs(q0[None], q1[None])) @ np.abs(q1 - q0)

    def _require_bounds(self) -> None:
        if self._bound_unsupported:
            raise ValueError(
                "the certified edge check needs one-coordinate joints (revolute, prismatic); "
                f"joints {self._bound_unsupported} are not: use mode='discrete'"
            )

    # ------------------------------------------------------ certified edges
    def _certification_model(self) -> tuple[pin.GeometryModel, Any]:
        """Geometry for the certification queries, and its thread pool (built once).

        The checker's own model, except that every arm mesh that is convex up to
        ``_HULL_VOLUME_TOL`` (relative volume) is replaced by its convex hull: the hull
        contains the mesh, so clearance certified for the hull holds for the mesh,
        and GJK on a hull does not slow down with the security margin as a mesh's BVH
        traversal does (Panda links, margin 0.1 m: 5.3e4 vs 6.3e3 configurations/s).
        """
        if self._cert is not None:
            return self._cert
        gm = self.geom_model
        hulls = {}
        for g in self.arm_geometry_ids:
            geom = gm.geometryObjects[g].geometry
            if not isinstance(geom, coal.BVHModelBase):
                continue
            mesh = geom.clone()  # buildConvexHull stores the hull on the mesh: not the shared one
            try:
                mesh.buildConvexHull(True, "Qt")
                hull = mesh.convex
                v_mesh, v_hull = float(mesh.computeVolume()), float(hull.computeVolume())
            except Exception:  # qhull failure, degenerate mesh: keep the mesh
                continue
            # The hull always contains the mesh (sound either way); the volume test only
            # keeps hulls that hug their mesh, so certification loses nothing visible.
            if v_mesh > 0 and abs(v_hull - v_mesh) <= _HULL_VOLUME_TOL * v_hull:
                hull.computeLocalAABB()
                hulls[g] = hull
        if not hulls:
            self._cert = (gm, self._pool)
            return self._cert
        cm = pin.GeometryModel()
        for g, go in enumerate(gm.geometryObjects):
            if g in hulls:
                go = pin.GeometryObject(
                    go.name, go.parentJoint, go.parentFrame, go.placement, hulls[g]
                )
            else:
                go = pin.GeometryObject(go)
            cm.addGeometryObject(go)
        for cp in gm.collisionPairs:
            cm.addCollisionPair(pin.CollisionPair(cp.first, cp.second))
        pool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(
            self.model, cm, self.num_threads
        )
        self.certification_hulls = sorted(gm.geometryObjects[g].name for g in hulls)
        self._cert = (cm, pool)
        return self._cert

    def _weights_normalised(self, qabs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """W (P, nq) and the distinct rows W[p] / S_p of the active moving pairs."""
        key = qabs.tobytes()
        hit = self._normalised.get(key)
        if hit is not None:
            return hit
        W = self._pair_weights(qabs)
        S = W.sum(axis=1)
        rows = self._active & (S > 0)
        Wn = np.unique(W[rows] / S[rows, None], axis=0) if rows.any() else np.zeros((0, W.shape[1]))
        if len(self._normalised) > 256:
            self._normalised.clear()
        self._normalised[key] = (W, Wn)
        return W, Wn

    def _exact_state(self) -> _State:
        manager = self._manager if self.single_backend == "broadphase" else None
        return _State(self.geom_data, manager, self._pool, self.geom_model)

    def _level(self, h: float, W: np.ndarray, qabs: np.ndarray) -> _State:
        """Query state whose pair p answers "clearance ≤ c_p?" on the certification
        geometry, ``c_p = margin_p + S_p h / 2 + CERTIFY_EPS``, ``S_p = Σ_k W[p, k]``."""
        key = (h, qabs.tobytes())
        hit = self._levels.get(key)
        if hit is not None:
            return hit
        if len(self._levels) > 256:
            self._levels.clear()
        cm, pool = self._certification_model()
        if cm is self.geom_model:
            gd = self.geom_data.copy()
        else:
            gd = cm.createData()
            pin.updateGeometryPlacements(self.model, self.data, cm, gd, pin.neutral(self.model))
        c = self._margins + W.sum(axis=1) * (h / 2) + CERTIFY_EPS
        for k in range(self._npairs):
            req = gd.collisionRequests[k]
            req.security_margin = float(c[k])
            req.enable_contact = True
            req.gjk_tolerance = GJK_TOLERANCE
            if self._active[k]:
                gd.activateCollisionPair(k)
            else:
                gd.deactivateCollisionPair(k)
        manager = None
        if self.single_backend == "broadphase":
            manager = pin.BroadPhaseManager_NaiveCollisionManager(self.model, cm, gd)
        state = _State(gd, manager, pool, cm)
        self._levels[key] = state
        return state

    def _use_pool(self, pool: Any, gd: pin.GeometryData) -> None:
        if self._pool_gd.get(id(pool)) is not gd:
            pool.update(gd)  # copies gd's requests and pair flags into every thread
            self._pool_gd[id(pool)] = gd

    def _threads_for(self, n: int) -> int:
        # Small batches on one thread: on a loaded machine an OpenMP barrier waiting for
        # a descheduled thread cost ~10 ms per call (measured), far more than the work.
        return self.num_threads if n >= _PARALLEL_MIN else 1

    def _trajectories_collide(
        self, state: _State, trajectories: list[np.ndarray], parallel: bool
    ) -> list[np.ndarray]:
        """Per-configuration collision of each (n_i, nq) trajectory under ``state``,
        stopping each trajectory at its first collision (later entries False)."""
        if not parallel:
            out = []
            for T in trajectories:
                r = np.zeros(len(T), dtype=bool)
                for j, q in enumerate(T):
                    if self._collides_with(state, q):
                        r[j] = True
                        break
                out.append(r)
            return out
        self._use_pool(state.pool, state.gd)
        vec = pin.StdVec_MatrixXs()
        for T in trajectories:
            vec.append(T.T)  # (nq, n_i) Fortran view of a C-ordered block: no copy
        res = pin.computeCollisionsInParallel(
            self._threads_for(sum(len(T) for T in trajectories)), state.pool, vec, True
        )
        return [np.asarray(v, dtype=bool) for v in res]

    def _collides_with(self, state: _State, q: np.ndarray) -> bool:
        if state.manager is None:
            return pin.computeCollisions(self.model, self.data, state.gm, state.gd, q, True)
        return pin.computeCollisions(self.model, self.data, state.manager, q, True)

    def _batch_collides(self, state: _State, Q: np.ndarray, parallel: bool) -> np.ndarray:
        """Collision (K,) of each row of Q under ``state``."""
        if parallel:
            self._use_pool(state.pool, state.gd)
            res = pin.computeCollisionsInParallel(
                self._threads_for(Q.shape[0]), state.pool, np.asfortranarray(Q.T), True, False
            )
            return np.asarray(res, dtype=bool)
        return np.array([self._collides_with(state, q) for q in Q], dtype=bool)

    def _certify(self, Q0: np.ndarray, Q1: np.ndarray, h0: float, parallel: bool) -> np.ndarray:
        """Certified validity (K,) of the straight edges Q0[e] → Q1[e] (see module docstring)."""
        self._require_bounds()
        K = Q0.shape[0]
        D = Q1 - Q0
        qabs = self._qabs(Q0, Q1)
        W, Wn = self._weights_normalised(qabs)
        lam = (np.abs(D) @ Wn.T).max(axis=1) if Wn.size else np.zeros(K)  # normalised length
        n = np.maximum(1, np.ceil(lam / h0)).astype(np.int64)
        exact = self._exact_state()
        stats = {"edges": K, "levels": 1, "certify_queries": 0, "exact_queries": 0,
                 "too_close": 0}
        rejected = np.zeros(K, dtype=bool)

        # Level 0: edge e has n[e] segments. Their midpoints, ends first then by bisection,
        # are checked at the certification margins with early exit: an edge with no
        # failure is accepted with n[e] queries. An edge with one is checked at the exact
        # margins (early exit: colliding edges stop here), then its remaining midpoints
        # at the certification margins; failed segments go on to level 1.
        level0 = self._level(h0, W, qabs)
        traj: list[np.ndarray] = [np.empty(0)] * K  # edge e's midpoints in check order
        order_of: list[np.ndarray] = [np.empty(0, dtype=np.int64)] * K
        for m in map(int, np.unique(n)):  # build edges with the same count vectorised
            idx = np.flatnonzero(n == m)
            order = _bisection_order(m - 1) if m > 1 else np.zeros(1, dtype=np.int64)
            t = (order + 0.5) / m
            configs = Q0[idx, None, :] + t[None, :, None] * D[idx, None, :]  # (k, m, nq)
            for e, C in zip(idx.tolist(), configs, strict=True):
                traj[e] = C
                order_of[e] = order
        res = self._trajectories_collide(level0, traj, parallel)
        first = np.array([int(np.argmax(r)) if r.any() else -1 for r in res], dtype=np.int64)
        stats["certify_queries"] += int(np.where(first < 0, n, first + 1).sum())
        bad = np.flatnonzero(first >= 0)
        if bad.size:
            hits = self._trajectories_collide(exact, [traj[e] for e in bad], parallel)
            stats["exact_queries"] += sum(int(np.argmax(r)) + 1 if r.any() else len(r)
                                          for r in hits)
            hit = np.array([r.any() for r in hits], dtype=bool)
            rejected[bad[hit]] = True
            bad = bad[~hit]
        # the rest of these edges' midpoints (after the first failure), in one batch
        rest = [traj[e][first[e] + 1 :] for e in bad]
        sizes = np.array([len(r) for r in rest], dtype=np.int64)
        rest_fail = (self._batch_collides(level0, np.concatenate(rest), parallel)
                     if sizes.sum() else np.zeros(0, dtype=bool))
        stats["certify_queries"] += int(sizes.sum())
        seg_e_parts, seg_i_parts = [], []
        pos = 0
        for e, size in zip(bad.tolist(), sizes.tolist(), strict=True):
            f = np.zeros(n[e], dtype=bool)
            f[first[e]] = True
            f[first[e] + 1 :] = rest_fail[pos : pos + size]
            pos += size
            seg_i_parts.append(order_of[e][f])
            seg_e_parts.append(np.full(seg_i_parts[-1].size, e, dtype=np.int64))
        if not seg_e_parts:
            self.last_certify_stats = stats
            return ~rejected
        # Levels 1, 2, ...: bisect the failed segments (midpoints exactly free) and certify
        # the halves by their midpoints; a half that fails is checked at the exact margins.
        e = np.concatenate(seg_e_parts)
        i = np.concatenate(seg_i_parts)
        m = n[e]
        h = h0 / 2
        while e.size:
            seg_e = np.repeat(e, 2)
            seg_i = np.stack([2 * i, 2 * i + 1], axis=1).ravel()
            seg_n = np.repeat(2 * m, 2)
            if h < self.min_step:  # too close to call: reject what is left
                undecided = np.unique(seg_e)
                stats["too_close"] = int(undecided.size)
                rejected[undecided] = True
                break
            stats["levels"] += 1
            Qm = Q0[seg_e] + ((seg_i + 0.5) / seg_n)[:, None] * D[seg_e]
            fail = self._batch_collides(self._level(h, W, qabs), Qm, parallel)
            stats["certify_queries"] += int(Qm.shape[0])
            if fail.any():
                hit = self._batch_collides(exact, Qm[fail], parallel)
                stats["exact_queries"] += int(fail.sum())
                rejected[seg_e[fail][hit]] = True
                fail &= ~rejected[seg_e]
            e, i, m = seg_e[fail], seg_i[fail], seg_n[fail]
            h /= 2
        self.last_certify_stats = stats
        return ~rejected

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
            edge_mode=self.edge_mode,
            min_step=self.min_step,
        )

    def describe(self) -> dict:
        """Plain data fixing which configurations and edges are free (hashed into roadmap keys).

        Arm fingerprint, the checked world (known obstacles and hazards, or all with
        ``include_hidden``), self-collision pairs (geometry names), margin (m), hazard
        clearance enforcement, edge mode, min_step (rad) and the query tolerances.
        Threads and single-query backend do not change answers and are left out.
        """
        names = [go.name for go in self.geom_model.geometryObjects]
        pairs = self.geom_model.collisionPairs
        return {
            "checker": "mpd_pin.CollisionChecker/1",
            "arm": self.arm.fingerprint(),
            "world": self.world.known(include_hidden=self._include_hidden).fingerprint(),
            "include_hidden": self._include_hidden,
            "self_pairs": sorted(
                sorted((names[pairs[k].first], names[pairs[k].second])) for k in self.self_pairs
            ),
            "margin": self.margin,
            "hazard_clearance": self._hazard_clearance,
            "edge_mode": self.edge_mode,
            "min_step": self.min_step,
            "gjk_tolerance": GJK_TOLERANCE,
            "certify_eps": CERTIFY_EPS,
        }

    def fingerprint(self) -> str:
        """SHA-256 hex digest of :meth:`describe` (deterministic across processes)."""
        text = json.dumps(self.describe(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

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
        return ~self._batch_collides(self._exact_state(), Q, parallel=True)

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

    def clearance(self, q: Any, *, hazards: bool = True) -> float:
        """Signed minimum distance (m) from the arm to the known obstacles and hazards.

        Negative: penetration; +inf if there is nothing to measure to. Hazards count
        by their raw geometry (their clearance threshold is not subtracted: see
        :meth:`hazard_margin`); ``hazards=False`` measures to obstacles only.
        Self-collision is not included. For mesh geometry Coal reports penetrations
        as distances ≤ 0, not depths.
        """
        q = self._q(q)
        self._sync()
        best = math.inf
        if self._dist_idx:
            pin.computeDistances(self.model, self.data, self.geom_model, self._dist_data, q)
            res = self._dist_data.distanceResults
            best = min(res[k].min_distance for k in self._dist_idx)
        if hazards and self._haz_idx:
            pin.computeDistances(self.model, self.data, self.geom_model, self._hazard_data, q)
            res = self._hazard_data.distanceResults
            best = min(best, min(res[k].min_distance for k in self._haz_idx))
        return float(best)

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
    def _mode(self, mode: str | None) -> str:
        if mode is None:
            return self.edge_mode
        if mode not in EDGE_MODES:
            raise ValueError(f"mode must be one of {EDGE_MODES} or None, got {mode!r}")
        return mode

    def edge_free(self, q0: Any, q1: Any, resolution: float, mode: str | None = None) -> bool:
        """True if the straight joint-space edge q0 → q1 is collision-free.

        ``mode="certified"`` (the checker's default ``edge_mode``): proven free along
        its whole length (module docstring, "Certified edges"); ``resolution`` (rad)
        is the normalised joint step of the initial segments, each certified by one
        query at its midpoint and bisected where that is not enough.

        ``mode="discrete"``: every configuration of :func:`edge_configurations` at
        joint step ``resolution`` is free (ends first, then by bisection, stopping at
        the first collision). An obstacle thinner than the arm's sweep between two
        consecutive checks can be missed.
        """
        q0 = self._q(q0, "q0")
        q1 = self._q(q1, "q1")
        r = self._resolution(resolution)
        mode = self._mode(mode)
        self._sync()
        if mode == "certified":
            return bool(self._certify(q0[None], q1[None], r, parallel=False)[0])
        Q = edge_configurations(q0, q1, r)
        for i in _bisection_order(len(Q) - 1):
            if self._collides(Q[i]):
                return False
        return True

    def edges_free(
        self, Q0: Any, Q1: Any, resolution: float, mode: str | None = None
    ) -> np.ndarray:
        """``edge_free`` for each row pair of ``Q0``, ``Q1`` (K, nq), as a (K,) bool array.

        Certified: all edges advance level by level together, each level's midpoint
        queries in one parallel batch on the broad-phase pool. Discrete: each edge is
        one trajectory in bisection order with per-trajectory early exit.
        """
        Q0 = self._batch(Q0, "Q0")
        Q1 = self._batch(Q1, "Q1")
        if Q0.shape != Q1.shape:
            raise ValueError(f"Q0 and Q1 must have the same shape, got {Q0.shape} and {Q1.shape}")
        r = self._resolution(resolution)
        mode = self._mode(mode)
        self._sync()
        K = Q0.shape[0]
        if K == 0:
            return np.zeros(0, dtype=bool)
        if mode == "certified":
            return self._certify(Q0, Q1, r, parallel=True)
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
        self._use_pool(self._pool, self.geom_data)
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
            f"include_hidden={self._include_hidden}, hazard_clearance={self._hazard_clearance}, "
            f"edge_mode={self.edge_mode!r})"
        )

    @property
    def known_obstacles(self) -> Sequence[str]:
        """Names of the obstacles and hazards currently checked."""
        return [
            n
            for n in [*self.obstacle_pairs, *self.hazard_pairs]
            if self._include_hidden or self.world.is_known(n)
        ]
