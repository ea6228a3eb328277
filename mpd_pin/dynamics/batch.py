"""Batched inverse dynamics with its exact time derivative (docs/design.md §3).

The feed-forward voltage of docs/design.md §3 needs, along a reference trajectory,

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
zero base jerk (exact for a purely linear g: see _prepare).  Body forces and
their derivatives (I_i is constant in the body frame):

    f_i = I_i a_i + v_i ×* I_i v_i
    ḟ_i = I_i j_i + a_i ×* I_i v_i + v_i ×* I_i a_i

Backward pass: F_i = f_i + Σ_c X_cᵀ F_c and, since d/dt X_cᵀ = X_cᵀ (S_c q̇_c)×*,
Ḟ_i = ḟ_i + Σ_c X_cᵀ (Ḟ_c + S_c q̇_c ×* F_c).  Finally τ_i = S_iᵀ F_i +
armature_i q̈_i and τ̇_i = S_iᵀ Ḟ_i + armature_i q⃛_i: what ``pin.rnea`` returns
(it adds ``model.armature · q̈``) and its exact time derivative.

Implementation (each choice measured, see ``bench/batch_dynamics.py``):

* every 1-DoF joint becomes a joint about / along the local z axis by giving
  each body an internal frame rotated by a constant R_a with R_a e_z = axis;
  inertias and placements are re-expressed once per call;
* the constant part of X_i is one 6×6 BLAS product applied to v, a and j at
  once; the q-dependent part is a rotation about z (or a shift along z) done
  with component arithmetic on rows ordered (u_x, ω_x, u_y, ω_y, u_z, ω_z),
  so that every pair a z-rotation mixes is a contiguous 2-row block;
* v ×* I v is a quadratic form in only 12 monomials (ω_k ω_l and ω_k u_l,
  k ≠ l), so f = [I | Q]·[a; monomials] and ḟ = [I | Q]·[j; d/dt monomials]
  are one stacked BLAS product after 12 + 21 elementwise products;
* the batch is cut in chunks; for a chunk size the whole computation is
  recorded once as a list of numpy calls on fixed buffers and replayed per
  chunk (Python only dispatches), BLAS calls are kept below OpenBLAS's
  multithreading threshold, and sin/cos use a 1-ulp polynomial that is about
  twice as fast as numpy's here.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

__all__ = ["BatchRneaDerivative", "rnea_with_derivative"]

DEFAULT_CHUNK = 2048

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

# The monomials v_k v_l of the body velocity v = (u, ω) that appear in v ×* I v, as
# index pairs into v in Pinocchio's order (0..2 = u, 3..5 = ω): ω_k ω_l and ω_k u_l
# with k ≠ l (u_k u_l and u_k ω_k cancel; checked in _force_matrices).
_MONOMIALS = [
    (3, 3), (4, 4), (5, 5),  # ω0², ω1², ω2²
    (3, 4), (4, 5), (5, 3),  # ω0ω1, ω1ω2, ω2ω0
    (3, 1), (4, 2), (5, 0),  # ω0u1, ω1u2, ω2u0
    (4, 0), (5, 1), (3, 2),  # ω1u0, ω2u1, ω0u2
]  # fmt: skip
_N_MONO = len(_MONOMIALS)  # 12


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def _basis_cross_force() -> np.ndarray:
    """(6, 6, 6) array: [k] is the matrix of e_k ×* (motion e_k = (u, ω) basis vector)."""
    out = np.zeros((6, 6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = 1.0
        out[k, :3, :3] = _skew(e[3:])
        out[k, 3:, 3:] = _skew(e[3:])
        out[k, 3:, :3] = _skew(e[:3])
    return out


_CROSS_FORCE = _basis_cross_force()
_MONO_A = np.array([a for a, _ in _MONOMIALS])
_MONO_B = np.array([b for _, b in _MONOMIALS])
_MONO_MASK = np.zeros((6, 6), dtype=bool)  # monomials v_k v_l (either order) that we form
_MONO_MASK[_MONO_A, _MONO_B] = _MONO_MASK[_MONO_B, _MONO_A] = True


def _frame_with_z(axis: np.ndarray) -> np.ndarray:
    """A rotation R with R @ e_z == axis (axis: a unit vector)."""
    k = int(np.argmax(np.abs(axis)))
    if abs(axis[k]) == 1.0:  # aligned with ±e_k: an exact signed permutation
        sign = float(axis[k])
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
    lf: np.ndarray  # (6, 6 + 12): f = lf @ [a; monomials(v)], ḟ = lf @ [j; d/dt monomials]


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


def _force_matrices(i6: np.ndarray) -> np.ndarray:
    """[I | Q] with v ×* I v = Q · monomials(v), for (n, 6, 6) spatial inertias: (n, 6, 18).

    f = I a + v ×* I v = [I | Q]·[a; monomials(v)], and as the derivative of a
    monomial is linear in (v, a), ḟ = I j + d/dt(v ×* I v) = [I | Q]·[j; d/dt monomials].
    """
    # v ×* I v = Σ_kl t[r, k, l] v_k v_l with t[:, :, k, l] = (e_k ×* I)[:, l]
    t = np.einsum("krm,nml->nrkl", _CROSS_FORCE, i6)
    sym = t + t.transpose(0, 1, 3, 2)
    if np.abs(sym[:, :, ~_MONO_MASK]).max(initial=0.0) > 1e-12 * max(1.0, np.abs(i6).max()):
        raise AssertionError("internal error: unexpected monomials in v ×* I v")
    q = sym[:, :, _MONO_A, _MONO_B]
    q[:, :, _MONO_A == _MONO_B] *= 0.5  # squares: t[k, k] counted twice in sym
    return np.concatenate([i6, q], axis=2)


def _prepare(model: pin.Model) -> tuple[list[_Joint], np.ndarray]:
    """Constant per-joint data in internal (joint axis = z) frames, and the base acceleration."""
    kinds = [_joint_axis(model, i) for i in range(1, model.njoints)]
    if model.nq != model.nv:  # pragma: no cover - excluded by the joint types above
        raise ValueError(f"rnea_with_derivative needs nq == nv, got nq={model.nq}, nv={model.nv}")
    nj = model.njoints - 1
    frames = [np.eye(3)]  # R_a of each body's internal frame w.r.t. its Pinocchio frame
    xms = np.zeros((nj, 6, 6))
    i6s = np.zeros((nj, 6, 6))
    for i in range(1, model.njoints):
        ra = _frame_with_z(kinds[i - 1][1])
        frames.append(ra)
        pl = model.jointPlacements[i]
        rp = frames[model.parents[i]]
        rt = rp.T @ pl.rotation @ ra  # joint base frame, seen from the parent internal frame
        xm = xms[i - 1]
        xm[:3, :3] = xm[3:, 3:] = rt.T
        xm[:3, 3:] = -rt.T @ _skew(rp.T @ pl.translation)
        inr = model.inertias[i]
        m = inr.mass
        cx = _skew(ra.T @ inr.lever)
        i6 = i6s[i - 1]
        i6[:3, :3] = m * np.eye(3)
        i6[:3, 3:] = -m * cx
        i6[3:, :3] = m * cx
        i6[3:, 3:] = ra.T @ inr.inertia @ ra - m * cx @ cx
    lfs = _force_matrices(i6s)
    joints = []
    for i in range(1, model.njoints):
        iv = model.joints[i].idx_v
        xm = xms[i - 1]
        joints.append(
            _Joint(
                model.parents[i],
                kinds[i - 1][0],
                iv,
                float(model.armature[iv]),
                xm,
                xm.T.copy(),
                lfs[i - 1],
            )
        )
    gravity = np.asarray(model.gravity.vector, dtype=float)
    if np.any(gravity[3:]):
        # Treating gravity as a base acceleration a_0 = -g with zero jerk gives the exact
        # τ̇ only for a uniform (purely linear) field γ: then the extra terms it puts in
        # each body's ḟ, I(γ × v) + γ ×* I v + v ×* I γ, vanish identically.  Pinocchio's
        # computeRNEADerivatives refuses an angular part too.
        raise ValueError("model.gravity must be purely linear (no angular part)")
    return joints, -gravity


def _as_batch(x, nv: int, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != nv:
        raise ValueError(f"{name} must have shape (nv, B) = ({nv}, B), got {np.shape(x)}")
    return arr


def rnea_with_derivative(
    model: pin.Model,
    Q,
    V,
    A,
    Jerk,
    *,
    chunk: int = DEFAULT_CHUNK,
    threads: int = 1,
    out: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse dynamics τ and its time derivative τ̇ for a batch of trajectory points.

    Q, V, A, Jerk: (nv, B) arrays of q [rad or m], q̇ [rad/s], q̈ [rad/s²] and
    q⃛ [rad/s³] (1-D (nv,) arrays are one configuration and give 1-D results).
    Returns ``(tau, tau_dot)``, each (nv, B): τ = RNEA(q, q̇, q̈) in N·m (N for
    prismatic joints), equal to ``pin.rnea`` including ``model.armature · q̈``
    and ``model.gravity``; τ̇ = dτ/dt along the trajectory in N·m/s (N/s), i.e.
    ∂τ/∂q q̇ + ∂τ/∂q̇ q̈ + M(q) q⃛ with M including the armature.  docs/design.md §3.

    Only 1-DoF revolute and prismatic joints (any axis) are supported; anything
    else raises ValueError.  ``chunk`` is the number of configurations processed
    together (the default was chosen by measurement on the Panda).  ``threads``
    > 1 processes chunks in that many threads; the many short numpy calls
    contend for the GIL, and on the 2-core test machine 2 threads were slower
    (1.03 vs 0.73 µs per Panda configuration), so the default is 1.  ``out``
    may give two preallocated float64 (nv, B) arrays to write into.

    Each call re-reads the model (~0.2 ms) and records its plan (~1 ms): for
    many calls on one model use :class:`BatchRneaDerivative` (as
    :func:`mpd_pin.dynamics.tracking.feedforward_tables` does, one per drive).
    """
    return BatchRneaDerivative(model, chunk=chunk, threads=threads)(Q, V, A, Jerk, out=out)


