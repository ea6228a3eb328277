"""Obstacle shapes: box, cylinder, sphere, extruded convex polygon (docs/design.md §4).

Every obstacle is a frozen dataclass with a pose in the world frame: ``position``
(m) and orientation as roll-pitch-yaw ``rpy`` (rad, ``R = Rz(yaw) Ry(pitch) Rx(roll)``,
Pinocchio's convention) or, equivalently, a 3×3 ``rotation=`` matrix at
construction (stored as rpy). Shapes:

* :class:`Box` — full side lengths ``size = (sx, sy, sz)`` (m), centred on its pose;
* :class:`Cylinder` — ``radius`` and ``length`` (m) along the local z axis, centred;
* :class:`Sphere` — ``radius`` (m);
* :class:`Polygon` — a convex polygon given in the local x–z plane, extruded along
  local y over ``thickness`` (m), centred on y = 0 (the paper's triangles).

Planar arms move in the x–z plane, so planar scenes use the ``.planar(...)``
constructors: shapes centred on y = 0 and extruded across the plane (``depth``,
default 1 m, much thicker than any link). For a body symmetric about the plane
y = 0 and a link cylinder whose axis lies in that plane, overlap (and distance)
in 3-D equal overlap (and distance) of their y = 0 cross-sections, which is what
:meth:`Obstacle.section_xz` returns and what the 2-D plots show.

An obstacle with ``hidden=True`` is not known at first: :class:`World` reports it
only after :meth:`World.reveal`. :class:`Hazard` wraps a shape with a
``clearance`` (m): the zone may never be entered and may only be approached to
beyond that distance when clearance is enforced.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import InitVar, dataclass
from typing import Any, ClassVar

import numpy as np
import pinocchio as pin

__all__ = ["Box", "Cylinder", "Sphere", "Polygon", "Obstacle", "SHAPES", "geometry_object"]

_ROT_TOL = 1e-9


# --------------------------------------------------------------------- helpers
def _vec(value: Any, n: int, what: str) -> tuple[float, ...]:
    """``value`` as a tuple of ``n`` finite floats, else ValueError."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,):
        raise ValueError(f"{what} must be {n} numbers, got shape {arr.shape}: {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite (no NaN or infinity), got {arr.tolist()}")
    return tuple(float(x) + 0.0 for x in arr)  # + 0.0 turns -0.0 into 0.0


