"""RK4 tracking of tabulated references: the batched integrator behind every energy.

docs/design.md §3e. The reference of K motions is given on the half-step grid
t = j·h/2 as tables (nt, K, nq) — q_ref, q̇_ref, q̈_ref, q⃛_ref — from which
:func:`feedforward_tables` makes the feed-forward voltage V_ff and current i_ff
(τ_ff and τ̇_ff by RNEA and its derivative), and :func:`integrate_tables` integrates
the motor-augmented ODE with classic RK4 through ``pin.abaInParallel``. The state of
all motions is one preallocated array X = [q, q̇, i, E⁺, E, B] of shape (6, K, nq) (each
row block C-contiguous, so its transpose is the (nq, K) Fortran array Pinocchio wants),
whose last row holds in its first column the shared bus's B⁺ = ∫ max(P, 0) dt, P = Σ_k
V_k i_k (B⁻ = B⁺ − Σ_k E_k; docs/design.md §3i) and 0 elsewhere;
stage derivatives are written in place, the accelerations straight into them by
``abaInParallel``; a stage computes V = sat(W − Kp q − Kd q̇). The rest-to-rest
quintic edges of :mod:`mpd_pin.dynamics.simulate` and the non-stop motions of
:mod:`mpd_pin.motion` are two ways of filling these tables; the integration is one.

A batch has a fixed cost (the lazy planner runs many small ones), kept low the way
Pinocchio keeps its Data: what depends only on the drive is made once and kept for the
drive (:func:`_cache`) — the ``ModelPool`` (:func:`model_pool`), the batched-RNEA evaluators
with their recorded plans (:func:`_rnea_evaluators`), the per-joint integrator constants
(:func:`_step_constants`) — and the RK4 loop reuses buffers and views made before it, in
fewer and cheaper numpy calls per step than it once needed (docs/design.md §3e, measured by
``bench/rk4_batch.py``). Every floating-point operation is the one it always was, in the
same order: the energies are bit-identical (``tests/test_rk4_batch.py``).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .current import current_step
from .motor import Drive

__all__ = ["feedforward_tables", "integrate_tables", "TrackedSeries"]


#: What the integrator keeps per drive (see the module docstring), by drive: held outside
#: the drive so that a copy of a drive (copy.deepcopy) never shares or copies it (a copied
#: RNEA plan would no longer alias its own buffers), and freed with the drive.
_CACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cache(drive: Drive) -> dict:
    cache = _CACHES.get(drive)
    if cache is None:
        cache = _CACHES[drive] = {}
    return cache


def model_pool(drive: Drive, threads: int) -> pin.ModelPool:
    """A ModelPool of the drive's (armature-carrying) model with ``threads`` Data, kept for
    the drive (rebuilt if ``drive.model`` is replaced)."""
    cache = _cache(drive)
    cached = cache.get("pool")
    if cached is None or cached[0] != threads or cached[2] is not drive.model:
        cached = cache["pool"] = (threads, pin.ModelPool(drive.model, threads), drive.model)
    return cached[1]


def _rnea_evaluators(drive: Drive) -> list:
    """Idle :class:`~mpd_pin.dynamics.batch.BatchRneaDerivative` evaluators of the drive's
    (armature-carrying) model, kept for the drive: reading the model and recording a plan
    cost ~2 ms, once per drive instead of once per batch. Dropped when ``drive.model`` is
    replaced or its armature or gravity change (an evaluator reads the model only once)."""
    model = drive.model
    stamp = (np.asarray(model.armature, dtype=float).tobytes(),
             np.asarray(model.gravity.vector, dtype=float).tobytes())
    cache = _cache(drive)
    cached = cache.get("rnea")
    if cached is None or cached[0] is not model or cached[1] != stamp:
        cached = cache["rnea"] = (model, stamp, [])
    return cached[2]


def feedforward_tables(drive: Drive, Qr: np.ndarray, Vr: np.ndarray, Ar: np.ndarray,
                       Jr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V_ff (V) and i_ff (A), each (nt, K, nq), along references tabulated as q (rad),
    q̇ (rad/s), q̈ (rad/s²), q⃛ (rad/s³) arrays of shape (nt, K, nq) (docs/design.md §3c):

    τ_ff = RNEA(q, q̇, q̈) + n²B q̇ (armature n²J in the model), i_ff = τ_ff/(n Kt),
    V_ff = R i_ff + L τ̇_ff/(n Kt) + n Ke q̇, τ̇_ff = d/dt RNEA + n²B q̈.
    """
    nt, K, nq = Qr.shape
    flat = (nt * K, nq)
    free = _rnea_evaluators(drive)
    try:
        evaluate = free.pop()  # one evaluator per concurrent caller (their buffers are shared)
    except IndexError:
        from .batch import BatchRneaDerivative

        evaluate = BatchRneaDerivative(drive.model)
    tau_r, dtau_r = evaluate(
        Qr.reshape(flat).T, Vr.reshape(flat).T, Ar.reshape(flat).T, Jr.reshape(flat).T
    )
    free.append(evaluate)
    tau_ff = tau_r.T.reshape(nt, K, nq) + drive.damping * Vr
    dtau_ff = dtau_r.T.reshape(nt, K, nq) + drive.damping * Ar
    i_ff = tau_ff / drive.torque_per_amp
    Vff = drive.R * i_ff + drive.L * (dtau_ff / drive.torque_per_amp) + drive.emf_per_rad_s * Vr
    return Vff, i_ff


