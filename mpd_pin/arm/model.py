"""Robot arms: a Pinocchio model plus its collision and visual geometry (docs/design.md §1–2).

``Arm`` loads any fixed-base URDF arm whose joints are revolute or prismatic
(one coordinate each, so ``nq == nv``), or a robot from example-robot-data with
its gripper joints locked. Its rigid-body terms follow paper 000 eq. (1),
``D(q) q̈ + C(q, q̇) q̇ + G(q) = τ``:

* ``D(q)`` — ``pin.crba`` (joint-space inertia, kg·m² / kg),
* ``C(q, q̇)`` — ``pin.computeCoriolisMatrix`` (Christoffel-consistent, ``Ḋ − 2C`` skew),
* ``G(q)`` — ``pin.computeGeneralizedGravity`` (N·m / N).

The model's ``armature`` is kept at zero here: motor rotor inertia belongs to the
drive (:class:`mpd_pin.Drive`), never to the arm, so it is not counted twice.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from .description import (
    check_srdf_links,
    expand_xacro,
    has_floating_joint,
    read_urdf_text,
    rename_joints_named_like_links,
    resolve_meshes,
    resolve_package_uri,
    revolute_for_continuous,
    validate_urdf,
    zero_missing_limits,
)

__all__ = ["Arm", "GRIPPER_KEYWORDS", "expand_xacro", "resolve_package_uri"]

#: Joints whose name contains one of these are locked by ``Arm.from_example_robot_data``.
GRIPPER_KEYWORDS = ("finger", "gripper", "hand_joint", "jaw")


def _lock_values(model: pin.Model, lock: Mapping[str, float], where: str) -> dict[str, float]:
    """Check ``lock`` (joint name -> value, rad or m) against ``model``: every joint
    exists, has one coordinate, and its value is finite and within its limits."""
    out: dict[str, float] = {}
    for name, value in lock.items():
        if not model.existJointName(name) or model.getJointId(name) >= model.njoints:
            movable = list(model.names)[1:]
            raise ValueError(f"cannot lock joint {name!r}: {where} has no such joint "
                             f"(joints: {movable})")
        jid = model.getJointId(name)
        idx = model.joints[jid].idx_q
        if model.joints[jid].nq != 1:
            raise ValueError(f"cannot lock joint {name!r} of {where}: not a one-coordinate joint")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"locked joint {name!r}: expected a number, got {value!r}") from None
        lo, hi = float(model.lowerPositionLimit[idx]), float(model.upperPositionLimit[idx])
        if not math.isfinite(v) or not lo - 1e-9 <= v <= hi + 1e-9:
            raise ValueError(f"locked joint {name!r} = {v:g} is outside its limits "
                             f"[{lo:g}, {hi:g}] of {where}")
        out[name] = v
    return out


def _reduce(
    full: pin.Model, geoms: list[pin.GeometryModel], q0: np.ndarray, locked: Sequence[str]
) -> tuple[pin.Model, list[pin.GeometryModel], np.ndarray]:
    """Lock the joints ``locked`` of ``full`` at ``q0`` (``pin.buildReducedModel``);
    returns the reduced model, geometry models and the kept joints' part of ``q0``."""
    ids = sorted(full.getJointId(n) for n in locked)
    if not ids:
        return full, geoms, np.asarray(q0, dtype=float).copy()
    model, reduced = pin.buildReducedModel(full, geoms, ids, q0)
    keep = [n for j, n in enumerate(full.names) if j > 0 and j not in ids]
    q_ref = np.array([q0[full.joints[full.getJointId(n)].idx_q] for n in keep], dtype=float)
    return model, list(reduced), q_ref


