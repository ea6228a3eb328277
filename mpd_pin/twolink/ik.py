"""Analytic kinematics of the planar two-link arm (paper 002 §3, eqs. 1–6).

The arm moves in the vertical x–z plane (docs/design.md §1): both joints turn about
``0 -1 0``, so positive angles turn +x towards +z and the end effector is

    x = l1 cos q1 + l2 cos(q1 + q2),   z = l1 sin q1 + l2 sin(q1 + q2)      (eqs. 1–2)

(paper 002 writes them with x–y; here the paper's y is our z). Inverse
kinematics by the law of cosines, with ``atan2`` throughout (eqs. 3–6):

    D  = (x² + z² − l1² − l2²) / (2 l1 l2)                                  (eq. 3)
    s2 = ∓ √(1 − D²)                                                        (eq. 4)
    q2 = atan2(s2, D)                                                       (eq. 5)
    q1 = atan2(z, x) − atan2(l2 s2, l1 + l2 D)                              (eq. 6)

Branches. ``"up"`` (elbow up) takes the minus sign of eq. 4, so q2 ∈ [−π, 0]:
the elbow lies on the counter-clockwise side of the ray from the base to the
end effector — above it when the end effector is to the right of the base
(x > 0), as in the paper's Fig. 1(b). ``"down"`` (elbow down) takes the plus
sign, q2 ∈ [0, π]. On the outer circle r = l1 + l2 (and the inner one
r = |l1 − l2|) both branches coincide.

q1 is wrapped to [−π, π). A point is *reachable* on a branch when
|l1 − l2| ≤ r ≤ l1 + l2 (to 1e-12 relative) and both angles lie within the
joint limits; unreachable points are reported by a boolean mask and get
q = (0, 0), never NaN.

Angles in rad, lengths in m.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..arm.model import Arm

__all__ = [
    "BRANCHES",
    "IKSolution",
    "TwoLinkKinematics",
    "branch_index",
    "forward_kinematics",
    "elbow_positions",
    "inverse_kinematics",
    "link_lengths",
]

#: Branch names, in index order (index 0 = elbow up, 1 = elbow down).
BRANCHES: tuple[str, str] = ("up", "down")

_REACH_TOL = 1e-12


def branch_index(branch: str | int) -> int:
    """0 for ``"up"``, 1 for ``"down"`` (the integers 0 and 1 are accepted too)."""
    if isinstance(branch, (int, np.integer)) and not isinstance(branch, bool) and branch in (0, 1):
        return int(branch)
    if isinstance(branch, str) and branch in BRANCHES:
        return BRANCHES.index(branch)
    raise ValueError(f"branch must be 'up' or 'down' (or 0 / 1), got {branch!r}")


def _points(points: object) -> np.ndarray:
    """``points`` as a float array of shape (..., 2), finite, else ValueError."""
    try:
        p = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"points must be (x, z) pairs in m, got {points!r}") from None
    if p.ndim == 0 or p.shape[-1] != 2:
        raise ValueError(f"points must have shape (..., 2) of (x, z) in m, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points contain NaN or infinity")
    return p


def forward_kinematics(q: object, l1: float, l2: float) -> np.ndarray:
    """End-effector (x, z) (m) of joint angles ``q`` (..., 2) (rad); paper 002 eqs. 1–2."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 0 or q.shape[-1] != 2:
        raise ValueError(f"q must have shape (..., 2) (rad), got {q.shape}")
    q1 = q[..., 0]
    q12 = q1 + q[..., 1]
    return np.stack(
        [l1 * np.cos(q1) + l2 * np.cos(q12), l1 * np.sin(q1) + l2 * np.sin(q12)], axis=-1
    )


def elbow_positions(q: object, l1: float) -> np.ndarray:
    """Elbow (joint 2) position (x, z) (m) of joint angles ``q`` (..., 2) (rad)."""
    q = np.asarray(q, dtype=float)
    return np.stack([l1 * np.cos(q[..., 0]), l1 * np.sin(q[..., 0])], axis=-1)


