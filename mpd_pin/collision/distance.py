"""Signed distances of the collision pairs and their joint-space gradients (docs/design.md §9g).

The trajectory optimisation constrains every collision pair the checker enforces —
arm–obstacle, self-collision and hazard pairs, each with its own margin (a hazard's
clearance where the checker enforces it) — by its signed distance d(q) ≥ margin. d is
measured with every arm mesh replaced by its convex hull: the hull contains the mesh,
so its distance never overstates the mesh's, and GJK on convex shapes returns the witness
points p₁, p₂ and the normal n (from the first object to the second) that give the
gradient

    ∂d/∂q = nᵀ (J₂(p₂) − J₁(p₁)),   J(p) = J_v − [p − o_j]× J_ω,

with J_v, J_ω the world-aligned Jacobian of the joint j that carries the geometry
(``pin.getJointJacobian``, LOCAL_WORLD_ALIGNED) and o_j its origin; a fixed obstacle has
J = 0. Plain functions and one preallocated (model, data) pair, as Pinocchio's
algorithms are used.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

__all__ = ["PairDistances", "GJK_TOLERANCE"]

#: GJK's tolerance for the optimisation's distances (relative): at Coal's default 1e-6
#: the witness points wander by ~1e-7 m between neighbouring configurations, and finite
#: differences of d disagreed with the witness-point gradient by up to 0.4 m/rad on the
#: Panda; at 1e-9 they agree to 1e-6 (tests/test_optimize.py).
GJK_TOLERANCE = 1e-9


def _convex_model(gm: pin.GeometryModel) -> pin.GeometryModel:
    """``gm`` with every mesh (BVH) replaced by its convex hull, the same pairs: a hull
    contains its mesh, so its distance never overstates the mesh's, and GJK on a hull
    costs microseconds where a non-convex mesh's BVH distance cost milliseconds (UR5)."""
    out = pin.GeometryModel()
    for go in gm.geometryObjects:
        geom = go.geometry
        if isinstance(geom, coal.BVHModelBase):
            mesh = geom.clone()
            mesh.buildConvexHull(True, "Qt")
            geom = mesh.convex
            geom.computeLocalAABB()
        out.addGeometryObject(pin.GeometryObject(go.name, go.parentJoint, go.parentFrame,
                                                 go.placement, geom))
    for cp in gm.collisionPairs:
        out.addCollisionPair(pin.CollisionPair(cp.first, cp.second))
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (n, 3) arrays: the operations of ``np.cross``, in its order (the
    same bits), without its axis handling (40 µs a call in the optimiser's loop)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


class PairDistances:
    """Signed distances (m) of the pairs a :class:`~mpd_pin.collision.CollisionChecker`
    enforces, with gradients in joint space (m/rad).

    ``pairs`` (P,) are collision-pair indices of the checker's geometry model,
    ``margins`` (P,) their required clearance (m). Build once per checker state; the
    data are reused by every call (not thread-safe)."""

    def __init__(self, checker) -> None:
        gm, state = checker.distance_setup()
        gm = _convex_model(gm)
        self.model: pin.Model = checker.model
        self.data: pin.Data = self.model.createData()
        self.gm: pin.GeometryModel = gm
        self.gd: pin.GeometryData = gm.createData()
        for req in self.gd.distanceRequests:  # witness points smooth to ~1e-9 m: the
            req.gjk_tolerance = GJK_TOLERANCE  # default 1e-6 gives gradients off by 0.2
        self.pairs = np.flatnonzero(np.asarray(state.active, dtype=bool)).astype(np.int64)
        self.margins = np.asarray(state.margins, dtype=float)[self.pairs]
        cps = gm.collisionPairs
        self._first = np.array([cps[int(k)].first for k in self.pairs], dtype=np.int64)
        self._second = np.array([cps[int(k)].second for k in self.pairs], dtype=np.int64)
        joint = np.array([go.parentJoint for go in gm.geometryObjects], dtype=np.int64)
        self._j1 = joint[self._first] if self.pairs.size else np.zeros(0, np.int64)
        self._j2 = joint[self._second] if self.pairs.size else np.zeros(0, np.int64)
        #: (P,) bool: pairs of two bodies no joint moves (an arm's base and its table):
        #: the same distance in every configuration
        self.static = (self._j1 == 0) & (self._j2 == 0)
        self.nq = self.model.nq
        # (njoints, 1, nv): 1 on the columns of the joints that move joint j (its support)
        self._support = np.zeros((self.model.njoints, 1, self.model.nv))
        for j in range(1, self.model.njoints):
            for k in self.model.supports[j]:
                if k > 0:
                    jm = self.model.joints[k]
                    self._support[j, 0, jm.idx_v: jm.idx_v + jm.nv] = 1.0
        # the enforced pairs' result objects, read in place after each computeDistances
        # (the vector is never resized; indexing it anew cost a third of distances())
        self._results = [self.gd.distanceResults[int(k)] for k in self.pairs]
        active = np.zeros(len(cps), dtype=bool)
        active[self.pairs] = True
        for k, on in enumerate(active.tolist()):
            if on:
                self.gd.activateCollisionPair(k)
            else:
                self.gd.deactivateCollisionPair(k)

    @property
    def size(self) -> int:
        """The number of enforced pairs P."""
        return int(self.pairs.size)

    def _place(self, q: np.ndarray, jacobians: bool) -> None:
        if jacobians:
            pin.computeJointJacobians(self.model, self.data, q)  # also the placements
        else:
            pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.gm, self.gd)

    def distances(self, Q: np.ndarray) -> np.ndarray:
        """d (S, P): the signed distance (m) of every enforced pair at each row of ``Q``
        (S, nq) rad."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        out = np.empty((Q.shape[0], self.size))
        model, data, gm, gd = self.model, self.data, self.gm, self.gd
        results = self._results
        for s, q in enumerate(Q):
            pin.computeDistances(model, data, gm, gd, q)  # the active (enforced) pairs
            out[s] = [r.min_distance for r in results]
        return out

    def distances_and_gradients(self, Q: np.ndarray, select: list[np.ndarray]
                                ) -> tuple[np.ndarray, np.ndarray]:
        """For each row s of ``Q`` (S, nq) the columns ``select[s]`` (indices into the
        enforced pairs): d (n,) m and ∂d/∂q (n, nq) m/rad, concatenated over s in order.

        A point p fixed to joint j moves at J_v q̇ + (J_ω q̇) × p with the joint's WORLD
        Jacobian, so nᵀ ṗ = (nᵀ J_v + (p × n)ᵀ J_ω) q̇."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        n = int(sum(len(x) for x in select))
        if not n:
            return np.zeros(0), np.zeros((0, self.nq))
        d = np.empty(n)
        nrm, P1, P2 = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
        own = np.empty(n, dtype=np.int64)
        ca = np.empty(n, dtype=np.int64)
        jac = np.empty((len(select), self.model.njoints, 6, self.nq))
        gm, gd, pairs = self.gm, self.gd, self.pairs.tolist()
        distance, J_all, support = pin.computeDistance, self.data.J, self._support
        r = 0
        for s, cols in enumerate(select):
            if not len(cols):
                continue
            self._place(Q[s], True)
            # every joint's WORLD Jacobian (row 0, the universe, is zero): the stacked
            # data.J of computeJointJacobians on each joint's supporting columns, which is
            # what pin.getJointJacobian(…, WORLD) returns, in one product
            np.multiply(np.asarray(J_all)[None], support, out=jac[s])
            cols = np.asarray(cols, dtype=np.int64)
            own[r: r + cols.size] = s
            ca[r: r + cols.size] = cols
            for c in cols.tolist():  # the result object is the pair's: read it at once
                res = distance(gm, gd, pairs[c])
                d[r] = res.min_distance
                nrm[r] = res.normal
                P1[r] = res.getNearestPoint1()
                P2[r] = res.getNearestPoint2()
                r += 1
        G = np.zeros((n, self.nq))
        for joints, p, sign in ((self._j2, P2, 1.0), (self._j1, P1, -1.0)):
            J = jac[own, joints[ca]]  # (n, 6, nq)
            pxn = _cross(p, nrm)
            G += sign * (np.einsum("ni,nij->nj", nrm, J[:, :3])
                         + np.einsum("ni,nij->nj", pxn, J[:, 3:]))
        return d, G
