"""RK4 tracking of tabulated references: the batched integrator behind every energy.

docs/design.md §3e. The reference of K motions is given on the half-step grid
t = j·h/2 as tables (nt, K, nq) — q_ref, q̇_ref, q̈_ref, q⃛_ref — from which
:func:`feedforward_tables` makes the feed-forward voltage V_ff and current i_ff
(τ_ff and τ̇_ff by RNEA and its derivative), and :func:`integrate_tables` integrates
the motor-augmented ODE with classic RK4 through ``pin.abaInParallel``. The state of
all motions is one preallocated array X = [q, q̇, i, E⁺, E] of shape (5, K, nq) (each
row block C-contiguous, so its transpose is the (nq, K) Fortran array Pinocchio wants);
stage derivatives are written in place, the accelerations straight into them by
``abaInParallel``; a stage computes V = sat(W − Kp q − Kd q̇). The rest-to-rest
quintic edges of :mod:`mpd_pin.dynamics.simulate` and the non-stop motions of
:mod:`mpd_pin.motion` are two ways of filling these tables; the integration is one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .current import current_step
from .motor import Drive

__all__ = ["feedforward_tables", "integrate_tables", "TrackedSeries"]


def _pool(drive: Drive, threads: int) -> pin.ModelPool:
    """A ModelPool of the drive's (armature-carrying) model, cached on the drive."""
    key = ("_mpd_pool", threads)
    cached = drive.__dict__.get("_pool_cache")
    if cached is None or cached[0] != key or cached[2] is not drive.model:
        cached = (key, pin.ModelPool(drive.model, threads), drive.model)
        drive.__dict__["_pool_cache"] = cached
    return cached[1]



