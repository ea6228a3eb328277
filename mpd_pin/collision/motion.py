"""Motion validity: straight joint-space edges, checked step-wise or certified whole.

docs/design.md §4. Plain functions over the Pinocchio model and data, the query
states of :mod:`mpd_pin.collision.validity`, the pair state of
:mod:`mpd_pin.collision.geometry` and the bounds of :mod:`mpd_pin.collision.bounds`.
What the certified check derives from a pair state (per-level requests,
normalised weights) lives in a :class:`LevelCache` keyed by the state's epoch.

Discrete edges
--------------
:func:`edge_configurations` at a fixed joint step, ends first then by bisection
(:func:`bisection_order`), stopping at the first collision. A batch passes each
edge as one trajectory in bisection order with per-trajectory early exit: 3.9e4
edges/s at 0.05 rad for the 3-link arm (1.2× a loop of single edges, 1.9× one
flat batch of all configurations), 1.2e4 edges/s for the Panda (load ≈ 2).

Certified edges (the checker's default)
---------------------------------------
A discrete check at a fixed joint step misses overlaps thinner than the sweep
between two checks (~0.15 % of the random planar edges accepted at 0.05 rad
collide at 0.005 rad). The certified check proves the whole straight segment
q(t) = q0 + t (q1 − q0), t ∈ [0, 1], free; ``mode="discrete"`` (or
``edge_mode="discrete"``) keeps the old check for comparison. It rests on the
displacement bound B_p(Δq) = W[p] · |Δq| of each pair p
(:mod:`mpd_pin.collision.bounds`).

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
itself (and every mesh with ``certification_model(..., hulls=False)``).

*Hull screen.* A mesh that is not nearly convex (UR5, Kinova, xArm7 and so100 links;
the z1's 43,404- and 23,052-triangle gripper halves) is certified on itself, and its
BVH traversal near an obstacle is slow: 320 µs a configuration on a z1 query, where
certification took 9.7 of 14 CPU-s. Every certification query and every check at the
exact margins inside :func:`certify` and :func:`certify_boxes` therefore asks a model
with *every* arm mesh as its convex hull first (the same pairs and requests, the
state's ``screen``, :class:`~mpd_pin.collision.validity.QueryState`); the hull
contains the mesh, so a configuration clear there is clear on the mesh, and only the
screen's hits are asked again on the meshes (for a trajectory with early exit: from its
first hit on). The answers are the same; the built-in UR5 and Kinova energies are
unchanged to the last digit. On that z1 query the hulls answered 27,151 queries in
0.12 s, 43 % of them hit and went on to the meshes (2.9 s), and the query took 7.6
instead of 16.6 CPU-s.
A level whose margins grow by more than :data:`HULL_ONLY_ABOVE` is asked on the hulls
alone (a mesh query slows down with its margin: 11 ms a configuration at 4.2 cm on an
xArm7): what they do not clear is bisected, so a certificate's answer stays the same
(docs/design.md §4d, "Coarse levels on the hulls alone").

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
single certified edges: 5–7e3 (planar) / 2.2–2.4e3 (Panda) edges/s.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import coal
import numpy as np
import pinocchio as pin

from .bounds import MotionBounds, max_abs, pair_weights, require_supported
from .geometry import CollisionGeometry, PairState, set_collision_request
from .validity import PoolLoader, QueryState, batch_collides, collides, trajectories_collide

__all__ = [
    "EDGE_MODES",
    "CERTIFY_EPS",
    "MIN_STEP",
    "HULL_VOLUME_TOL",
    "bisection_order",
    "edge_configurations",
    "edge_collides_discrete",
    "edges_collide_discrete",
    "CertificationModel",
    "certification_model",
    "LevelCache",
    "certify",
    "certify_boxes",
    "box_sizes",
]

#: Edge checks: "certified" (continuous, conservative; the default) or "discrete".
EDGE_MODES = ("certified", "discrete")

#: Extra clearance (m) every certificate demands beyond the bound, covering Coal's
#: distance error near contact (< 4e-7 m measured, see mpd_pin.collision.geometry).
CERTIFY_EPS = 1e-6

#: Default smallest segment (normalised joint step, rad) the certified check refines
#: to; an edge still undecided there is rejected ("too close to call").
MIN_STEP = 1e-6

#: Meshes within this relative volume of their convex hull certify on the hull.
HULL_VOLUME_TOL = 1e-3

#: A certification level whose margins exceed the exact ones by more than this (m) on
#: some pair is asked on the hull screen alone, never on the meshes (module docstring,
#: "Hull screen").
HULL_ONLY_ABOVE = 0.01


@functools.lru_cache(maxsize=1024)
def bisection_order(n: int) -> np.ndarray:
    """Indices 0..n with both ends first, then midpoints coarse to fine (for early exit).

    The returned array is cached and read-only.
    """
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


# ------------------------------------------------------------------ discrete
def edge_collides_discrete(
    model: pin.Model,
    data: pin.Data,
    state: QueryState,
    q0: np.ndarray,
    q1: np.ndarray,
    resolution: float,
) -> bool:
    """Whether a configuration of :func:`edge_configurations` collides (bisection order,
    stopping at the first collision)."""
    Q = edge_configurations(q0, q1, resolution)
    for i in bisection_order(len(Q) - 1):
        if collides(model, data, state, Q[i]):
            return True
    return False


def edges_collide_discrete(
    state: QueryState, pools: PoolLoader, Q0: np.ndarray, Q1: np.ndarray, resolution: float
) -> np.ndarray:
    """:func:`edge_collides_discrete` (K,) for the edges Q0[e] → Q1[e], in parallel on the
    state's pool: each edge one trajectory in bisection order, with early exit."""
    K = Q0.shape[0]
    D = Q1 - Q0
    steps = np.maximum(1, np.ceil(np.abs(D).max(axis=1) / resolution - 1e-9).astype(np.int64))
    trajectories = pin.StdVec_MatrixXs()
    owner = np.empty(K, dtype=np.int64)  # edge index of each trajectory
    pos = 0
    for n in np.unique(steps):  # edges with the same step count, vectorised
        idx = np.flatnonzero(steps == n)
        t = (bisection_order(int(n)) / n)[None, :, None]
        configs = Q0[idx, None, :] + t * D[idx, None, :]  # (k, n + 1, nq), C order
        for i in range(idx.size):
            trajectories.append(configs[i].T)  # (nq, n + 1), Fortran order: no copy
        owner[pos : pos + idx.size] = idx
        pos += idx.size
    pools.load(state.pool, state.gd)
    res = pin.computeCollisionsInParallel(pools.num_threads, state.pool, trajectories, True)
    out = np.empty(K, dtype=bool)
    for j, v in enumerate(res):
        out[owner[j]] = any(v)
    return out


