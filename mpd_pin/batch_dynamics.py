"""Batched inverse dynamics with its exact time derivative (DESIGN §3).

The feed-forward voltage of DESIGN §3 needs, along a reference trajectory,

    τ(t) = RNEA(q, q̇, q̈)                                    [N·m, or N]
    τ̇(t) = ∂τ/∂q · q̇ + ∂τ/∂q̇ · q̈ + M(q) · q⃛                 [N·m/s, or N/s]

for very many time points at once.  :func:`rnea_with_derivative` evaluates both
with a third-order recursive Newton–Euler algorithm in spatial algebra
(Featherstone, body coordinates), vectorised with numpy over the batch; the
Python loop runs only over the joints.

Notation (Pinocchio's ordering, linear part first): a motion vector is
``(u, ω)``, a force ``(f, n)``.  For body i with parent λ(i), motion subspace
S_i and X_i the motion transform parent → child (a function of q_i only):

    v_i = X_i v_λ + S_i q̇_i
    a_i = X_i a_λ + S_i q̈_i + v_i × S_i q̇_i
    j_i = X_i j_λ + (X_i a_λ + a_i) × S_i q̇_i + v_i × S_i q̈_i + S_i q⃛_i

(from Ẋ_i = −(S_i q̇_i)× X_i).  Gravity is a base acceleration a_0 = −g with
zero base jerk.  Body forces and their derivatives (I_i is constant in the body
frame):

    f_i = I_i a_i + v_i ×* I_i v_i
    ḟ_i = I_i j_i + a_i ×* I_i v_i + v_i ×* I_i a_i

Backward pass: F_i = f_i + Σ_c X_cᵀ F_c and, since d/dt X_cᵀ = X_cᵀ (S_c q̇_c)×*,
Ḟ_i = ḟ_i + Σ_c X_cᵀ (Ḟ_c + S_c q̇_c ×* F_c).  Finally τ_i = S_iᵀ F_i +
armature_i q̈_i and τ̇_i = S_iᵀ Ḟ_i + armature_i q⃛_i: what ``pin.rnea`` returns
(it adds ``model.armature · q̈``) and its exact time derivative.

Implementation (chosen by measurement, see ``bench/batch_dynamics.py``):

* every 1-DoF joint becomes a joint about / along the local z axis by giving
  each body an internal frame rotated by a constant R_a with R_a e_z = axis;
  inertias and placements are re-expressed once per call;
* the constant part of X_i is one 6×6 BLAS product applied to v, a and j at
  once; the q-dependent part is a rotation about z (or a shift along z) done
  with component arithmetic;
* v ×* I v is a quadratic form with only 12 distinct monomials (ω_k ω_l and
  ω_k u_l, k ≠ l): f = [I | Q] · [a; monomials] and ḟ = [I | Q'] · [j; their
  derivatives] are two more BLAS products, so the elementwise work is just the
  monomials (33 products);
* the batch is processed in chunks whose temporaries stay in cache.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

__all__ = ["rnea_with_derivative"]

DEFAULT_CHUNK = 4096

_REVOLUTE_AXES = {
    "JointModelRX": (1.0, 0.0, 0.0),
    "JointModelRY": (0.0, 1.0, 0.0),
    "JointModelRZ": (0.0, 0.0, 1.0),
}
_PRISMATIC_AXES = {
    "JointModelPX": (1.0, 0.0, 0.0),
    "JointModelPY": (0.0, 1.0, 0.0),
    "JointModelPZ": (0.0, 0.0, 1.0),
}

# Monomials of the body velocity v = (u, ω) that appear in v ×* I v, as index
# pairs into v (0..2 = u, 3..5 = ω).  Grouped so that each group is one numpy
# product of two row slices: (first rows, second rows).
_MONO_GROUPS = (
    ((3, 6), (3, 6)),  # ω0ω0, ω1ω1, ω2ω2
    ((3, 5), (4, 6)),  # ω0ω1, ω1ω2
    ((5, 6), (3, 4)),  # ω2ω0
    ((3, 5), (1, 3)),  # ω0u1, ω1u2
    ((5, 6), (0, 1)),  # ω2u0
    ((4, 6), (0, 2)),  # ω1u0, ω2u1
    ((3, 4), (2, 3)),  # ω0u2
)
_MONOMIALS = [
    (a, b)
    for (a0, a1), (b0, b1) in _MONO_GROUPS
    for a, b in zip(range(a0, a1), range(b0, b1), strict=True)
]
_N_MONO = len(_MONOMIALS)  # 12
_N_SQUARES = 3  # the first three monomials are squares


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def _cross_force_matrix(v: np.ndarray) -> np.ndarray:
    """6×6 matrix of v×* (v = (u, ω), forces (f, n))."""
    out = np.zeros((6, 6))
    out[:3, :3] = _skew(v[3:])
    out[3:, 3:] = _skew(v[3:])
    out[3:, :3] = _skew(v[:3])
    return out


def _frame_with_z(axis: np.ndarray) -> np.ndarray:
    """A rotation R with R @ e_z == axis (axis: a unit vector)."""
    for k in range(3):
        for sign in (1.0, -1.0):
            e = np.zeros(3)
            e[k] = sign
            if np.array_equal(axis, e):  # exact permutation matrices for aligned axes
                r = np.zeros((3, 3))
                r[k, 2] = sign
                r[(k + 1) % 3, 0] = 1.0
                r[(k + 2) % 3, 1] = sign
                return r
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(axis, e1), axis])


@dataclass
class _Joint:
    parent: int  # parent joint index (0 = universe)
    revolute: bool
    iv: int  # velocity index
    armature: float
    xm: np.ndarray  # (6, 6) motion transform: parent internal frame -> joint base frame
    xf: np.ndarray  # (6, 6) force transform: joint base frame -> parent internal frame
    lf: np.ndarray  # (6, 6 + 12): f = lf @ [a; monomials(v)]
    lfd: np.ndarray  # (6, 6 + 21): ḟ = lfd @ [j; derivative terms of the monomials]


def _joint_axis(model: pin.Model, i: int) -> tuple[bool, np.ndarray]:
    joint = model.joints[i]
    name = joint.shortname()
    if name in _REVOLUTE_AXES:
        return True, np.array(_REVOLUTE_AXES[name])
    if name in _PRISMATIC_AXES:
        return False, np.array(_PRISMATIC_AXES[name])
    if name in ("JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned"):
        axis = np.array(joint.extract().axis, dtype=float)
        return name == "JointModelRevoluteUnaligned", axis / np.linalg.norm(axis)
    raise ValueError(
        f"rnea_with_derivative supports only 1-DoF revolute and prismatic joints with "
        f"nq == nv (JointModelRX/RY/RZ, JointModelRevoluteUnaligned, JointModelPX/PY/PZ, "
        f"JointModelPrismaticUnaligned); joint {i} '{model.names[i]}' is {name} "
        f"(nq={joint.nq}, nv={joint.nv})"
    )


def _force_matrices(i6: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[I | Q] and [I | Q'] with v ×* I v = Q · monomials(v) and d/dt of it = Q' · terms."""

    def quad(v):
        return _cross_force_matrix(v) @ i6 @ v

    eye = np.eye(6)
    q = np.zeros((6, _N_MONO))
    for k, (a, b) in enumerate(_MONOMIALS):
        if a == b:
            q[:, k] = quad(eye[a])
        else:
            q[:, k] = quad(eye[a] + eye[b]) - quad(eye[a]) - quad(eye[b])
    # check that no other monomial (u_k u_l, u_k ω_k) is needed
    rng = np.random.default_rng(12345)
    for _ in range(3):
        v = rng.normal(size=6)
        mono = np.array([v[a] * v[b] for a, b in _MONOMIALS])
        ref = quad(v)
        if not np.allclose(q @ mono, ref, rtol=1e-12, atol=1e-12 * (1.0 + np.abs(i6).max())):
            raise AssertionError("internal error: unexpected structure of v ×* I v")
    # derivative terms: squares -> a_k v_k (coefficient doubled); products ab -> a'b and ab'
    qd = np.concatenate([2.0 * q[:, :_N_SQUARES], q[:, _N_SQUARES:], q[:, _N_SQUARES:]], axis=1)
    return np.concatenate([i6, q], axis=1), np.concatenate([i6, qd], axis=1)


