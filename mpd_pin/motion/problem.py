"""The discretised trajectory-optimisation problem of one seed (docs/design.md §9g): the
clamped quintic B-spline basis, the free control points as variables, the smoothed
perfect-tracking supply energy with its adjoint gradient, and the collision, velocity
and effort rows with their Jacobians. :mod:`mpd_pin.motion.optimize` solves it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.interpolate import BSpline

from ..dynamics.motor import Drive
from .screen import joint_limits
from .spline import ViaSpline

__all__ = ["DEGREE", "OptimizeSettings", "Problem", "basis", "difference", "fit_curve",
           "clamped_knots", "spline_curve"]

DEGREE = 5


@dataclass(frozen=True)
class OptimizeSettings:
    """Settings of the trajectory optimisation (docs/design.md §9g).

    control_points: per joint (0: from the seed, 16–24); samples: Simpson intervals of the
    energy integral (even); collision_samples: times the distances are constrained at
    (0: 4 per knot span); margin: clearance (m) beyond each pair's own margin (less for
    a pair where the start or the goal leaves less: ``Problem.clearance``);
    activation: pairs closer than this (m) at a collision sample are constrained, at most
    ``pairs_per_sample`` (the closest) each time a round starts;
    velocity_fraction, effort_fraction: of the URDF limits; max_iterations: SLSQP
    iterations per round; rounds: at most, each adding the pairs its start comes near;
    tolerance: SLSQP's ftol on the energy relative to the seed's; sharpness: of the
    softplus, relative to the seed's peak power; retries: solves again, with collision
    samples added where the last one came too close between samples, after a failed
    check; budget: SLSQP iterations one seed's solves may take in all before they stop
    where they are (iterations, not seconds, so that a result never depends on the
    machine's speed or load); screen: iterations of each seed's screening solve when
    several seeds compete (:func:`~mpd_pin.motion.optimize.optimize_seeds`); cpu_limit:
    CPU seconds after which a solve stops regardless, a guard against pathological solves
    (reached only by solves that fail anyway: on the Panda's shared bus, SLSQP at 150 ms an
    iteration; such a screening solve ranks last); polish: iterations of the last solve of
    the best screened seed, with a fresh SLSQP model, on ``polish_points`` more control
    points per joint and at ``polish_tolerance`` (SLSQP's ftol), in rounds of ``polish_round``
    iterations (a round restarts SLSQP's quasi-Newton model: the finer solve's rounds of
    40 gained 0.1 % each, and 2 rounds of 120 cost 20 % less CPU for the same energies);
    refine_gain, refinements: when the finer solve gained more than ``refine_gain`` of its
    screen energy, the spline is too coarse for this motion, and up to ``refinements``
    more finer solves follow, each on ``polish_points`` more control points, each kept only
    when certified and cheaper simulated (the next level gained 0.25–0.44 of the last on
    the Panda bench, so a gain above 12.5 % leaves an estimated 5 % to a finer spline:
    docs/design.md §9g).
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
    screen: int = 80
    cpu_limit: float = 6.0
    polish: int = 240
    polish_points: int = 8
    polish_round: int = 120
    polish_tolerance: float = 1e-6
    refine_gain: float = 0.125
    refinements: int = 1


# ----------------------------------------------------------------------------- basis
def difference(n: int, h: float) -> np.ndarray:
    """D (n, n): d/dt on n samples h s apart, central inside and second-order one-sided
    at the ends, as ``np.gradient(f, h, edge_order=2)`` (1/s)."""
    D = np.zeros((n, n))
    r = np.arange(1, n - 1)
    D[r, r - 1], D[r, r + 1] = -0.5, 0.5
    D[0, :3] = (-1.5, 2.0, -0.5)
    D[-1, -3:] = (0.5, -2.0, 1.5)
    return D / h


def clamped_knots(n_c: int) -> np.ndarray:
    """Clamped uniform knots on [0, 1] for ``n_c`` control points of degree 5."""
    inner = np.linspace(0.0, 1.0, n_c - DEGREE + 1)
    return np.concatenate([np.zeros(DEGREE), inner, np.ones(DEGREE)])


def basis(knots: np.ndarray, n_c: int, tau: np.ndarray, nu: int) -> np.ndarray:
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
    knots = clamped_knots(n_c)
    tau = np.linspace(0.0, 1.0, 8 * n_c)
    B = basis(knots, n_c, tau, 0)
    target = np.asarray(q_of_tau(tau), float)
    C = np.empty((n_c, q0.size))
    C[:3], C[-3:] = q0, q1
    rhs = target - B[:, :3] @ C[:3] - B[:, -3:] @ C[-3:]
    C[3:-3] = np.linalg.lstsq(B[:, 3:-3], rhs, rcond=None)[0]
    return C


# ----------------------------------------------------------------------------- problem
class Problem:
    """The discretised problem of one seed (module docstring): objective, constraints and
    their Jacobians in the free control points x (flattened (n_c − 6, nq), row-major)."""

    def __init__(self, drive: Drive, distances, C0: np.ndarray, T: float,
                 settings: OptimizeSettings) -> None:
        self.drive, self.dist, self.T, self.s = drive, distances, float(T), settings
        self.model = drive.model
        self.data = self.model.createData()
        n_c, nq = C0.shape
        self.n_c, self.nq, self.nf = n_c, nq, n_c - 6
        self.knots = clamped_knots(n_c)
        self.C_fixed = C0.copy()
        S = int(settings.samples) + int(settings.samples) % 2
        self.tau = np.linspace(0.0, 1.0, S + 1)
        w = np.ones(S + 1)
        w[1:-1:2], w[2:-1:2] = 4.0, 2.0
        self.w = w * (self.T / (3.0 * S))  # Simpson weights in s
        self.h = self.T / S
        self.Dt = difference(S + 1, self.h).T  # Dᵀ of d/dt along the samples
        self.B = [basis(self.knots, n_c, self.tau, nu) / self.T**nu for nu in range(4)]
        self.Bf = [b[:, 3:-3] for b in self.B]
        n_col = settings.collision_samples or 4 * (n_c - DEGREE)
        self.tau_c = np.linspace(0.0, 1.0, n_col + 2)[1:-1]
        self.Bc = basis(self.knots, n_c, self.tau_c, 0)
        self.vlim, self.elim = joint_limits(drive)
        #: each pair's clearance (m) beyond its own margin: ``margin``, or what the start or
        #: the goal leaves where that is less: both are fixed, and a row that no curve can
        #: meet kept SLSQP from ever converging (the UR5's base, 7 mm above its table, at
        #: every collision sample). Below 0 where the convex hulls of a free start or goal
        #: overlap (an ur10's forearm and wrist by 1.4 cm); the certificate then judges the
        #: meshes themselves (docs/design.md §9g)
        P = distances.size if distances is not None else 0
        self.clearance = np.full(P, float(settings.margin))
        if P:
            ends = distances.distances(C0[[0, -1]]) - distances.margins[None, :]
            self.clearance = np.minimum(ends.min(axis=0), float(settings.margin))
        #: pairs of two bodies fixed to the world (an arm's base and its table): their
        #: distance is the same for every motion, so they get no rows (zero-gradient rows
        #: held at 0 by ``clearance``, at every collision sample)
        self.static = distances.static if P else np.zeros(P, dtype=bool)
        self.supply = drive.supply
        self._cache: dict[str, Any] = {}
        self._rows: tuple[np.ndarray, np.ndarray] | None = None  # collision rows' layout
        self.active: list[np.ndarray] = [np.zeros(0, np.int64)] * self.tau_c.size
        self.effort_rows = np.zeros((0, 2), np.int64)
        self.velocity_rows = np.zeros((0, 2), np.int64)
        #: velocity rows between the energy samples (:meth:`add_velocity_samples`): their
        #: times τ, and (index into those times, joint)
        self.tau_v = np.zeros(0)
        self.velocity_extra = np.zeros((0, 2), np.int64)
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
    def dynamics(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """q, q̇, q̈ (rad, rad/s, rad/s²), τ_ff (N·m), i (A), V (V), P (W) and the RNEA
        derivatives at the energy samples for the variables ``x`` (the last call cached)."""
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
        return self._power_weights(self.dynamics(x)["P"])[0]

    def energy_grad(self, x: np.ndarray) -> np.ndarray:
        """∂E/∂x by the adjoint of the chain x → (q, q̇, q̈, q⃛) → τ_ff, τ̇_ff → (i, V) → P:

            ∂E/∂x = Σ_s,a γ_sa ∂τ_sa/∂x + Σ_s w_P,sa i_sa K_e,a ∂q̇_sa/∂x,
            γ = w_P (V + R i)/K_t + Dᵀ (w_P i L/K_t),

        with D the second-order difference along the samples (τ̇ = D τ, as
        ``np.gradient``) and ∂τ/∂x = ∂τ/∂q B₀ + ∂τ/∂q̇ B₁ + M B₂ (+ damping B₁), so the
        joints' sums come before the basis matrices: O(S nq²), not O(S nq² nf)."""
        d = self.dynamics(x)
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
        v = self.dynamics(x)["v"]
        self.velocity_rows, n = self._grow(self.velocity_rows,
                                           np.argwhere(np.abs(v) > 0.5 * self.vlim[None, :]))
        return n

    def velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear rows A x + b ≥ 0: |q̇_k(t)| ≤ f v_lim,k at the energy samples where the
        round's start point is above half the limit, and at the times between them where
        an earlier solve went over (:meth:`add_velocity_samples`)."""
        B1 = [(self.B[1], self.velocity_rows)]
        if len(self.velocity_extra):
            B1.append((basis(self.knots, self.n_c, self.tau_v, 1) / self.T,
                       self.velocity_extra))
        Cfix = self.C_fixed.copy()
        Cfix[3:-3] = 0.0
        As, bs = [np.zeros((0, self.nf * self.nq))], [np.zeros(0)]
        for Bv, rows in B1:
            if not len(rows):
                continue
            s, k = rows[:, 0], rows[:, 1]
            lim = self.s.velocity_fraction * self.vlim[k]
            const = (Bv @ Cfix)[s, k]
            A = np.zeros((len(s), self.nf, self.nq))
            A[np.arange(len(s)), :, k] = Bv[s, 3:-3]
            A = A.reshape(len(s), -1)
            As += [-A, A]
            bs += [lim - const, lim + const]
        return np.vstack(As), np.concatenate(bs)

    def add_velocity_samples(self, x: np.ndarray, count: int = 4000) -> int:
        """Add velocity rows (``velocity_fraction`` of the limit) where |q̇| of the curve at
        ``x``, checked at ``count`` times as the priced motion's peak speed is
        (:meth:`~mpd_pin.motion.spline.ViaSpline.peak_speed_ratio`), exceeds a limit: each
        run of such times adds its fastest time, per joint. Returns how many rows were
        added (the peaks of a finer spline fell between the energy samples, and the
        simulated motion was refused for its speed: docs/design.md §9g)."""
        tau = np.linspace(0.0, 1.0, count)
        v = (basis(self.knots, self.n_c, tau, 1) / self.T) @ self.C(x)
        over = np.abs(v) / self.vlim[None, :] - 1.0  # > 0: over the limit
        have = {(float(self.tau_v[i]), int(k)) for i, k in self.velocity_extra}
        new_tau, rows = [], []
        for k in np.flatnonzero((over > 1e-9).any(axis=0)):
            hit = (over[:, k] > 1e-9).astype(int)
            edges = np.flatnonzero(np.diff(np.concatenate([[0], hit, [0]])))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                t = float(tau[a + int(np.argmax(over[a:b, k]))])
                if (t, int(k)) not in have:  # a row there already: the solve fell short
                    rows.append((self.tau_v.size + len(new_tau), int(k)))
                    new_tau.append(t)
        if not rows:
            return 0
        self.tau_v = np.concatenate([self.tau_v, new_tau])
        self.velocity_extra = np.vstack([self.velocity_extra,
                                         np.asarray(rows, np.int64)])
        return len(rows)

    def choose_effort_rows(self, x: np.ndarray) -> int:
        """Add the (sample, joint) rows where |τ_ff| at ``x`` is above half the limit (or
        above ``effort_fraction`` of it, when that is less than half)."""
        tau = self.dynamics(x)["tau"]
        near = min(0.5, float(self.s.effort_fraction)) * self.elim[None, :]
        self.effort_rows, n = self._grow(self.effort_rows, np.argwhere(np.abs(tau) > near))
        return n

    def effort_excess(self, x: np.ndarray) -> float:
        """max over every energy sample and joint of |τ_ff| − ``effort_fraction`` · τ_lim
        (N·m; ≤ 0: within the effort rows wherever they may be chosen)."""
        tau = self.dynamics(x)["tau"]
        return float(np.max(np.abs(tau) - self.s.effort_fraction * self.elim[None, :]))

    def effort(self, x: np.ndarray) -> np.ndarray:
        if not len(self.effort_rows):
            return np.zeros(0)
        tau = self.dynamics(x)["tau"]
        s, k = self.effort_rows[:, 0], self.effort_rows[:, 1]
        lim = self.s.effort_fraction * self.elim[k]
        return np.concatenate([lim - tau[s, k], lim + tau[s, k]])

    def effort_jac(self, x: np.ndarray) -> np.ndarray:
        if not len(self.effort_rows):
            return np.zeros((0, self.nf * self.nq))
        s, k = self.effort_rows[:, 0], self.effort_rows[:, 1]
        J = self._dtau_rows(self.dynamics(x), s, k)
        return np.vstack([-J, J])

    def add_samples(self, x: np.ndarray, count: int = 400) -> int:
        """Add collision samples where the curve at ``x``, checked at ``count`` times,
        comes closer than ``margin`` to any pair's margin between the current samples
        (each such time, its pairs within ``activation``); returns how many were added."""
        if self.dist is None or not self.dist.size:
            return 0
        tau = np.linspace(0.0, 1.0, count)[1:-1]
        Q = basis(self.knots, self.n_c, tau, 0) @ self.C(x)
        d = self.dist.distances(Q) - self.dist.margins[None, :]
        # below half its clearance (below the clearance itself where that is negative):
        # at an active row d = its clearance at the samples
        low = (d - np.minimum(0.5 * self.clearance, self.clearance)[None, :]).min(axis=1)
        close = low < 0.0
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
        self.Bc = basis(self.knots, self.n_c, self.tau_c, 0)
        self.active = self.active + [np.flatnonzero(d[b] < self.s.activation).astype(np.int64)
                                     for b in bad]
        self._cache.pop("collision", None)
        self._rows = None
        return int(bad.size)

    def choose_pairs(self, x: np.ndarray) -> int:
        """Add to the constrained (sample, pair) set those within ``activation`` (m) of
        their margin at ``x`` (the set only grows, so a solve never forgets a pair it met);
        returns how many rows were added."""
        if self.dist is None or not self.dist.size:
            return 0
        Q = self.Bc @ self.C(x)
        d = self.dist.distances(Q) - self.dist.margins[None, :]
        d[:, self.static] = np.inf  # no motion changes their distance: never a row
        added = 0
        for s, row in enumerate(d):
            near = np.flatnonzero(row < self.s.activation)
            near = np.setdiff1d(near, self.active[s])
            new = near[np.argsort(row[near])[: self.s.pairs_per_sample]]
            if new.size:
                self.active[s] = np.union1d(self.active[s], new).astype(np.int64)
                added += int(new.size)
        self._cache.pop("collision", None)
        self._rows = None
        return added

    def _collision(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = x.tobytes()
        c = self._cache.get("collision")
        if c is not None and c[0] == key:
            return c[1], c[2]
        Q = self.Bc @ self.C(x)
        dval, dq = self.dist.distances_and_gradients(Q, self.active)
        if self._rows is None:  # the rows' layout: changes only with the active set
            owner = np.concatenate([np.full(len(a), s) for s, a in enumerate(self.active)]
                                   ).astype(np.int64) if dval.size else np.zeros(0, np.int64)
            cols = np.concatenate(self.active) if dval.size else np.zeros(0, np.int64)
            self._rows = (self.dist.margins[cols] + self.clearance[cols],
                          self.Bc[:, 3:-3][owner][:, :, None])
        required, basis_rows = self._rows
        g = dval - required
        J = (basis_rows * dq[:, None, :]).reshape(len(dval), -1)
        self._cache["collision"] = (key, g, J)
        return g, J

    def collision(self, x: np.ndarray) -> np.ndarray:
        return self._collision(x)[0]

    def collision_jac(self, x: np.ndarray) -> np.ndarray:
        return self._collision(x)[1]
