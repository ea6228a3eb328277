"""The collision geometry of an arm in a World, and the pair state that follows the world.

docs/design.md §4. :func:`build_geometry` builds ONE Pinocchio ``GeometryModel``:
the arm's collision geometries, then every obstacle and hazard of the world
(hidden ones too) fixed to the universe joint. Its collision pairs are

* arm geometry × obstacle, for every obstacle;
* arm geometry × hazard ("No Enter" zones are never entered);
* self-collision pairs: the arm's own pairs when it has some (example-robot-data
  robots come with their SRDF-filtered pairs), otherwise every pair of
  geometries on non-adjacent joints (planar arms: non-adjacent links; none for
  two links). A payload's box (:mod:`mpd_pin.dynamics.payload`) is one more arm
  geometry, on the joint that carries it: the same non-adjacent rule applies to it, and
  an arm with its own pairs gets it paired with the links of non-adjacent joints.

Hidden obstacles are in the model from the start; their pairs are simply
inactive in the ``GeometryData`` until revealed, so revealing is a flag flip
plus one copy of the data into the thread pool (no model rebuild: ~35 µs for a
planar arm, ~160 µs for the Panda). Distances use two more ``GeometryData`` of
the same model, one with only the obstacle pairs active and one with only the
hazard pairs.

What changes with the world (which pairs are active, which margins they have)
is a :class:`PairState`, plain read-only arrays with an ``epoch`` that grows
whenever they change: anything derived from a state (the certified check's
per-level requests, :mod:`mpd_pin.collision.motion`) is keyed by its epoch.

Exactness and tolerances
------------------------
Every collision request has ``security_margin = 0``: a pair collides exactly
when the geometries overlap (touching counts as collision). The only extra
margin is the hazards' ``clearance`` when it is enforced
(:meth:`~mpd_pin.collision.CollisionChecker.set_hazard_clearance`).
``distance_upper_bound`` is set to the margin so GJK may stop as soon as it
proves separation (it does not change the boolean answer; no measurable speed-up
here).

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
"""

from __future__ import annotations

from typing import NamedTuple

import coal
import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..world import Hazard, World, geometry_object

__all__ = [
    "GJK_TOLERANCE",
    "CollisionGeometry",
    "PairState",
    "build_geometry",
    "pair_state",
    "apply_pair_state",
    "set_collision_request",
]

#: GJK tolerance of the collision requests (Coal's default is 1e-6; 1e-9 costs no
#: measurable time here and shrinks the band of undecided near-contact configurations).
GJK_TOLERANCE = 1e-9


class CollisionGeometry(NamedTuple):
    """The checker's geometry model and its collision pairs, grouped (fixed once built).

    ``model.collisionPairs[k]`` is pair k; ``self_pairs`` lists the self-collision
    pairs, ``obstacle_pairs`` / ``hazard_pairs`` the pairs of each obstacle / hazard
    by name (one per arm geometry); ``clearance`` is each hazard's clearance (m).
    Arm geometries are ``model.geometryObjects[0:len(arm_ids)]``.
    """

    model: pin.GeometryModel
    arm_ids: list[int]
    self_pairs: list[int]
    obstacle_pairs: dict[str, list[int]]
    hazard_pairs: dict[str, list[int]]
    clearance: dict[str, float]


class PairState(NamedTuple):
    """Which pairs are checked and with which margin (m), at one ``epoch``.

    ``active``: collision pairs checked; ``margins``: their security margins;
    ``obstacle`` / ``hazard``: pairs active in the obstacle- / hazard-distance data;
    ``obstacle_idx`` / ``hazard_idx``: the same as index lists. The arrays are
    read-only; a changed state is a new ``PairState`` with a larger epoch.
    """

    epoch: int
    active: np.ndarray
    margins: np.ndarray
    obstacle: np.ndarray
    hazard: np.ndarray
    obstacle_idx: list[int]
    hazard_idx: list[int]


def _self_pairs(arm: Arm) -> list[tuple[int, int]]:
    """The arm's own collision pairs, else every pair of geometries on non-adjacent joints."""
    arm_cm = arm.collision_model
    if len(arm_cm.collisionPairs) > 0:
        return [(cp.first, cp.second) for cp in arm_cm.collisionPairs]
    parents = list(arm.model.parents)
    out = []
    n_arm = arm_cm.ngeoms
    for i in range(n_arm):
        for j in range(i + 1, n_arm):
            ji = arm_cm.geometryObjects[i].parentJoint
            jj = arm_cm.geometryObjects[j].parentJoint
            if ji == jj or parents[ji] == jj or parents[jj] == ji:
                continue
            out.append((i, j))
    return out