@dataclass(frozen=True)
class IKSolution:
    """Result of :func:`inverse_kinematics` for N points on one branch.

    ``q`` (N, 2) joint angles (rad), (0, 0) where unreachable; ``reachable`` (N,)
    bool: inside the annulus |l1 − l2| ≤ r ≤ l1 + l2 and within the joint limits;
    ``in_workspace`` (N,) bool: inside the annulus (joint limits ignored).
    """

    q: np.ndarray
    reachable: np.ndarray
    in_workspace: np.ndarray


def inverse_kinematics(
    points: object,
    l1: float,
    l2: float,
    branch: str | int,
    *,
    lower: Sequence[float] | None = None,
    upper: Sequence[float] | None = None,
) -> IKSolution:
    """Joint angles (rad) putting the end effector at ``points`` (..., 2) (m); eqs. 3–6.

    ``branch`` is ``"up"`` or ``"down"`` (module docstring). ``lower``/``upper``
    are joint limits (rad); None means none. Vectorised over the leading axes.
    """
    p = _points(points)
    b = branch_index(branch)
    l1 = float(l1)
    l2 = float(l2)
    if not (l1 > 0 and l2 > 0 and math.isfinite(l1) and math.isfinite(l2)):
        raise ValueError(f"link lengths must be finite and > 0 (m), got {l1!r}, {l2!r}")
    x = p[..., 0]
    z = p[..., 1]
    D = (x * x + z * z - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)  # eq. 3
    in_ws = np.abs(D) <= 1.0 + _REACH_TOL
    Dc = np.clip(D, -1.0, 1.0)
    s2 = np.sqrt(np.maximum(1.0 - Dc * Dc, 0.0))  # eq. 4, magnitude
    s2 = -s2 if b == 0 else s2  # up: q2 <= 0; down: q2 >= 0
    if b == 0:
        s2 = np.where(s2 == 0.0, -0.0, s2)  # atan2(-0, -1) = -pi keeps q2 on the up side
    q2 = np.arctan2(s2, Dc)  # eq. 5
    q1 = np.arctan2(z, x) - np.arctan2(l2 * s2, l1 + l2 * Dc)  # eq. 6
    q1 = np.mod(q1 + np.pi, 2.0 * np.pi) - np.pi  # [-pi, pi)
    q = np.stack([q1, q2], axis=-1)
    ok = in_ws.copy()
    if lower is not None:
        lo = np.asarray(lower, dtype=float)
        ok &= np.all(q >= lo - 1e-12, axis=-1)
    if upper is not None:
        hi = np.asarray(upper, dtype=float)
        ok &= np.all(q <= hi + 1e-12, axis=-1)
    q = np.where(ok[..., None], q, 0.0)
    return IKSolution(q=q, reachable=np.asarray(ok), in_workspace=np.asarray(in_ws))


def link_lengths(arm: Arm, ee_frame: str = "ee") -> tuple[float, float]:
    """(l1, l2) (m) of a planar two-link arm, read from its Pinocchio model.

    Checks that the arm has two revolute joints about ``0 -1 0`` with link 1
    along +x of joint 1 and the end-effector frame along +x of joint 2; raises
    ValueError otherwise.
    """
    m = arm.model
    if m.nq != 2 or m.njoints != 3:
        raise ValueError(f"arm {arm.name!r} is not a two-link arm (nq = {m.nq})")
    for j in (1, 2):
        jm = m.joints[j]
        axis = None
        if jm.shortname() == "JointModelRevoluteUnaligned":
            axis = np.asarray(jm.extract().axis, dtype=float).ravel()
        elif jm.shortname() == "JointModelRY":
            axis = np.array([0.0, 1.0, 0.0])
        if axis is None or np.linalg.norm(axis - np.array([0.0, -1.0, 0.0])) > 1e-9:
            raise ValueError(
                f"arm {arm.name!r}: joint {m.names[j]!r} ({jm.shortname()}) is not a revolute "
                "joint about 0 -1 0 (the planar convention, docs/design.md §1)"
            )
    p2 = m.jointPlacements[2]
    if not np.allclose(p2.rotation, np.eye(3), atol=1e-12):
        raise ValueError(f"arm {arm.name!r}: joint 2 frame is rotated relative to link 1")
    t2 = np.asarray(p2.translation)
    if abs(t2[1]) > 1e-12 or abs(t2[2]) > 1e-12 or t2[0] <= 0:
        raise ValueError(f"arm {arm.name!r}: link 1 does not extend along +x (joint 2 at {t2})")
    if not m.existFrame(ee_frame):
        raise ValueError(f"arm {arm.name!r} has no frame {ee_frame!r}")
    fr = m.frames[m.getFrameId(ee_frame)]
    if fr.parentJoint != 2:
        raise ValueError(f"arm {arm.name!r}: frame {ee_frame!r} is not on joint 2")
    te = np.asarray(fr.placement.translation)
    if abs(te[1]) > 1e-12 or abs(te[2]) > 1e-12 or te[0] <= 0:
        raise ValueError(f"arm {arm.name!r}: link 2 does not extend along +x (ee at {te})")
    return float(t2[0]), float(te[0])


