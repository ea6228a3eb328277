"""CollisionChecker: configuration and edge validity for an arm in a World (docs/design.md §4).

:class:`CollisionChecker` is an OMPL-style validity checker: it knows the arm
and the world but nothing about the planner. It composes

* :mod:`~mpd_pin.collision.geometry`: the geometry model and its pairs, and the
  :class:`~mpd_pin.collision.geometry.PairState` (active pairs, margins, epoch)
  that follows the world;
* :mod:`~mpd_pin.collision.bounds`: the link-motion bounds of the pairs;
* :mod:`~mpd_pin.collision.validity`: configuration validity and distances;
* :mod:`~mpd_pin.collision.motion`: step-wise and certified edges.

It owns the preallocated Pinocchio ``Data`` and ``GeometryData`` every query
reuses, the thread pools, and the certified check's
:class:`~mpd_pin.collision.motion.LevelCache` (keyed by the pair state's epoch).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..dynamics.payload import Payload, carried_payload, payload_arm
from ..world import World
from . import validity
from .bounds import MotionBounds, displacement_bounds, motion_bounds, require_supported
from .geometry import (
    GJK_TOLERANCE,
    CollisionGeometry,
    PairState,
    apply_pair_state,
    build_geometry,
    pair_state,
)
from .motion import (
    CERTIFY_EPS,
    EDGE_MODES,
    MIN_STEP,
    CertificationModel,
    LevelCache,
    box_sizes,
    certification_model,
    certify,
    certify_boxes,
    edge_collides_discrete,
    edges_collide_discrete,
)
from .report import collision_phrase, geometry_label
from .validity import PoolLoader, QueryState, collides

__all__ = ["CollisionChecker"]


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
        None or True: self-collision pairs as described in
        :mod:`mpd_pin.collision.geometry`; False: none.
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
    certify_on_hulls:
        True (default): certified edges query nearly convex arm meshes through their
        convex hulls (:mod:`mpd_pin.collision.motion`, "Convex hulls"); False: on the
        meshes themselves (slower; for comparison). Exact checks always use the meshes.
    screen_on_hulls:
        True (default): certified edges and boxes query an arm mesh that is not nearly
        convex on its convex hull first, and on the mesh only where the hull is not
        clear (:mod:`mpd_pin.collision.motion`, "Hull screen"): the same answers, faster
        for detailed meshes. False: on the meshes only (for comparison).
    payload:
        A :class:`~mpd_pin.Payload` the arm carries (replacing any the arm already
        carries): its box (``size``, m) is checked against every obstacle and hazard and
        against the links on joints other than the one carrying it, its parent and its
        children (:mod:`mpd_pin.dynamics.payload`); a part without ``size`` has no shape.
        None (default): the arm as given (an arm from ``drive.with_payload(part).arm``
        already carries its part). :attr:`arm` is then the arm carrying the part.
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
        certify_on_hulls: bool = True,
        payload: Payload | None = None,
        screen_on_hulls: bool = True,
    ) -> None:
        if not isinstance(arm, Arm):
            raise ValueError(f"arm must be an mpd_pin.Arm, got {type(arm).__name__}")
        if payload is not None:
            arm = payload_arm(arm, payload)
        if world is None:
            world = World()
        if not isinstance(world, World):
            raise ValueError(f"world must be an mpd_pin.World, got {type(world).__name__}")
        if len(world) and not arm.collision_model.ngeoms:
            # every check would pass: an arm without shapes plans through any obstacle
            raise ValueError(
                f"arm {arm.name!r} has no collision geometry (its URDF has no <collision> "
                f"element), so the world's {len(world)} obstacle(s) and hazard(s) cannot "
                "be checked against it; give its links <collision> shapes, or plan "
                "without obstacles")
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
        self.certify_on_hulls = bool(certify_on_hulls)
        self.screen_on_hulls = bool(screen_on_hulls)
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
        arm = self.arm
        self.model: pin.Model = arm.model
        self.data: pin.Data = arm.model.createData()
        self.geometry: CollisionGeometry = build_geometry(arm, self.world, self._self_collision)
        gm = self.geometry.model
        self.geom_model: pin.GeometryModel = gm
        self.arm_geometry_ids: list[int] = self.geometry.arm_ids
        self.self_pairs: list[int] = self.geometry.self_pairs
        self.obstacle_pairs: dict[str, list[int]] = self.geometry.obstacle_pairs
        self.hazard_pairs: dict[str, list[int]] = self.geometry.hazard_pairs
        self._haz_clear_of = {
            k: self.geometry.clearance[n] for n, idx in self.hazard_pairs.items() for k in idx
        }
        # Preallocated data, reused by every query: collisions, obstacle and hazard distances.
        self.geom_data: pin.GeometryData = gm.createData()
        self._dist_data = gm.createData()
        self._hazard_data = gm.createData()
        if self._single_backend == "auto":
            meshes = any(
                go.geometry.getObjectType() != coal.OT_GEOM
                for go in arm.collision_model.geometryObjects
            )
            self.single_backend = "broadphase" if meshes else "pairs"
        else:
            self.single_backend = self._single_backend
        manager = pin.BroadPhaseManager_NaiveCollisionManager(self.model, gm, self.geom_data)
        self._pool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(
            self.model, gm, self.num_threads
        )
        self._pools = PoolLoader(self.num_threads)
        self._exact = QueryState(
            self.geom_data, manager if self.single_backend == "broadphase" else None,
            self._pool, gm,
        )
        # Valid placements before the pool's AABB trees are first updated (coal rejects the
        # uninitialised bounding volumes otherwise).
        for gd in (self._dist_data, self._hazard_data):
            for req in gd.distanceRequests:
                req.gjk_tolerance = GJK_TOLERANCE  # default 1e-6 (relative): ~1e-6 m errors
        q_ref = pin.neutral(self.model)
        for gd in (self.geom_data, self._dist_data, self._hazard_data):
            pin.updateGeometryPlacements(self.model, self.data, gm, gd, q_ref)
        self.bounds: MotionBounds = motion_bounds(self.model, arm.collision_model, gm)
        self._cert: CertificationModel | None = None  # built on the first certified check
        self._levels = LevelCache()
        self.last_certify_stats: dict[str, int] = {}
        self._state: PairState | None = None
        self._synced_version = -1
        self._sync(force=True)

    def _sync(self, force: bool = False) -> None:
        """Bring the pair state in line with the world (cheap when the world is unchanged).

        Only the pairs whose state changed are written; the thread pool then gets one
        copy of the updated ``GeometryData``. A changed state has a new epoch, which
        empties the certified check's level cache on its next use.
        """
        if not force and self._synced_version == self.world.version:
            return
        state = pair_state(
            self.geometry,
            self.world,
            margin=self.margin,
            include_hidden=self._include_hidden,
            hazard_clearance=self._hazard_clearance,
            previous=self._state,
        )
        changed = apply_pair_state(
            self.geom_data, self._dist_data, self._hazard_data, state, self._state
        )
        if changed or self._state is None:
            self._pools.load(self._pool, self.geom_data, force=True)
        self._state = state
        self._synced_version = self.world.version

    @property
    def pair_state(self) -> PairState:
        """The current :class:`~mpd_pin.collision.geometry.PairState` (after the last query)."""
        return self._state

    @property
    def certification_hulls(self) -> list[str]:
        """Arm meshes certified on their convex hull (known after the first certified check)."""
        return list(self._cert.hulls) if self._cert is not None else []

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
        return self._on(self.arm)

    @property
    def payload(self) -> Payload | None:
        """The :class:`~mpd_pin.Payload` the checked arm carries, or None."""
        return carried_payload(self.arm)

    def with_payload(self, part: Payload | None) -> CollisionChecker:
        """A new checker with the same world and settings whose arm carries ``part``
        (replacing any payload; None: the arm without payload). This one is unchanged."""
        return self._on(payload_arm(self.arm, part))

    def _on(self, arm: Arm) -> CollisionChecker:
        """A new checker of ``arm`` with this checker's world and settings."""
        return CollisionChecker(
            arm,
            self.world,
            include_hidden=self._include_hidden,
            self_collision=self._self_collision,
            hazard_clearance=self._hazard_clearance,
            margin=self.margin,
            num_threads=self.num_threads,
            single_backend=self._single_backend,
            edge_mode=self.edge_mode,
            min_step=self.min_step,
            certify_on_hulls=self.certify_on_hulls,
            screen_on_hulls=self.screen_on_hulls,
        )

    def describe(self) -> dict:
        """Plain data fixing which configurations and edges are free (hashed into roadmap keys).

        Arm fingerprint, the checked world (known obstacles and hazards, or all with
        ``include_hidden``), self-collision pairs (geometry names), margin (m), hazard
        clearance enforcement, edge mode, min_step (rad) and the query tolerances.
        Threads and single-query backend do not change answers and are left out;
        ``certify_on_hulls`` appears only when False (so the default checker's
        fingerprint, and the roadmap keys built on it, stay as they were).
        """
        names = [go.name for go in self.geom_model.geometryObjects]
        pairs = self.geom_model.collisionPairs
        out = {
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
        if not self.certify_on_hulls:
            out["certify_on_hulls"] = False
        return out

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

    def _mode(self, mode: str | None) -> str:
        if mode is None:
            return self.edge_mode
        if mode not in EDGE_MODES:
            raise ValueError(f"mode must be one of {EDGE_MODES} or None, got {mode!r}")
        return mode

    # ------------------------------------------------------- configurations
    def is_free(self, q: Any) -> bool:
        """True if configuration ``q`` is collision-free (obstacles, hazards, self)."""
        q = self._q(q)
        self._sync()
        return not collides(self.model, self.data, self._exact, q)

    def is_free_batch(self, Q: Any) -> np.ndarray:
        """Validity of each row of ``Q`` (K, nq) as a (K,) bool array (parallel)."""
        Q = self._batch(Q)
        self._sync()
        if Q.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        return ~validity.batch_collides(self.model, self.data, self._exact, Q, self._pools)

    def in_collision_pairs(self, q: Any) -> list[tuple[str, str]]:
        """Names of the geometry pairs in collision at ``q`` (diagnostics)."""
        q = self._q(q)
        self._sync()
        return validity.colliding_pairs(
            self.model, self.data, self.geom_model, self.geom_data, self._state.active, q
        )

    def colliding_pairs(self, q: Any) -> list[tuple[str, str]]:
        """What collides at ``q``, by name, for messages: one ``(link, other)`` per pair in
        collision, ``link`` the arm link holding the geometry (its frame, the URDF link:
        ``"link 'link3'"``) and ``other`` the obstacle, hazard or other link
        (``"obstacle 'divider'"``, ``"hazard 'zone'"``, ``"link 'link1'"``; unnamed
        obstacles carry the World's names, ``box0``); a carried payload's box is
        ``"payload 'name'"`` (:class:`~mpd_pin.Payload`). A link with several geometries is
        listed once per item it touches. Pairs count as in :meth:`is_free` (margin and
        enforced hazard clearances included); [] when ``q`` is free."""
        return [(a, b) for a, b, _ in self._named_collisions(q)]

    def describe_collision(self, q: Any, limit: int = 3) -> str:
        """:meth:`colliding_pairs` as one phrase, the links grouped by what they touch, e.g.
        "link 'link3' touches obstacle 'divider'", "links 'link2' and 'link3' touch
        obstacle 'box0'" ("come(s) within 0.05 m of" where a margin or hazard clearance
        applies); at most ``limit`` such groups, then "and N more"; "" when ``q`` is free."""
        return collision_phrase(self._named_collisions(q), limit)

    def _named_collisions(self, q: Any) -> list[tuple[str, str, float]]:
        """(link, other, margin m) of each colliding pair at ``q`` (:meth:`colliding_pairs`)."""
        q = self._q(q)
        self._sync()
        gm, gd, state = self.geom_model, self.geom_data, self._state
        pin.computeCollisions(self.model, self.data, gm, gd, q, False)
        out: list[tuple[str, str, float]] = []
        seen: set[tuple[str, str]] = set()
        for k in map(int, np.flatnonzero(state.active)):
            if not gd.collisionResults[k].isCollision():
                continue
            cp = gm.collisionPairs[k]
            pair = (self._geometry_label(cp.first), self._geometry_label(cp.second))
            if pair not in seen:
                seen.add(pair)
                out.append((*pair, float(state.margins[k])))
        return out

    def _geometry_label(self, i: int) -> str:
        """What geometry ``i`` is called in a report (:func:`.report.geometry_label`)."""
        return geometry_label(self.model, self.geom_model, self.arm_geometry_ids, i)

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
        model, data, gm, state = self.model, self.data, self.geom_model, self._state
        best = validity.min_distance(model, data, gm, self._dist_data, state.obstacle_idx, q)
        if hazards and state.hazard_idx:
            best = min(
                best,
                validity.min_distance(model, data, gm, self._hazard_data, state.hazard_idx, q),
            )
        return float(best)

    def hazard_margin(self, q: Any) -> float:
        """min over known hazards of (distance to the hazard − its clearance) (m); +inf if none.

        Negative means closer than allowed (or inside the zone).
        """
        q = self._q(q)
        self._sync()
        if not self._state.hazard_idx:
            return math.inf
        return validity.hazard_margin(
            self.model, self.data, self.geom_model, self._hazard_data, self._haz_clear_of,
            self._state.hazard_idx, q,
        )

    def distances(self, q: Any) -> dict[str, float]:
        """Signed distance (m) from the arm to each known obstacle and hazard, by name."""
        q = self._q(q)
        self._sync()
        groups = [(self.obstacle_pairs, self._dist_data), (self.hazard_pairs, self._hazard_data)]
        return validity.distances(self.model, self.data, self.geom_model, groups, q)

    # ---------------------------------------------------------------- edges
    def displacement_bounds(self, q0: Any, q1: Any) -> np.ndarray:
        """Bound (m) on the relative motion of each collision pair along q0 → q1, shape (P,).

        Every point of the pair's arm geometry moves (for self pairs: relative to the
        other geometry) along a path no longer than this while the joints move along
        the straight segment (:mod:`mpd_pin.collision.bounds`). Pair k is
        ``geom_model.collisionPairs[k]``.
        """
        q0 = self._q(q0, "q0")
        q1 = self._q(q1, "q1")
        return displacement_bounds(self.bounds, q0, q1)

    def _certify(self, Q0: np.ndarray, Q1: np.ndarray, h0: float, parallel: bool) -> np.ndarray:
        cert = self._cert_model()
        ok, self.last_certify_stats = certify(
            self.model, self.data, self._exact, cert, self._levels, self._state,
            self.bounds, Q0, Q1, h0, self.min_step, self._pools if parallel else None,
        )
        return ok

    def _cert_model(self) -> CertificationModel:
        """The certification geometry (convex hulls where they fit), built on first use."""
        require_supported(self.bounds)
        if self._cert is None:
            self._cert = certification_model(
                self.model, self.geometry, self._pool, self.num_threads,
                hulls=self.certify_on_hulls, screen=self.screen_on_hulls,
            )
        return self._cert

    def distance_setup(self) -> tuple[pin.GeometryModel, PairState]:
        """The certification geometry (nearly convex arm meshes as their convex hulls) and
        the current pair state (which pairs are enforced, with which margin in m): what
        :class:`~mpd_pin.collision.distance.PairDistances` measures (docs/design.md §9g)."""
        self._sync()
        return self._cert_model().gm, self._state

    def box_sizes(self, C: Any, Delta: Any) -> np.ndarray:
        """(B,) normalised size (rad) of the joint-space boxes ``C ± Delta`` (each row one
        box): the level :meth:`boxes_clear` needs (docs/design.md §4d, "Curves")."""
        self._sync()
        return box_sizes(self._levels, self._state, self.bounds, self._batch(C, "C"),
                         np.asarray(Delta, dtype=float))

    def boxes_clear(self, C: Any, Delta: Any, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Certify whole joint-space boxes ``|q − C[b]| ≤ Delta[b]`` (rad, per joint) of
        normalised size ≤ ``h`` (rad, :meth:`box_sizes`) by one query each at the centre:
        ``(clear, hit)`` (B,) bool — proven free, and centre in collision (exact margins).
        Curves certify by covering themselves with such boxes (:mod:`mpd_pin.motion`)."""
        C = self._batch(C, "C")
        self._sync()
        cert = self._cert_model()
        return certify_boxes(self.model, self.data, self._exact, cert, self._levels,
                             self._state, self.bounds, C, np.asarray(Delta, dtype=float),
                             float(h), self._pools if C.shape[0] > 1 else None)

    def edge_free(self, q0: Any, q1: Any, resolution: float, mode: str | None = None) -> bool:
        """True if the straight joint-space edge q0 → q1 is collision-free (on continuous
        joints the edge ends at ``arm.edge_target(q0, q1)``, the shorter way round, §1d).

        ``mode="certified"`` (the checker's default ``edge_mode``): proven free along
        its whole length (:mod:`mpd_pin.collision.motion`, "Certified edges");
        ``resolution`` (rad) is the normalised joint step of the initial segments, each
        certified by one query at its midpoint and bisected where that is not enough.

        ``mode="discrete"``: every configuration of :func:`edge_configurations` at
        joint step ``resolution`` is free (ends first, then by bisection, stopping at
        the first collision). An obstacle thinner than the arm's sweep between two
        consecutive checks can be missed.
        """
        q0 = self._q(q0, "q0")
        q1 = self.arm.edge_target(q0, self._q(q1, "q1"))  # shorter way round (§1d)
        r = self._resolution(resolution)
        mode = self._mode(mode)
        self._sync()
        if mode == "certified":
            return bool(self._certify(q0[None], q1[None], r, parallel=False)[0])
        return not edge_collides_discrete(self.model, self.data, self._exact, q0, q1, r)

    def edges_free(
        self, Q0: Any, Q1: Any, resolution: float, mode: str | None = None,
        progress: Any = None,
    ) -> np.ndarray:
        """``edge_free`` for each row pair of ``Q0``, ``Q1`` (K, nq), as a (K,) bool array.

        Certified: all edges advance level by level together, each level's midpoint
        queries in one parallel batch on the broad-phase pool. Discrete: each edge is
        one trajectory in bisection order with per-trajectory early exit.

        ``progress(done)`` (a callable, or None): the edges are checked in chunks and it is
        called with the number checked so far after each (:meth:`_edges_free_chunked`);
        the result is the same as in one batch.
        """
        Q0 = self._batch(Q0, "Q0")
        Q1 = self._batch(Q1, "Q1")
        if Q0.shape != Q1.shape:
            raise ValueError(f"Q0 and Q1 must have the same shape, got {Q0.shape} and {Q1.shape}")
        Q1 = self.arm.edge_target(Q0, Q1)  # shorter way round on continuous joints (§1d)
        r = self._resolution(resolution)
        mode = self._mode(mode)
        self._sync()
        if Q0.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        if progress is not None:
            return self._edges_free_chunked(Q0, Q1, r, mode, progress)
        if mode == "certified":
            return self._certify(Q0, Q1, r, parallel=True)
        return ~edges_collide_discrete(self._exact, self._pools, Q0, Q1, r)

    def _edges_free_chunked(self, Q0: np.ndarray, Q1: np.ndarray, r: float, mode: str,
                            progress: Any, seconds: float = 1.0) -> np.ndarray:
        """:meth:`edges_free` of the checked batch Q0 → Q1 in consecutive chunks, calling
        ``progress(done)`` after each. Chunks are sized to take about ``seconds`` each at
        the rate measured so far (the first has 32 edges), between 32 and the larger of
        256 and 2 % of the edges; on the panda scenario's roadmap (5144 edges) chunks of 256
        took as long as one batch. Every edge's answer depends on that edge alone, so the
        result is the one batch's — except for certified checks of an arm with prismatic
        joints, whose motion bounds depend on the largest |q| in the batch: those go in one
        chunk. ``last_certify_stats`` sums the chunks' counts (``levels``: the most)."""
        import time

        K = Q0.shape[0]
        certified = mode == "certified"
        low, high = 32, max(256, math.ceil(0.02 * K))
        size = K if certified and self.bounds.prismatic is not None else min(low, K)
        free = np.empty(K, dtype=bool)
        stats: dict[str, int] = {}
        done = 0
        while done < K:
            part = slice(done, min(K, done + size))
            t0 = time.perf_counter()
            if certified:
                free[part] = self._certify(Q0[part], Q1[part], r, parallel=True)
                for k, v in self.last_certify_stats.items():
                    stats[k] = max(stats.get(k, 0), v) if k == "levels" else stats.get(k, 0) + v
            else:
                free[part] = ~edges_collide_discrete(self._exact, self._pools, Q0[part],
                                                     Q1[part], r)
            took = time.perf_counter() - t0
            done = part.stop
            progress(done)
            rate = (part.stop - part.start) / max(took, 1e-6)
            size = int(min(high, max(low, rate * seconds)))
        if certified:
            self.last_certify_stats = stats
        return free

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