class _VisualModel:
    """The ``visual_model`` field of :class:`Arm`: as given, or built on first use by the
    arm's ``visual_source`` (docs/design.md §1c): loading the Panda's visual meshes took
    0.42 s of its 1.3 s, and only the replay draws them. Without either, an empty model."""

    def __set_name__(self, owner, name: str) -> None:
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return None  # the field's default
        value = obj.__dict__.get(self.slot)
        if value is None:
            source = obj.__dict__.get("visual_source")
            value = source() if source is not None else pin.GeometryModel()
            obj.__dict__[self.slot] = value
            obj.__dict__["visual_source"] = None
        return value

    def __set__(self, obj, value) -> None:
        obj.__dict__[self.slot] = value


def _visual_source(full: pin.Model, xml: str, dirs: list[str], q0: np.ndarray,
                   locked: Sequence[str]):
    """A loader of the visual geometry of URDF ``xml`` on ``full``, with the joints
    ``locked`` removed at ``q0`` as :func:`_reduce` removes them from the model."""

    def load() -> pin.GeometryModel:
        try:
            visual = pin.buildGeomFromUrdfString(full, xml, pin.GeometryType.VISUAL, None, dirs)
        except (RuntimeError, ValueError) as exc:
            raise ValueError(f"Pinocchio could not load the visual geometry: {exc}") from None
        return _reduce(full, [visual], q0, locked)[1][0]

    return load


def _erd_files(name: str) -> Any:
    """Where example-robot-data keeps robot ``name``'s files: an object with
    ``urdf_filename``, ``df_path``, ``model_path``, ``srdf_path`` and ``ref_posture``.

    Its loaders build the whole robot when made (meshes and all: 0.42 s of the 3.5 s of
    ``mpd-pin run panda``), and only their file paths are read here; for a loader with
    the library's own ``__init__`` they are computed as that ``__init__`` computes them
    (tests/test_arm.py compares every such robot's with the loader's own); a loader with
    its own ``__init__`` is made as before."""
    from types import SimpleNamespace

    from example_robot_data import robots_loader
    from example_robot_data.utils import RobotLoader, getModelPath

    cls = robots_loader.ROBOTS[name]
    if cls.__init__ is not RobotLoader.__init__ or not cls.urdf_filename or cls.sdf_filename:
        return robots_loader.loader(name)
    rel = os.path.join(cls.path, cls.urdf_subpath, cls.urdf_filename)
    model_path = cls.model_path if cls.model_path is not None else getModelPath(rel)
    srdf = (os.path.join(model_path, cls.path, cls.srdf_subpath, cls.srdf_filename)
            if cls.srdf_filename else None)
    return SimpleNamespace(urdf_filename=cls.urdf_filename,
                           df_path=os.path.join(model_path, rel), model_path=model_path,
                           srdf_path=srdf, ref_posture=cls.ref_posture)


