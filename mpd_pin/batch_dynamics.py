"""Batched inverse dynamics with its exact time derivative (DESIGN §3).

The feed-forward voltage of DESIGN §3 needs, along a reference trajectory,

    τ(t)  = RNEA(q, q̇, q̈)                                   [N·m or N]
    τ̇(t)  = ∂τ/∂q · q̇ + ∂τ/∂q̇ · q̈ + M(q) · q⃛                [N·m/s or N/s]

for very many time points at once.  :func:`rnea_with_derivative` evaluates both
with a third-order recursive Newton–Euler algorithm written in spatial algebra
(Featherstone, body coordinates), vectorised with numpy over the batch; the
Python loop runs only over the joints.

Notation (Pinocchio's ordering, linear part first): a motion vector is
``(v, ω)``, a force ``(f, n)``.  For body i with parent λ(i), motion subspace
S_i and X_i the motion transform parent → child (which depends on q_i only):

    v_i = X_i v_λ + S_i q̇_i
    a_i = X_i a_λ + S_i q̈_i + v_i × S_i q̇_i
    j_i = X_i j_λ + (X_i a_λ + a_i) × S_i q̇_i + v_i × S_i q̈_i + S_i q⃛_i

using Ẋ_i = −(S_i q̇_i)× X_i.  Gravity is a base acceleration a_0 = −g with
zero base jerk.  Body forces and their derivatives (I_i constant in body frame):

    f_i = I_i a_i + v_i ×* I_i v_i
    ḟ_i = I_i j_i + a_i ×* I_i v_i + v_i ×* I_i a_i

Backward pass: F_i = f_i + Σ_c X_cᵀ F_c and, since d/dt X_cᵀ = X_cᵀ (S_c q̇_c)×*,
Ḟ_i = ḟ_i + Σ_c X_cᵀ (Ḟ_c + S_c q̇_c ×* F_c).  Finally τ_i = S_iᵀ F_i +
armature_i q̈_i and τ̇_i = S_iᵀ Ḟ_i + armature_i q⃛_i, which is exactly what
``pin.rnea`` (it adds ``model.armature · a``) and the derivative of it give.

Implementation notes.  Every 1-DoF joint is rewritten as a joint about (or
along) the local z axis by giving each body an internal frame rotated by a
constant R_a with R_a e_z = axis; inertias and joint placements are expressed
in those frames once.  The parent → child transform is then a constant 6×6
matrix (applied with one BLAS call to v, a and j together) followed by a
rotation about z (revolute) or a shift along z (prismatic), done with
component arithmetic on the batch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

__all__ = ["rnea_with_derivative"]

DEFAULT_CHUNK = 1024

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


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def _frame_with_z(axis: np.ndarray) -> np.ndarray:
    """A rotation R with R @ e_z == axis (axis a unit vector)."""
    exact = {
        (0.0, 0.0, 1.0): np.eye(3),
        (1.0, 0.0, 0.0): np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        (0.0, 1.0, 0.0): np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
    }
    key = tuple(float(x) for x in axis)
    if key in exact:
        return exact[key]
    if key in {tuple(-x for x in k) for k in exact}:
        r = exact[tuple(-x + 0.0 for x in key)]
        return r @ np.diag([1.0, -1.0, -1.0])  # rotate by π about x: e_z -> -e_z
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.column_stack([e1, e2, axis])


@dataclass
class _Joint:
    parent: int  # index into the joint list (0 = universe)
    revolute: bool
    iv: int  # velocity index
    armature: float
    xm: np.ndarray  # (6, 6) motion transform parent frame -> joint base frame
    xf: np.ndarray  # (6, 6) force transform joint base frame -> parent frame (= xm.T)
    inertia: np.ndarray  # (6, 6) spatial inertia in the body's internal frame


def _joint_axis(joint) -> tuple[bool, np.ndarray]:
    name = joint.shortname()
    if name in _REVOLUTE_AXES:
        return True, np.array(_REVOLUTE_AXES[name])
    if name in _PRISMATIC_AXES:
        return False, np.array(_PRISMATIC_AXES[name])
    if name in ("JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned"):
        axis = np.array(joint.extract().axis, dtype=float)
        return name == "JointModelRevoluteUnaligned", axis / np.linalg.norm(axis)
    raise ValueError(
        f"rnea_with_derivative supports only 1-DoF revolute/prismatic joints with nq == nv "
        f"(JointModelR{{X,Y,Z}}, JointModelP{{X,Y,Z}}, JointModelRevoluteUnaligned, "
        f"JointModelPrismaticUnaligned); joint {joint.id} is {name} "
        f"(nq={joint.nq}, nv={joint.nv})"
    )


def _prepare(model: pin.Model) -> tuple[list[_Joint], np.ndarray]:
    """Constant per-joint data in internal (joint-axis = z) frames; base acceleration."""
    if model.nq != model.nv:
        raise ValueError(f"rnea_with_derivative needs nq == nv, got nq={model.nq}, nv={model.nv}")
    frames = [np.eye(3)]  # R_a of each joint's internal frame w.r.t. its body frame
    joints: list[_Joint] = []
    for i in range(1, model.njoints):
        jm = model.joints[i]
        revolute, axis = _joint_axis(jm)
        ra = _frame_with_z(axis)
        frames.append(ra)
        parent = model.parents[i]
        pl = model.jointPlacements[i]
        rp = frames[parent]
        rt = rp.T @ pl.rotation @ ra
        pt = rp.T @ pl.translation
        xm = np.zeros((6, 6))
        xm[:3, :3] = rt.T
        xm[:3, 3:] = -rt.T @ _skew(pt)
        xm[3:, 3:] = rt.T
        inr = model.inertias[i]
        m = inr.mass
        c = ra.T @ inr.lever
        ic = ra.T @ inr.inertia @ ra
        cx = _skew(c)
        i6 = np.zeros((6, 6))
        i6[:3, :3] = m * np.eye(3)
        i6[:3, 3:] = -m * cx
        i6[3:, :3] = m * cx
        i6[3:, 3:] = ic - m * cx @ cx
        joints.append(
            _Joint(
                parent=parent,
                revolute=revolute,
                iv=jm.idx_v,
                armature=float(model.armature[jm.idx_v]),
                xm=xm,
                xf=np.ascontiguousarray(xm.T),
                inertia=i6,
            )
        )
    _check_kinematics(model, joints, frames)
    a0 = -np.asarray(model.gravity.vector, dtype=float)
    return joints, a0


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
    return arr


def rnea_with_derivative(
    model: pin.Model, Q, V, A, Jerk, *, chunk: int = DEFAULT_CHUNK
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse dynamics τ and its time derivative τ̇ for a batch of trajectory points.

    Q, V, A, Jerk: (nv, B) arrays of q [rad or m], q̇ [rad/s], q̈ [rad/s²] and
    q⃛ [rad/s³] (1-D (nv,) arrays are treated as B = 1 and give 1-D results).
    Returns ``(tau, tau_dot)``, each (nv, B): τ = RNEA(q, q̇, q̈) in N·m (N for
    prismatic joints), identical to ``pin.rnea`` including ``model.armature · q̈``
    and ``model.gravity``; τ̇ = dτ/dt along the trajectory in N·m/s, i.e.
    ∂τ/∂q q̇ + ∂τ/∂q̇ q̈ + M(q) q⃛ (M including armature).  See DESIGN §3.

    Only 1-DoF revolute and prismatic joints (any axis) are supported; other
    joint types raise ValueError.  ``chunk`` is the number of configurations
    processed together (sized so the temporaries stay in cache).
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
    tau = np.empty((nv, batch))
    tau_dot = np.empty((nv, batch))
    for start in range(0, batch, chunk):
        sl = slice(start, min(start + chunk, batch))
        _rnea3_chunk(joints, a0, Q[:, sl], V[:, sl], A[:, sl], Jerk[:, sl], tau[:, sl], tau_dot[:, sl])
    if squeeze:
        return tau[:, 0], tau_dot[:, 0]
    return tau, tau_dot


def _rnea3_chunk(joints, a0, q, qd, qdd, qddd, tau, tau_dot) -> None:
    nb = q.shape[1]
    nj = len(joints)
    w_all = np.empty((nj, 6, 3, nb))  # per body: v, a, j in the internal frame
    f_all = np.empty((nj, 6, 2, nb))  # per body: F, Ḟ
    cq_all = np.empty((nj, nb))
    sq_all = np.empty((nj, nb))
    tmp = np.empty((2, nb))
    tmp2 = np.empty((2, nb))
    for k, jt in enumerate(joints):
        w = w_all[k]
        iv = jt.iv
        qi, wi, wdi, wddi = q[iv], qd[iv], qdd[iv], qddd[iv]
        # transform parent's (v, a, j) into the joint base frame
        if jt.parent == 0:
            w[:, 0] = 0.0
            w[:, 1] = (jt.xm @ a0)[:, None]
            w[:, 2] = 0.0
        else:
            np.matmul(jt.xm, w_all[jt.parent - 1].reshape(6, 3 * nb), out=w.reshape(6, 3 * nb))
        w4 = w.reshape(2, 3, 3, nb)  # [lin/ang, xyz, v/a/j, batch]
        x = w4[:, 0]  # (2, 3, nb): x components of lin/ang of v, a, j
        y = w4[:, 1]
        if jt.revolute:
            c = np.cos(qi, out=cq_all[k])
            s = np.sin(qi, out=sq_all[k])
            # rotate by Rz(q)^T: x' = c x + s y, y' = -s x + c y
            xs = x * s
            x *= c
            x += y * s
            y *= c
            y -= xs
            vx, vy = x[:, 0], y[:, 0]
            ax, ay = x[:, 1], y[:, 1]
            jx, jy = x[:, 2], y[:, 2]
            # jerk: w (2 ⊥(at) - w ⊥⊥... ) see module docstring, pairs (0,3) and (1,4)
            np.multiply(ay, 2.0, out=tmp)
            tmp -= vx * wi
            tmp *= wi
            tmp += vy * wdi
            jx += tmp
            np.multiply(ax, -2.0, out=tmp)
            tmp -= vy * wi
            tmp *= wi
            tmp -= vx * wdi
            jy += tmp
            ax += vy * wi
            ay -= vx * wi
            w[5, 0] += wi
            w[5, 1] += wdi
            w[5, 2] += wddi
        else:
            # shift by -q e_z: v' = v + q (ω1, -ω0, 0)
            cq_all[k] = qi
            x[0] += y[1] * qi
            y[0] -= x[1] * qi
            # velocity-product terms with s = (w e_z, 0):  x × s = w (η1, -η0, 0, 0, 0, 0)
            vwx, vwy = x[1, 0], y[1, 0]  # ω_x, ω_y of v
            awx, awy = x[1, 1], y[1, 1]
            w[0, 2] += wi * (2.0 * awy) + wdi * vwy
            w[1, 2] += -wi * (2.0 * awx) - wdi * vwx
            w[0, 1] += wi * vwy
            w[1, 1] -= wi * vwx
            w[2, 0] += wi
            w[2, 1] += wdi
            w[2, 2] += wddi
        # body force and its derivative
        h = (jt.inertia @ w.reshape(6, 3 * nb)).reshape(6, 3, nb)
        f = f_all[k]
        f[:, 0] = h[:, 1]
        f[:, 1] = h[:, 2]
        v = w[:, 0]
        a = w[:, 1]
        _add_cross_force(f[:, 0], v, h[:, 0])
        _add_cross_force(f[:, 1], a, h[:, 0])
        _add_cross_force(f[:, 1], v, h[:, 1])
    for k in range(nj - 1, -1, -1):
        jt = joints[k]
        f = f_all[k]
        iv = jt.iv
        row = 5 if jt.revolute else 2
        np.multiply(qdd[iv], jt.armature, out=tau[iv])
        tau[iv] += f[row, 0]
        np.multiply(qddd[iv], jt.armature, out=tau_dot[iv])
        tau_dot[iv] += f[row, 1]
        if jt.parent == 0:
            continue
        wi = qd[iv]
        if jt.revolute:
            f[0, 1] -= wi * f[1, 0]
            f[1, 1] += wi * f[0, 0]
            f[3, 1] -= wi * f[4, 0]
            f[4, 1] += wi * f[3, 0]
            f4 = f.reshape(2, 3, 2, f.shape[-1])
            x = f4[:, 0]
            y = f4[:, 1]
            c, s = cq_all[k], sq_all[k]
            # rotate by Rz(q): x' = c x - s y, y' = s x + c y
            xs = x * s
            x *= c
            x -= y * s
            y *= c
            y += xs
        else:
            qi = cq_all[k]
            f[3, 1] -= wi * f[1, 0]
            f[4, 1] += wi * f[0, 0]
            f[3] -= qi * f[1]
            f[4] += qi * f[0]
        fp = f_all[jt.parent - 1].reshape(6, -1)
        fp += jt.xf @ f.reshape(6, -1)


def _add_cross_force(out: np.ndarray, m: np.ndarray, h: np.ndarray) -> None:
    """out += m ×* h for motion m = (u, ω) and force h = (f, n) (rows, batch last)."""
    u0, u1, u2, w0, w1, w2 = m
    f0, f1, f2, n0, n1, n2 = h
    out[0] += w1 * f2 - w2 * f1
    out[1] += w2 * f0 - w0 * f2
    out[2] += w0 * f1 - w1 * f0
    out[3] += w1 * n2 - w2 * n1 + u1 * f2 - u2 * f1
    out[4] += w2 * n0 - w0 * n2 + u2 * f0 - u0 * f2
    out[5] += w0 * n1 - w1 * n0 + u0 * f1 - u1 * f0