@dataclass(frozen=True)
class TrackedSeries:
    """The time series of one batch, recorded at every RK4 step point (N+1 samples).

    q (rad), v (rad/s), i (A), V (V), energy_t (cumulative E⁺ per joint, J),
    net_energy_t (cumulative E, J): each (N+1, K, nq); bus_energy_t (cumulative
    [B⁺, B⁻] of the shared bus, J): (N+1, K, 2).
    """

    q: np.ndarray
    v: np.ndarray
    i: np.ndarray
    V: np.ndarray
    energy_t: np.ndarray
    net_energy_t: np.ndarray
    bus_energy_t: np.ndarray


#: Batches of fewer motions than this run ``abaInParallel`` on one thread: waking a second
#: OpenMP thread costs more than it saves on a few configurations (measured on the Panda,
#: 2 cores: 3 vs 11 µs CPU per call for one configuration, 31 vs 40 µs for 16; wall time
#: no better with 2 threads below 64 either). Results do not depend on the thread count.
ABA_PARALLEL_MIN = 64


@dataclass(frozen=True, eq=False)
class _StepConstants:
    """Per-drive constants of the integrator at one step ``h`` (docs/design.md §3e): per
    joint, the very values the stage formulas always used (so results stay bit-identical).

    ``stiff`` marks the joints with the exponential current update; its coefficients are
    spread to all joints (0 on classical joints, whose values are never used)."""

    key: tuple
    stiff: np.ndarray  # (nq,) bool
    any_stiff: bool
    all_stiff: bool
    saturate: bool
    joint: dict  # name -> (nq,) per-joint constant (see _step_constants)


def _spread(values: np.ndarray, stiff: np.ndarray) -> np.ndarray:
    out = np.zeros(stiff.shape)
    out[stiff] = values
    return out