def _prepare(model: pin.Model) -> tuple[list[_Joint], np.ndarray]:
    """Constant per-joint data in internal (joint axis = z) frames, and the base acceleration."""
    kinds = [_joint_axis(model, i) for i in range(1, model.njoints)]
    if model.nq != model.nv:  # pragma: no cover - excluded by the joint types above
        raise ValueError(f"rnea_with_derivative needs nq == nv, got nq={model.nq}, nv={model.nv}")
    frames = [np.eye(3)]  # R_a of each body's internal frame w.r.t. its Pinocchio frame
    joints: list[_Joint] = []
    for i in range(1, model.njoints):
        revolute, axis = kinds[i - 1]
        ra = _frame_with_z(axis)
        frames.append(ra)
        parent = model.parents[i]
        pl = model.jointPlacements[i]
        rp = frames[parent]
        rt = rp.T @ pl.rotation @ ra  # joint base frame, seen from the parent internal frame
        pt = rp.T @ pl.translation
        xm = np.zeros((6, 6))
        xm[:3, :3] = rt.T
        xm[:3, 3:] = -rt.T @ _skew(pt)
        xm[3:, 3:] = rt.T
        inr = model.inertias[i]
        m = inr.mass
        c = ra.T @ inr.lever
        cx = _skew(c)
        i6 = np.zeros((6, 6))
        i6[:3, :3] = m * np.eye(3)
        i6[:3, 3:] = -m * cx
        i6[3:, :3] = m * cx
        i6[3:, 3:] = ra.T @ inr.inertia @ ra - m * cx @ cx
        lf, lfd = _force_matrices(i6)
        iv = model.joints[i].idx_v
        joints.append(
            _Joint(parent, revolute, iv, float(model.armature[iv]), xm, xm.T.copy(), lf, lfd)
        )
    _check_kinematics(model, joints, frames)
    return joints, -np.asarray(model.gravity.vector, dtype=float)