# ----------------------------------------------------------------- certified
class CertificationModel(NamedTuple):
    """Geometry model of the certification queries, its thread pool, and the names of the
    arm meshes replaced by their convex hulls in it (sorted); ``screen``: (model, pool)
    of the same geometry with every arm mesh as its convex hull, when some mesh is not
    nearly convex and so stays a mesh in ``gm`` (the hull screen, module docstring)."""

    gm: pin.GeometryModel
    pool: Any
    hulls: list[str]
    screen: tuple[pin.GeometryModel, Any] | None = None


def _hull(geom: Any, tight: bool = True) -> Any | None:
    """The convex hull of a mesh: with ``tight`` only of a nearly convex one (module
    docstring); None for a shape that is not a mesh, or when qhull fails."""
    if not isinstance(geom, coal.BVHModelBase):
        return None
    mesh = geom.clone()  # buildConvexHull stores the hull on the mesh: not the shared one
    try:
        mesh.buildConvexHull(True, "Qt")
        hull = mesh.convex
        if tight:
            v_mesh, v_hull = float(mesh.computeVolume()), float(hull.computeVolume())
    except Exception:  # qhull failure, degenerate mesh: keep the mesh
        return None
    # The hull always contains the mesh (sound either way); the volume test only keeps
    # hulls that hug their mesh, so certification loses nothing visible.
    if not tight or (v_mesh > 0 and abs(v_hull - v_mesh) <= HULL_VOLUME_TOL * v_hull):
        hull.computeLocalAABB()
        return hull
    return None


def _with_geometry(gm: pin.GeometryModel, replace: dict[int, Any]) -> pin.GeometryModel:
    """A copy of ``gm`` (objects and collision pairs, in order) whose objects ``g`` in
    ``replace`` have the geometry ``replace[g]``."""
    out = pin.GeometryModel()
    for g, go in enumerate(gm.geometryObjects):
        if g in replace:
            go = pin.GeometryObject(go.name, go.parentJoint, go.parentFrame, go.placement,
                                    replace[g])
        else:
            go = pin.GeometryObject(go)
        out.addGeometryObject(go)
    for cp in gm.collisionPairs:
        out.addCollisionPair(pin.CollisionPair(cp.first, cp.second))
    return out