@dataclass(eq=False)
class Arm:
    """A fixed-base arm: Pinocchio model, collision and visual geometry, joint limits.

    Build with :meth:`from_urdf` or :meth:`from_example_robot_data`. Algorithms
    take preallocated ``data`` (one per Arm) in Pinocchio's style.
    """

    model: pin.Model
    collision_model: pin.GeometryModel
    #: the visual geometry (built on first use when the arm has a ``visual_source``)
    visual_model: pin.GeometryModel | None = _VisualModel()
    name: str = "arm"
    srdf_path: str | None = None
    urdf_xml: str | None = None
    q_reference: np.ndarray | None = None
    #: joints that are ``continuous`` in the URDF: angles in [−π, π] rad, edges the shorter
    #: way round (docs/design.md §1d)
    continuous_joints: tuple[str, ...] = ()
    #: joints locked out of the model: name -> value (rad or m), as reported in result.json
    locked_joints: dict[str, float] = field(default_factory=dict)
    #: builds ``visual_model`` when it is first read (None: given, or none)
    visual_source: Callable[[], pin.GeometryModel] | None = field(default=None, repr=False)
    data: pin.Data = field(init=False, repr=False)

    def __post_init__(self) -> None:
        m = self.model
        if m.nv == 0:
            raise ValueError(f"arm {self.name!r} has no movable joint")
        if m.nq != m.nv:
            bad = [m.names[j] for j in range(1, m.njoints) if m.joints[j].nq != m.joints[j].nv]
            raise ValueError(
                f"arm {self.name!r}: joints {bad} have nq != nv (continuous, spherical or "
                "floating joints); mpd_pin needs revolute/prismatic joints with limits"
            )
        if np.any(self.model.armature != 0.0):
            raise ValueError(
                "the arm model must have zero armature; rotor inertia goes in DCMotor.J"
            )
        _drop_adjacent_pairs(m, self.collision_model)
        self.data = m.createData()
        if self.q_reference is None:
            self.q_reference = pin.neutral(m)

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_urdf(
        cls,
        path_or_xml: str | os.PathLike,
        *,
        package_dirs: Sequence[str | os.PathLike] | None = None,
        srdf_path: str | os.PathLike | None = None,
        name: str | None = None,
        strict_srdf: bool = True,
        xacro_args: Mapping[str, object] | None = None,
        lock: Mapping[str, float] | None = None,
        validate: bool = True,
    ) -> Arm:
        """Load an arm from a URDF or xacro file path, or a URDF XML string (docs/design.md §1c).

        ``validate``: parse the URDF with yourdfpy first, so that a malformed file fails
        with one clear message (False only for files known good: example-robot-data's,
        where it cost 0.3 s of ``mpd-pin run panda``).

        A path ending in ``.xacro`` is expanded in-process with ``xacro_args`` (its
        ``<xacro:arg>`` values). Every ``<mesh filename>`` is resolved before Pinocchio
        sees it (:func:`resolve_package_uri`): ``package://NAME/…`` in ``package_dirs``,
        an ancestor folder of the file named ``NAME``, or ``ROS_PACKAGE_PATH``; a missing
        mesh is a ValueError naming the URI and the folders searched.

        ``continuous`` joints are planned as revolute joints in [−π, π] rad, their edges
        the shorter way round (:attr:`continuous_joints`, :meth:`edge_target`, §1d); a
        ``<limit>`` without ``effort`` or ``velocity`` gets 0 there ("not stated", §7b);
        a URDF with a ``floating`` joint is refused.
        ``strict_srdf=False`` ignores SRDF pairs naming links the URDF lacks (as Pinocchio
        does) instead of refusing the SRDF: used for the data example-robot-data ships.

        With ``srdf_path`` the collision model gets every pair of its geometries, minus the
        SRDF's ``disable_collisions`` pairs (list adjacent links there too, as MoveIt SRDFs
        do); the checker then uses exactly these self-collision pairs. Without it there
        are no pairs and the checker uses non-adjacent links.

        ``lock`` maps joint names to values (rad or m, within the joint's limits): those
        joints are removed from the model, fixed at these values (``pin.buildReducedModel``)
        and listed in :attr:`locked_joints`.
        """
        xml, path = read_urdf_text(path_or_xml)
        dirs = [str(d) for d in (package_dirs or [])]
        if path is not None and path.suffix == ".xacro":
            xml = expand_xacro(path, xacro_args, dirs)
        elif xacro_args:
            raise ValueError("xacro_args given, but the URDF is not a .xacro file")
        where = str(path) if path is not None else "the URDF string"
        if validate:
            validate_urdf(xml, where)
        if has_floating_joint(xml):
            raise ValueError(f"URDF in {where} has a floating joint: a floating base is not an arm")
        xml, continuous = revolute_for_continuous(zero_missing_limits(xml))
        xml = resolve_meshes(xml, path, dirs)
        try:
            model = pin.buildModelFromXML(xml)
            collision = pin.buildGeomFromUrdfString(
                model, xml, pin.GeometryType.COLLISION, None, dirs
            )
        except (RuntimeError, ValueError) as exc:
            raise ValueError(f"Pinocchio could not load {where}: {exc}") from None
        if srdf_path is not None:
            srdf_path = str(srdf_path)
            if not Path(srdf_path).is_file():
                raise ValueError(f"SRDF file not found: {srdf_path!r}")
            if strict_srdf:
                check_srdf_links(srdf_path, model)
            collision.addAllCollisionPairs()
            try:
                pin.removeCollisionPairs(model, collision, srdf_path)
            except (RuntimeError, ValueError) as exc:
                raise ValueError(f"Pinocchio could not read SRDF {srdf_path!r}: {exc}") from None
        locked = _lock_values(model, lock or {}, where)
        q0 = pin.neutral(model)
        for joint, value in locked.items():
            q0[model.joints[model.getJointId(joint)].idx_q] = value
        q_ref = None
        visual = _visual_source(model, xml, dirs, q0, list(locked))
        if locked:
            model, (collision,), _ = _reduce(model, [collision], q0, list(locked))
        return cls(
            model=model,
            collision_model=collision,
            visual_source=visual,
            name=name or model.name or "arm",
            srdf_path=srdf_path,
            urdf_xml=xml,
            q_reference=q_ref,
            continuous_joints=tuple(n for n in continuous if model.existJointName(n)),
            locked_joints=locked,
        )

    @classmethod
    def from_example_robot_data(
        cls, name: str, *, lock: Sequence[str] | Mapping[str, float] | None = None
    ) -> Arm:
        """Load ``name`` from example-robot-data (no download: the data ship with the package).

        Joints whose names contain a :data:`GRIPPER_KEYWORDS` entry are locked at
        the robot's reference posture (e.g. Panda → 7 joints), plus any in ``lock``:
        joint names (locked at the reference posture) or a mapping name -> value (rad or
        m, within the limits). :attr:`locked_joints` gives every locked joint's value.
        """
        from example_robot_data import robots_loader

        if name not in robots_loader.ROBOTS:
            known = ", ".join(sorted(robots_loader.ROBOTS))
            raise ValueError(f"unknown example-robot-data robot {name!r}; known: {known}")
        loader = _erd_files(name)
        if not getattr(loader, "urdf_filename", ""):
            raise ValueError(f"example-robot-data robot {name!r} is described by SDF, not URDF")
        xml = rename_joints_named_like_links(Path(loader.df_path).read_text(encoding="utf-8"))
        if has_floating_joint(xml):
            raise ValueError(f"example-robot-data robot {name!r} is floating-base, not an arm")
        # Built from the URDF itself: its loader may add a free-flyer root (e.g. so100) that
        # the URDF does not have, and continuous joints become revolute (_revolute_for_...).
        # Rotor parameters of the SRDF are not loaded: rotor inertia belongs to the motors.
        base = cls.from_urdf(
            xml,
            package_dirs=[os.path.join(loader.model_path, "../..")],
            srdf_path=getattr(loader, "srdf_path", None),
            name=name,
            strict_srdf=False,
            validate=False,  # the package's own data, read-only and tested upstream
        )
        full = base.model
        q0 = pin.neutral(full)
        if base.srdf_path is not None:
            pin.loadReferenceConfigurations(full, base.srdf_path, False)
            if loader.ref_posture in full.referenceConfigurations:
                q0 = np.array(full.referenceConfigurations[loader.ref_posture], dtype=float)
        names = list(full.names)
        if lock is None:
            lock_at: dict[str, float | None] = {}
        elif isinstance(lock, Mapping):
            lock_at = dict(lock)
        else:  # names only: locked at the reference posture
            lock_at = dict.fromkeys([lock] if isinstance(lock, str) else lock)
        missing = set(lock_at) - set(names[1:])
        if missing:
            raise ValueError(f"cannot lock unknown joints {sorted(missing)} of {name!r}")
        given = _lock_values(full, {k: v for k, v in lock_at.items() if v is not None}, name)
        for joint, value in given.items():
            q0[full.joints[full.getJointId(joint)].idx_q] = value
        to_lock = [
            n for n in names[1:]
            if any(k in n.lower() for k in GRIPPER_KEYWORDS) or n in lock_at
        ]
        if len(to_lock) == len(names) - 1:  # nothing would move: say why, not just that
            by_name = [n for n in to_lock if n not in lock_at]
            raise ValueError(
                f"example-robot-data robot {name!r}: every joint would be locked"
                + (f", {by_name} as gripper joints (names containing one of "
                   f"{', '.join(GRIPPER_KEYWORDS)})" if by_name else "")
                + (f", {sorted(lock_at)} by lock=" if lock_at else "")
                + "; to move them load its URDF with "
                f"Arm.from_urdf({os.path.normpath(loader.df_path)!r})")
        model, (collision,), q_ref = _reduce(full, [base.collision_model], q0, to_lock)
        locked = {n: float(q0[full.joints[full.getJointId(n)].idx_q]) for n in to_lock}
        model.name = name

        def visual() -> pin.GeometryModel:  # the base's, reduced as the model is
            return _reduce(full, [base.visual_model], q0, to_lock)[1][0]

        return cls(
            model=model,
            collision_model=collision,
            visual_source=visual,
            name=name,
            srdf_path=base.srdf_path,
            urdf_xml=base.urdf_xml,  # the full URDF; with locked_joints it rebuilds model
            q_reference=q_ref,
            continuous_joints=tuple(n for n in base.continuous_joints if model.existJointName(n)),
            locked_joints=locked,
        )

    # --------------------------------------------------------------- properties
    @property
    def nq(self) -> int:
        """Number of joint coordinates (= number of velocities)."""
        return self.model.nq

    @property
    def lower_limits(self) -> np.ndarray:
        """Lower joint position limits (rad or m)."""
        return self.model.lowerPositionLimit.copy()

    @property
    def upper_limits(self) -> np.ndarray:
        """Upper joint position limits (rad or m)."""
        return self.model.upperPositionLimit.copy()

    @property
    def joint_names(self) -> list[str]:
        """Names of the movable joints, in coordinate order."""
        return list(self.model.names)[1:]

    @property
    def continuous_mask(self) -> np.ndarray:
        """(nq,) bool: True for the joints of :attr:`continuous_joints` (docs/design.md §1d)."""
        return np.array([n in self.continuous_joints for n in self.joint_names], dtype=bool)

    def edge_target(self, Q0, Q1) -> np.ndarray:
        """Where the edge ``Q0 → Q1`` ends (rad; (nq,) or (K, nq)): ``Q1``, unwrapped to
        ``Q0 + wrap(Q1 − Q0)`` on continuous joints, the shorter way round
        (:func:`mpd_pin.arm.continuous.edge_target`, docs/design.md §1d)."""
        from .continuous import edge_target

        return edge_target(Q0, Q1, self.continuous_mask if self.continuous_joints else None)

    def fingerprint(self) -> str:
        """SHA-256 of everything that determines dynamics and collision geometry.

        Joint placements, types, axes and limits (position, velocity, effort), link
        inertias, gravity, and the
        collision objects (names, parents, placements, geometry type and size, mesh
        scale, and the SHA-256 of each mesh file's bytes — not its path, so moving
        the files keeps the fingerprint), and the collision pairs.
        """
        h = hashlib.sha256()
        m = self.model
        h.update(repr((m.nq, m.nv, list(m.names), list(m.parents))).encode())
        for j in range(1, m.njoints):
            h.update(m.joints[j].shortname().encode())
            if "Unaligned" in m.joints[j].shortname():  # the axis is not in the name
                h.update(np.asarray(m.joints[j].extract().axis, dtype=float).tobytes())
            h.update(np.asarray(m.jointPlacements[j].homogeneous).tobytes())
            ine = m.inertias[j]
            h.update(np.array([ine.mass, *ine.lever, *ine.inertia.ravel()]).tobytes())
        for arr in (
            m.lowerPositionLimit, m.upperPositionLimit, m.velocityLimit, m.effortLimit,
            m.gravity.vector,
        ):
            h.update(np.asarray(arr, dtype=float).tobytes())
        for g in self.collision_model.geometryObjects:
            mesh = Path(g.meshPath) if g.meshPath else None
            if mesh is not None and mesh.is_file():
                source = "file:" + hashlib.sha256(mesh.read_bytes()).hexdigest()
            else:
                source = g.meshPath  # "CYLINDER", "BOX", ... for primitives
            h.update(f"{g.name}|{g.parentJoint}|{type(g.geometry).__name__}|{source}".encode())
            h.update(np.asarray(g.placement.homogeneous).tobytes())
            h.update(np.asarray(g.meshScale, dtype=float).tobytes())
            for attr in ("radius", "halfLength", "halfSide"):
                if hasattr(g.geometry, attr):
                    h.update(np.atleast_1d(np.asarray(getattr(g.geometry, attr), float)).tobytes())
        for pair in self.collision_model.collisionPairs:
            h.update(f"{pair.first},{pair.second};".encode())
        return h.hexdigest()

    # --------------------------------------------------------------- checking
    def check_configuration(self, q, what: str = "q") -> np.ndarray:
        """Return ``q`` as a float array of length nq, or raise ValueError (NaN, wrong length)."""
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.nq,):
            raise ValueError(f"{what} must have {self.nq} joint values, got shape {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} contains NaN or infinity: {arr.tolist()}")
        return arr

    def within_limits(self, q, tol: float = 1e-9) -> bool:
        """True if ``q`` lies inside the joint limits (with tolerance ``tol``)."""
        q = self.check_configuration(q)
        return bool(
            np.all(q >= self.model.lowerPositionLimit - tol)
            and np.all(q <= self.model.upperPositionLimit + tol)
        )

    # ------------------------------------------------------ rigid-body terms
    def mass_matrix(self, q) -> np.ndarray:
        """D(q), the joint-space inertia matrix (paper 000 eq. 1), via ``pin.crba``."""
        q = self.check_configuration(q)
        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T

    def coriolis_matrix(self, q, v) -> np.ndarray:
        """C(q, q̇) with C q̇ the Coriolis/centrifugal torques (N·m), Christoffel-consistent."""
        q = self.check_configuration(q)
        v = self.check_configuration(v, "v")
        return pin.computeCoriolisMatrix(self.model, self.data, q, v).copy()

    def gravity(self, q) -> np.ndarray:
        """G(q), the generalized gravity torques (N·m) for gravity along −z."""
        q = self.check_configuration(q)
        return pin.computeGeneralizedGravity(self.model, self.data, q).copy()

    def frame_position(self, q, frame: str) -> np.ndarray:
        """World position (m) of a named frame at configuration ``q``."""
        q = self.check_configuration(q)
        if not self.model.existFrame(frame):
            raise ValueError(f"arm {self.name!r} has no frame {frame!r}")
        fid = self.model.getFrameId(frame)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[fid].translation.copy()


def _drop_adjacent_pairs(model: pin.Model, collision: pin.GeometryModel) -> int:
    """Remove collision pairs of geometries on the same joint or on parent/child joints.

    Such geometries touch at their joint by construction (MoveIt's "Adjacent" rule; the
    collision checker applies the same rule when an arm has no pairs). An SRDF normally
    disables them, but not every shipped one does: example-robot-data's Kinova SRDF has no
    ``disable_collisions`` at all, and none of 2,000 random configurations was free with
    its adjacent links paired. Returns the number of pairs removed (Panda: 0, UR5: 1).
    """
    drop = []
    for pair in collision.collisionPairs:
        a = collision.geometryObjects[pair.first].parentJoint
        b = collision.geometryObjects[pair.second].parentJoint
        if a == b or model.parents[a] == b or model.parents[b] == a:
            drop.append(pin.CollisionPair(pair.first, pair.second))
    for pair in drop:
        collision.removeCollisionPair(pair)
    return len(drop)