def _positive(value: Any, what: str) -> float:
    """``value`` as a finite float > 0, else ValueError."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{what} must be finite and > 0, got {value!r}")
    return x


def _rpy_from_rotation(rotation: Any) -> tuple[float, float, float]:
    """Roll-pitch-yaw (rad) of a proper rotation matrix, else ValueError."""
    try:
        R = np.asarray(rotation, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"rotation must be a 3×3 matrix, got {rotation!r}") from None
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"rotation must be a finite 3×3 matrix, got shape {R.shape}")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or abs(np.linalg.det(R) - 1.0) > 1e-6:
        raise ValueError("rotation must be orthonormal with determinant +1")
    return tuple(float(x) + 0.0 for x in pin.rpy.matrixToRpy(R))


def _planar_rpy(angle: float) -> tuple[float, float, float]:
    """rpy that turns local x by ``angle`` (rad) towards +z, i.e. about the arm axis −y."""
    a = float(angle)
    if not math.isfinite(a):
        raise ValueError(f"angle must be finite, got {angle!r}")
    return (0.0, -a + 0.0, 0.0)


def _convex_hull_section(points: np.ndarray) -> np.ndarray | None:
    """Counter-clockwise convex hull (x, z) of 2-D points, None when degenerate."""
    pts = np.unique(np.round(points, 12), axis=0)
    if len(pts) < 3:
        return None
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    hull = np.array(lower[:-1] + upper[:-1])
    return hull if len(hull) >= 3 else None


def _slice_polytope(vertices: np.ndarray, edges: Sequence[tuple[int, int]]) -> np.ndarray | None:
    """Cross-section (x, z) at world y = 0 of a convex polytope given by vertices and edges."""
    pts = []
    y = vertices[:, 1]
    for i, j in edges:
        yi, yj = y[i], y[j]
        if yi == 0.0:
            pts.append(vertices[i][[0, 2]])
        if (yi < 0.0 < yj) or (yj < 0.0 < yi):
            t = yi / (yi - yj)
            p = vertices[i] + t * (vertices[j] - vertices[i])
            pts.append(p[[0, 2]])
        if yj == 0.0:
            pts.append(vertices[j][[0, 2]])
    if len(pts) < 3:
        return None
    return _convex_hull_section(np.array(pts))


def _prism_edges(n: int) -> list[tuple[int, int]]:
    """Edges of a prism whose vertices are (bottom_k, top_k) = (2k, 2k+1)."""
    edges = []
    for k in range(n):
        edges.append((2 * k, 2 * k + 1))
        edges.append((2 * k, 2 * ((k + 1) % n)))
        edges.append((2 * k + 1, 2 * ((k + 1) % n) + 1))
    return edges


# ------------------------------------------------------------------ obstacles
class _Shape:
    """Common behaviour of obstacle shapes (mixed into the frozen dataclasses)."""

    kind: ClassVar[str] = ""
    name: str
    hidden: bool
    position: tuple[float, float, float]
    rpy: tuple[float, float, float]

    def _check_common(self, rotation: Any) -> None:
        if not isinstance(self.name, str):
            raise ValueError(f"obstacle name must be a string, got {self.name!r}")
        if not isinstance(self.hidden, (bool, np.bool_)):
            raise ValueError(f"hidden must be True or False, got {self.hidden!r}")
        object.__setattr__(self, "hidden", bool(self.hidden))
        object.__setattr__(self, "position", _vec(self.position, 3, f"{self.kind} position"))
        if rotation is not None:
            object.__setattr__(self, "rpy", _rpy_from_rotation(rotation))
        else:
            object.__setattr__(self, "rpy", _vec(self.rpy, 3, f"{self.kind} rpy"))

    # pose -----------------------------------------------------------------
    @property
    def rotation_matrix(self) -> np.ndarray:
        """Orientation as a 3×3 rotation matrix (world from local)."""
        return pin.rpy.rpyToMatrix(*self.rpy)

    @property
    def placement(self) -> pin.SE3:
        """Pose (world from local) as a Pinocchio SE3."""
        return pin.SE3(self.rotation_matrix, np.array(self.position))

    def geometry(self):  # pragma: no cover - overridden
        """The Coal collision geometry, in the local frame."""
        raise NotImplementedError

    def section_xz(self, n: int = 64) -> np.ndarray | None:
        """Cross-section with the plane y = 0 as a counter-clockwise (M, 2) array of (x, z) (m).

        Exact for boxes and polygons; cylinders are approximated by ``n``-gon
        prisms and spheres by an ``n``-gon. None when the shape misses the plane.
        """
        verts, edges = self._polytope(n)
        world = verts @ self.rotation_matrix.T + np.array(self.position)
        return _slice_polytope(world, edges)

    def _polytope(self, n: int) -> tuple[np.ndarray, list[tuple[int, int]]]:  # pragma: no cover
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON/TOML friendly) describing this obstacle."""
        out: dict[str, Any] = {"type": self.kind, "name": self.name, "hidden": self.hidden}
        out.update(self._params())
        out["position"] = list(self.position)
        if "rpy" in self.__dataclass_fields__:
            out["rpy"] = list(self.rpy)
        return out

    def _params(self) -> dict[str, Any]:  # pragma: no cover - overridden
        raise NotImplementedError