def certification_model(
    model: pin.Model,
    geometry: CollisionGeometry,
    pool: Any,
    num_threads: int,
    hulls: bool = True,
    screen: bool = True,
) -> CertificationModel:
    """The checker's own geometry model and ``pool``, except that with ``hulls`` every arm
    mesh that is convex up to :data:`HULL_VOLUME_TOL` (relative volume) is replaced by
    its convex hull (in a new model with its own pool of ``num_threads``): the hull
    contains the mesh, so clearance certified for the hull holds for the mesh, and GJK
    on a hull does not slow down with the security margin as a mesh's BVH traversal
    does (Panda links, margin 0.1 m: 5.3e4 vs 6.3e3 configurations/s).
    ``hulls=False`` certifies on the meshes themselves (for comparison). With ``screen``
    (and ``hulls``), when a mesh is left as it is (not nearly convex), ``.screen`` holds
    a model with every arm mesh as its convex hull, which certification queries ask
    first (module docstring, "Hull screen").
    """
    gm = geometry.model
    found, loose = {}, {}
    if hulls:
        for g in geometry.arm_ids:
            geom = gm.geometryObjects[g].geometry
            hull = _hull(geom)
            if hull is not None:
                found[g] = hull
            elif screen and (hull := _hull(geom, tight=False)) is not None:
                loose[g] = hull  # not nearly convex: a screen only
    screen = None
    if loose:
        sm = _with_geometry(gm, {**found, **loose})
        screen = (sm, pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(
            model, sm, num_threads))
    if not found:
        return CertificationModel(gm, pool, [], screen)
    cm = _with_geometry(gm, found)
    cpool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(model, cm, num_threads)
    return CertificationModel(cm, cpool, sorted(gm.geometryObjects[g].name for g in found),
                              screen)


class LevelCache:
    """What the certified check derives from one :class:`PairState`: the query state of
    each level (by h and |q|max) and the normalised weights (by |q|max). Stamped with
    the state's epoch; :meth:`at` empties it when the epoch differs."""

    def __init__(self) -> None:
        self.epoch = -1
        self.levels: dict[tuple[float, bytes], QueryState] = {}
        self.normalised: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def at(self, epoch: int) -> LevelCache:
        """This cache, emptied unless it was derived from pair-state ``epoch``."""
        if epoch != self.epoch:
            self.levels.clear()
            self.normalised.clear()
            self.epoch = epoch
        return self


