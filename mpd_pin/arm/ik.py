"""Numerical position inverse kinematics (damped least squares with random restarts).

Used to turn end-effector targets of scenario files into joint configurations.
For the two-link arm of paper 002 the analytic solution is in
:mod:`mpd_pin.twolink`.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .model import Arm

__all__ = ["solve_position_ik"]


def solve_position_ik(
    arm: Arm,
    frame: str,
    target,
    *,
    world=None,
    seed: int = 0,
    restarts: int = 50,
    iterations: int = 200,
    tol: float = 1e-6,
    damping: float = 1e-6,
) -> np.ndarray:
    """A configuration (rad) within joint limits putting ``frame`` at ``target`` (m).

    Damped least squares ``Δq = Jᵀ (J Jᵀ + λ I)⁻¹ e`` on the frame position, from
    the arm's reference posture and then from seeded random starts. Of the
    solutions found (collision-free ones only, with ``world``), the one farthest
    from the joint limits (relative to each joint's range) is returned. Raises ValueError
    if no start converges to within ``tol`` m (unreachable target) or if every
    solution found collides.
    """
    target = np.asarray(target, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ValueError(f"target must be a finite 3-vector (m), got {target.tolist()}")
    if not arm.model.existFrame(frame):
        raise ValueError(f"arm {arm.name!r} has no frame {frame!r}")
    checker = None
    if world is not None:
        from ..collision import CollisionChecker

        checker = CollisionChecker(arm, world)
    model, data = arm.model, arm.model.createData()
    fid = model.getFrameId(frame)
    lo, hi = arm.lower_limits, arm.upper_limits
    rng = np.random.default_rng(seed)
    starts = [np.clip(arm.q_reference, lo, hi)] + [rng.uniform(lo, hi) for _ in range(restarts)]
    converged = 0
    best = np.inf
    solutions: list[np.ndarray] = []
    for q in starts:
        q = q.copy()
        for _ in range(iterations):
            pin.framesForwardKinematics(model, data, q)
            err = target - data.oMf[fid].translation
            if np.linalg.norm(err) < tol:
                break
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
            dq = J.T @ np.linalg.solve(J @ J.T + damping * np.eye(3), err)
            q = np.clip(q + dq, lo, hi)
        pin.framesForwardKinematics(model, data, q)
        res = float(np.linalg.norm(target - data.oMf[fid].translation))
        best = min(best, res)
        if res < tol:
            converged += 1
            if checker is None or checker.is_free(q):
                solutions.append(q)
    if solutions:
        # The most interior solution: farthest (relatively) from every joint limit.
        mid, half = (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-12)
        return min(solutions, key=lambda q: float(np.max(np.abs(q - mid) / half)))
    if converged == 0:
        closest = f"closest {best:.3g} m" if np.isfinite(best) else "no finite residual"
        raise ValueError(
            f"target {target.tolist()} is out of reach of frame {frame!r} "
            f"({closest} after {len(starts)} starts)"
        )
    raise ValueError(f"every IK solution found for {target.tolist()} is in collision")