@dataclass(frozen=True)
class Box(_Shape):
    """Box with full side lengths ``size`` (m) along its local axes, centred on its pose."""

    size: tuple[float, float, float]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    hidden: bool = False
    rotation: InitVar[Any] = None
    kind: ClassVar[str] = "box"

    def __post_init__(self, rotation: Any) -> None:
        size = _vec(self.size, 3, "box size")
        if any(s <= 0.0 for s in size):
            raise ValueError(f"box size must be > 0 along every axis, got {list(size)}")
        object.__setattr__(self, "size", size)
        self._check_common(rotation)

    @classmethod
    def planar(
        cls,
        center_xz: Sequence[float],
        width: float,
        height: float,
        *,
        angle: float = 0.0,
        depth: float = 1.0,
        name: str = "",
        hidden: bool = False,
    ) -> Box:
        """Rectangle ``width`` (along x) × ``height`` (along z) (m) centred at ``center_xz``.

        ``angle`` (rad) turns the rectangle in the x–z plane the way the arm's
        joints turn (x towards +z); ``depth`` (m) is the extrusion across the plane.
        """
        cx, cz = _vec(center_xz, 2, "box center_xz")
        return cls(
            size=(width, depth, height),
            position=(cx, 0.0, cz),
            rpy=_planar_rpy(angle),
            name=name,
            hidden=hidden,
        )

    def geometry(self):
        import coal

        return coal.Box(*self.size)

    def _polytope(self, n: int):
        h = np.array(self.size) / 2.0
        verts = np.array(
            [[sx * h[0], sy * h[1], sz * h[2]]
             for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
        )
        edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
        return verts, edges

    def _params(self) -> dict[str, Any]:
        return {"size": list(self.size)}


@dataclass(frozen=True)
class Cylinder(_Shape):
    """Solid cylinder of ``radius`` and ``length`` (m) along its local z axis, centred."""

    radius: float
    length: float
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    hidden: bool = False
    rotation: InitVar[Any] = None
    kind: ClassVar[str] = "cylinder"

    def __post_init__(self, rotation: Any) -> None:
        object.__setattr__(self, "radius", _positive(self.radius, "cylinder radius"))
        object.__setattr__(self, "length", _positive(self.length, "cylinder length"))
        self._check_common(rotation)

    @classmethod
    def planar(
        cls,
        center_xz: Sequence[float],
        radius: float,
        *,
        depth: float = 1.0,
        name: str = "",
        hidden: bool = False,
    ) -> Cylinder:
        """Disc of ``radius`` (m) at ``center_xz`` in the x–z plane: a cylinder along y.

        ``depth`` (m) is its length across the plane.
        """
        cx, cz = _vec(center_xz, 2, "cylinder center_xz")
        return cls(
            radius=radius,
            length=depth,
            position=(cx, 0.0, cz),
            rpy=(math.pi / 2.0, 0.0, 0.0),
            name=name,
            hidden=hidden,
        )

    def geometry(self):
        import coal

        return coal.Cylinder(self.radius, self.length)

    def _polytope(self, n: int):
        a = 2.0 * np.pi * np.arange(n) / n
        h = self.length / 2.0
        verts = np.zeros((2 * n, 3))
        verts[0::2, 0] = verts[1::2, 0] = self.radius * np.cos(a)
        verts[0::2, 1] = verts[1::2, 1] = self.radius * np.sin(a)
        verts[0::2, 2], verts[1::2, 2] = -h, h
        return verts, _prism_edges(n)

    def _params(self) -> dict[str, Any]:
        return {"radius": self.radius, "length": self.length}


@dataclass(frozen=True)
class Sphere(_Shape):
    """Solid sphere of ``radius`` (m) centred at ``position``."""

    radius: float
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    hidden: bool = False
    kind: ClassVar[str] = "sphere"

    @property
    def rpy(self) -> tuple[float, float, float]:  # type: ignore[override]
        """A sphere has no orientation: always (0, 0, 0)."""
        return (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive(self.radius, "sphere radius"))
        if not isinstance(self.name, str):
            raise ValueError(f"obstacle name must be a string, got {self.name!r}")
        if not isinstance(self.hidden, (bool, np.bool_)):
            raise ValueError(f"hidden must be True or False, got {self.hidden!r}")
        object.__setattr__(self, "hidden", bool(self.hidden))
        object.__setattr__(self, "position", _vec(self.position, 3, "sphere position"))

    @classmethod
    def planar(
        cls, center_xz: Sequence[float], radius: float, *, name: str = "", hidden: bool = False
    ) -> Sphere:
        """Sphere of ``radius`` (m) centred at ``center_xz`` on the plane y = 0."""
        cx, cz = _vec(center_xz, 2, "sphere center_xz")
        return cls(radius=radius, position=(cx, 0.0, cz), name=name, hidden=hidden)

    def geometry(self):
        import coal

        return coal.Sphere(self.radius)

    def section_xz(self, n: int = 64) -> np.ndarray | None:
        y = self.position[1]
        if abs(y) >= self.radius:
            return None
        rho = math.sqrt(self.radius**2 - y**2)
        a = 2.0 * np.pi * np.arange(n) / n
        return np.column_stack(
            [self.position[0] + rho * np.cos(a), self.position[2] + rho * np.sin(a)]
        )

    def _params(self) -> dict[str, Any]:
        return {"radius": self.radius}


@dataclass(frozen=True)
class Polygon(_Shape):
    """Convex polygon in the local x–z plane, extruded along local y over ``thickness`` (m).

    ``vertices_xz`` are (x, z) pairs (m), at least three, strictly convex, in
    either winding; they are stored counter-clockwise (x to the right, z up).
    """

    vertices_xz: tuple[tuple[float, float], ...]
    thickness: float = 1.0
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    hidden: bool = False
    rotation: InitVar[Any] = None
    kind: ClassVar[str] = "polygon"

    def __post_init__(self, rotation: Any) -> None:
        try:
            v = np.asarray(self.vertices_xz, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"polygon vertices must be (x, z) pairs, got {self.vertices_xz!r}"
            ) from None
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ValueError(f"polygon needs at least 3 (x, z) vertices, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError("polygon vertices must be finite (no NaN or infinity)")
        edges = np.roll(v, -1, axis=0) - v
        scale = float(np.abs(v - v.mean(axis=0)).max())
        if scale == 0.0 or np.any(np.linalg.norm(edges, axis=1) <= 1e-12 * scale):
            raise ValueError("degenerate polygon: repeated vertices")
        nxt = np.roll(edges, -1, axis=0)
        cross = edges[:, 0] * nxt[:, 1] - edges[:, 1] * nxt[:, 0]
        dot = np.einsum("ij,ij->i", edges, nxt)
        area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        if abs(area2) <= 1e-12 * scale**2:
            raise ValueError("degenerate polygon: zero area (collinear vertices)")
        tol = 1e-12 * scale**2
        if np.any(np.abs(cross) <= tol):
            raise ValueError(
                "polygon must be strictly convex: three consecutive vertices are collinear"
            )
        if not (np.all(cross > 0) or np.all(cross < 0)):
            raise ValueError("polygon is not convex (its vertices turn both ways)")
        turning = float(np.sum(np.arctan2(cross, dot)))
        if abs(abs(turning) - 2.0 * math.pi) > 1e-6:
            raise ValueError("polygon is not simple (its boundary winds more than once)")
        if area2 < 0:
            v = v[::-1]
        object.__setattr__(
            self, "vertices_xz", tuple((float(x) + 0.0, float(z) + 0.0) for x, z in v)
        )
        object.__setattr__(self, "thickness", _positive(self.thickness, "polygon thickness"))
        self._check_common(rotation)

    @classmethod
    def planar(
        cls,
        vertices_xz: Sequence[Sequence[float]],
        *,
        depth: float = 1.0,
        name: str = "",
        hidden: bool = False,
    ) -> Polygon:
        """Convex polygon with world (x, z) vertices (m), extruded across the plane over ``depth``.
        """
        return cls(vertices_xz=vertices_xz, thickness=depth, name=name, hidden=hidden)

    def _prism_vertices(self) -> np.ndarray:
        h = self.thickness / 2.0
        out = []
        for x, z in self.vertices_xz:
            out.append((x, -h, z))
            out.append((x, h, z))
        return np.array(out)

    def geometry(self):
        import coal

        verts = self._prism_vertices()
        n = len(self.vertices_xz)
        pts = coal.StdVec_Vec3s()
        for p in verts:
            pts.append(np.array(p))
        tris = coal.StdVec_Triangle()
        # Caps (fans); the side faces are quads split in two. Winding: outward normals.
        for k in range(1, n - 1):
            tris.append(coal.Triangle(0, 2 * k, 2 * (k + 1)))  # y = -h cap
            tris.append(coal.Triangle(1, 2 * (k + 1) + 1, 2 * k + 1))  # y = +h cap
        for k in range(n):
            a, b = 2 * k, 2 * ((k + 1) % n)
            tris.append(coal.Triangle(a, a + 1, b + 1))
            tris.append(coal.Triangle(a, b + 1, b))
        return coal.Convex(pts, tris)

    def _polytope(self, n: int):
        return self._prism_vertices(), _prism_edges(len(self.vertices_xz))

    def _params(self) -> dict[str, Any]:
        return {"vertices_xz": [list(p) for p in self.vertices_xz], "thickness": self.thickness}


Obstacle = Box | Cylinder | Sphere | Polygon
SHAPES: dict[str, type] = {c.kind: c for c in (Box, Cylinder, Sphere, Polygon)}




def geometry_object(shape: Obstacle, name: str) -> pin.GeometryObject:
    """A Pinocchio GeometryObject for ``shape``, fixed to the universe joint (joint 0, frame 0)."""
    return pin.GeometryObject(name, 0, 0, shape.placement, shape.geometry())