def _weights_normalised(
    cache: LevelCache, bounds: MotionBounds, state: PairState, qabs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """W (P, nq) and the distinct rows W[p] / S_p of the active moving pairs."""
    key = qabs.tobytes()
    hit = cache.normalised.get(key)
    if hit is not None:
        return hit
    W = pair_weights(bounds, qabs)
    S = W.sum(axis=1)
    rows = state.active & (S > 0)
    Wn = np.unique(W[rows] / S[rows, None], axis=0) if rows.any() else np.zeros((0, W.shape[1]))
    if len(cache.normalised) > 256:
        cache.normalised.clear()
    cache.normalised[key] = (W, Wn)
    return W, Wn


def _level(
    model: pin.Model,
    data: pin.Data,
    exact: QueryState,
    cert: CertificationModel,
    cache: LevelCache,
    state: PairState,
    h: float,
    W: np.ndarray,
    qabs: np.ndarray,
) -> QueryState:
    """Query state whose pair p answers "clearance ≤ c_p?" on the certification
    geometry, ``c_p = margin_p + S_p h / 2 + CERTIFY_EPS``, ``S_p = Σ_k W[p, k]``."""
    key = (h, qabs.tobytes())
    hit = cache.levels.get(key)
    if hit is not None:
        return hit
    if len(cache.levels) > 256:
        cache.levels.clear()
    grow = W.sum(axis=1) * (h / 2)
    c = state.margins + grow + CERTIFY_EPS
    screen = None
    if cert.screen is not None:
        screen = _query_state(model, data, exact, *cert.screen, c, state.active, False)
    if screen is not None and float(grow.max(initial=0.0)) > HULL_ONLY_ABOVE:
        level = screen  # conservative: a configuration clear on the hulls is clear
    else:
        level = _query_state(model, data, exact, cert.gm, cert.pool, c, state.active,
                             False, screen)
    cache.levels[key] = level
    return level


def _query_state(model: pin.Model, data: pin.Data, exact: QueryState, gm: pin.GeometryModel,
                 pool: Any, margins: np.ndarray, active: np.ndarray, upper_bound: bool,
                 screen: QueryState | None = None) -> QueryState:
    """A query state on ``gm`` whose pair k answers "clearance ≤ margins[k]?" (active
    pairs only), with the checker's kind of single-query manager."""
    if gm is exact.gm:
        gd = exact.gd.copy()
    else:
        gd = gm.createData()
        pin.updateGeometryPlacements(model, data, gm, gd, pin.neutral(model))
    for k in range(len(margins)):
        set_collision_request(gd.collisionRequests[k], margins[k], upper_bound=upper_bound)
        if active[k]:
            gd.activateCollisionPair(k)
        else:
            gd.deactivateCollisionPair(k)
    manager = None
    if exact.manager is not None:
        manager = pin.BroadPhaseManager_NaiveCollisionManager(model, gm, gd)
    return QueryState(gd, manager, pool, gm, screen)


def _exact(model: pin.Model, data: pin.Data, exact: QueryState, cert: CertificationModel,
           cache: LevelCache, state: PairState) -> QueryState:
    """The checker's exact query state ``exact`` (in ``state``), screened on the hulls when
    ``cert`` has a screen (module docstring): the same answers."""
    if cert.screen is None:
        return exact
    hit = cache.levels.get(("exact", b""))
    if hit is None:
        screen = _query_state(model, data, exact, *cert.screen, state.margins, state.active,
                              True)
        hit = cache.levels[("exact", b"")] = exact._replace(screen=screen)
    return hit


def _segments(n: np.ndarray, Q0: np.ndarray, D: np.ndarray) -> tuple[list, list]:
    """Per edge e: the midpoints of its n[e] segments in check order (ends first, then by
    bisection) as an (n[e], nq) array, and the segment index of each."""
    K = Q0.shape[0]
    traj: list[np.ndarray] = [np.empty(0)] * K
    order_of: list[np.ndarray] = [np.empty(0, dtype=np.int64)] * K
    for m in map(int, np.unique(n)):  # build edges with the same count vectorised
        idx = np.flatnonzero(n == m)
        order = bisection_order(m - 1) if m > 1 else np.zeros(1, dtype=np.int64)
        t = (order + 0.5) / m
        configs = Q0[idx, None, :] + t[None, :, None] * D[idx, None, :]  # (k, m, nq)
        for e, C in zip(idx.tolist(), configs, strict=True):
            traj[e] = C
            order_of[e] = order
    return traj, order_of


def certify(
    model: pin.Model,
    data: pin.Data,
    exact: QueryState,
    cert: CertificationModel,
    cache: LevelCache,
    state: PairState,
    bounds: MotionBounds,
    Q0: np.ndarray,
    Q1: np.ndarray,
    h0: float,
    min_step: float,
    pools: PoolLoader | None,
) -> tuple[np.ndarray, dict[str, int]]:
    """Certified validity (K,) of the straight edges Q0[e] → Q1[e] (module docstring) and
    the query counts. ``exact``: the checker's own query state in ``state``; ``cache``
    must belong to ``cert`` (it is emptied when ``state``'s epoch is new); ``h0``: the
    initial normalised segment length (rad); in parallel when ``pools`` is given."""
    require_supported(bounds)
    cache = cache.at(state.epoch)
    K = Q0.shape[0]
    D = Q1 - Q0
    qabs = max_abs(bounds, Q0, Q1)
    W, Wn = _weights_normalised(cache, bounds, state, qabs)
    lam = (np.abs(D) @ Wn.T).max(axis=1) if Wn.size else np.zeros(K)  # normalised length
    n = np.maximum(1, np.ceil(lam / h0)).astype(np.int64)
    stats = {"edges": K, "levels": 1, "certify_queries": 0, "exact_queries": 0,
             "too_close": 0}
    rejected = np.zeros(K, dtype=bool)

    def level(h: float) -> QueryState:
        return _level(model, data, exact, cert, cache, state, h, W, qabs)

    checked = _exact(model, data, exact, cert, cache, state)  # the exact margins

    # Level 0: edge e has n[e] segments. Their midpoints, ends first then by bisection,
    # are checked at the certification margins with early exit: an edge with no
    # failure is accepted with n[e] queries. An edge with one is checked at the exact
    # margins (early exit: colliding edges stop here), then its remaining midpoints
    # at the certification margins; failed segments go on to level 1.
    level0 = level(h0)
    traj, order_of = _segments(n, Q0, D)
    res = trajectories_collide(model, data, level0, traj, pools)
    first = np.array([int(np.argmax(r)) if r.any() else -1 for r in res], dtype=np.int64)
    stats["certify_queries"] += int(np.where(first < 0, n, first + 1).sum())
    bad = np.flatnonzero(first >= 0)
    if bad.size:
        hits = trajectories_collide(model, data, checked, [traj[e] for e in bad], pools)
        stats["exact_queries"] += sum(int(np.argmax(r)) + 1 if r.any() else len(r)
                                      for r in hits)
        hit = np.array([r.any() for r in hits], dtype=bool)
        rejected[bad[hit]] = True
        bad = bad[~hit]
    # the rest of these edges' midpoints (after the first failure), in one batch
    rest = [traj[e][first[e] + 1 :] for e in bad]
    sizes = np.array([len(r) for r in rest], dtype=np.int64)
    rest_fail = (batch_collides(model, data, level0, np.concatenate(rest), pools)
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
        return ~rejected, stats
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
        if h < min_step:  # too close to call: reject what is left
            undecided = np.unique(seg_e)
            stats["too_close"] = int(undecided.size)
            rejected[undecided] = True
            break
        stats["levels"] += 1
        Qm = Q0[seg_e] + ((seg_i + 0.5) / seg_n)[:, None] * D[seg_e]
        fail = batch_collides(model, data, level(h), Qm, pools)
        stats["certify_queries"] += int(Qm.shape[0])
        if fail.any():
            hit = batch_collides(model, data, checked, Qm[fail], pools)
            stats["exact_queries"] += int(fail.sum())
            rejected[seg_e[fail][hit]] = True
            fail &= ~rejected[seg_e]
        e, i, m = seg_e[fail], seg_i[fail], seg_n[fail]
        h /= 2
    return ~rejected, stats


def certify_boxes(
    model: pin.Model,
    data: pin.Data,
    exact: QueryState,
    cert: CertificationModel,
    cache: LevelCache,
    state: PairState,
    bounds: MotionBounds,
    C: np.ndarray,
    Delta: np.ndarray,
    h: float,
    pools: PoolLoader | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Certify joint-space boxes |q_k − C[b, k]| ≤ Delta[b, k] (rad) whole: ``(clear, hit)``,
    (B,) bool each (docs/design.md §4d, "Curves").

    The bound B_p = Σ_k W[p, k] |Δq_k| is joint-wise, so every configuration of box b is
    within W[p] · Delta[b] of its centre for pair p, whatever path leads there. One query
    per box at the centre with the margins of level ``h`` (normalised rad) certifies it
    when the box's normalised size max_p W[p] · 2 Delta[b] / S_p is at most ``h``
    (ValueError otherwise). ``clear``: certified; ``hit``: the centre itself collides at
    the exact margins (checked only where ``clear`` is False)."""
    require_supported(bounds)
    cache = cache.at(state.epoch)
    C = np.ascontiguousarray(C, dtype=float)
    Delta = np.abs(np.asarray(Delta, dtype=float))
    B = C.shape[0]
    if B == 0:
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
    qabs = max_abs(bounds, C - Delta, C + Delta)
    W, Wn = _weights_normalised(cache, bounds, state, qabs)
    lam = (2.0 * Delta @ Wn.T).max(axis=1) if Wn.size else np.zeros(B)
    if np.any(lam > h * (1.0 + 1e-9)):
        raise ValueError(f"boxes of normalised size up to {lam.max():.3g} rad exceed level {h:g}")
    fail = batch_collides(model, data, _level(model, data, exact, cert, cache, state, h, W, qabs),
                          C, pools)
    hit = np.zeros(B, dtype=bool)
    if fail.any():
        hit[fail] = batch_collides(model, data, _exact(model, data, exact, cert, cache, state),
                                   C[fail], pools)
    return ~fail, hit


def box_sizes(
    cache: LevelCache, state: PairState, bounds: MotionBounds, C: np.ndarray, Delta: np.ndarray
) -> np.ndarray:
    """(B,) normalised size max_p W[p] · 2 Delta[b] / S_p (rad) of boxes around ``C``."""
    cache = cache.at(state.epoch)
    Delta = np.abs(np.asarray(Delta, dtype=float))
    qabs = max_abs(bounds, C - Delta, C + Delta)
    _, Wn = _weights_normalised(cache, bounds, state, qabs)
    return (2.0 * Delta @ Wn.T).max(axis=1) if Wn.size else np.zeros(C.shape[0])