class BatchRneaDerivative:
    """:func:`rnea_with_derivative` for one model, reusable across calls.

    Reads the model once, at construction (later changes to the model, e.g.
    to ``model.armature``, are not seen: build a new one), and keeps the
    recorded plans and their buffers between calls.  One instance must not be
    called from several threads at once (its buffers are shared); its own
    ``threads`` option is safe.
    """

    def __init__(self, model: pin.Model, *, chunk: int = DEFAULT_CHUNK, threads: int = 1):
        if chunk < 1 or threads < 1:
            raise ValueError("chunk and threads must be >= 1")
        self._joints, self._a0 = _prepare(model)
        self.nv = model.nv
        self.chunk = int(chunk)
        self.threads = int(threads)
        self._plans: dict[int, list[_Plan]] = {}

    #: Plan sizes kept (least recently used dropped first): small batches round their size
    #: up to a multiple of 64, so a long-lived evaluator could otherwise collect up to 32
    #: sizes of buffers (~6 MB each at 2048 Panda configurations).
    MAX_PLAN_SIZES = 6

    def _get_plans(self, nb: int, workers: int) -> list[_Plan]:
        plans = self._plans.pop(nb, [])
        self._plans[nb] = plans  # now the most recently used
        while len(self._plans) > self.MAX_PLAN_SIZES:
            del self._plans[next(iter(self._plans))]
        while len(plans) < workers:
            plans.append(_Plan(self._joints, self._a0, self.nv, nb))
        return plans[:workers]

    def __call__(
        self, Q, V, A, Jerk, *, out: tuple[np.ndarray, np.ndarray] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(tau, tau_dot) of the batch, as :func:`rnea_with_derivative`."""
        nv = self.nv
        squeeze = np.ndim(Q) == 1
        Q, V, A, Jerk = (
            _as_batch(x, nv, n)
            for x, n in zip((Q, V, A, Jerk), ("Q", "V", "A", "Jerk"), strict=True)
        )
        batch = Q.shape[1]
        for x, n in zip((V, A, Jerk), ("V", "A", "Jerk"), strict=True):
            if x.shape[1] != batch:
                raise ValueError(f"{n} has batch size {x.shape[1]}, Q has {batch}")
        if out is None:
            tau = np.empty((nv, batch))
            tau_dot = np.empty((nv, batch))
        else:
            tau, tau_dot = out
            for o in (tau, tau_dot):
                if not isinstance(o, np.ndarray) or o.dtype != np.float64 or o.shape != (nv, batch):
                    raise ValueError(f"out must be two float64 arrays of shape ({nv}, {batch})")
        if batch:
            # small batches: round the plan size up (zero padding) so that plans are reused
            nb = min(self.chunk, -(-batch // 64) * 64)
            starts = range(0, batch, nb)
            workers = min(self.threads, len(starts))
            plans = self._get_plans(nb, workers)

            def work(i: int) -> None:
                for start in starts[i::workers]:
                    plans[i].run(Q, V, A, Jerk, tau, tau_dot, start)

            if workers == 1:
                work(0)
            else:
                with ThreadPoolExecutor(workers) as pool:
                    for done in [pool.submit(work, i) for i in range(workers)]:
                        done.result()
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
    if q.size == 0 or not np.abs(q).max() < _TRIG_MAX:  # (also NaN)
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


# Internal row order of a 6-vector: (u_x, ω_x, u_y, ω_y, u_z, ω_z), so that the pairs
# a rotation about z or a cross product with e_z mixes are adjacent rows.
_PERM = np.array([0, 3, 1, 4, 2, 5])  # internal row r holds Pinocchio component _PERM[r]
_ROW = np.argsort(_PERM)  # Pinocchio component i sits in internal row _ROW[i]
_N_EXTRA = _N_MONO  # rows after the 6 motion rows of the a- and j-blocks


# OpenBLAS multithreads a GEMM above about m·n·k = 2^18; for these skinny products
# the extra thread only adds synchronisation (and, on a busy machine, spin-waits
# that cost far more than the product).  Keep every call below that size.
_GEMM_MAX_MNK = 1 << 18


class _Plan:
    """Fixed buffers for ``nb`` configurations and the recorded sequence of numpy calls.

    All intermediate arrays are views into buffers allocated once, so the whole
    chunk computation is a list of (function, arguments) replayed per chunk:
    Python only dispatches, it never slices or allocates inside the loop.  The
    operands are laid out so that almost every call works on contiguous blocks
    of the same shape (numpy's fast path).
    """

    def __init__(self, joints: list[_Joint], a0: np.ndarray, nv: int, nb: int):
        self.nb = nb
        self.tape: list[tuple] = []
        nj = len(joints)
        z = np.zeros  # zero-filled: padding columns of a last, short chunk stay finite
        self.inputs = z((4, nv, nb))  # q, q̇, q̈, q⃛
        self.outputs = z((2, nv, nb))  # τ, τ̇
        self.trig = z((5, nv, nb))  # cos q, sin q, 3 scratch rows for _sincos
        self.pairs = z((4, nv, 2, nb))  # cos q, sin q, q̇, q̈ of each joint, on 2 rows each
        self.forces = z((nj, 2, 6, nb))  # per body: (F, Ḟ) x 6 internal rows
        self.scratch = z((8, nb))
        self.xf_out = z((2, 6, nb))
        # motion buffers (blocks v, a, j) x (6 motion rows + 12 extra rows); a body's is
        # recycled once its last child has read it
        last_child = [0] * (nj + 1)
        for k, jt in enumerate(joints):
            last_child[jt.parent] = k + 1
        live: set[int] = set()
        peak = 0
        for body in range(1, nj + 1):
            live.add(body)
            peak = max(peak, len(live))
            live = {b for b in live if last_child[b] > body}
        self.motion = z((peak, 3, 6 + _N_EXTRA, nb))
        free = list(range(peak))
        owner: dict[int, int] = {}
        a0p = a0[_PERM]
        for k, jt in enumerate(joints):
            body = k + 1
            owner[body] = free.pop()
            parent = None
            if jt.parent:
                parent = self.motion[owner[jt.parent]]
                if last_child[jt.parent] == body:
                    free.append(owner.pop(jt.parent))
            self._forward(k, jt, a0p, parent, self.motion[owner[body]])
            if last_child[body] == 0:
                free.append(owner.pop(body))
        for k in range(nj - 1, -1, -1):
            self._backward(k, joints[k])

    # ---------------------------------------------------------------- recording
    def _do(self, fn, *args) -> None:
        self.tape.append((fn, args))

    def _gemm(self, mat: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
        """out = mat @ x (x, out: stacks of matrices), in column blocks keeping BLAS 1-threaded."""
        step = max(256, _GEMM_MAX_MNK // mat.size)
        for c0 in range(0, x.shape[-1], step):
            self._do(np.matmul, mat, x[..., c0 : c0 + step], out[..., c0 : c0 + step])

    @staticmethod
    def _internal(mat: np.ndarray) -> np.ndarray:
        out = np.array(mat)
        out[:6] = out[_PERM]
        out[:, :6] = out[:, _PERM]
        return out

    def _forward(self, k: int, jt: _Joint, a0p: np.ndarray, parent, w: np.ndarray) -> None:
        """Record v, a, j of body k (internal frame), then its f and ḟ."""
        do = self._do
        iv = jt.iv
        q, qd, qdd, qddd = self.inputs[:, iv]
        c2, s2, w2, wd2 = self.pairs[:, iv]
        sc = self.scratch
        t2a, t2b, t2c = sc[0:2], sc[2:4], sc[4:6]
        if parent is None:
            self._root_motion(jt, self._internal(jt.xm) @ a0p, w, q, qd, qdd, qddd)
        else:
            self._gemm(self._internal(jt.xm), parent[:, :6], w[:, :6])
            if jt.revolute:
                # into the body frame, Rz(q)^T: x' = c x + s y,  y' = c y - s x
                for b in range(3):
                    x, y = w[b, 0:2], w[b, 2:4]  # (u_x, ω_x) and (u_y, ω_y)
                    do(np.multiply, x, s2, t2a)
                    do(np.multiply, x, c2, x)
                    do(np.multiply, y, s2, t2b)
                    do(np.add, x, t2b, x)
                    do(np.multiply, y, c2, y)
                    do(np.subtract, y, t2a, y)
                # s = q̇ e_ωz:  m × s = q̇ (m_y, -m_x, 0) on both the linear and angular pair;
                # a += q̇ ⊥v;  j += q̇ ⊥(a_before + a_after) + q̈ ⊥v
                vx, vy, ax, ay, jx, jy = (w[b, r : r + 2] for b in range(3) for r in (0, 2))
                do(np.multiply, vx, w2, t2a)
                do(np.multiply, vy, w2, t2b)
                do(np.add, ay, ay, t2c)
                do(np.subtract, t2c, t2a, t2c)
                do(np.multiply, t2c, w2, t2c)
                do(np.add, jx, t2c, jx)
                do(np.multiply, vy, wd2, t2c)
                do(np.add, jx, t2c, jx)
                do(np.add, ax, ax, t2c)
                do(np.add, t2c, t2b, t2c)
                do(np.multiply, t2c, w2, t2c)
                do(np.subtract, jy, t2c, jy)
                do(np.multiply, vx, wd2, t2c)
                do(np.subtract, jy, t2c, jy)
                do(np.add, ax, t2b, ax)
                do(np.subtract, ay, t2a, ay)
                for b, rate in enumerate((qd, qdd, qddd)):
                    do(np.add, w[b, 5], rate, w[b, 5])
            else:
                t1 = t2a[0]
                for b in range(3):  # shift by -q e_z: u' = u + q (ω_y, -ω_x, 0)
                    do(np.multiply, w[b, 3], q, t1)
                    do(np.add, w[b, 0], t1, w[b, 0])
                    do(np.multiply, w[b, 1], q, t1)
                    do(np.subtract, w[b, 2], t1, w[b, 2])
                # s = q̇ e_uz:  m × s = q̇ (ω_y, -ω_x, 0, 0, 0, 0)
                # a += q̇ (ω_y, -ω_x, 0)(v);  j += 2 q̇ (α_y, -α_x, 0) + q̈ (ω_y, -ω_x, 0)
                v, a, j = w[0], w[1], w[2]
                for dst, op, terms in (
                    (j[0], np.add, ((a[3], qd), (a[3], qd), (v[3], qdd))),
                    (j[2], np.subtract, ((a[1], qd), (a[1], qd), (v[1], qdd))),
                    (a[0], np.add, ((v[3], qd),)),
                    (a[2], np.subtract, ((v[1], qd),)),
                ):
                    for src, rate in terms:
                        do(np.multiply, src, rate, t1)
                        do(op, dst, t1, dst)
                for b, rate in enumerate((qd, qdd, qddd)):
                    do(np.add, w[b, 4], rate, w[b, 4])
        # f = [I|Q] [a; monomials(v)],  ḟ = [I|Q] [j; d/dt monomials(v)]: one stacked product
        # The monomials' rows are not evenly spaced in the internal order: 1-D products
        # (numpy's fast path) beat strided multi-row calls here.
        v, a = w[0], w[1]
        mono, dmono, tmp = w[1, 6:], w[2, 6:], w[0, 6]
        for row, (ia, ib) in enumerate(_MONOMIALS):
            ra, rb = _ROW[ia], _ROW[ib]
            do(np.multiply, v[ra], v[rb], mono[row])
            if ia == ib:  # d/dt ω_k² = 2 α_k ω_k
                do(np.add, a[ra], a[ra], tmp)
                do(np.multiply, tmp, v[ra], dmono[row])
            else:
                do(np.multiply, a[ra], v[rb], dmono[row])
                do(np.multiply, v[ra], a[rb], tmp)
                do(np.add, dmono[row], tmp, dmono[row])
        self._gemm(self._internal(jt.lf), w[1:3], self.forces[k])

    def _root_motion(self, jt, ac, w, q, qd, qdd, qddd) -> None:
        """v, a, j of a body whose parent is the fixed base (v = j = 0, a = ac)."""
        do = self._do
        c, s = self.trig[0, jt.iv], self.trig[1, jt.iv]
        t1 = self.scratch[0]
        do(np.copyto, w[:, :6], 0.0)
        at, j = w[1], w[2]  # the base acceleration in the body frame: ac moved by q
        if jt.revolute:
            for lo in (0, 1):  # linear, angular: rotate by Rz(q)^T
                cx, cy = ac[lo], ac[lo + 2]
                for dst, cc, cs in ((at[lo], cx, cy), (at[lo + 2], cy, -cx)):
                    if cc:
                        do(np.multiply, c, cc, dst)
                    if cs:
                        do(np.multiply, s, cs, t1)
                        do(np.add, dst, t1, dst)
                if ac[lo + 4]:
                    do(np.copyto, at[lo + 4], ac[lo + 4])
            # v = q̇ e_ωz (so v × s = 0), a = at + q̈ e_ωz, j = 2 q̇ ⊥at + q⃛ e_ωz
            do(np.copyto, w[0, 5], qd)
            do(np.add, at[5], qdd, at[5])
            for lo in (0, 1):
                do(np.multiply, at[lo + 2], qd, j[lo])
                do(np.add, j[lo], j[lo], j[lo])
                do(np.multiply, at[lo], qd, j[lo + 2])
                do(np.add, j[lo + 2], j[lo + 2], j[lo + 2])
                do(np.negative, j[lo + 2], j[lo + 2])
            do(np.copyto, j[5], qddd)
        else:
            # shift by -q e_z: u' = u + q (ω_y, -ω_x, 0); ω unchanged
            for r in range(6):
                if ac[r]:
                    do(np.copyto, at[r], ac[r])
            if ac[3]:
                do(np.multiply, q, ac[3], t1)
                do(np.add, at[0], t1, at[0])
            if ac[1]:
                do(np.multiply, q, ac[1], t1)
                do(np.subtract, at[2], t1, at[2])
            # v = q̇ e_uz, a = at + q̈ e_uz, j = 2 q̇ (α_y, -α_x, 0; 0) + q⃛ e_uz
            do(np.copyto, w[0, 4], qd)
            do(np.add, at[4], qdd, at[4])
            if ac[3]:
                do(np.multiply, qd, 2.0 * ac[3], j[0])
            if ac[1]:
                do(np.multiply, qd, -2.0 * ac[1], j[2])
            do(np.copyto, j[4], qddd)

    def _backward(self, k: int, jt: _Joint) -> None:
        """Record τ_k, τ̇_k and the transfer of (F, Ḟ) of body k to its parent."""
        do = self._do
        iv = jt.iv
        f = self.forces[k]
        tau, tau_dot = self.outputs[:, iv]
        row = 5 if jt.revolute else 4
        if jt.armature:
            qdd, qddd = self.inputs[2, iv], self.inputs[3, iv]
            do(np.multiply, qdd, jt.armature, tau)
            do(np.add, tau, f[0, row], tau)
            do(np.multiply, qddd, jt.armature, tau_dot)
            do(np.add, tau_dot, f[1, row], tau_dot)
        else:
            do(np.copyto, tau, f[0, row])
            do(np.copyto, tau_dot, f[1, row])
        if jt.parent == 0:
            return
        q, qd = self.inputs[0, iv], self.inputs[1, iv]
        c2, s2, w2, _ = self.pairs[:, iv]
        sc = self.scratch
        t2a, t2b = sc[0:2], sc[2:4]
        if jt.revolute:
            # Ḟ += s ×* F with s = q̇ e_ωz: adds q̇ (-F_y, F_x, 0) to the force and the moment
            do(np.multiply, f[0, 2:4], w2, t2a)
            do(np.subtract, f[1, 0:2], t2a, f[1, 0:2])
            do(np.multiply, f[0, 0:2], w2, t2a)
            do(np.add, f[1, 2:4], t2a, f[1, 2:4])
            # back to the joint base frame, Rz(q): x' = c x - s y,  y' = c y + s x
            for b in range(2):
                x, y = f[b, 0:2], f[b, 2:4]
                do(np.multiply, x, s2, t2a)
                do(np.multiply, x, c2, x)
                do(np.multiply, y, s2, t2b)
                do(np.subtract, x, t2b, x)
                do(np.multiply, y, c2, y)
                do(np.add, y, t2a, y)
        else:
            t1 = t2a[0]
            # Ḟ += s ×* F with s = q̇ e_uz: adds q̇ (-f_y, f_x, 0) to the moment
            do(np.multiply, f[0, 2], qd, t1)
            do(np.subtract, f[1, 1], t1, f[1, 1])
            do(np.multiply, f[0, 0], qd, t1)
            do(np.add, f[1, 3], t1, f[1, 3])
            for b in range(2):  # shift by +q e_z: n' = n + q e_z × f
                do(np.multiply, f[b, 2], q, t1)
                do(np.subtract, f[b, 1], t1, f[b, 1])
                do(np.multiply, f[b, 0], q, t1)
                do(np.add, f[b, 3], t1, f[b, 3])
        parent_f = self.forces[jt.parent - 1]
        self._gemm(self._internal(jt.xf), f, self.xf_out)
        do(np.add, parent_f, self.xf_out, parent_f)

    # ------------------------------------------------------------------ running
    def run(self, Q, V, A, Jerk, tau, tau_dot, start: int) -> None:
        """Compute columns start : start + nb (or fewer, at the end) of τ and τ̇."""
        n = min(self.nb, Q.shape[1] - start)
        cols = slice(start, start + n)
        inputs = self.inputs
        for dst, src in zip(inputs, (Q, V, A, Jerk), strict=True):
            np.copyto(dst[:, :n], src[:, cols])
        if n < self.nb:  # padding columns: keep them finite and quiet
            inputs[:, :, n:] = 0.0
        _sincos(inputs[0], self.trig[0], self.trig[1], self.trig[2:])
        np.copyto(self.pairs[0:2], self.trig[0:2, :, None, :])
        np.copyto(self.pairs[2:4], inputs[1:3, :, None, :])
        for fn, args in self.tape:
            fn(*args)
        np.copyto(tau[:, cols], self.outputs[0, :, :n])
        np.copyto(tau_dot[:, cols], self.outputs[1, :, :n])