def feedforward_tables(drive: Drive, Qr: np.ndarray, Vr: np.ndarray, Ar: np.ndarray,
                       Jr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V_ff (V) and i_ff (A), each (nt, K, nq), along references tabulated as q (rad),
    q̇ (rad/s), q̈ (rad/s²), q⃛ (rad/s³) arrays of shape (nt, K, nq) (docs/design.md §3c):

    τ_ff = RNEA(q, q̇, q̈) + n²B q̇ (armature n²J in the model), i_ff = τ_ff/(n Kt),
    V_ff = R i_ff + L τ̇_ff/(n Kt) + n Ke q̇, τ̇_ff = d/dt RNEA + n²B q̈.
    """
    from .batch import rnea_with_derivative

    nt, K, nq = Qr.shape
    flat = (nt * K, nq)
    tau_r, dtau_r = rnea_with_derivative(
        drive.model, Qr.reshape(flat).T, Vr.reshape(flat).T, Ar.reshape(flat).T, Jr.reshape(flat).T
    )
    tau_ff = tau_r.T.reshape(nt, K, nq) + drive.damping * Vr
    dtau_ff = dtau_r.T.reshape(nt, K, nq) + drive.damping * Ar
    i_ff = tau_ff / drive.torque_per_amp
    Vff = drive.R * i_ff + drive.L * (dtau_ff / drive.torque_per_amp) + drive.emf_per_rad_s * Vr
    return Vff, i_ff


@dataclass(frozen=True)
class TrackedSeries:
    """The time series of one batch, recorded at every RK4 step point (N+1 samples).

    q (rad), v (rad/s), i (A), V (V), energy_t (cumulative E⁺ per joint, J),
    net_energy_t (cumulative E, J): each (N+1, K, nq).
    """

    q: np.ndarray
    v: np.ndarray
    i: np.ndarray
    V: np.ndarray
    energy_t: np.ndarray
    net_energy_t: np.ndarray


@np.errstate(over="ignore", invalid="ignore")  # divergence is detected and reported below
def integrate_tables(
    drive: Drive, Q0: np.ndarray, Q1: np.ndarray, W: np.ndarray, i0: np.ndarray,
    N: np.ndarray, h: float, threads: int, pool: pin.ModelPool | None = None,
    *, record: bool = False,
):
    """RK4 on K motions with step ``h`` (s), motion k lasting N[k] steps (docs/design.md §3e).

    Q0 (K, nq): start configurations (rad), at rest; Q1: where each should end (rad, for
    the end error); W (2·max N + 1, K, nq): the reference part of the voltage,
    V_ff + Kp q_ref + Kd q̇_ref (V), on the half-step grid (a row past its own N[k] steps
    holds its end); i0 (K, nq): initial currents (A). Returns the
    :class:`~mpd_pin.dynamics.simulate.EdgeOutcomes` arrays (E⁺, E, end error, end
    velocity, peak torque), each (K, nq), and with ``record`` a :class:`TrackedSeries`.
    Each row is computed exactly as if alone (rows never mix; layout: module docstring).
    """
    K, nq = Q0.shape
    N = np.asarray(N, dtype=np.int64)
    n_max = int(N.max())
    kp, kd, vmax = drive.kp_vec, drive.kd_vec, drive.v_max
    if pool is None:
        pool = _pool(drive, threads)
    invL = 1.0 / drive.L
    r_l, ke_l, ktn, damp = drive.R * invL, drive.emf_per_rad_s * invL, drive.torque_per_amp, (
        drive.damping
    )
    saturate = drive.saturated

    X = np.zeros((5, K, nq))
    X[0] = Q0
    X[2] = i0
    Xs = np.zeros_like(X)
    k1, k2, k3, k4 = (np.empty_like(X) for _ in range(4))
    V = np.empty((K, nq))
    trq = np.empty((K, nq))
    tmp = np.empty((K, nq))

    def stage(j: int, x: np.ndarray, out: np.ndarray) -> None:
        q, v, i = x[0], x[1], x[2]
        np.multiply(q, kp, out=V)
        np.subtract(W[j], V, out=V)
        np.multiply(v, kd, out=tmp)
        np.subtract(V, tmp, out=V)
        if saturate:
            np.clip(V, -vmax, vmax, out=V)
        np.multiply(i, ktn, out=trq)
        np.multiply(v, damp, out=tmp)
        np.subtract(trq, tmp, out=trq)
        pin.abaInParallel(threads, pool, q.T, v.T, trq.T, out[1].T)
        np.copyto(out[0], v)
        di = out[2]
        np.multiply(V, invL, out=di)  # di/dt = (V − R i − n Ke q̇) / L
        np.multiply(i, r_l, out=tmp)
        di -= tmp
        np.multiply(v, ke_l, out=tmp)
        di -= tmp
        np.multiply(V, i, out=out[4])
        np.maximum(out[4], 0.0, out=out[3])

    xs, x3 = Xs[:3], X[:3]
    w = h / 6.0
    cs = current_step(drive, h)
    sj = np.flatnonzero(cs.stiff)
    kp_s, kd_s, ke_s = kp[sj], kd[sj], drive.emf_per_rad_s[sj]
    vmax_s = vmax[sj] if saturate else None

    def forcing(j: int, x: np.ndarray) -> np.ndarray:
        """N = (V − n Ke q̇)/L (A/s) of the stiff joints at stage state ``x``, (K, s)."""
        q, v = x[0][:, sj], x[1][:, sj]
        Vs = W[j][:, sj] - kp_s * q - kd_s * v
        if saturate:
            np.clip(Vs, -vmax_s, vmax_s, out=Vs)
        return (Vs - ke_s * v) * cs.inv_L

    peak_i = np.abs(X[2])
    rec = None
    if record:
        rec = [np.empty((n_max + 1, K, nq)) for _ in range(6)]
    result = [np.empty((K, nq)) for _ in range(5)]
    ending = {int(n): np.flatnonzero(N == n) for n in np.unique(N)}
    for n in range(n_max):
        j = 2 * n
        if cs.any:
            i0, n0 = X[2][:, sj], forcing(j, X)
        stage(j, X, k1)
        if rec is not None:
            _record(rec, n, X, V)
        np.multiply(k1[:3], 0.5 * h, out=xs)
        xs += x3
        if cs.any:
            Xs[2][:, sj] = cs.half(i0, n0, forcing(j + 1, Xs))
        stage(j + 1, Xs, k2)
        np.multiply(k2[:3], 0.5 * h, out=xs)
        xs += x3
        if cs.any:
            Xs[2][:, sj] = cs.half(i0, n0, forcing(j + 1, Xs))
        stage(j + 1, Xs, k3)
        np.multiply(k3[:3], h, out=xs)
        xs += x3
        if cs.any:
            Xs[2][:, sj] = cs.full(i0, n0, forcing(j + 2, Xs))
        stage(j + 2, Xs, k4)
        k2 += k3
        k2 *= 2.0
        k2 += k1
        k2 += k4
        k2 *= w
        X += k2
        if cs.any:
            X[2][:, sj] = cs.full(i0, n0, forcing(j + 2, X))
        np.abs(X[2], out=tmp)
        np.maximum(peak_i, tmp, out=peak_i)
        idx = ending.get(n + 1)
        if idx is not None:
            for arr, now in zip(result, (X[3], X[4], X[0] - Q1, X[1], peak_i), strict=True):
                arr[idx] = now[idx]
    if rec is not None:  # the last sample and its voltage
        stage(2 * n_max, X, k1)
        _record(rec, n_max, X, V)
    return _finish(result, rec, drive.torque_per_amp)


def _finish(result: list[np.ndarray], rec: list[np.ndarray] | None, torque_per_amp):
    """Peak current → peak torque (N·m), the divergence check, and the return value of
    :func:`integrate_tables`."""
    result[4] *= torque_per_amp
    if not (np.all(np.isfinite(result[0])) and np.all(np.isfinite(result[2]))):
        raise ValueError("integration diverged on some edges; reduce dt or the gains")
    if rec is not None:
        return tuple(result), TrackedSeries(*rec)
    return tuple(result)


def _record(rec: list[np.ndarray], n: int, X: np.ndarray, V: np.ndarray) -> None:
    """Store sample n: the state of X before step n's update and the voltage of its first
    stage (V at the sample, as in :func:`~mpd_pin.dynamics.simulate.simulate_edge`)."""
    rec[0][n], rec[1][n], rec[2][n] = X[0], X[1], X[2]
    rec[3][n] = V
    rec[4][n], rec[5][n] = X[3], X[4]