def build_geometry(arm: Arm, world: World, self_collision: bool | None) -> CollisionGeometry:
    """Arm geometry, then every obstacle and hazard of ``world`` (hidden ones too), and the
    pairs: self pairs first (unless ``self_collision is False``), then arm × each item."""
    gm = pin.GeometryModel()
    arm_cm = arm.collision_model
    for go in arm_cm.geometryObjects:
        gm.addGeometryObject(pin.GeometryObject(go))
    arm_ids = list(range(arm_cm.ngeoms))
    self_pairs = _self_pairs(arm) if self_collision is not False else []
    geom_of: dict[str, int] = {}
    clearance: dict[str, float] = {}
    for item in world:
        if isinstance(item, Hazard):
            gid = gm.addGeometryObject(geometry_object(item.shape, f"hazard:{item.name}"))
            clearance[item.name] = item.clearance
        else:
            gid = gm.addGeometryObject(geometry_object(item, f"obstacle:{item.name}"))
        geom_of[item.name] = gid
    self_idx: list[int] = []
    obstacle_pairs: dict[str, list[int]] = {}
    hazard_pairs: dict[str, list[int]] = {}
    k = 0
    for i, j in self_pairs:
        gm.addCollisionPair(pin.CollisionPair(i, j))
        self_idx.append(k)
        k += 1
    for item in world:
        target = hazard_pairs if isinstance(item, Hazard) else obstacle_pairs
        target[item.name] = []
        for a in arm_ids:
            gm.addCollisionPair(pin.CollisionPair(a, geom_of[item.name]))
            target[item.name].append(k)
            k += 1
    return CollisionGeometry(gm, arm_ids, self_idx, obstacle_pairs, hazard_pairs, clearance)


def _read_only(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.flags.writeable = False


def pair_state(
    geometry: CollisionGeometry,
    world: World,
    *,
    margin: float,
    include_hidden: bool,
    hazard_clearance: bool,
    previous: PairState | None = None,
) -> PairState:
    """The pair state the world asks for: ``previous`` itself if nothing changed, else a new
    state with ``epoch = previous.epoch + 1`` (0 without ``previous``).

    Self pairs are always active, obstacles and hazards when known (or with
    ``include_hidden``); every margin is ``margin`` (m) except enforced hazard
    clearances larger than it.
    """
    n = len(geometry.model.collisionPairs)
    active = np.zeros(n, dtype=bool)
    margins = np.full(n, margin)
    dist = np.zeros(n, dtype=bool)
    haz = np.zeros(n, dtype=bool)
    active[geometry.self_pairs] = True
    for name, idx in geometry.obstacle_pairs.items():
        if include_hidden or world.is_known(name):
            active[idx] = True
            dist[idx] = True
    for name, idx in geometry.hazard_pairs.items():
        if include_hidden or world.is_known(name):
            active[idx] = True
            haz[idx] = True
        margins[idx] = max(margin, geometry.clearance[name] if hazard_clearance else 0.0)
    if previous is not None and (
        np.array_equal(active, previous.active)
        and np.array_equal(margins, previous.margins)
        and np.array_equal(dist, previous.obstacle)
        and np.array_equal(haz, previous.hazard)
    ):
        return previous
    _read_only(active, margins, dist, haz)
    epoch = 0 if previous is None else previous.epoch + 1
    return PairState(
        epoch,
        active,
        margins,
        dist,
        haz,
        [int(k) for k in np.flatnonzero(dist)],
        [int(k) for k in np.flatnonzero(haz)],
    )


def set_collision_request(
    req: coal.CollisionRequest, margin: float, upper_bound: bool = True
) -> None:
    """Collision request answering "clearance ≤ ``margin`` (m)?", EPA on, GJK at
    :data:`GJK_TOLERANCE`; ``upper_bound``: GJK may stop once separation beyond the
    margin is proven (``distance_upper_bound = margin + 1e-9``)."""
    req.security_margin = float(margin)
    # Run EPA when GJK is inconclusive: without it (Pinocchio's default
    # enable_contact=False) shallow penetrations of the link cylinders, up to
    # ~2e-4 m in our tests, were reported as free.
    req.enable_contact = True
    req.gjk_tolerance = GJK_TOLERANCE
    if upper_bound:
        req.distance_upper_bound = float(margin) + 1e-9


def _set_active(gd: pin.GeometryData, flags: np.ndarray, pairs: np.ndarray) -> None:
    for k in map(int, pairs):
        if flags[k]:
            gd.activateCollisionPair(k)
        else:
            gd.deactivateCollisionPair(k)


def apply_pair_state(
    gd: pin.GeometryData,
    obstacle_distance: pin.GeometryData,
    hazard_distance: pin.GeometryData,
    state: PairState,
    previous: PairState | None,
) -> bool:
    """Write ``state`` into the collision data ``gd`` and the two distance data.

    Only the pairs that differ from ``previous`` are touched (all of them without
    ``previous``). Returns whether ``gd`` changed (then thread pools holding copies of
    it need an update).
    """
    n = len(state.active)
    if previous is None:
        margin_k = active_k = obstacle_k = hazard_k = np.arange(n)
    elif previous is state:
        return False
    else:
        margin_k = np.flatnonzero(state.margins != previous.margins)
        active_k = np.flatnonzero(state.active != previous.active)
        obstacle_k = np.flatnonzero(state.obstacle != previous.obstacle)
        hazard_k = np.flatnonzero(state.hazard != previous.hazard)
    for k in map(int, margin_k):
        set_collision_request(gd.collisionRequests[k], state.margins[k])
    _set_active(gd, state.active, active_k)
    _set_active(obstacle_distance, state.obstacle, obstacle_k)
    _set_active(hazard_distance, state.hazard, hazard_k)
    return bool(margin_k.size or active_k.size)
