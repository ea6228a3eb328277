"""Particle swarm optimisation of the D* path (paper 002 §5, eqs. 8–9, Fig. 3).

:func:`pso_minimize` is a plain global-best PSO, vectorised over the swarm:

    vel ← w·vel + c1·r1·(pbest − pos) + c2·r2·(gbest − pos)      (eq. 8)
    pos ← pos + vel                                               (eq. 9)

with r1, r2 ~ U[0, 1] per particle and dimension, the velocity clamped to
[−vmax, vmax] with ``vmax = k·posmax`` (0.1 ≤ k ≤ 1, posmax the largest bound
magnitude of the search space), positions clipped to the bounds (the velocity
component that pushed out is zeroed). The paper's coefficients are the
defaults: c1 = 1, c2 = 3, w = 1. A seeded ``numpy.random.Generator`` makes a
run reproducible.

:class:`ViaPointSmoother` is the paper's use of it: a particle is a set of
*via points chosen from the D* path* — here their sample indices along the
executed D* motion (continuous in the swarm, rounded when decoded). The
start, the via points and the goal, at the times the D* motion passed them,
are joined by ``scipy.interpolate.CubicSpline`` (x and z as functions of the
sample index), and the smoothed motion is that spline evaluated at every
motion sample. Its cost is the end-effector path length (m) — the polyline
through the positions at the motion samples — and it is infinite (forbidden)
when any sample is out of reach, needs a joint step larger than
``max_joint_step`` (rad), or collides with the obstacles *at that sample's
time* — or, between two samples, at one of the ``substeps − 1`` sub-steps
(joints interpolated linearly, obstacles at the sub-step's time). The elbow
branch follows the D* motion's branch at the same sample whenever that keeps
the joints continuous (within ``max_joint_step``), and otherwise stays on the
other one, so a spline that passes a D* branch switch a little inside the
workspace rim can switch a few samples earlier or later.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from .ik import TwoLinkKinematics
from .moving import SampledCollisionChecker

__all__ = ["PSOOptions", "PSOResult", "pso_minimize", "ViaPointSmoother", "SmoothedMotion"]


@dataclass(frozen=True)
class PSOOptions:
    """Swarm size, iterations and coefficients (paper 002: c1 = 1, c2 = 3, w = 1)."""

    particles: int = 30
    iterations: int = 60
    c1: float = 1.0
    c2: float = 3.0
    w: float = 1.0
    k: float = 0.2

    def __post_init__(self) -> None:
        if int(self.particles) < 1 or int(self.iterations) < 0:
            raise ValueError("PSO needs particles ≥ 1 and iterations ≥ 0")
        for name in ("c1", "c2", "w"):
            v = float(getattr(self, name))
            if not math.isfinite(v) or v < 0:
                raise ValueError(f"PSO {name} must be finite and ≥ 0, got {v!r}")
        if not (0.1 <= float(self.k) <= 1.0):
            raise ValueError(f"PSO velocity clamp factor k must be in [0.1, 1], got {self.k!r}")


@dataclass
class PSOResult:
    """Best position and cost, and the best cost after initialisation and each iteration."""

    x: np.ndarray
    cost: float
    cost_curve: list[float]
    evaluations: int
    positions: list[np.ndarray] = field(default_factory=list, repr=False)


def pso_minimize(
    cost: Callable[[np.ndarray], np.ndarray],
    lower: np.ndarray,
    upper: np.ndarray,
    options: PSOOptions,
    rng: np.random.Generator,
    *,
    initial: np.ndarray | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> PSOResult:
    """Minimise ``cost`` (a function of a (P, D) swarm returning (P,) costs, inf allowed).

    ``lower``/``upper`` (D,) bound the search space; ``initial`` (M ≤ P, D)
    optionally replaces the first M random particles. ``callback(iteration,
    best_cost)`` is called after each iteration.
    """
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    if lo.shape != hi.shape or lo.ndim != 1 or np.any(hi < lo):
        raise ValueError("PSO bounds must be two (D,) arrays with lower ≤ upper")
    P, D = int(options.particles), lo.size
    posmax = np.maximum(np.abs(lo), np.abs(hi))
    vmax = float(options.k) * posmax
    pos = lo + (hi - lo) * rng.random((P, D))
    if initial is not None:
        init = np.clip(np.atleast_2d(np.asarray(initial, dtype=float)), lo, hi)[:P]
        pos[: len(init)] = init
    vel = vmax * (2.0 * rng.random((P, D)) - 1.0)
    f = np.asarray(cost(pos), dtype=float)
    evaluations = P
    pbest, pbest_f = pos.copy(), f.copy()
    g = int(np.argmin(pbest_f))
    gbest, gbest_f = pbest[g].copy(), float(pbest_f[g])
    curve = [gbest_f]
    w, c1, c2 = float(options.w), float(options.c1), float(options.c2)
    for it in range(int(options.iterations)):
        r1 = rng.random((P, D))
        r2 = rng.random((P, D))
        vel = w * vel + c1 * r1 * (pbest - pos) + c2 * r2 * (gbest - pos)  # eq. 8
        np.clip(vel, -vmax, vmax, out=vel)
        pos = pos + vel  # eq. 9
        out = (pos < lo) | (pos > hi)
        pos = np.clip(pos, lo, hi)
        vel[out] = 0.0
        f = np.asarray(cost(pos), dtype=float)
        evaluations += P
        better = f < pbest_f
        pbest[better] = pos[better]
        pbest_f[better] = f[better]
        g = int(np.argmin(pbest_f))
        if pbest_f[g] < gbest_f:
            gbest, gbest_f = pbest[g].copy(), float(pbest_f[g])
        curve.append(gbest_f)
        if callback is not None:
            callback(it + 1, gbest_f)
    return PSOResult(x=gbest, cost=gbest_f, cost_curve=curve, evaluations=evaluations)


@dataclass
class SmoothedMotion:
    """A motion sampled at every motion sample: ee points (K+1, 2) m, q (K+1, 2) rad."""

    knots: np.ndarray
    points: np.ndarray
    q: np.ndarray
    branches: np.ndarray
    feasible: bool
    length: float
    reason: str = ""


def path_length(points: np.ndarray) -> float:
    """Length (m) of the polyline through ``points`` (N, 2)."""
    p = np.asarray(points, dtype=float)
    if len(p) < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


class ViaPointSmoother:
    """Cost of via-point selections on a D* motion (module docstring); vectorised over a swarm.

    ``points`` (K+1, 2) m and ``branches`` (K+1,) of the D* motion, one row per
    motion sample; ``checker`` gives the obstacles of each sample (and
    sub-step: ``substeps``, 1 = samples only).
    ``bc_type``: CubicSpline end conditions. ``"clamped"`` makes the spline's
    derivative zero at its two ends (dx/dk = dz/dk = 0 at k = 0 and k = K) —
    *not* a motion that starts and ends at rest sample by sample: the first
    and last steps are x(1) − x(0) and x(K) − x(K−1), a whole grid move when
    a via point sits on sample 1 or K−1 (they are bounded, like every step,
    by ``max_joint_step``).
    """

    def __init__(
        self,
        kin: TwoLinkKinematics,
        checker: SampledCollisionChecker,
        points: np.ndarray,
        branches: np.ndarray,
        *,
        num_via: int,
        max_joint_step: float,
        substeps: int = 1,
        goal_branches: tuple[int, ...] = (0, 1),
        bc_type: str = "clamped",
    ) -> None:
        self.kin = kin
        self.checker = checker
        self.points = np.asarray(points, dtype=float)
        self.branches = np.asarray(branches, dtype=np.int64)
        self.K = len(self.points) - 1
        if self.K < 2:
            raise ValueError("the D* motion is too short to smooth (fewer than 3 samples)")
        self.num_via = int(num_via)
        if self.num_via < 1:
            raise ValueError(f"num_via must be ≥ 1, got {num_via!r}")
        self.max_joint_step = float(max_joint_step)
        self.substeps = int(substeps)
        if self.substeps < 1:
            raise ValueError(f"substeps must be ≥ 1, got {substeps!r}")
        if bc_type not in ("clamped", "natural", "not-a-knot"):
            raise ValueError(f"bc_type must be clamped, natural or not-a-knot, got {bc_type!r}")
        self.bc_type = bc_type
        self.goal_branches = np.array(sorted(set(int(b) for b in goal_branches)), dtype=np.int64)
        self._cache: dict[tuple[int, ...], float] = {}
        self.evaluated = 0
        self.collision_queries = 0

    # bounds of the swarm: via sample indices strictly inside the motion
    @property
    def lower(self) -> np.ndarray:
        return np.full(self.num_via, 1.0)

    @property
    def upper(self) -> np.ndarray:
        return np.full(self.num_via, float(self.K - 1))

    def knots(self, x: np.ndarray) -> np.ndarray:
        """Sample indices [0, sorted unique round(x) in 1..K−1, K] of one particle."""
        via = np.clip(np.rint(np.asarray(x, dtype=float)), 1, self.K - 1).astype(np.int64)
        return np.concatenate([[0], np.unique(via), [self.K]])

    def even_particle(self) -> np.ndarray:
        """Via points evenly spread along the D* motion (a deterministic initial particle)."""
        return np.linspace(0, self.K, self.num_via + 2)[1:-1]

    def _spline_points(self, knots: np.ndarray) -> np.ndarray:
        if len(knots) == 2 and self.bc_type == "not-a-knot":
            bc = "clamped"
        else:
            bc = self.bc_type
        cs = CubicSpline(knots.astype(float), self.points[knots], bc_type=bc, axis=0)
        return cs(np.arange(self.K + 1, dtype=float))

    def _kinematics(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
        """Branches, joint angles and feasibility of spline points ``pts`` (U, K+1, 2).

        The branch starts as the D* motion's; at each later sample the arm takes
        the D* motion's branch when that configuration is reachable within
        ``max_joint_step`` of the previous one, else keeps the other branch if
        that one is; if neither is, the path is infeasible. The last sample's
        branch must be one the goal accepts. Returns (branches (U, K+1),
        q (U, K+1, 2), feasible (U,), reason per path ('' when feasible)).
        """
        U = pts.shape[0]
        sols = (self.kin.ik(pts, 0), self.kin.ik(pts, 1))
        qb = np.stack([sols[0].q, sols[1].q])  # (2, U, K+1, 2)
        rb = np.stack([sols[0].reachable, sols[1].reachable])  # (2, U, K+1)
        rows = np.arange(U)
        b = np.full(U, self.branches[0], dtype=np.int64)
        B = np.empty((U, self.K + 1), dtype=np.int64)
        B[:, 0] = b
        q = np.empty((U, self.K + 1, 2))
        q[:, 0] = qb[b, rows, 0]
        ok = rb[b, rows, 0].copy()
        reason = ["" if o else "sample 0 out of reach" for o in ok]
        lim = self.max_joint_step
        for k in range(1, self.K + 1):
            want = self.branches[k]
            q_prev = q[:, k - 1]
            qc, qo = qb[b, rows, k], qb[1 - b, rows, k]
            ok_c = rb[b, rows, k] & (np.abs(qc - q_prev).max(axis=1) <= lim)
            ok_o = rb[1 - b, rows, k] & (np.abs(qo - q_prev).max(axis=1) <= lim)
            switch = ok_o & (((1 - b) == want) | ~ok_c)
            b = np.where(switch, 1 - b, b)
            B[:, k] = b
            q[:, k] = np.where(switch[:, None], qo, qc)
            bad = ok & ~(ok_c | ok_o)
            for i in np.flatnonzero(bad):
                reach = bool(rb[0, i, k] or rb[1, i, k])
                reason[i] = (f"joint step > {lim} rad at sample {k}" if reach
                             else f"sample {k} out of reach")
            ok &= ok_c | ok_o
        bad = ok & ~np.isin(b, self.goal_branches)
        for i in np.flatnonzero(bad):
            reason[i] = "ends on a branch the goal does not accept"
        ok &= ~bad
        return B, q, ok, reason

    def motion(self, x: np.ndarray | None = None, *, knots: np.ndarray | None = None
               ) -> SmoothedMotion:
        """The smoothed motion of one particle (or of explicit ``knots``), fully checked."""
        kn = self.knots(x) if knots is None else np.asarray(knots, dtype=np.int64)
        pts = self._spline_points(kn)
        B, q, ok, reasons = self._kinematics(pts[None])
        reason = reasons[0]
        if not reason:
            for k in range(self.K + 1):
                if not self.checker.is_free(q[0, k], k):
                    reason = f"collision at sample {k}"
                    break
                if k < self.K and not self.checker.is_free_between(
                    q[0, k], q[0, k + 1], k, self.substeps
                ):
                    reason = f"collision between samples {k} and {k + 1}"
                    break
        return SmoothedMotion(
            knots=kn,
            points=pts,
            q=q[0],
            branches=B[0],
            feasible=not reason,
            length=path_length(pts),
            reason=reason,
        )

    def costs(self, X: np.ndarray) -> np.ndarray:
        """Path length (m) of each particle's smoothed motion; inf where infeasible."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = X.shape[0]
        out = np.full(P, np.inf)
        keys = [tuple(self.knots(x).tolist()) for x in X]
        todo: dict[tuple[int, ...], list[int]] = {}
        for i, key in enumerate(keys):
            if key in self._cache:
                out[i] = self._cache[key]
            else:
                todo.setdefault(key, []).append(i)
        if not todo:
            return out
        uniq = list(todo)
        pts = np.stack([self._spline_points(np.asarray(k)) for k in uniq])  # (U, K+1, 2)
        self.evaluated += len(uniq)
        _, q, ok, _ = self._kinematics(pts)
        # Collisions at every sample after the first, against the obstacles of that sample,
        # and at the sub-steps between the previous sample and this one.
        for k in range(1, self.K + 1):
            idx = np.flatnonzero(ok)
            if idx.size == 0:
                break
            free = self.checker.is_free_batch(q[idx, k], k)
            self.collision_queries += idx.size
            ok[idx[~free]] = False
            idx = idx[free]
            if self.substeps > 1 and idx.size:
                free = self.checker.is_free_between_batch(q[idx, k - 1], q[idx, k], k - 1,
                                                          self.substeps)
                self.collision_queries += idx.size * (self.substeps - 1)
                ok[idx[~free]] = False
        lengths = np.linalg.norm(np.diff(pts, axis=1), axis=2).sum(axis=1)
        vals = np.where(ok, lengths, np.inf)
        for key, v in zip(uniq, vals.tolist(), strict=True):
            self._cache[key] = v
            for i in todo[key]:
                out[i] = v
        return out