def _step_constants(drive: Drive, h: float) -> _StepConstants:
    """The integrator's constants for ``drive`` at step ``h`` (s), kept for the drive
    (recomputed if any motor constant or gain changes, or ``h``)."""
    arrays = (drive.R, drive.L, drive.emf_per_rad_s, drive.torque_per_amp, drive.damping,
              drive.kp_vec, drive.kd_vec, drive.v_max)
    key = (float(h), *(np.asarray(a, dtype=float).tobytes() for a in arrays))
    cache = _cache(drive)
    cached = cache.get("step")
    if cached is not None and cached.key == key:
        return cached
    inv_l = 1.0 / drive.L
    cs = current_step(drive, h)
    stiff = cs.stiff.copy()
    joint = {
        "kp": drive.kp_vec, "kd": drive.kd_vec, "lo": -drive.v_max, "hi": drive.v_max,
        "damp": drive.damping, "ktn": drive.torque_per_amp, "ke": drive.emf_per_rad_s,
        "inv_l": inv_l, "r_l": drive.R * inv_l, "ke_l": drive.emf_per_rad_s * inv_l,
        # the exponential current update (CurrentStep), 0 on classical joints
        "decay_half": _spread(cs.decay_half, stiff), "decay": _spread(cs.decay, stiff),
        "w0_half": _spread(cs.w0_half, stiff), "w0": _spread(cs.w0, stiff),
        "wc_half": _spread(cs.wc_half, stiff), "wc": _spread(cs.wc, stiff),
        "inv_l_stiff": _spread(cs.inv_L, stiff),
    }
    consts = _StepConstants(key, stiff, bool(stiff.any()), bool(stiff.all()), drive.saturated,
                            {k: np.asarray(v, dtype=float) for k, v in joint.items()})
    cache["step"] = consts
    return consts


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
    velocity, peak torque), each (K, nq), and the bus energies [B⁺, B⁻] (K, 2), and with
    ``record`` a :class:`TrackedSeries`. Each row is computed exactly as if alone (rows
    never mix; layout: module docstring).

    Every stage evaluates, elementwise and with exactly these operations in this order
    (docs/design.md §3c–§3e; any change of order would change the energies' last bits):

        V  = sat((W_j − Kp q) − Kd q̇)
        N  = (V − n Ke q̇) · (1/L)                  stiff joints: the stage current is
        i  = (e^{cz} i₀ + w₀ N₀) + w_c N            the exponential update
        τ  = n Kt i − n²B q̇,   q̈ = ABA(q, q̇, τ)
        di = ((V · (1/L)) − (R/L) i) − (n Ke/L) q̇   classical joints
        P  = V i,  P⁺ = max(P, 0)
        P_bus = Σ_k P,  B⁺' = max(P_bus, 0)        (row 5, column 0)

    Cheap in Python calls: the voltage of a state depends on (q, q̇) only, so it is
    evaluated once per stage state and serves the stiff forcing N, the stage derivative
    and (at a step's end) the next step's first stage; every constant is a full (K, nq)
    array and every operand contiguous and of one shape, numpy's fast path, with products
    of adjacent state rows (q, q̇ or q̇, i) by two constants in one call; buffers and views
    are made once, before the loop; ``abaInParallel`` runs on one thread below
    :data:`ABA_PARALLEL_MIN` motions.
    """
    K, nq = Q0.shape
    N = np.asarray(N, dtype=np.int64)
    n_max = int(N.max())
    if pool is None:
        pool = model_pool(drive, threads)
    aba_threads = max(1, int(threads)) if K >= ABA_PARALLEL_MIN else 1
    X = np.zeros((6, K, nq))  # row 5: B⁺ in column 0, the other columns stay 0
    X[0] = Q0
    X[2] = i0
    V = np.empty((K, nq))
    step = _rk4_stepper(_step_constants(drive, h), list(W), X, V, h, pool, aba_threads)
    tmp = np.empty((K, nq))
    peak_i = np.abs(X[2])
    rec = None
    if record:
        # state rows q, q̇, i, E⁺, E in one block, the voltage, the bus's B⁺ (column 0)
        rec = [np.empty((n_max + 1, 5, K, nq)), np.empty((n_max + 1, K, nq)),
               np.empty((n_max + 1, K))]
    result = [np.empty((K, nq)) for _ in range(5)] + [np.empty((K, 2))]
    ending = {int(n): np.flatnonzero(N == n) for n in np.unique(N)}
    for n in range(n_max):
        if rec is not None:
            _record(rec, n, X, V)
        step(n)
        np.abs(X[2], out=tmp)
        np.maximum(peak_i, tmp, out=peak_i)
        idx = ending.get(n + 1)
        if idx is not None:
            for arr, now in zip(result[:5], (X[3], X[4], X[0] - Q1, X[1], peak_i),
                                strict=True):
                arr[idx] = now[idx]
            result[5][idx] = _bus_pair(X[5][idx, 0], X[4][idx])
    if rec is not None:  # the last sample and its voltage (V is that of (2 n_max, X))
        _record(rec, n_max, X, V)
    return _finish(result, rec, drive.torque_per_amp)


def _joint_arrays(c: _StepConstants, K: int, *names: str) -> np.ndarray:
    """The named per-joint constants of ``c`` as one contiguous (len(names), K, nq) array."""
    out = np.empty((len(names), K, c.stiff.size))
    for row, name in zip(out, names, strict=True):
        row[...] = c.joint[name]
    return out


def _state_views(x: np.ndarray) -> tuple:
    """(x, q̇, i, (q, q̇), (q̇, i), qᵀ, q̇ᵀ) of a state array, made once."""
    return x, x[1], x[2], x[0:2], x[1:3], x[0].T, x[1].T


def _derivative_views(k: np.ndarray) -> tuple:
    """(q̇ row, q̈ row transposed for ABA, di/dt, P⁺, P rows, B⁺' column) of a derivative
    array."""
    return k[0], k[1].T, k[2], k[3], k[4], k[5][:, 0]


def _rk4_stepper(c: _StepConstants, W_rows: list, X: np.ndarray, V: np.ndarray, h: float,
                 pool: pin.ModelPool, aba_threads: int):
    """``step(n)``: one RK4 step n of :func:`integrate_tables` on the state X (6, K, nq), in
    place, with the voltage rows ``W_rows`` (grid rows 2n, 2n+1, 2n+2); on return, and after
    every step, ``V`` holds the voltage of X's state (the next step's first stage).

    The stage formulas are those in :func:`integrate_tables`'s docstring; buffers, views and
    full-shape constants are made here once, before the loop."""
    _, K, nq = X.shape
    any_stiff, all_stiff, saturate, stiff = c.any_stiff, c.all_stiff, c.saturate, c.stiff
    classical = not all_stiff
    kpkd = _joint_arrays(c, K, "kp", "kd")  # × (q, q̇)
    dampktn = _joint_arrays(c, K, "damp", "ktn")  # × (q̇, i)
    lo, hi = _joint_arrays(c, K, "lo", "hi")
    kel_rl = _joint_arrays(c, K, "ke_l", "r_l") if classical else None  # × (q̇, i)
    inv_l = _joint_arrays(c, K, "inv_l")[0] if classical else None
    wc_half = wc = None  # the stiff joints' stage weights (none without stiff joints)
    if any_stiff:
        ke, inv_l_s, wc_half, wc, dec_half, dec, w0_half, w0 = _joint_arrays(
            c, K, "ke", "inv_l_stiff", "wc_half", "wc", "decay_half", "decay", "w0_half", "w0")
    rows = 3 if classical else 2  # the stiff currents come from the exponential update
    half_h = np.full((rows, K, nq), 0.5 * h)
    step_h = np.full((rows, K, nq), h)
    two = np.full((6, K, nq), 2.0)
    weight = np.full((6, K, nq), h / 6.0)
    zero = np.zeros((K, nq))
    zero_k = np.zeros(K)
    Xs = np.zeros_like(X)
    k1, k2, k3, k4 = (np.zeros_like(X) for _ in range(4))
    qv_kp, qv_kd = qv_prod = np.empty((2, K, nq))  # (Kp q, Kd q̇)
    vi_damp, vi_ktn = vi_prod = np.empty((2, K, nq))  # (n²B q̇, n Kt i)
    vi_kel, vi_rl = vi_prod2 = np.empty((2, K, nq))  # (n Ke/L q̇, R/L i)
    tmp, trq, nc, i_new = (np.empty((K, nq)) for _ in range(4))  # nc: stiff forcing N
    base_half, base_full, base_tmp = (np.empty((K, nq)) for _ in range(3))
    multiply, subtract, add = np.multiply, np.subtract, np.add
    maximum, minimum, copyto, aba = np.maximum, np.minimum, np.copyto, pin.abaInParallel
    trq_t = trq.T

    def voltage(j: int, x: tuple) -> None:
        """V at state ``x`` and grid row j; with stiff joints also their forcing N."""
        multiply(x[3], kpkd, out=qv_prod)
        subtract(W_rows[j], qv_kp, out=V)
        subtract(V, qv_kd, out=V)
        if saturate:
            maximum(V, lo, out=V)
            minimum(V, hi, out=V)
        if any_stiff:
            multiply(x[1], ke, out=nc)
            subtract(V, nc, out=nc)
            multiply(nc, inv_l_s, out=nc)

    def current(x: tuple, wgt: np.ndarray, base: np.ndarray) -> None:
        """The stiff joints' stage current (e^{cz} i₀ + w₀ N₀) + w_c N, into x's i row."""
        multiply(nc, wgt, out=tmp)
        if all_stiff:
            add(base, tmp, out=x[2])
        else:
            add(base, tmp, out=i_new)
            copyto(x[2], i_new, where=stiff)

    def derivative(x: tuple, k: tuple) -> None:
        """The stage derivative [q̇, q̈, di/dt, P⁺, P] and the bus's max(P_bus, 0) at ``x``
        (V already evaluated)."""
        multiply(x[4], dampktn, out=vi_prod)
        subtract(vi_ktn, vi_damp, out=trq)  # n Kt i − n²B q̇
        aba(aba_threads, pool, x[5], x[6], trq_t, k[1])
        copyto(k[0], x[1])
        if classical:  # di/dt = ((V/L) − (R/L) i) − (n Ke/L) q̇
            kdi = k[2]
            multiply(x[4], kel_rl, out=vi_prod2)
            multiply(V, inv_l, out=kdi)
            subtract(kdi, vi_rl, out=kdi)
            subtract(kdi, vi_kel, out=kdi)
        multiply(V, x[2], out=k[4])
        maximum(k[4], zero, out=k[3])
        add.reduce(k[4], axis=1, out=k[5])  # (np.sum costs 2.5 µs more per call)
        maximum(k[5], zero_k, out=k[5])

    def stage(k_prev: np.ndarray, step: np.ndarray, j: int, wgt, base, k: tuple) -> None:
        """One RK4 stage: Xs = X + step·k_prev (the integrated rows), its voltage at grid
        row j, the stiff currents (weight ``wgt`` on ``base``), its derivative into k."""
        multiply(k_prev, step, out=xsr)
        add(xsr, xr, out=xsr)
        voltage(j, ss)
        if any_stiff:
            current(ss, wgt, base)
        derivative(ss, k)

    def rk4_step(n: int) -> None:
        j = 2 * n
        if any_stiff:  # e^{cz} i(t) + w₀ N(t), with N(t) of this state (in nc)
            multiply(i_now, dec_half, out=base_half)
            multiply(nc, w0_half, out=base_tmp)
            add(base_half, base_tmp, out=base_half)
            multiply(i_now, dec, out=base_full)
            multiply(nc, w0, out=base_tmp)
            add(base_full, base_tmp, out=base_full)
        derivative(sx, kv1)
        stage(k1r, half_h, j + 1, wc_half, base_half, kv2)
        stage(k2r, half_h, j + 1, wc_half, base_half, kv3)
        stage(k3r, step_h, j + 2, wc, base_full, kv4)
        add(k2, k3, out=k2)  # X += h/6 · (((k2 + k3)·2 + k1) + k4)
        multiply(k2, two, out=k2)
        add(k2, k1, out=k2)
        add(k2, k4, out=k2)
        multiply(k2, weight, out=k2)
        add(X, k2, out=X)
        voltage(j + 2, sx)  # the end state: also the next step's first stage
        if any_stiff:
            current(sx, wc, base_full)

    xr, xsr = X[:rows], Xs[:rows]
    k1r, k2r, k3r = k1[:rows], k2[:rows], k3[:rows]
    i_now = X[2]
    sx, ss = _state_views(X), _state_views(Xs)
    kv1, kv2, kv3, kv4 = (_derivative_views(k) for k in (k1, k2, k3, k4))
    voltage(0, sx)
    return rk4_step


def _finish(result: list[np.ndarray], rec: list[np.ndarray] | None, torque_per_amp):
    """Peak current → peak torque (N·m), the divergence check, and the return value of
    :func:`integrate_tables`."""
    result[4] *= torque_per_amp
    if not (np.all(np.isfinite(result[0])) and np.all(np.isfinite(result[2]))):
        raise ValueError("integration diverged on some edges; reduce dt or the gains")
    if rec is not None:
        state, volts, b_plus = rec
        q, v, i, e_plus, e_net = (state[:, r] for r in range(5))
        return tuple(result), TrackedSeries(q, v, i, volts, e_plus, e_net,
                                            _bus_pair(b_plus, e_net))
    return tuple(result)


def _bus_pair(b_plus: np.ndarray, net: np.ndarray) -> np.ndarray:
    """[B⁺, B⁻] (…, 2) J from B⁺ and the net energies E per joint (…, nq): B⁻ = ∫ max(−P, 0)
    = B⁺ − ∫ P, ∫ P = Σ_k E_k — exact for RK4, whose weights are linear in the integrand
    (max(−P, 0) = max(P, 0) − P at every stage); a round-off below 0 is 0."""
    b_minus = np.maximum(b_plus - net.sum(axis=-1), 0.0)
    return np.stack([b_plus, b_minus], axis=-1)


def _record(rec: list[np.ndarray], n: int, X: np.ndarray, V: np.ndarray) -> None:
    """Store sample n: the state of X before step n's update and the voltage of its first
    stage (V at the sample, as in :func:`~mpd_pin.dynamics.simulate.simulate_edge`)."""
    rec[0][n] = X[:5]
    rec[1][n] = V
    rec[2][n] = X[5][:, 0]  # [B⁺, B⁻] of every sample after the loop (_finish), at once


