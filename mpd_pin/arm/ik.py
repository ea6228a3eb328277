"""Numerical position inverse kinematics (damped least squares with random restarts).

Used to turn end-effector targets of scenario files into joint configurations
(docs/design.md §7e). Which of several solutions is returned is chosen by a *seed
posture* (the solution nearest to it: the general way to pick a branch on any arm) and,
optionally, an *elbow* side (the elbow joint above or below the line from the shoulder to
the target). An unreachable target is reported with its true distance to the workspace
(a bounded least-squares minimisation of the distance, not the last iterate's residual).
For the two-link arm of paper 002 the analytic solution is in :mod:`mpd_pin.twolink`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from .model import Arm

__all__ = ["solve_position_ik", "elbow_side", "ELBOW_SIDES"]

#: Values of ``elbow``: the elbow joint's origin above (+z) or below the shoulder–target line.
ELBOW_SIDES = ("up", "down")


class _Kin:
    """Frame position and Jacobian of one arm frame (Pinocchio model and data)."""

    def __init__(self, arm: Arm, frame: str) -> None:
        self.model, self.data = arm.model, arm.model.createData()
        self.fid = self.model.getFrameId(frame)

    def position(self, q: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.fid].translation.copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, q)
        return pin.computeFrameJacobian(self.model, self.data, q, self.fid,
                                        pin.LOCAL_WORLD_ALIGNED)[:3]


def _dls(kin: _Kin, q: np.ndarray, target: np.ndarray, lo, hi, iterations: int, tol: float,
         damping: float) -> tuple[np.ndarray, float]:
    """Damped least squares from ``q``: the best iterate (clipped to the limits) and its
    residual (m)."""
    best_q, best = q.copy(), np.inf
    for step in range(iterations + 1):  # iterations steps, each result checked
        err = target - kin.position(q)
        res = float(np.linalg.norm(err))
        if res < best:
            best_q, best = q.copy(), res
        if res < tol or step == iterations:
            break
        J = kin.jacobian(q)
        q = np.clip(q + J.T @ np.linalg.solve(J @ J.T + damping * np.eye(3), err), lo, hi)
    return best_q, best


def _nearest_point(kin: _Kin, starts: Sequence[np.ndarray], target: np.ndarray, lo, hi
                   ) -> tuple[np.ndarray, float]:
    """The configuration (within the limits) whose frame is nearest to ``target``, by a
    bounded least-squares minimisation of the distance from each of ``starts``, and that
    distance (m): the distance from the target to the workspace."""
    from scipy.optimize import least_squares

    bounded = bool(np.all(hi > lo))
    best_q, best = None, np.inf
    for q0 in starts:
        q0 = np.clip(q0, lo, hi)
        if bounded:  # least_squares wants a start strictly inside the bounds
            span = hi - lo
            q0 = np.clip(q0, lo + 1e-9 * span, hi - 1e-9 * span)
        sol = least_squares(lambda q: kin.position(q) - target, q0, jac=kin.jacobian,
                            bounds=(lo, hi) if bounded else (-np.inf, np.inf),
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
        q = np.clip(sol.x, lo, hi)
        d = float(np.linalg.norm(kin.position(q) - target))
        if d < best:
            best_q, best = q, d
    return best_q, best


def elbow_side(arm: Arm, q: np.ndarray, target, elbow_joint: str | None = None) -> str | None:
    """``"up"`` or ``"down"``: where the origin of ``elbow_joint`` (default: the arm's second
    moving joint) lies at ``q`` relative to the line from the first joint's origin (the
    shoulder) to ``target`` (m) — above it (+z, the world's vertical) or below. ``None``
    when it is on the line (within 1 µm) or the arm has fewer than two joints."""
    model = arm.model
    if elbow_joint is None:
        if model.njoints < 3:
            return None
        jid = 2
    else:
        if not model.existJointName(elbow_joint):
            raise ValueError(f"arm {arm.name!r} has no joint {elbow_joint!r}")
        jid = model.getJointId(elbow_joint)
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    shoulder, elbow = data.oMi[1].translation, data.oMi[jid].translation
    line = np.asarray(target, float) - shoulder
    d = elbow - shoulder
    if np.linalg.norm(line) > 1e-12:
        u = line / np.linalg.norm(line)
        d = d - (d @ u) * u
    if abs(d[2]) < 1e-6:
        return None
    return "up" if d[2] > 0 else "down"


def _choose(arm: Arm, solutions: list[np.ndarray], target, seed_posture, elbow, elbow_joint,
            lo, hi) -> np.ndarray:
    """The solution returned: of those on the ``elbow`` side (all, without), the one nearest
    to ``seed_posture`` (rad, Euclidean), or without a seed the most interior one (farthest,
    relative to each joint's range, from every limit). ValueError if none is on that side."""
    if elbow is not None:
        sides = [elbow_side(arm, q, target, elbow_joint) for q in solutions]
        kept = [q for q, s in zip(solutions, sides, strict=True) if s == elbow]
        if not kept:
            found = ", ".join(f"{sides.count(s)} {s or 'on the line'}" for s in set(sides))
            raise ValueError(f"no collision-free IK solution with the elbow {elbow} for "
                             f"{target.tolist()} (found: {found})")
        solutions = kept
    if seed_posture is not None:
        return min(solutions, key=lambda q: float(np.linalg.norm(q - seed_posture)))
    mid, half = (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-12)
    return min(solutions, key=lambda q: float(np.max(np.abs(q - mid) / half)))


def solve_position_ik(
    arm: Arm,
    frame: str,
    target,
    *,
    world=None,
    seed: int = 0,
    seed_posture=None,
    elbow: str | None = None,
    elbow_joint: str | None = None,
    restarts: int = 50,
    iterations: int = 200,
    tol: float = 1e-6,
    damping: float = 1e-6,
) -> np.ndarray:
    """A configuration (rad) within joint limits putting ``frame`` at ``target`` (m).

    Damped least squares ``Δq = Jᵀ (J Jᵀ + λ I)⁻¹ e`` on the frame position, from
    ``seed_posture`` (rad, when given), the arm's reference posture and ``restarts`` seeded
    random starts (``seed``); when none converges, a bounded least-squares minimisation of
    the distance from the closest starts. Of the solutions found (collision-free ones only,
    with ``world``; on the ``elbow`` side, ``"up"``/``"down"``, when given — see
    :func:`elbow_side`), the one nearest to ``seed_posture`` is returned, or without a seed
    the one farthest from the joint limits (relative to each joint's range).
    Raises ValueError for an unreachable target (naming its distance to the workspace, m),
    when every solution collides, or when none is on the ``elbow`` side.
    """
    target = np.asarray(target, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ValueError(f"target must be a finite 3-vector (m), got {target.tolist()}")
    if not arm.model.existFrame(frame):
        raise ValueError(f"arm {arm.name!r} has no frame {frame!r}")
    if elbow is not None and elbow not in ELBOW_SIDES:
        raise ValueError(f"elbow must be one of {ELBOW_SIDES}, got {elbow!r}")
    lo, hi = arm.lower_limits, arm.upper_limits
    if seed_posture is not None:
        seed_posture = np.asarray(seed_posture, dtype=float)
        if seed_posture.shape != (arm.nq,):
            raise ValueError(f"seed posture must have {arm.nq} values (rad), got "
                             f"{seed_posture.tolist()}")
    checker = None
    if world is not None:
        from ..collision import CollisionChecker

        checker = CollisionChecker(arm, world)
    kin = _Kin(arm, frame)
    rng = np.random.default_rng(seed)
    starts = ([np.clip(seed_posture, lo, hi)] if seed_posture is not None else []) + [
        np.clip(arm.q_reference, lo, hi)] + [rng.uniform(lo, hi) for _ in range(restarts)]
    ends = [_dls(kin, q.copy(), target, lo, hi, iterations, tol, damping) for q in starts]
    converged = [q for q, res in ends if res < tol]
    if not converged:  # refine the closest ends: either a solution or the true distance
        closest = [q for q, _ in sorted(ends, key=lambda e: e[1])[:8]]
        q_near, dist = _nearest_point(kin, closest, target, lo, hi)
        if dist >= tol:
            near = (np.round(kin.position(q_near), 4) + 0.0).tolist()  # no -0.0
            raise ValueError(
                f"target {target.tolist()} is out of reach of frame {frame!r}: {dist:.3g} m "
                f"beyond reach (the nearest point it reaches is {near}, m)"
            )
        converged = [q_near]
    solutions = [q for q in converged if checker is None or checker.is_free(q)]
    if not solutions:
        raise ValueError(f"every IK solution found for {target.tolist()} is in collision")
    return _choose(arm, solutions, target, seed_posture, elbow, elbow_joint, lo, hi)
