"""Trajectory optimisation at a fixed duration, then certification (docs/design.md §9g).

A motion of duration T is one clamped quintic B-spline in time, q(t) = Σ_i c_i N_i(t/T),
with ``n_c`` control points per joint on uniform knots; the first three and the last three
control points are the start and the goal, so q̇ = q̈ = 0 at both ends and the motion
leaves and joins the holding state as every other motion does. The free control points
x minimise the perfect-tracking supply energy (the screen of §9e/§9c, paper 000 eq. 2)

    E(x) = ∫₀ᵀ Σ_k s(V_ff,k i_ff,k) dt          (a supply per joint; s ≈ max(·, 0))
    E(x) = ∫₀ᵀ s(P) − η s(−P) dt, P = Σ_k V_ff,k i_ff,k     (a shared bus, §3i)

by Simpson's rule, with s a softplus of sharpness ``sharpness``/P_scale, subject to

* signed distance d_p(q(t_s)) ≥ margin_p + ``margin`` for every pair p the checker
  enforces (obstacles, self-collision, hazards with their clearance) at collision
  samples t_s, the pairs within ``activation`` of it (re-chosen each round);
* |q̇| ≤ ``velocity_fraction`` · v_lim at the energy samples where the seed comes within
  half the limit (linear in x);
* |τ_ff| ≤ ``effort_fraction`` · τ_lim at the energy samples where the seed comes within
  half the limit;
* the joint range on the control points themselves (bounds; convex hull again).

Gradients are analytic: q, q̇, q̈, q⃛ are linear in x through the basis matrices;
``pin.computeRNEADerivatives`` gives ∂τ/∂q, ∂τ/∂q̇ and M = ∂τ/∂q̈; the L·τ̇ term of V_ff
differentiates through d/dt of ∂τ/∂x along the sample grid (second order); distances
through the witness points (:mod:`mpd_pin.collision.distance`). The solver is scipy's
SLSQP (design §9g says why). The result is certified by the Bernstein boxes of §9c and
simulated with the RK4 of §3; it is kept only when certified, within the limits and
cheaper *simulated* than its seed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.interpolate import BSpline
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits

from ..collision.distance import PairDistances
from ..dynamics.motor import Drive
from ..dynamics.supply import supply_energy
from .certify import first_failure
from .energy import (
    MotionEnergy,
    _fastest,
    _simulate_nonstop,
    _snap,
    check_waypoints,
    limit_reasons,
)
from .screen import joint_limits
from .spline import ViaSpline, unit_knots, via_spline

__all__ = ["OptimizeSettings", "OptimizedMotion", "optimize_curve", "optimize_motion", "polish",
           "spline_curve", "fit_curve", "seed_curve"]

DEGREE = 5


@dataclass(frozen=True)
class OptimizeSettings:
    """Settings of the trajectory optimisation (docs/design.md §9g).

    control_points: per joint (0: from the seed, 16–24); samples: Simpson intervals of the
    energy integral (even); collision_samples: times the distances are constrained at
    (0: 4 per knot span); margin: clearance (m) beyond each pair's own margin;
    activation: pairs closer than this (m) at a collision sample are constrained, at most
    ``pairs_per_sample`` (the closest) each time a round starts;
    velocity_fraction, effort_fraction: of the URDF limits; max_iterations: SLSQP
    iterations per round; rounds: at most, each adding the pairs its start comes near;
    tolerance: SLSQP's ftol on the energy relative to the seed's; sharpness: of the
    softplus, relative to the seed's peak power; retries: solves again, with collision
    samples added where the last one came too close between samples, after a failed
    check; budget: SLSQP iterations one seed's solves may take in all before they stop
    where they are (iterations, not seconds, so that a result never depends on the
    machine's speed or load); query_budget: iterations all seeds of one query share (a
    later seed gets what the earlier ones left, and none starts with less than a tenth of
    it); cpu_limit: CPU seconds after which a seed stops regardless, a guard against
    pathological solves only (never reached on the bench's queries); polish: iterations
    of one more solve from the query's best optimum, with a fresh SLSQP model (0: none),
    on ``polish_points`` more control points per joint.
    """

    control_points: int = 0
    samples: int = 96
    collision_samples: int = 0
    margin: float = 0.01
    activation: float = 0.06
    pairs_per_sample: int = 64
    velocity_fraction: float = 0.99
    effort_fraction: float = 0.95
    max_iterations: int = 40
    rounds: int = 4
    tolerance: float = 1e-5
    sharpness: float = 200.0
    retries: int = 3
    budget: int = 240
    query_budget: int = 400
    cpu_limit: float = 6.0
    polish: int = 240
    polish_points: int = 8


@dataclass
class OptimizedMotion:
    """The outcome of one optimisation: the motion (None when the seed is kept), and the
    record of ``motion.optimization`` (docs/design.md §9g)."""

    motion: MotionEnergy | None
    record: dict[str, Any] = field(default_factory=dict)


# ----------------------------------------------------------------------------- basis
def _difference(n: int, h: float) -> np.ndarray:
    """D (n, n): d/dt on n samples h s apart, central inside and second-order one-sided
    at the ends, as ``np.gradient(f, h, edge_order=2)`` (1/s)."""
    D = np.zeros((n, n))
    r = np.arange(1, n - 1)
    D[r, r - 1], D[r, r + 1] = -0.5, 0.5
    D[0, :3] = (-1.5, 2.0, -0.5)
    D[-1, -3:] = (0.5, -2.0, 1.5)
    return D / h


def _knots(n_c: int) -> np.ndarray:
    """Clamped uniform knots on [0, 1] for ``n_c`` control points of degree 5."""
    inner = np.linspace(0.0, 1.0, n_c - DEGREE + 1)
    return np.concatenate([np.zeros(DEGREE), inner, np.ones(DEGREE)])


def _basis(knots: np.ndarray, n_c: int, tau: np.ndarray, nu: int) -> np.ndarray:
    """(len(tau), n_c): the ν-th derivative (per unit of τ) of every basis function."""
    b = BSpline(knots, np.eye(n_c), DEGREE, extrapolate=False)
    out = b.derivative(nu)(tau) if nu else b(tau)
    return np.nan_to_num(out)


def spline_curve(knots: np.ndarray, C: np.ndarray, duration: float) -> ViaSpline:
    """The curve of control points ``C`` (n_c, nq) on unit ``knots``, as a
    :class:`~mpd_pin.motion.spline.ViaSpline` of duration ``duration`` (s) at unit stretch:
    its ``waypoints`` are the curve at its breakpoints, so it simulates, certifies and
    records like every non-stop piece."""
    T = float(duration)
    spl = BSpline(np.asarray(knots, float) * T, np.asarray(C, float), DEGREE)
    times = np.unique(spl.t)
    times = times[(times >= 0) & (times <= T)]
    return ViaSpline(spl(times), times, spl, optimised=True)


def fit_curve(q_of_tau, n_c: int, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Control points (n_c, nq) whose curve fits ``q_of_tau`` (τ ∈ [0, 1] → (…, nq) rad) in
    least squares, the first and last three fixed at ``q0`` and ``q1``."""
    knots = _knots(n_c)
    tau = np.linspace(0.0, 1.0, 8 * n_c)
    B = _basis(knots, n_c, tau, 0)
    target = np.asarray(q_of_tau(tau), float)
    C = np.empty((n_c, q0.size))
    C[:3], C[-3:] = q0, q1
    rhs = target - B[:, :3] @ C[:3] - B[:, -3:] @ C[-3:]
    C[3:-3] = np.linalg.lstsq(B[:, 3:-3], rhs, rcond=None)[0]
    return C


# ----------------------------------------------------------------------------- problem
class _Problem:
    """The discretised problem of one seed (module docstring): objective, constraints and
    their Jacobians in the free control points x (flattened (n_c − 6, nq), row-major)."""

    def __init__(self, drive: Drive, distances, C0: np.ndarray, T: float,
                 settings: OptimizeSettings) -> None:
        self.drive, self.dist, self.T, self.s = drive, distances, float(T), settings
        self.model = drive.model
        self.data = self.model.createData()
        n_c, nq = C0.shape
        self.n_c, self.nq, self.nf = n_c, nq, n_c - 6
        self.knots = _knots(n_c)
        self.C_fixed = C0.copy()
        S = int(settings.samples) + int(settings.samples) % 2
        self.tau = np.linspace(0.0, 1.0, S + 1)
        w = np.ones(S + 1)
        w[1:-1:2], w[2:-1:2] = 4.0, 2.0
        self.w = w * (self.T / (3.0 * S))  # Simpson weights in s
        self.h = self.T / S
        self.Dt = _difference(S + 1, self.h).T  # Dᵀ of d/dt along the samples
        self.B = [_basis(self.knots, n_c, self.tau, nu) / self.T**nu for nu in range(4)]
        self.Bf = [b[:, 3:-3] for b in self.B]
        n_col = settings.collision_samples or 4 * (n_c - DEGREE)
        self.tau_c = np.linspace(0.0, 1.0, n_col + 2)[1:-1]
        self.Bc = _basis(self.knots, n_c, self.tau_c, 0)
        self.vlim, self.elim = joint_limits(drive)
        self.supply = drive.supply
        self._cache: dict[str, Any] = {}
        self.active: list[np.ndarray] = [np.zeros(0, np.int64)] * self.tau_c.size
        self.effort_rows = np.zeros((0, 2), np.int64)
        self.velocity_rows = np.zeros((0, 2), np.int64)
        self.beta = 1.0

    # -- variables
    def C(self, x: np.ndarray) -> np.ndarray:
        C = self.C_fixed.copy()
        C[3:-3] = x.reshape(self.nf, self.nq)
        return C

    def x0(self) -> np.ndarray:
        return self.C_fixed[3:-3].ravel().copy()

    def bounds(self) -> list[tuple[float, float]]:
        lo = np.asarray(self.drive.arm.lower_limits, float)
        hi = np.asarray(self.drive.arm.upper_limits, float)
        lo = np.where(np.isfinite(lo), lo, -1e3)
        hi = np.where(np.isfinite(hi), hi, 1e3)
        return list(zip(np.tile(lo, self.nf), np.tile(hi, self.nf), strict=True))

    # -- dynamics along the samples
    def _dynamics(self, x: np.ndarray) -> dict[str, np.ndarray]:
        key = x.tobytes()
        if self._cache.get("key") == key:
            return self._cache
        C = self.C(x)
        q, v, a, j = (b @ C for b in self.B)
        S1, nq = q.shape
        tau = np.empty((S1, nq))
        dq = np.empty((S1, nq, nq))
        dv = np.empty((S1, nq, nq))
        M = np.empty((S1, nq, nq))
        model, data = self.model, self.data
        for s in range(S1):
            r = pin.computeRNEADerivatives(model, data, q[s], v[s], a[s])
            tau[s] = data.tau
            dq[s], dv[s], M[s] = r[0], r[1], r[2]
        drv = self.drive
        tau_ff = tau + drv.damping * v
        dtau_ff = (np.einsum("sab,sb->sa", dq, v) + np.einsum("sab,sb->sa", dv, a)
                   + np.einsum("sab,sb->sa", M, j) + drv.damping * a)
        kt = drv.torque_per_amp
        i = tau_ff / kt
        V = drv.R * i + drv.L * dtau_ff / kt + drv.emf_per_rad_s * v
        self._cache = {"key": key, "q": q, "v": v, "a": a, "tau": tau_ff, "i": i, "V": V,
                       "P": V * i, "dq": dq, "dv": dv, "M": M}
        return self._cache

    def _dtau_rows(self, d: dict, s: np.ndarray, k: np.ndarray) -> np.ndarray:
        """∂τ_ff,k(t_s)/∂x (n, nf·nq) for the (sample, joint) rows ``(s, k)``: joint k's
        torque at sample s against every free control point."""
        B0, B1, B2 = self.Bf[0][s], self.Bf[1][s], self.Bf[2][s]  # (n, nf)
        G = (B0[:, :, None] * d["dq"][s, k][:, None, :] + B1[:, :, None] * d["dv"][s, k][:, None, :]
             + B2[:, :, None] * d["M"][s, k][:, None, :])  # (n, nf, nq)
        G[np.arange(len(s)), :, k] += self.drive.damping[k][:, None] * B1
        return G.reshape(len(s), -1)

    def _soft(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """softplus(P) (W) and its slope, sharpness ``beta`` (1/W)."""
        z = self.beta * P
        sp = (np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z)))) / self.beta
        return sp, 0.5 * (1.0 + np.tanh(0.5 * z))

    def _power_weights(self, P: np.ndarray) -> tuple[float, np.ndarray]:
        """The smoothed supply energy (J) and ∂E/∂P_k at each sample (s)."""
        if self.supply.bus == "per_joint":
            sp, slope = self._soft(P)
            return float(self.w @ sp.sum(axis=1)), self.w[:, None] * slope
        eta = self.supply.regeneration
        Pb = P.sum(axis=1)
        sp, slope = self._soft(Pb)
        sn, slope_n = self._soft(-Pb)
        E = float(self.w @ (sp - eta * sn))
        g = self.w * (slope + eta * slope_n)
        return E, np.repeat(g[:, None], self.nq, axis=1)

    def energy(self, x: np.ndarray) -> float:
        return self._power_weights(self._dynamics(x)["P"])[0]

    def energy_grad(self, x: np.ndarray) -> np.ndarray:
        """∂E/∂x by the adjoint of the chain x → (q, q̇, q̈, q⃛) → τ_ff, τ̇_ff → (i, V) → P:

            ∂E/∂x = Σ_s,a γ_sa ∂τ_sa/∂x + Σ_s w_P,sa i_sa K_e,a ∂q̇_sa/∂x,
            γ = w_P (V + R i)/K_t + Dᵀ (w_P i L/K_t),

        with D the second-order difference along the samples (τ̇ = D τ, as
        ``np.gradient``) and ∂τ/∂x = ∂τ/∂q B₀ + ∂τ/∂q̇ B₁ + M B₂ (+ damping B₁), so the
        joints' sums come before the basis matrices: O(S nq²), not O(S nq² nf)."""
        d = self._dynamics(x)
        _, wP = self._power_weights(d["P"])  # (S+1, nq)
        drv = self.drive
        kt = drv.torque_per_amp
        i, V = d["i"], d["V"]
        gamma = wP * (V + drv.R * i) / kt + self.Dt @ (wP * i * drv.L / kt)
        u = np.einsum("sa,sab->sb", gamma, d["dq"])
        w = np.einsum("sa,sab->sb", gamma, d["M"])
        v = (np.einsum("sa,sab->sb", gamma, d["dv"]) + gamma * drv.damping
             + wP * i * drv.emf_per_rad_s)
        B0, B1, B2 = self.Bf[0], self.Bf[1], self.Bf[2]
        return (B0.T @ u + B1.T @ v + B2.T @ w).ravel()

    # -- constraints (all as g(x) ≥ 0)
    @staticmethod
    def _grow(rows: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, int]:
        both = np.unique(np.vstack([rows, new]), axis=0) if len(new) else rows
        return both.astype(np.int64), len(both) - len(rows)

    def choose_velocity_rows(self, x: np.ndarray) -> int:
        """Add the (sample, joint) rows where |q̇| at ``x`` is above half the limit."""
        v = self._dynamics(x)["v"]
        self.velocity_rows, n = self._grow(self.velocity_rows,
                                           np.argwhere(np.abs(v) > 0.5 * self.vlim[None, :]))
        return n

    def velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear rows A x + b ≥ 0: |q̇_k(t_s)| ≤ f v_lim,k at the energy samples where the
        round's start point is above half the limit."""
        rows = self.velocity_rows
        if not len(rows):
            return np.zeros((0, self.nf * self.nq)), np.zeros(0)
        s, k = rows[:, 0], rows[:, 1]
        lim = self.s.velocity_fraction * self.vlim[k]
        Cfix = self.C_fixed.copy()
        Cfix[3:-3] = 0.0
        const = (self.B[1] @ Cfix)[s, k]
        A = np.zeros((len(s), self.nf, self.nq))
        A[np.arange(len(s)), :, k] = self.Bf[1][s]
        A = A.reshape(len(s), -1)
        return np.vstack([-A, A]), np.concatenate([lim - const, lim + const])

    def choose_effort_rows(self, x: np.ndarray) -> int:
        """Add the (sample, joint) rows where |τ_ff| at ``x`` is above half the limit."""
        tau = self._dynamics(x)["tau"]
        self.effort_rows, n = self._grow(self.effort_rows,
                                         np.argwhere(np.abs(tau) > 0.5 * self.elim[None, :]))
        return n

    def effort(self, x: np.ndarray) -> np.ndarray:
        if not len(self.effort_rows):
            return np.zeros(0)
        tau = self._dynamics(x)["tau"]
        s, k = self.effort_rows[:, 0], self.effort_rows[:, 1]
        lim = self.s.effort_fraction * self.elim[k]
        return np.concatenate([lim - tau[s, k], lim + tau[s, k]])

    def effort_jac(self, x: np.ndarray) -> np.ndarray:
        if not len(self.effort_rows):
            return np.zeros((0, self.nf * self.nq))
        s, k = self.effort_rows[:, 0], self.effort_rows[:, 1]
        J = self._dtau_rows(self._dynamics(x), s, k)
        return np.vstack([-J, J])

    def add_samples(self, x: np.ndarray, count: int = 400) -> int:
        """Add collision samples where the curve at ``x``, checked at ``count`` times,
        comes closer than ``margin`` to any pair's margin between the current samples
        (each such time, its pairs within ``activation``); returns how many were added."""
        if self.dist is None or not self.dist.size:
            return 0
        tau = np.linspace(0.0, 1.0, count)[1:-1]
        Q = _basis(self.knots, self.n_c, tau, 0) @ self.C(x)
        d = self.dist.distances(Q) - self.dist.margins[None, :]
        low = d.min(axis=1)
        close = low < 0.5 * self.s.margin  # at an active constraint d = margin at the samples
        if not close.any():
            return 0
        # per run of close times: its closest time and up to 6 more spread over the run
        # and a step beyond each end (one sample per run chased the penetration along)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], close.astype(int), [0]])))
        picks = []
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            a, b = max(a - 1, 0), min(b + 1, tau.size)
            picks += [a + int(np.argmin(low[a:b]))]
            picks += np.linspace(a, b - 1, min(b - a, 6)).round().astype(int).tolist()
        bad = np.unique(picks)
        self.tau_c = np.concatenate([self.tau_c, tau[bad]])
        self.Bc = _basis(self.knots, self.n_c, self.tau_c, 0)
        self.active = self.active + [np.flatnonzero(d[b] < self.s.activation).astype(np.int64)
                                     for b in bad]
        self._cache.pop("collision", None)
        return int(bad.size)

    def choose_pairs(self, x: np.ndarray) -> int:
        """Add to the constrained (sample, pair) set those within ``activation`` (m) of
        their margin at ``x`` (the set only grows, so a solve never forgets a pair it met);
        returns how many rows were added."""
        if self.dist is None or not self.dist.size:
            return 0
        Q = self.Bc @ self.C(x)
        d = self.dist.distances(Q) - self.dist.margins[None, :]
        added = 0
        for s, row in enumerate(d):
            near = np.flatnonzero(row < self.s.activation)
            near = np.setdiff1d(near, self.active[s])
            new = near[np.argsort(row[near])[: self.s.pairs_per_sample]]
            if new.size:
                self.active[s] = np.union1d(self.active[s], new).astype(np.int64)
                added += int(new.size)
        self._cache.pop("collision", None)
        return added

    def _collision(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = x.tobytes()
        c = self._cache.get("collision")
        if c is not None and c[0] == key:
            return c[1], c[2]
        Q = self.Bc @ self.C(x)
        dval, dq = self.dist.distances_and_gradients(Q, self.active)
        owner = np.concatenate([np.full(len(a), s) for s, a in enumerate(self.active)]
                               ).astype(np.int64) if dval.size else np.zeros(0, np.int64)
        cols = np.concatenate(self.active) if dval.size else np.zeros(0, np.int64)
        g = dval - self.dist.margins[cols] - self.s.margin
        Bf = self.Bc[:, 3:-3]
        J = (Bf[owner][:, :, None] * dq[:, None, :]).reshape(len(dval), -1)
        self._cache["collision"] = (key, g, J)
        return g, J

    def collision(self, x: np.ndarray) -> np.ndarray:
        return self._collision(x)[0]

    def collision_jac(self, x: np.ndarray) -> np.ndarray:
        return self._collision(x)[1]


# ----------------------------------------------------------------------------- solve
#: A row below −this (m for distances, rad/s, N·m) makes an iterate infeasible for
#: :func:`_solve`'s record of the cheapest feasible one.
FEASIBLE = 1e-4


def _solve(prob: _Problem, x: np.ndarray, settings: OptimizeSettings,
           deadline: float = np.inf, iterations: int = 10**9) -> tuple[np.ndarray, dict]:
    """Rounds of SLSQP from ``x``. Each round adds the (sample, pair) rows, velocity and
    effort rows its start point comes near; the solve ends when a round converges and its
    end point adds no collision row, or after ``iterations`` SLSQP iterations in all (or
    past the CPU time ``deadline``). Returns the last iterate and counters."""
    iters, status, msg = 0, 0, ""
    best: list = [np.inf, None]  # energy, iterate
    for _ in range(max(1, int(settings.rounds))):
        added = (prob.choose_pairs(x) + prob.choose_effort_rows(x)
                 + prob.choose_velocity_rows(x))
        if iters and status == 0 and not added:
            break
        A, b = prob.velocity()
        cons = []
        if len(b):
            cons.append({"type": "ineq", "fun": lambda z, A=A, b=b: A @ z + b,
                         "jac": lambda z, A=A: A})
        if any(len(a) for a in prob.active):
            cons.append({"type": "ineq", "fun": prob.collision, "jac": prob.collision_jac})
        if len(prob.effort_rows):
            cons.append({"type": "ineq", "fun": prob.effort, "jac": prob.effort_jac})
        scale = max(abs(prob.energy(x)), 1e-9)

        def keep(z, cons=cons, inside=True):  # the cheapest iterate within every row so far
            if inside and time.process_time() > deadline:
                raise StopIteration  # SLSQP stops and returns its current iterate
            worst = min((float(np.min(c["fun"](z), initial=np.inf)) for c in cons),
                        default=np.inf)
            if worst >= -FEASIBLE and prob.energy(z) < best[0]:
                best[:] = [prob.energy(z), np.array(z, float)]

        if time.process_time() > deadline:
            status, msg = 9, "CPU limit reached"
            break
        if iters >= iterations:
            status, msg = 9, "iteration budget used up"
            break
        keep(x, inside=False)
        res = minimize(lambda z, k=scale: prob.energy(z) / k, x,
                       jac=lambda z, k=scale: prob.energy_grad(z) / k, method="SLSQP",
                       bounds=prob.bounds(), constraints=cons, callback=keep,
                       options={"maxiter": int(min(settings.max_iterations,
                                                   iterations - iters)),
                                "ftol": float(settings.tolerance)})
        iters += int(res.nit)
        status, msg = int(res.status), str(res.message)
        x = np.asarray(res.x, float)
        keep(x, inside=False)
        if status not in (0, 9) and best[1] is not None:
            # SLSQP's subproblem failed ("more than 3n iterations in LSQ subproblem",
            # "positive directional derivative"): its last iterate can be far worse than
            # where it started; go on from the cheapest iterate within every row instead
            x = best[1].copy()
    info = {"iterations": iters, "solver_status": status, "solver_message": msg}
    if best[1] is not None and status != 0:  # stopped early: its last iterate may be outside
        x = best[1]
    return x, info


def seed_curve(drive: Drive, motion: MotionEnergy) -> ViaSpline:
    """The curve an optimisation starts from (docs/design.md §9g): an optimised motion's
    own spline; else the non-stop spline through all of ``motion``'s waypoints (a
    stop-and-go motion's polyline, or a non-stop motion's pieces, joined without stops)."""
    if motion.curve is not None:
        return motion.curve
    vlim, _ = joint_limits(drive)
    W = motion.waypoints
    return via_spline(W, unit_knots(W, vlim))


def _control_points(settings: OptimizeSettings, via: int) -> int:
    if settings.control_points:
        return max(int(settings.control_points), 8)
    return int(np.clip(12 + 2 * via, 16, 24))


def optimize_curve(
    drive: Drive,
    checker: Any,
    seed: ViaSpline,
    duration: float,
    options: Any,
    *,
    settings: OptimizeSettings | None = None,
    seed_motion: MotionEnergy | None = None,
    distances: Any = None,
) -> OptimizedMotion:
    """Optimise the motion of duration ``duration`` (s, on the dt grid) seeded by the curve
    ``seed`` (stretched to that duration) and keep it when it is certified free by
    ``checker`` (None: no obstacles), within the velocity, effort and arrival limits of
    ``options`` (:class:`~mpd_pin.planning.roadmap.RoadmapOptions`) and cheaper than
    ``seed_motion`` when simulated (docs/design.md §9g). ``distances``: a
    :class:`~mpd_pin.collision.distance.PairDistances` of ``checker`` to reuse.
    Never raises for a failed solve: the seed is kept and the record says why."""
    settings = settings or OptimizeSettings()
    w0, c0 = time.perf_counter(), time.process_time()
    dt = float(options.dt)
    T = float(_snap(duration, dt))
    q0, q1 = seed.waypoints[0], seed.waypoints[-1]
    if seed.optimised and not settings.control_points:  # a restart: its own polygon
        n_c = int(seed.spline.c.shape[0])
    else:
        n_c = _control_points(settings, seed.waypoints.shape[0] - 2)
    stretch = seed.unit_duration

    def seed_q(tau):
        return seed.spline(np.clip(tau, 0.0, 1.0) * stretch)

    C0 = fit_curve(seed_q, n_c, q0, q1)
    if checker is not None and distances is None:
        distances = PairDistances(checker)
    with threadpool_limits(1):  # small dense algebra: a second BLAS thread only spins
        return _optimize(drive, checker, T, options, settings, seed_motion, distances,
                         C0, n_c, w0, c0)


def _optimize(drive, checker, T, options, settings, seed_motion, distances, C0, n_c,
              w0, c0) -> OptimizedMotion:
    """The body of :func:`optimize_curve` (BLAS on one thread)."""
    rec: dict[str, Any] = {"duration": T, "control_points": n_c,
                           "seed_energy": None if seed_motion is None
                           else float(seed_motion.total_energy)}
    prob = _Problem(drive, distances, C0, T, settings)
    x0 = prob.x0()
    P0 = prob._dynamics(x0)["P"]
    prob.beta = settings.sharpness / max(float(np.max(np.abs(P0))), 1e-9)
    rec["screen_energy_in"] = prob.energy(x0)
    kept = None
    x = x0
    for attempt in range(int(settings.retries) + 1):
        used = rec.get("iterations", 0)
        if attempt and (used >= settings.budget
                        or time.process_time() > c0 + settings.cpu_limit):
            rec["why"] = rec.get("why", "") + (f"; iteration budget ({settings.budget}) used up"
                                               if used >= settings.budget else
                                               f"; CPU limit ({settings.cpu_limit:g} s) reached")
            break
        if attempt and prob.energy(x) > rec["screen_energy_in"]:
            x = x0  # a failed solve that ended above its seed: again from the seed
        try:
            x, info = _solve(prob, x, settings, deadline=c0 + settings.cpu_limit,
                             iterations=int(settings.budget) - used)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
            rec.update(kept_seed=True, why=f"solver failed: {exc}")
            break
        info["iterations"] += rec.get("iterations", 0)
        rec.update(info)
        rec["screen_energy_out"] = prob.energy(x)
        curve = spline_curve(prob.knots, prob.C(x), T)
        if checker is not None:
            fail = _sampled_failure(checker, curve)
            # collision samples where it came too close between them, for the next solve
            added = prob.add_samples(x)
            rec["samples_added"] = rec.get("samples_added", 0) + added
            if fail is None and not added:
                fail = first_failure(checker, curve, options.resolution)
            elif fail is None:
                fail = -1.0  # closer than the margin between samples: solve again first
            if fail is not None:
                rec["certified"] = False
                rec["why"] = ("not certified free" + (f" at t = {fail:.3f} s" if fail >= 0
                                                      else " (closer than the margin between "
                                                      "the collision samples)"))
                continue
        rec["certified"] = True
        rec.pop("why", None)
        kept = _price(drive, curve, T, options)
        break
    rec.update(seconds=time.perf_counter() - w0, cpu_seconds=time.process_time() - c0,
               margin=settings.margin)
    if kept is None:
        rec.setdefault("why", "no certified optimum")
        rec["kept_seed"] = True
        return OptimizedMotion(None, rec)
    rec["energy"] = float(kept.total_energy)
    if not kept.feasible:
        rec.update(kept_seed=True, why=f"the optimum is infeasible when simulated: "
                   f"{kept.reason}")
        return OptimizedMotion(None, rec)
    if seed_motion is not None and seed_motion.feasible and (
            kept.total_energy >= seed_motion.total_energy):
        rec.update(kept_seed=True, why="no less energy than the seed when simulated")
        return OptimizedMotion(None, rec)
    rec["kept_seed"] = False
    return OptimizedMotion(kept, rec)


def polish(drive: Drive, checker: Any, out: OptimizedMotion, options: Any,
           settings: OptimizeSettings | None = None, distances: Any = None) -> OptimizedMotion:
    """Two solves more from an optimum ``out.motion``, each with a fresh SLSQP model and
    ``settings.polish`` iterations (docs/design.md §9g): one on its own control polygon
    (SLSQP's BFGS model can meet ``ftol`` short of the optimum), then one on a finer
    spline, its curve fitted with ``settings.polish_points`` more control points per joint
    (the coarse spline leaves energy on the table: an independent optimiser on a finer
    spline found up to 15 % less). Each is kept only when cheaper, simulated;
    ``record["polish"]`` holds the two records."""
    settings = settings or OptimizeSettings()
    if out.motion is None or not settings.polish:
        return out
    won, records, cpu = out.motion, [], 0.0
    for extra in (0, int(settings.polish_points)):
        if records and not extra:
            break
        n_c = int(won.curve.spline.c.shape[0]) + extra
        again = optimize_curve(drive, checker, seed_curve(drive, won), won.duration, options,
                               settings=replace(settings, budget=int(settings.polish),
                                                control_points=n_c),
                               seed_motion=won, distances=distances)
        records.append(again.record)
        cpu += float(again.record["cpu_seconds"])
        won = again.motion or won
    rec = {**out.record, "polish": records, "cpu_seconds": out.record["cpu_seconds"] + cpu}
    return OptimizedMotion(won, rec)


def _sampled_failure(checker: Any, curve: ViaSpline, samples: int = 400) -> float | None:
    """The first of ``samples`` evenly spaced times (s) at which the curve collides, or None:
    a cheap test before the certificate, which is slow on a curve that collides."""
    t = np.linspace(0.0, curve.unit_duration, samples)
    hit = ~checker.is_free_batch(curve.spline(t))
    return float(t[np.argmax(hit)]) if hit.any() else None


def _price(drive: Drive, curve: ViaSpline, T: float, options) -> MotionEnergy:
    """Simulate the optimised curve at T (RK4, §3) and check it as a non-stop piece."""
    vlim, elim = joint_limits(drive)
    E, _, err, _, peak, B = _simulate_nonstop(drive, curve, np.array([T]), float(options.dt))
    vel = curve.peak_speed_ratio(vlim) * curve.unit_duration / T
    eff = float(np.max(peak[0] / elim))
    e = float(np.max(np.abs(err[0])))
    reasons = limit_reasons(options, eff, e, vel, "the goal")
    total = float(supply_energy(drive.supply, E[0], B[0]))
    W = curve.waypoints
    m = W.shape[0] - 1
    return MotionEnergy("nonstop", W, E[0].copy(), total, T, e, float(vel), eff, not reasons,
                        0, [(0, m)], np.array([T]), "; ".join(reasons),
                        energy_by_execution={"nonstop": total if not reasons else None},
                        fastest=T if math.isfinite(T) else 0.0, bus_energy=B[0].copy(),
                        supply=drive.supply, curve=curve)


def optimize_motion(
    drive: Drive,
    world: Any,
    waypoints: Any,
    duration: float,
    *,
    options: Any = None,
    checker: Any = None,
    settings: OptimizeSettings | None = None,
) -> MotionEnergy:
    """A locally energy-optimal, certified motion of ``duration`` (s) from any joint-space
    path ``waypoints`` ((m+1, nq) rad: OMPL, MoveIt, a teach pendant; docs/design.md §9g).

    The seed is the non-stop quintic spline through the waypoints (§9b) stretched to
    ``duration``; the optimum is kept when it is certified free in ``world`` (a
    :class:`~mpd_pin.World`; or pass a ``checker``), within the limits of ``options``
    (:class:`~mpd_pin.RoadmapOptions`: dt, resolution, limits) and cheaper simulated than
    the seed, else the seed's own motion at ``duration`` is returned. Either way a
    :class:`~mpd_pin.MotionEnergy` like :func:`~mpd_pin.trajectory_energy`'s, with
    ``.optimization`` saying what happened. ValueError (one line) for waypoints of the wrong
    shape, with NaN or in collision (naming the row, from 1), or a ``duration`` below the
    fastest the velocity limits allow the seed (naming that minimum)."""
    from ..collision import CollisionChecker
    from ..planning.roadmap import RoadmapOptions

    options = options or RoadmapOptions()
    W = check_waypoints(drive, waypoints)
    try:
        T = float(duration)
    except (TypeError, ValueError):
        raise ValueError(f"duration must be a number > 0 (s), got {duration!r}") from None
    if not (math.isfinite(T) and T > 0):
        raise ValueError(f"duration must be a number > 0 (s), got {duration!r}")
    if checker is None:
        checker = CollisionChecker(drive.arm, world)
    free = checker.is_free_batch(W)
    if not free.all():
        k = int(np.flatnonzero(~free)[0])
        raise ValueError(f"waypoint row {k + 1} (counting from 1) is in collision: "
                         f"{checker.describe_collision(W[k])}")
    vlim, _ = joint_limits(drive)
    seed = via_spline(W, unit_knots(W, vlim))
    t_min = _fastest(seed, vlim, options, float(options.dt))
    T = float(_snap(T, float(options.dt)))
    if T < t_min - 1e-9:
        raise ValueError(f"duration {duration:g} s is below the fastest the velocity limits "
                         f"allow this path, {t_min:.3f} s")
    base = _price(drive, seed, T, options)
    fail = first_failure(checker, seed, options.resolution)
    if fail is not None:
        base.feasible = False
        base.reason = "; ".join(filter(None, [base.reason, "the spline through the waypoints "
                                              f"is not certified free at t = "
                                              f"{fail * T / seed.unit_duration:.3f} s"]))
    base.curve = None  # the seed is the spline through its waypoints: recorded as such
    base.fastest = t_min
    out = optimize_curve(drive, checker, seed, T, options, settings=settings,
                         seed_motion=base)
    if out.motion is None:
        base.optimization = out.record
        return base
    out = polish(drive, checker, out, options, settings)
    out.motion.fastest = t_min
    out.motion.optimization = out.record
    out.motion.alternative = base
    return out.motion