class TwoLinkKinematics:
    """Kinematics of a planar two-link :class:`~mpd_pin.arm.Arm` (paper 002 eqs. 1–6).

    Link lengths and joint limits come from the Pinocchio model
    (:func:`link_lengths`). ``fk`` and ``ik`` are vectorised numpy;
    :meth:`pinocchio_fk` is Pinocchio's own forward kinematics, for checks.
    """

    def __init__(self, arm: Arm, ee_frame: str = "ee") -> None:
        self.arm = arm
        self.ee_frame = ee_frame
        self.l1, self.l2 = link_lengths(arm, ee_frame)
        self.lower = np.asarray(arm.model.lowerPositionLimit, dtype=float).copy()
        self.upper = np.asarray(arm.model.upperPositionLimit, dtype=float).copy()

    @property
    def reach(self) -> tuple[float, float]:
        """Inner and outer radius (m) of the reachable annulus."""
        return abs(self.l1 - self.l2), self.l1 + self.l2

    def fk(self, q: object) -> np.ndarray:
        """End-effector (x, z) (m) of ``q`` (..., 2) (rad), eqs. 1–2."""
        return forward_kinematics(q, self.l1, self.l2)

    def elbow(self, q: object) -> np.ndarray:
        """Elbow (x, z) (m) of ``q`` (..., 2) (rad)."""
        return elbow_positions(q, self.l1)

    def ik(self, points: object, branch: str | int) -> IKSolution:
        """Joint angles (rad) for ``points`` (..., 2) (m) on ``branch``, eqs. 3–6."""
        return inverse_kinematics(
            points, self.l1, self.l2, branch, lower=self.lower, upper=self.upper
        )

    def ik_point(
        self, point: Sequence[float], branch: str | int, what: str = "point"
    ) -> np.ndarray:
        """Joint angles (rad) of one point (x, z) (m); ValueError if unreachable."""
        p = _points(point)
        if p.shape != (2,):
            raise ValueError(f"{what} must be one (x, z) pair in m, got shape {p.shape}")
        sol = self.ik(p, branch)
        if not bool(sol.reachable):
            r = float(np.hypot(*p))
            lo, hi = self.reach
            why = (
                f"distance {r:.4f} m from the base is outside [{lo:.4f}, {hi:.4f}] m"
                if not bool(sol.in_workspace)
                else "the joint limits exclude it"
            )
            raise ValueError(
                f"{what} ({p[0]:.4f}, {p[1]:.4f}) m is unreachable with elbow "
                f"{BRANCHES[branch_index(branch)]}: {why}"
            )
        return sol.q.copy()

    def pinocchio_fk(self, q: object) -> np.ndarray:
        """End-effector (x, z) (m) from Pinocchio's ``framesForwardKinematics`` (one q)."""
        q = self.arm.check_configuration(q)
        model = self.arm.model
        data = self.arm.data
        pin.framesForwardKinematics(model, data, q)
        t = data.oMf[model.getFrameId(self.ee_frame)].translation
        return np.array([t[0], t[2]])
