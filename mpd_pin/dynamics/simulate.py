"""Electrical energy of a move between two configurations (docs/design.md §3, paper 000 eq. 2).

The motor-augmented ODE, per joint k, with state x = [q, q̇, i] and input V:

    (D(q) + diag(n²J)) q̈ + C(q, q̇) q̇ + G(q) = n Kt i − n² B q̇
    L di/dt = V − R i − n Ke q̇

tracks a quintic rest-to-rest reference ``q_ref = q⁰ + (q¹ − q⁰) s(t/T)``,
``s(τ) = 10τ³ − 15τ⁴ + 6τ⁵``, under the voltage controller of
:class:`mpd_pin.Drive`. Classic fixed-step RK4 integrates it together with the
energies ``E⁺ = ∫ max(V i, 0) dt`` (the edge cost, no regeneration) and
``E = ∫ V i dt`` (net), and the shared bus's ``B⁺ = ∫ max(P, 0) dt`` and
``B⁻ = ∫ max(−P, 0) dt`` with ``P = Σ_k V_k i_k`` (docs/design.md §3i). The
controller is evaluated as a continuous function of (t, x) inside every RK4
stage, so the feed-forward is needed at the half-step grid ``t = j·dt/2``.

* :func:`simulate_edge` — one edge, the reference implementation: D from CRBA,
  C and G from Pinocchio, a linear solve per stage; returns the time series.
* :func:`edge_energies` — K edges at once: (nq, K) batches through
  ``pin.abaInParallel`` on a model whose armature is n²J. Equal to
  :func:`simulate_edge` edge by edge to round-off.
* :func:`ideal_edge_energy` — the same integrals along the reference with
  V = V_ff, i = i_ff (perfect tracking, no simulation).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .current import current_step
from .motor import Drive
from .supply import PER_JOINT, Supply, supply_energy
from .tracking import feedforward_tables, integrate_tables, model_pool

__all__ = [
    "EdgeSimulation",
    "quintic",
    "simulate_edge",
    "edge_energies",
    "ideal_edge_energy",
    "ideal_edge_energies",
    "step_count",
    "EdgeOutcomes",
    "edge_outcomes",
    "integrate_batch",
]


# ----------------------------------------------------------------------------- reference
def quintic(tau: np.ndarray | float, duration: float | np.ndarray) -> tuple[np.ndarray, ...]:
    """Quintic time scaling and its time derivatives at normalised time ``tau`` ∈ [0, 1].

    ``duration`` (s) is a scalar or one value per column of a 2-D ``tau`` (one per edge).
    Returns ``(s, ṡ, s̈, s⃛)`` with ``s = 10τ³ − 15τ⁴ + 6τ⁵`` and derivatives
    with respect to time t = τ·T (1/s, 1/s², 1/s³).
    """
    tau = np.asarray(tau, dtype=float)
    T = np.asarray(duration, dtype=float) if np.ndim(duration) else float(duration)
    s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    sd = 30.0 * tau**2 * (1.0 - tau) ** 2 / T
    sdd = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * tau**2) / T**2
    sddd = 60.0 * (1.0 - 6.0 * tau + 6.0 * tau**2) / T**3
    return s, sd, sdd, sddd


def step_count(duration: float, dt: float) -> int:
    """Number of RK4 steps N = T/dt; raises ValueError unless it is a positive whole number."""
    for name, val in (("duration", duration), ("dt", dt)):
        try:
            num = float(val)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a number (s), got {val!r}") from None
        if not math.isfinite(num) or num <= 0:
            raise ValueError(f"{name} must be a finite number > 0 (s), got {val!r}")
    ratio = float(duration) / float(dt)
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            f"duration/dt must be a whole number of steps: {duration} s / {dt} s = {ratio:.12g}"
        )
    return int(n)


#: Largest reference table (time samples × edges × joints) one batch holds: 2²¹ floats
#: (16 MB) per array; the feed-forward needs about eight such arrays at once.
_BATCH_BUDGET = 1 << 21

# ------------------------------------------------------------------------ feed-forward
def _feedforward_single(drive: Drive, q0: np.ndarray, dq: np.ndarray, tau: np.ndarray, T: float):
    """V_ff, i_ff (nq each, per time) along the reference, D/C/G explicitly (reference path).

    τ_ff = D(q_r) q̈_r + C(q_r, q̇_r) q̇_r + G(q_r) + n²J q̈_r + n²B q̇_r,
    τ̇_ff = ∂τ/∂q q̇_r + ∂τ/∂q̇ q̈_r + (D + n²J) q⃛_r + n²B q̈_r  (computeRNEADerivatives),
    i_ff = τ_ff/(n Kt),  V_ff = R i_ff + L di_ff/dt + n Ke q̇_r.
    """
    arm = drive.arm
    model, data = arm.model, arm.data
    s, sd, sdd, sddd = quintic(tau, T)
    nt = tau.size
    Vff = np.empty((nt, drive.nq))
    iff = np.empty((nt, drive.nq))
    for j in range(nt):
        qr = q0 + dq * s[j]
        vr = dq * sd[j]
        ar = dq * sdd[j]
        jr = dq * sddd[j]
        D = arm.mass_matrix(qr)
        C = arm.coriolis_matrix(qr, vr)
        G = arm.gravity(qr)
        tau_ff = D @ ar + C @ vr + G + drive.armature * ar + drive.damping * vr
        pin.computeRNEADerivatives(model, data, qr, vr, ar)
        dtau = (
            data.dtau_dq @ vr
            + data.dtau_dv @ ar
            + D @ jr
            + drive.armature * jr
            + drive.damping * ar
        )
        i_ff = tau_ff / drive.torque_per_amp
        di_ff = dtau / drive.torque_per_amp
        iff[j] = i_ff
        Vff[j] = drive.R * i_ff + drive.L * di_ff + drive.emf_per_rad_s * vr
    return Vff, iff


def _per_edge(a: np.ndarray) -> np.ndarray:
    """(nt,) → (nt, 1, 1) or (nt, K) → (nt, K, 1), to broadcast against (nt, K, nq)."""
    return a[:, None, None] if a.ndim == 1 else a[..., None]


def feedforward_batch(drive: Drive, Q0: np.ndarray, DQ: np.ndarray, tau: np.ndarray, T):
    """V_ff and i_ff, shape (nt, K, nq), for K edges at the normalised times ``tau``
    ((nt,) shared, or (nt, K) with ``T`` (s) one per edge)."""
    s, sd, sdd, sddd = (_per_edge(a) for a in quintic(tau, T))
    # (nt, K, nq) laid out so that the (nq, nt*K) transpose is Fortran-contiguous.
    Qr = Q0[None] + DQ[None] * s
    Vr = DQ[None] * sd
    Ar = DQ[None] * sdd
    Jr = DQ[None] * sddd
    return feedforward_tables(drive, Qr, Vr, Ar, Jr)


# ------------------------------------------------------------------------ single edge
@dataclass(frozen=True)
class EdgeSimulation:
    """Time series of one simulated edge (N+1 samples at the RK4 step points).

    t (s), q (rad), v (rad/s), i (A), V (V) with shape (N+1, nq) (t: (N+1,));
    energy = E⁺ per joint (J), net_energy = E per joint (J);
    energy_t, net_energy_t: the cumulative integrals at each sample (J);
    q_ref: the reference at each sample (rad);
    bus_energy: [B⁺, B⁻] = [∫ max(P, 0), ∫ max(−P, 0)] of the bus power P = Σ_k V_k i_k
    (J), bus_energy_t their cumulative values (N+1, 2); supply: the drive's
    :class:`~mpd_pin.Supply`, which :attr:`supply_energy` applies.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    i: np.ndarray
    V: np.ndarray
    q_ref: np.ndarray
    energy: np.ndarray
    net_energy: np.ndarray
    energy_t: np.ndarray
    net_energy_t: np.ndarray
    bus_energy: np.ndarray
    bus_energy_t: np.ndarray
    supply: Supply = PER_JOINT

    @property
    def total_energy(self) -> float:
        """Σ E⁺ over joints (J): the edge cost with a supply per joint (paper 000)."""
        return float(self.energy.sum())

    @property
    def supply_energy(self) -> float:
        """Energy drawn from the supply (J) under :attr:`supply` (docs/design.md §3i):
        Σ E⁺ per joint, or B⁺ − η B⁻ on a shared bus. The planner's edge cost."""
        return float(supply_energy(self.supply, self.energy, self.bus_energy))

    @property
    def P_bus(self) -> np.ndarray:
        """Bus power P = Σ_k V_k i_k (W) at each sample, (N+1,)."""
        return (self.V * self.i).sum(axis=1)