def _check_kinematics(model: pin.Model, joints: list[_Joint], frames: list[np.ndarray]) -> None:
    """Guard: the z-axis rewrite must reproduce Pinocchio's liMi at a test configuration."""
    data = model.createData()
    q = np.linspace(0.3, 0.9, model.nq)
    pin.forwardKinematics(model, data, q)
    for k, jt in enumerate(joints):
        i = k + 1
        ra = frames[i]
        qi = q[jt.iv]
        if jt.revolute:
            cz, sz = np.cos(qi), np.sin(qi)
            rj = ra @ np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]]) @ ra.T
            pj = np.zeros(3)
        else:
            rj = np.eye(3)
            pj = ra[:, 2] * qi
        pl = model.jointPlacements[i]
        ref = data.liMi[i]
        ok = np.allclose(pl.rotation @ rj, ref.rotation, atol=1e-12) and np.allclose(
            pl.translation + pl.rotation @ pj, ref.translation, atol=1e-12
        )
        if not ok:  # pragma: no cover - would mean a Pinocchio joint convention changed
            raise ValueError(f"joint {i} ({model.names[i]}): unexpected joint kinematics")


def _as_batch(x, nv: int, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != nv:
        raise ValueError(f"{name} must have shape (nv, B) = ({nv}, B), got {np.shape(x)}")
    if arr.strides[1] != arr.itemsize:  # rows must be contiguous for fast elementwise ops
        arr = np.ascontiguousarray(arr)
    return arr


def rnea_with_derivative(
    model: pin.Model,
    Q,
    V,
    A,
    Jerk,
    *,
    chunk: int = DEFAULT_CHUNK,
    out: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse dynamics τ and its time derivative τ̇ for a batch of trajectory points.

    Q, V, A, Jerk: (nv, B) arrays of q [rad or m], q̇ [rad/s], q̈ [rad/s²] and
    q⃛ [rad/s³] (1-D (nv,) arrays are one configuration and give 1-D results).
    Returns ``(tau, tau_dot)``, each (nv, B): τ = RNEA(q, q̇, q̈) in N·m (N for
    prismatic joints), equal to ``pin.rnea`` including ``model.armature · q̈``
    and ``model.gravity``; τ̇ = dτ/dt along the trajectory in N·m/s (N/s), i.e.
    ∂τ/∂q q̇ + ∂τ/∂q̇ q̈ + M(q) q⃛ with M including the armature.  DESIGN §3.

    Only 1-DoF revolute and prismatic joints (any axis) are supported; anything
    else raises ValueError.  ``chunk`` is the number of configurations processed
    together (the default was chosen by measurement on the Panda).  ``out`` may
    give two preallocated float64 (nv, B) arrays with contiguous rows to write
    into (saves allocating and first-touching ~2·8·nv·B bytes per call).
    """
    joints, a0 = _prepare(model)
    nv = model.nv
    squeeze = np.ndim(Q) == 1
    Q, V, A, Jerk = (
        _as_batch(x, nv, n) for x, n in zip((Q, V, A, Jerk), ("Q", "V", "A", "Jerk"), strict=True)
    )
    batch = Q.shape[1]
    for x, n in zip((V, A, Jerk), ("V", "A", "Jerk"), strict=True):
        if x.shape[1] != batch:
            raise ValueError(f"{n} has batch size {x.shape[1]}, Q has {batch}")
    if chunk < 1:
        raise ValueError("chunk must be >= 1")
    if out is None:
        tau = np.empty((nv, batch))
        tau_dot = np.empty((nv, batch))
    else:
        tau, tau_dot = out
        for o in (tau, tau_dot):
            if (
                not isinstance(o, np.ndarray)
                or o.dtype != np.float64
                or o.shape != (nv, batch)
                or o.strides[1] != o.itemsize
            ):
                raise ValueError("out must be two float64 (nv, B) arrays with contiguous rows")
    if batch:
        ws = _Workspace(joints, nv, min(chunk, batch))
        for start in range(0, batch, chunk):
            sl = slice(start, min(start + chunk, batch))
            _rnea3_chunk(
                joints,
                a0,
                Q[:, sl],
                V[:, sl],
                A[:, sl],
                Jerk[:, sl],
                tau[:, sl],
                tau_dot[:, sl],
                ws,
            )
    if squeeze:
        return tau[:, 0], tau_dot[:, 0]
    return tau, tau_dot


# sin/cos of the joint angles: numpy's float64 sin and cos cost ~10 ns per element
# here (scalar libm); this Cody–Waite reduction + fdlibm kernels is within 1 ulp of
# them (checked in the tests) and about twice as fast.  Used for |q| < _TRIG_MAX.
_S = (
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
)
_C = (
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
)
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_HI = 1.57079632673412561417e00  # first 33 bits of π/2: k·_PIO2_HI is exact for |k| < 2^20
_PIO2_LO = 6.07710050650619224932e-11  # π/2 − _PIO2_HI
_TRIG_MAX = 1.0e5
_QUAD_COS = np.array([1.0, 0.0, -1.0, 0.0])  # cos(nπ/2)
_QUAD_SIN = np.array([0.0, 1.0, 0.0, -1.0])  # sin(nπ/2)


def _sincos(q: np.ndarray, cos: np.ndarray, sin: np.ndarray, tmp: np.ndarray) -> None:
    """cos[:] = cos(q), sin[:] = sin(q) (q: radians); tmp: scratch of shape (3, *q.shape)."""
    if q.size == 0 or np.abs(q).max() >= _TRIG_MAX:
        np.cos(q, out=cos)
        np.sin(q, out=sin)
        return
    k, r, z = tmp
    np.multiply(q, _INV_PIO2, out=k)
    np.rint(k, out=k)  # q = k π/2 + r, |r| ≤ π/4
    np.multiply(k, _PIO2_HI, out=r)
    np.subtract(q, r, out=r)
    np.multiply(k, _PIO2_LO, out=z)
    r -= z
    np.multiply(r, r, out=z)
    s = sin
    np.multiply(z, _S[5], out=s)
    for coef in _S[4::-1]:
        s += coef
        s *= z
    s *= r
    s += r  # sin r
    c = cos
    np.multiply(z, _C[5], out=c)
    for coef in _C[4::-1]:
        c += coef
        c *= z
    c *= z
    z *= 0.5
    c -= z
    c += 1.0  # cos r
    quadrant = k.astype(np.int64)
    quadrant &= 3
    qc = _QUAD_COS[quadrant]
    qs = _QUAD_SIN[quadrant]
    # sin q = sin r·cos(nπ/2) + cos r·sin(nπ/2);  cos q = cos r·cos(nπ/2) − sin r·sin(nπ/2)
    np.multiply(s, qs, out=r)
    np.multiply(c, qs, out=z)
    s *= qc
    s += z
    c *= qc
    c -= r


# rows of a body's motion buffer: 6 motion rows, then the monomial rows
_ROWS = 6 + 2 * _N_MONO - _N_SQUARES  # 27


class _Workspace:
    """Flat scratch memory for chunks of up to ``cap`` configurations."""

    def __init__(self, joints: list[_Joint], nv: int, cap: int):
        nj = len(joints)
        self.cap = cap
        # children of each body; a body's motion buffer is recycled after its last child
        last_child = [0] * (nj + 1)
        for k, jt in enumerate(joints):
            last_child[jt.parent] = k + 1
        self.last_child = last_child
        live: set[int] = set()
        peak = 0
        for body in range(1, nj + 1):
            live.add(body)
            peak = max(peak, len(live))
            live = {b for b in live if last_child[b] > body}
        self.n_motion = peak
        self.motion = np.empty(peak * _ROWS * 3 * cap)
        self.force = np.empty(nj * 12 * cap)
        self.trig = np.empty(5 * nv * cap)
        self.scratch = np.empty(24 * cap)
        self.xf_out = np.empty(12 * cap)

    def motion_buffer(self, i: int, nb: int) -> np.ndarray:
        size = _ROWS * 3 * nb
        return self.motion[i * size : (i + 1) * size].reshape(_ROWS, 3, nb)


# OpenBLAS multithreads a GEMM above about m·n·k = 2^18; for these skinny products
# the extra thread only adds synchronisation (and, with busy cores, spin-waits that
# cost more than the product).  Keep every call below that size.
_GEMM_MAX_MNK = 1 << 18


def _gemm(mat: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """out = mat @ x, split into column blocks so that BLAS stays single-threaded."""
    cols = x.shape[1]
    step = max(256, _GEMM_MAX_MNK // mat.size)
    if cols <= step:
        np.matmul(mat, x, out=out)
        return
    for c0 in range(0, cols, step):
        np.matmul(mat, x[:, c0 : c0 + step], out=out[:, c0 : c0 + step])


def _rnea3_chunk(joints, a0, q, qd, qdd, qddd, tau, tau_dot, ws: _Workspace) -> None:
    nb = q.shape[1]
    nj = len(joints)
    nv = q.shape[0]
    trig = ws.trig[: 5 * nv * nb].reshape(5, nv, nb)
    cos, sin = trig[0], trig[1]
    _sincos(q, cos, sin, trig[2:])
    forces = ws.force[: nj * 12 * nb].reshape(nj, 6, 2, nb)  # per body: rows 6, blocks F, Ḟ
    scr = ws.scratch[: 24 * nb]
    t6a = scr[: 6 * nb].reshape(2, 3, nb)
    t6b = scr[6 * nb : 12 * nb].reshape(2, 3, nb)
    t2a, t2b, t2c, w2, wd2, _ = scr[12 * nb :].reshape(6, 2, nb)
    free = list(range(ws.n_motion))
    owner: dict[int, int] = {}  # body -> its motion buffer
    for k, jt in enumerate(joints):
        body = k + 1
        owner[body] = free.pop()
        big = ws.motion_buffer(owner[body], nb)  # rows: motion (6) + monomials; blocks v, a, j
        w = big[:6]
        iv = jt.iv
        wi, wdi, wddi = qd[iv], qdd[iv], qddd[iv]
        # parent's (v, a, j) in this joint's base frame: one BLAS product for all three
        if jt.parent == 0:
            w[:, 0] = 0.0
            w[:, 1] = (jt.xm @ a0)[:, None]
            w[:, 2] = 0.0
        else:
            parent_big = ws.motion_buffer(owner[jt.parent], nb)
            _gemm(jt.xm, parent_big[:6].reshape(6, 3 * nb), w.reshape(6, 3 * nb))
            if ws.last_child[jt.parent] == body:
                free.append(owner.pop(jt.parent))
        w4 = w.reshape(2, 3, 3, nb)  # [lin/ang, xyz, v/a/j, batch]
        x = w4[:, 0]  # (2, 3, nb): x components (linear, angular) of v, a, j
        y = w4[:, 1]
        if jt.revolute:
            c, s = cos[iv], sin[iv]
            # into the body frame, Rz(q)^T: x' = c x + s y,  y' = c y - s x
            np.multiply(x, s, out=t6a)
            x *= c
            np.multiply(y, s, out=t6b)
            x += t6b
            y *= c
            y -= t6a
            # with s = q̇ e_ωz:  m × s = q̇ (m_y, -m_x, 0) on the (linear, angular) pairs
            #   a += q̇ ⊥v;  j += q̇ ⊥(a_before + a_after) + q̈ ⊥v
            np.copyto(w2, wi)
            np.copyto(wd2, wdi)
            vx, vy, ax, ay, jx, jy = x[:, 0], y[:, 0], x[:, 1], y[:, 1], x[:, 2], y[:, 2]
            np.multiply(vx, w2, out=t2a)
            np.multiply(vy, w2, out=t2b)
            np.multiply(ay, 2.0, out=t2c)
            t2c -= t2a
            t2c *= w2
            jx += t2c
            np.multiply(vy, wd2, out=t2c)
            jx += t2c
            np.multiply(ax, 2.0, out=t2c)
            t2c += t2b
            t2c *= w2
            jy -= t2c
            np.multiply(vx, wd2, out=t2c)
            jy -= t2c
            ax += t2b
            ay -= t2a
            w[5, 0] += wi
            w[5, 1] += wdi
            w[5, 2] += wddi
        else:
            qi = q[iv]
            # shift by -q e_z: u' = u + q (ω_y, -ω_x, 0) for v, a and j
            np.multiply(y[1], qi, out=t6a[0])
            x[0] += t6a[0]
            np.multiply(x[1], qi, out=t6a[0])
            y[0] -= t6a[0]
            # with s = q̇ e_uz:  m × s = q̇ (ω_y, -ω_x, 0, 0, 0, 0)
            vwx, vwy, awx, awy = x[1, 0], y[1, 0], x[1, 1], y[1, 1]
            t1 = t2a[0]
            np.multiply(awy, 2.0 * wi, out=t1)
            w[0, 2] += t1
            np.multiply(vwy, wdi, out=t1)
            w[0, 2] += t1
            np.multiply(awx, 2.0 * wi, out=t1)
            w[1, 2] -= t1
            np.multiply(vwx, wdi, out=t1)
            w[1, 2] -= t1
            np.multiply(vwy, wi, out=t1)
            w[0, 1] += t1
            np.multiply(vwx, wi, out=t1)
            w[1, 1] -= t1
            w[2, 0] += wi
            w[2, 1] += wdi
            w[2, 2] += wddi
        # body force f = [I|Q] [a; monomials(v)] and ḟ = [I|Q'] [j; d/dt monomials]
        v, a = w[:, 0], w[:, 1]
        mono, dmono = big[6 : 6 + _N_MONO, 1], big[6:, 2]
        row = 0
        for (a0_, a1_), (b0_, b1_) in _MONO_GROUPS:
            n = a1_ - a0_
            np.multiply(v[a0_:a1_], v[b0_:b1_], out=mono[row : row + n])
            if row < _N_SQUARES:
                np.multiply(a[a0_:a1_], v[b0_:b1_], out=dmono[row : row + n])
            else:
                np.multiply(a[a0_:a1_], v[b0_:b1_], out=dmono[row : row + n])
                r2 = row + _N_MONO - _N_SQUARES
                np.multiply(v[a0_:a1_], a[b0_:b1_], out=dmono[r2 : r2 + n])
            row += n
        f = forces[k]
        _gemm(jt.lf, big[: 6 + _N_MONO, 1], f[:, 0])
        _gemm(jt.lfd, big[:, 2], f[:, 1])
        if ws.last_child[body] == 0:  # a leaf: nobody needs its motion any more
            free.append(owner.pop(body))
    for k in range(nj - 1, -1, -1):
        jt = joints[k]
        f = forces[k]
        iv = jt.iv
        row = 5 if jt.revolute else 2
        if jt.armature:
            np.multiply(qdd[iv], jt.armature, out=tau[iv])
            tau[iv] += f[row, 0]
            np.multiply(qddd[iv], jt.armature, out=tau_dot[iv])
            tau_dot[iv] += f[row, 1]
        else:
            tau[iv] = f[row, 0]
            tau_dot[iv] = f[row, 1]
        if jt.parent == 0:
            continue
        wi = qd[iv]
        f4 = f.reshape(2, 3, 2, nb)
        x = f4[:, 0]  # (2, 2, nb): [lin/ang, F/Ḟ]
        y = f4[:, 1]
        t4a = t6a.reshape(-1)[: 4 * nb].reshape(2, 2, nb)
        t4b = t6b.reshape(-1)[: 4 * nb].reshape(2, 2, nb)
        if jt.revolute:
            # Ḟ += s ×* F with s = q̇ e_ωz: adds q̇ (-F_y, F_x, 0) to force and moment
            np.copyto(w2, wi)
            np.multiply(y[:, 0], w2, out=t2a)
            x[:, 1] -= t2a
            np.multiply(x[:, 0], w2, out=t2a)
            y[:, 1] += t2a
            # back to the joint base frame, Rz(q): x' = c x - s y,  y' = c y + s x
            c, s = cos[iv], sin[iv]
            np.multiply(x, s, out=t4a)
            x *= c
            np.multiply(y, s, out=t4b)
            x -= t4b
            y *= c
            y += t4a
        else:
            qi = q[iv]
            # Ḟ += s ×* F with s = q̇ e_uz: adds q̇ (-f_y, f_x, 0) to the moment
            np.multiply(y[0, 0], wi, out=t2a[0])
            x[1, 1] -= t2a[0]
            np.multiply(x[0, 0], wi, out=t2a[0])
            y[1, 1] += t2a[0]
            # shift by +q e_z: n' = n + q e_z × f, for F and Ḟ
            np.multiply(y[0], qi, out=t2a)
            x[1] -= t2a
            np.multiply(x[0], qi, out=t2a)
            y[1] += t2a
        fp = forces[jt.parent - 1].reshape(6, 2 * nb)
        tmp = ws.xf_out[: 12 * nb].reshape(6, 2 * nb)
        _gemm(jt.xf, f.reshape(6, 2 * nb), tmp)
        fp += tmp
