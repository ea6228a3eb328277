"""Payloads: a rigid part carried by the arm, in its dynamics and its collision geometry.

A :class:`Payload` is plain data: a mass (kg), a centre of mass (m, in the coordinates of
the frame that carries it), an inertia about that centre (kg·m²) and an optional box size
(m). :func:`payload_arm` builds an :class:`~mpd_pin.Arm` that carries it, leaving the
given arm untouched:

* **Dynamics.** The part's spatial inertia ``Y = pin.Inertia(mass, com, I)`` is expressed
  in the frame; the frame is fixed to one joint at placement ``X`` (``frame.placement``),
  so ``model.inertias[joint] += X.act(Y)`` on a copy of the Pinocchio model (what a URDF
  with the part as a fixed link would give, up to rounding). Every dynamics term (CRBA,
  RNEA, ABA, gravity) then includes the part. The copy's model digest
  (:func:`mpd_pin.dynamics.remote.model_digest`) and :meth:`Arm.fingerprint` differ from
  the original's, so caches keyed by them keep the two apart.
* **Collision.** A part with a ``size`` is a ``coal.Box`` of that size, its axes the
  frame's, centred on the com, added to a copy of the arm's collision model on the same
  joint; a part without ``size`` has no collision shape (a point mass touches nothing).
  The box is checked against every obstacle and hazard, and against the arm's geometries
  on the joints that are neither the joint carrying it, nor that joint's parent or
  children: the carrying joint moves the hand, the fingers and the part rigidly together
  (a grasped part touches its gripper by construction), and a parent or child link meets
  the part at the joint between them (the checker's "non-adjacent" rule for links).

The frame defaults to :func:`default_payload_frame`: ``"ee"`` when the arm has that frame
(the built-in planar arms), else the model's last frame (the Panda: ``panda_hand_tcp``),
the default end-effector frame of scenario files (``ee_frame``). ``mpd_pin.arm`` itself
defines no end-effector frame.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pinocchio as pin

from ..arm.model import Arm

__all__ = [
    "Payload",
    "carried_payload",
    "default_payload_frame",
    "payload_arm",
    "payload_frame",
    "payload_model",
    "unloaded_arm",
]

#: Relative tolerance of the inertia checks (symmetry, positive semi-definiteness,
#: triangle inequality), times the largest entry of the matrix.
INERTIA_TOLERANCE = 1e-9

#: Name prefix of the payload's collision geometry in the arm's collision model.
GEOMETRY_PREFIX = "payload:"


def _number(value: Any, what: str) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{what} must be a number, got {value!r}")
    try:
        num = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(num):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return num


def _vector(value: Any, what: str, unit: str) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be 3 numbers ({unit}), got {value!r}") from None
    if arr.shape != (3,):
        raise ValueError(f"{what} must be 3 numbers ({unit}), got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite, got {arr.tolist()}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _inertia_matrix(value: Any) -> np.ndarray:
    """A 3×3 array from a 3×3 matrix or the 6 values (ixx, ixy, ixz, iyy, iyz, izz)."""
    what = "Payload.inertia"
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a 3x3 matrix or 6 numbers (kg·m²), "
                         f"got {value!r}") from None
    if arr.shape == (6,):
        xx, xy, xz, yy, yz, zz = arr
        arr = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    if arr.shape != (3, 3):
        raise ValueError(f"{what} must be a 3x3 matrix or 6 numbers (ixx, ixy, ixz, iyy, "
                         f"iyz, izz; kg·m²), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite, got {arr.tolist()}")
    tol = INERTIA_TOLERANCE * float(np.abs(arr).max())
    if np.abs(arr - arr.T).max() > tol:
        raise ValueError(f"{what} must be symmetric, got {arr.tolist()}")
    arr = 0.5 * (arr + arr.T)
    moments = np.linalg.eigvalsh(arr)  # ascending
    if moments[0] < -tol:
        raise ValueError(f"{what} must be positive semi-definite, got principal moments "
                         f"{moments.tolist()} kg·m²")
    if moments[0] + moments[1] < moments[2] - tol:
        raise ValueError(f"{what} violates the triangle inequality: principal moments "
                         f"{moments.tolist()} kg·m² (each must be at most the sum of the "
                         "other two)")
    return arr


def box_inertia(mass: float, size: Sequence[float]) -> np.ndarray:
    """Inertia (kg·m²) of a uniform solid box of ``mass`` (kg) and side lengths ``size``
    (m) about its centre, in its own axes: ``m/12 · diag(b² + c², a² + c², a² + b²)``."""
    a, b, c = (float(s) for s in size)
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


@dataclass(frozen=True)
class Payload:
    """A rigid part carried by the arm (docs/design.md, "Payloads").

    Parameters
    ----------
    mass: kg, finite and > 0.
    com: centre of mass (m), in the coordinates of ``frame``.
    inertia: inertia about the com (kg·m², frame axes): a symmetric positive
        semi-definite 3×3 matrix satisfying the triangle inequality, or its 6 values
        ``(ixx, ixy, ixz, iyy, iyz, izz)`` (URDF order). None: that of a uniform solid box
        of ``size``; without ``size`` either, a point mass (zero inertia).
    size: full side lengths (m, > 0) of the part's box along the frame's axes, centred
        on the com, or one number for a cube. It is the part's collision shape; None:
        the part has no collision shape (it is checked against nothing).
    frame: name of the arm frame that carries the part; None: the arm's end-effector
        frame (:func:`default_payload_frame`). It must exist and move with a joint.
    name: names the part in collision messages ("payload 'name'").

    A bad field raises one ValueError naming it (``Payload.mass`` …); the frame is
    checked when the part is put on an arm (:meth:`mpd_pin.Drive.with_payload`,
    ``CollisionChecker(..., payload=)``).
    """

    mass: float
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[tuple[float, float, float], ...] | None = None
    size: tuple[float, float, float] | None = None
    frame: str | None = None
    name: str = "payload"

    def __post_init__(self) -> None:
        mass = _number(self.mass, "Payload.mass")
        if mass <= 0.0:
            raise ValueError(f"Payload.mass must be > 0 (kg), got {self.mass!r}")
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "com", _vector(self.com, "Payload.com", "m"))
        if self.size is not None:
            size = self.size
            if np.ndim(size) == 0:
                size = (size, size, size)
            size = _vector(size, "Payload.size", "m")
            if min(size) <= 0.0:
                raise ValueError(f"Payload.size must be > 0 along every axis (m), got "
                                 f"{list(size)}")
            object.__setattr__(self, "size", size)
        if self.inertia is not None:
            I = _inertia_matrix(self.inertia)  # noqa: E741 - the usual symbol
            object.__setattr__(self, "inertia", tuple(tuple(map(float, row)) for row in I))
        if self.frame is not None and (not isinstance(self.frame, str) or not self.frame):
            raise ValueError(f"Payload.frame must be a frame name or None, got {self.frame!r}")
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Payload.name must be a non-empty string, got {self.name!r}")

    @property
    def inertia_matrix(self) -> np.ndarray:
        """The 3×3 inertia (kg·m²) about the com in the frame's axes: ``inertia``, else the
        solid box of ``size``, else zero (a point mass)."""
        if self.inertia is not None:
            return np.array(self.inertia, dtype=float)
        if self.size is not None:
            return box_inertia(self.mass, self.size)
        return np.zeros((3, 3))

    def spatial_inertia(self) -> pin.Inertia:
        """The part's spatial inertia in the carrying frame's coordinates."""
        return pin.Inertia(self.mass, np.array(self.com), self.inertia_matrix)

    def describe(self) -> dict[str, Any]:
        """Plain data (JSON friendly): mass (kg), com (m), inertia (kg·m², 3×3 about the
        com), size (m or None), frame (None: the arm's end-effector frame) and name."""
        return {
            "mass": self.mass,
            "com": list(self.com),
            "inertia": self.inertia_matrix.tolist(),
            "size": None if self.size is None else list(self.size),
            "frame": self.frame,
            "name": self.name,
        }


# ------------------------------------------------------------------------- frames
def default_payload_frame(arm: Arm) -> str:
    """The frame a payload without ``frame`` rides on: ``"ee"`` if the arm has one, else
    the model's last frame (the default ``ee_frame`` of scenario files)."""
    if arm.model.existFrame("ee"):
        return "ee"
    return arm.model.frames[len(arm.model.frames) - 1].name


def payload_frame(arm: Arm, part: Payload) -> int:
    """Index of the frame carrying ``part`` on ``arm``; ValueError naming ``Payload.frame``
    if there is no such frame or it does not move (fixed to the base)."""
    name = part.frame if part.frame is not None else default_payload_frame(arm)
    model = arm.model
    if not model.existFrame(name):
        import difflib

        names = [f.name for f in model.frames]
        near = difflib.get_close_matches(name, names, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else f" (frames: {', '.join(names)})"
        raise ValueError(f"Payload.frame: arm {arm.name!r} has no frame {name!r}{hint}")
    fid = model.getFrameId(name)
    if model.frames[fid].parentJoint == 0:
        raise ValueError(f"Payload.frame: frame {name!r} of arm {arm.name!r} is fixed to the "
                         "base (no joint moves it); carry the part on a moving frame")
    return fid


# ------------------------------------------------------------------------ applying
def payload_model(model: pin.Model, part: Payload, frame_id: int) -> pin.Model:
    """A deep copy of ``model`` whose joint carrying frame ``frame_id`` also carries
    ``part``: ``inertias[joint] += frame.placement.act(part.spatial_inertia())``."""
    out = model.copy()
    frame = out.frames[frame_id]
    joint = frame.parentJoint
    out.inertias[joint] = out.inertias[joint] + frame.placement.act(part.spatial_inertia())
    return out


def _payload_collision_model(arm: Arm, model: pin.Model, part: Payload,
                             frame_id: int) -> pin.GeometryModel:
    """A copy of the arm's collision model with the part's box on its joint (none without
    ``size``), and, if the arm lists its self-collision pairs, the box paired with every
    geometry on a joint that is not the carrying joint, its parent or one of its children."""
    cm = arm.collision_model.copy()
    if part.size is None:
        return cm
    import coal

    frame = model.frames[frame_id]
    joint = int(frame.parentJoint)
    placement = frame.placement * pin.SE3(np.eye(3), np.array(part.com))
    box = coal.Box(*part.size)
    box.computeLocalAABB()
    go = pin.GeometryObject(f"{GEOMETRY_PREFIX}{part.name}", joint, int(frame_id), placement, box)
    go.meshPath = "BOX"  # as Pinocchio's URDF parser names primitive boxes
    others = list(cm.geometryObjects)
    paired = len(cm.collisionPairs) > 0
    gid = cm.addGeometryObject(go)
    if paired:
        parents = list(model.parents)
        for i, other in enumerate(others):
            j = int(other.parentJoint)
            if j == joint or parents[joint] == j or parents[j] == joint:
                continue  # (Arm.__post_init__ would drop such an adjacent pair too)
            cm.addCollisionPair(pin.CollisionPair(i, gid))
    return cm


#: Arms built by :func:`payload_arm`: the carrying arm -> (the arm without it, the part).
_CARRIED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def carried_payload(arm: Arm) -> Payload | None:
    """The payload ``arm`` carries (built by :func:`payload_arm`), or None."""
    entry = _CARRIED.get(arm)
    return None if entry is None else entry[1]


def unloaded_arm(arm: Arm) -> Arm:
    """The arm ``arm`` was built from by :func:`payload_arm` (``arm`` itself if it carries
    no payload)."""
    entry = _CARRIED.get(arm)
    return arm if entry is None else entry[0]


def payload_arm(arm: Arm, part: Payload | None) -> Arm:
    """A new :class:`~mpd_pin.Arm` carrying ``part`` (module docstring); ``arm`` is left
    untouched. A payload replaces the one ``arm`` may carry (it is put on the arm without
    it); ``part=None`` gives the arm without payload.

    The new arm has a deep copy of the model with the part's inertia, and a copy of the
    collision model with the part's box (if it has a ``size``); name, visual model, URDF
    text (the arm's, without the part), SRDF path, reference posture, continuous and
    locked joints are the arm's.
    """
    base = unloaded_arm(arm)
    if part is None:
        return base
    if not isinstance(part, Payload):
        raise ValueError(f"payload must be an mpd_pin.Payload or None, got {part!r}")
    fid = payload_frame(base, part)
    model = payload_model(base.model, part, fid)
    loaded = replace(
        base,
        model=model,
        collision_model=_payload_collision_model(base, model, part, fid),
        q_reference=None if base.q_reference is None else np.array(base.q_reference),
        locked_joints=dict(base.locked_joints),
    )
    _CARRIED[loaded] = (base, part)
    return loaded