def _check_edge(drive: Drive, q0, q1) -> tuple[np.ndarray, np.ndarray]:
    q0 = drive.arm.check_configuration(q0, "q0")
    q1 = drive.arm.check_configuration(q1, "q1")
    return q0, q1


@np.errstate(over="ignore", invalid="ignore")  # divergence is detected and reported below
def simulate_edge(drive: Drive, q0, q1, duration: float = 1.0, dt: float = 5e-3) -> EdgeSimulation:
    """Simulate the move q0 → q1 (rad) over ``duration`` s, RK4 step ``dt`` s (docs/design.md §3).

    Starts at rest holding the arm (i = G(q0)/(n Kt)). Joints whose electrical pole is
    stiff at this step (dt·R/L > ``STIFF_LIMIT``) get the exponential current update of
    :class:`~mpd_pin.dynamics.current.CurrentStep`, so any L/R works at any dt. Raises
    ValueError for NaN or
    wrong-length configurations, T/dt not whole, or a diverging integration.
    """
    q0, q1 = _check_edge(drive, q0, q1)
    N = step_count(duration, dt)
    T, h = float(duration), float(duration) / N
    nq = drive.nq
    arm = drive.arm
    dq = q1 - q0
    half = np.arange(2 * N + 1) / (2 * N)
    Vff, _ = (
        _feedforward_single(drive, q0, dq, half, T)
        if drive.feedforward
        else (np.zeros((2 * N + 1, nq)), None)
    )
    s, sd, _, _ = quintic(half, T)
    kp, kd, vmax = drive.kp_vec, drive.kd_vec, drive.v_max
    Rm, Lm, ktn, ken, damp, arma = (
        drive.R,
        drive.L,
        drive.torque_per_amp,
        drive.emf_per_rad_s,
        drive.damping,
        drive.armature,
    )

    def voltage(j: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        V = Vff[j] + kp * (q0 + dq * s[j] - q) + kd * (dq * sd[j] - v)
        return np.clip(V, -vmax, vmax)

    def deriv(j: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, v, i = x[:nq], x[nq : 2 * nq], x[2 * nq : 3 * nq]
        V = voltage(j, q, v)
        D = arm.mass_matrix(q) + np.diag(arma)
        rhs = ktn * i - damp * v - arm.coriolis_matrix(q, v) @ v - arm.gravity(q)
        a = np.linalg.solve(D, rhs)
        di = (V - Rm * i - ken * v) / Lm
        P = V * i
        Pb = P.sum()
        return np.concatenate([v, a, di, np.maximum(P, 0.0), P,
                               [max(Pb, 0.0), max(-Pb, 0.0)]]), V

    x = np.concatenate([q0, np.zeros(nq), arm.gravity(q0) / ktn, np.zeros(2 * nq + 2)])
    X = np.empty((N + 1, 5 * nq + 2))
    Vs = np.empty((N + 1, nq))
    X[0] = x
    cs = current_step(drive, h)
    sj = np.flatnonzero(cs.stiff)
    ci = 2 * nq + sj  # indices of the stiff currents in x

    def forcing(j: int, xs: np.ndarray) -> np.ndarray:
        """N = (V − n Ke q̇)/L of the stiff joints at the stage state ``xs`` (A/s)."""
        v = xs[nq : 2 * nq]
        return (voltage(j, xs[:nq], v)[sj] - ken[sj] * v[sj]) * cs.inv_L

    for n in range(N):
        j = 2 * n
        try:
            if cs.any:
                i0, n0 = x[ci], forcing(j, x)
            k1, V0 = deriv(j, x)
            xs = x + 0.5 * h * k1
            if cs.any:
                xs[ci] = cs.half(i0, n0, forcing(j + 1, xs))
            k2, _ = deriv(j + 1, xs)
            xs = x + 0.5 * h * k2
            if cs.any:
                xs[ci] = cs.half(i0, n0, forcing(j + 1, xs))
            k3, _ = deriv(j + 1, xs)
            xs = x + h * k3
            if cs.any:
                xs[ci] = cs.full(i0, n0, forcing(j + 2, xs))
            k4, _ = deriv(j + 2, xs)
        except ValueError:  # a stage state overflowed to inf/NaN
            k1 = np.full_like(x, np.nan)
            k2 = k3 = k4 = k1
            V0 = np.full(nq, np.nan)
        Vs[n] = V0
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        if cs.any and np.all(np.isfinite(x)):
            x[ci] = cs.full(i0, n0, forcing(j + 2, x))
        if not np.all(np.isfinite(x)):
            raise ValueError(
                f"integration diverged at t = {(n + 1) * h:.4g} s; reduce dt or the gains"
            )
        X[n + 1] = x
    Vs[N] = voltage(2 * N, X[N, :nq], X[N, nq : 2 * nq])
    t = np.arange(N + 1) * h
    return EdgeSimulation(
        t=t,
        q=X[:, :nq].copy(),
        v=X[:, nq : 2 * nq].copy(),
        i=X[:, 2 * nq : 3 * nq].copy(),
        V=Vs,
        q_ref=q0 + np.outer(s[::2], dq),
        energy=X[N, 3 * nq : 4 * nq].copy(),
        net_energy=X[N, 4 * nq : 5 * nq].copy(),
        energy_t=X[:, 3 * nq : 4 * nq].copy(),
        net_energy_t=X[:, 4 * nq : 5 * nq].copy(),
        bus_energy=X[N, 5 * nq :].copy(),
        bus_energy_t=X[:, 5 * nq :].copy(),
        supply=drive.supply,
    )


# ------------------------------------------------------------------------ many edges
def check_batch(drive: Drive, Q0, Q1) -> tuple[np.ndarray, np.ndarray]:
    Q0 = np.asarray(Q0, dtype=float)
    Q1 = np.asarray(Q1, dtype=float)
    nq = drive.nq
    if Q0.ndim == 1:
        Q0 = Q0[None]
    if Q1.ndim == 1:
        Q1 = Q1[None]
    if Q0.ndim != 2 or Q0.shape[1] != nq or Q0.shape != Q1.shape:
        raise ValueError(
            f"Q0 and Q1 must both have shape (K, {nq}) (one edge per row), "
            f"got {Q0.shape} and {Q1.shape}"
        )
    bad = ~(np.isfinite(Q0).all(axis=1) & np.isfinite(Q1).all(axis=1))
    if bad.any():
        raise ValueError(
            f"edges {np.flatnonzero(bad)[:10].tolist()} contain NaN or infinite joint values"
        )
    return np.ascontiguousarray(Q0), np.ascontiguousarray(Q1)


def _reference_table(drive: Drive, Q0, DQ, half, T, s, sd, pool, threads: int):
    """W = V_ff + Kp q_ref + Kd q̇_ref on the half-step grid, (nt, K, nq) V, and the
    initial (holding) current i0 = G(q⁰)/(n Kt), (K, nq) A."""
    K, nq = Q0.shape
    kp, kd = drive.kp_vec, drive.kd_vec
    if drive.feedforward:
        W, i_ff = feedforward_batch(drive, Q0, DQ, half, T)  # W holds V_ff: (nt, K, nq)
        i0 = i_ff[0].copy()  # τ_ff(0) = G(q0): the holding current
        del i_ff
    else:
        W = np.zeros((half.shape[0], K, nq))
        G = pin.rneaInParallel(
            threads, pool, Q0.T, np.zeros((nq, K), order="F"), np.zeros((nq, K), order="F")
        )
        i0 = np.ascontiguousarray(np.asarray(G).T) / drive.torque_per_amp
    W += kp * (Q0[None] + DQ[None] * s)
    W += kd * (DQ[None] * sd)
    return W, i0


@np.errstate(over="ignore", invalid="ignore")  # divergence is detected and reported below
def integrate_batch(
    drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray, N: np.ndarray, h: float,
    threads: int, *, record: bool = False,
):
    """RK4 on K edges with step ``h`` (s), edge k lasting T[k] = N[k]·h; returns the
    :class:`EdgeOutcomes` arrays (E⁺, E, end error, end velocity, peak torque), each (K, nq).

    The state of all edges is one preallocated array X = [q, q̇, i, E⁺, E] of shape
    (5, K, nq) (each row block C-contiguous, so its transpose is the (nq, K)
    Fortran array Pinocchio wants); the stage derivatives are written in place
    and the accelerations straight into them by ``abaInParallel``. The reference
    part of the voltage, W = V_ff + Kp q_ref + Kd q̇_ref, is tabulated on the
    half-step grid once, so a stage computes V = sat(W − Kp q − Kd q̇). Edges of
    different lengths run together: the batch runs max N steps, an edge's reference
    holds its end node after its own N[k] steps, and its results are taken at step
    N[k] — each row is computed exactly as if alone (rows never mix).
    """
    K, nq = Q0.shape
    T = np.asarray(T, dtype=float)
    N = np.asarray(N, dtype=np.int64)
    n_max = int(N.max())
    DQ = Q1 - Q0
    half = np.minimum(np.arange(2 * n_max + 1)[:, None] / (2 * N)[None, :], 1.0)  # (nt, K)
    s, sd, _, _ = (_per_edge(a) for a in quintic(half, T))
    pool = model_pool(drive, threads)
    W, i0 = _reference_table(drive, Q0, DQ, half, T, s, sd, pool, threads)
    return integrate_tables(drive, Q0, Q1, W, i0, N, h, threads, pool, record=record)


@dataclass(frozen=True)
class EdgeOutcomes:
    """What K simulated edges did, one row per edge (all arrays (K, nq)).

    energy: E⁺ per joint (J); net_energy: E per joint (J); end_error: q(T) − q¹ (rad);
    end_velocity: q̇(T) (rad/s); peak_torque: max over the RK4 step points of the motor
    torque at the joint, |n Kt i| (N·m). The feasibility rules of docs/design.md §3g read
    the last three: a motion that does not arrive, or needs more torque than the joint
    may take, is not an edge. bus_energy (K, 2): [B⁺, B⁻] of the shared bus (J,
    docs/design.md §3i).
    """

    energy: np.ndarray
    net_energy: np.ndarray
    end_error: np.ndarray
    end_velocity: np.ndarray
    peak_torque: np.ndarray
    bus_energy: np.ndarray

    @staticmethod
    def zeros(K: int, nq: int) -> EdgeOutcomes:
        """Outcomes of K edges, all 0 (to be filled row by row)."""
        return EdgeOutcomes(*(np.zeros((K, _columns(f, nq))) for f in _OUTCOME_FIELDS))


#: The fields of :class:`EdgeOutcomes`, in order.
_OUTCOME_FIELDS = ("energy", "net_energy", "end_error", "end_velocity", "peak_torque",
                   "bus_energy")


def _columns(name: str, nq: int) -> int:
    """Columns of an :class:`EdgeOutcomes` field: 2 for ``bus_energy``, else nq."""
    return 2 if name == "bus_energy" else nq


def edge_outcomes(
    drive: Drive,
    Q0,
    Q1,
    duration: float | np.ndarray = 1.0,
    dt: float = 5e-3,
    *,
    chunk: int = 1024,
    threads: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> EdgeOutcomes:
    """Simulate the K edges ``Q0[k] → Q1[k]`` together; see :func:`edge_energies`."""
    Q0, Q1 = check_batch(drive, Q0, Q1)
    K = Q0.shape[0]
    threads = int(threads or os.cpu_count() or 1)
    durations = (
        np.broadcast_to(np.asarray(duration, dtype=float), (K,))
        if np.ndim(duration) == 0
        else np.asarray(duration, dtype=float)
    )
    if durations.shape != (K,):
        raise ValueError(
            f"duration must be a scalar or one value per edge ({K}), got shape {durations.shape}"
        )
    zeros = EdgeOutcomes.zeros(K, drive.nq)
    out = [getattr(zeros, f) for f in _OUTCOME_FIELDS]
    steps = np.array([step_count(T, dt) for T in durations.tolist()], dtype=np.int64)
    # Edges with the same step h = T/N (bit for bit) run together, shortest first, in
    # chunks of at most ``chunk`` edges whose tables (nt × K × nq) stay within the budget.
    groups: dict[float, list[int]] = {}
    for k in range(K):
        groups.setdefault(float(durations[k]) / int(steps[k]), []).append(k)
    done = 0
    for h, members in groups.items():
        idx = np.asarray(members)
        idx = idx[np.argsort(steps[idx], kind="stable")]
        start = 0
        while start < idx.size:
            stop = start + 1  # grow the chunk while its table fits (idx is sorted by N)
            while (
                stop < idx.size
                and stop - start < chunk
                and (2 * int(steps[idx[stop]]) + 1) * drive.nq * (stop + 1 - start)
                <= _BATCH_BUDGET
            ):
                stop += 1
            sel = idx[start:stop]
            parts = integrate_batch(
                drive, Q0[sel], Q1[sel], durations[sel], steps[sel], h, threads
            )
            for arr, part in zip(out, parts, strict=True):
                arr[sel] = part
            done += sel.size
            start = stop
            if progress is not None:
                progress(done)
    return EdgeOutcomes(*out)


def edge_energies(
    drive: Drive,
    Q0,
    Q1,
    duration: float | np.ndarray = 1.0,
    dt: float = 5e-3,
    *,
    net: bool = False,
    chunk: int = 1024,
    threads: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """E⁺ per joint (J), shape (K, nq), for the K edges ``Q0[k] → Q1[k]`` (docs/design.md §3).

    The same ODE, controller and RK4 as :func:`simulate_edge`, integrated for
    all edges at once with ``pin.abaInParallel``. ``duration`` (s) is a scalar or
    one value per edge (each a whole multiple of ``dt``; edges are grouped by
    step count). ``net=True`` also returns E (J). ``progress(k)`` is called with
    the number of edges finished after each chunk of at most ``chunk`` edges.
    :func:`edge_outcomes` returns the end states and peak torques as well.
    """
    res = edge_outcomes(drive, Q0, Q1, duration, dt, chunk=chunk, threads=threads,
                        progress=progress)
    return (res.energy, res.net_energy) if net else res.energy


# ------------------------------------------------------------------------ ideal tracking
def _simpson_energies(Vff: np.ndarray, iff: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Composite Simpson over the half-step grid (what RK4 does to a pure quadrature)."""
    P = Vff * iff
    Pp = np.maximum(P, 0.0)
    w = np.ones(P.shape[0])
    w[1:-1:2] = 4.0
    w[2:-1:2] = 2.0
    w *= h / 6.0
    return np.tensordot(w, Pp, axes=(0, 0)), np.tensordot(w, P, axes=(0, 0))


def ideal_edge_energy(
    drive: Drive, q0, q1, duration: float = 1.0, dt: float = 5e-3, *, net: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """E⁺ per joint (J) along the reference with perfect tracking: V = V_ff, i = i_ff.

    The integrals are taken with RK4's quadrature (Simpson on the half-step
    grid). It is the limit of :func:`simulate_edge` as the gains grow when the
    electrical time constant L/R is short against the edge (e.g. ``SERVO_MOTOR``);
    with ``PAPER_MOTOR`` (L/R = 0.5 s) a high-gain loop rings through the edge and
    E⁺ counts the positive half of that ringing, so the two stay apart.
    Uses the feed-forward formulas of docs/design.md §3 whatever ``drive.feedforward`` says.
    """
    q0, q1 = _check_edge(drive, q0, q1)
    N = step_count(duration, dt)
    half = np.arange(2 * N + 1) / (2 * N)
    Vff, iff = _feedforward_single(drive, q0, q1 - q0, half, float(duration))
    Ep, En = _simpson_energies(Vff, iff, float(duration) / N)
    return (Ep, En) if net else Ep


def ideal_edge_energies(
    drive: Drive, Q0, Q1, duration: float = 1.0, dt: float = 5e-3
) -> np.ndarray:
    """Batched :func:`ideal_edge_energy`: (K, nq) E⁺ (J) with perfect tracking, no simulation."""
    Q0, Q1 = check_batch(drive, Q0, Q1)
    N = step_count(duration, dt)
    half = np.arange(2 * N + 1) / (2 * N)
    Vff, iff = feedforward_batch(drive, Q0, Q1 - Q0, half, float(duration))
    Ep, _ = _simpson_energies(Vff, iff, float(duration) / N)
    return Ep
