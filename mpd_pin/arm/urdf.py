"""Planar serial arms as URDF, built with yourdfpy (docs/design.md §1).

Convention: the arm moves in the vertical x–z plane. Every revolute joint turns
about ``0 -1 0``, each link extends along +x of its own frame, and gravity is
Pinocchio's default −z, so the end effector is at
``x = Σ lₖ cos(q₁+…+qₖ)``, ``z = Σ lₖ sin(q₁+…+qₖ)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["planar_arm_urdf", "cylinder_inertia"]


def cylinder_inertia(mass: float, length: float, radius: float) -> np.ndarray:
    """Inertia (kg·m²) of a uniform solid cylinder about its centre of mass, axis along x.

    ``Ixx = m r²/2`` and ``Iyy = Izz = m (3 r² + l²)/12``.
    """
    ixx = 0.5 * mass * radius**2
    iyy = mass * (3.0 * radius**2 + length**2) / 12.0
    return np.diag([ixx, iyy, iyy])


def _origin(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Homogeneous 4×4 transform from translation (m) and roll-pitch-yaw (rad)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    rot = np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = xyz
    return out


def _per_joint(value: float | Sequence[float], n: int, what: str) -> np.ndarray:
    arr = (
        np.broadcast_to(np.asarray(value, dtype=float), (n,))
        if np.ndim(value) == 0
        else np.asarray(value, dtype=float)
    )
    if arr.shape != (n,):
        raise ValueError(f"{what}: expected a scalar or {n} values, got shape {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: values must be finite, got {arr.tolist()}")
    return arr.copy()


def planar_arm_urdf(
    lengths: Sequence[float],
    masses: Sequence[float],
    radius: float | Sequence[float] = 0.03,
    name: str = "planar_arm",
    *,
    lower: float | Sequence[float] = -math.pi,
    upper: float | Sequence[float] = math.pi,
    effort: float = 100.0,
    velocity: float = 10.0,
) -> str:
    """URDF text of a planar serial arm in the vertical x–z plane (docs/design.md §1).

    Parameters
    ----------
    lengths, masses:
        Link lengths (m) and masses (kg), one per link, all > 0.
    radius:
        Link radius (m), scalar or one per link; links are uniform solid cylinders.
    name:
        Robot name in the URDF.
    lower, upper:
        Joint limits (rad), scalar or per joint.
    effort, velocity:
        URDF ``<limit>`` effort (N·m) and velocity (rad/s), informative only.

    Each link ``linkK`` carries its inertial at ``l/2`` along x with the inertia
    about the centre of mass, and one cylinder along the link (rotated
    ``rpy="0 π/2 0"``) as visual and collision geometry. A massless ``ee`` link
    is fixed at the tip of the last link.
    """
    lengths = np.asarray(lengths, dtype=float)
    masses = np.asarray(masses, dtype=float)
    if lengths.ndim != 1 or lengths.size == 0:
        raise ValueError("lengths must be a non-empty 1-D sequence of link lengths (m)")
    n = lengths.size
    if masses.shape != (n,):
        raise ValueError(f"masses must have one value per link ({n}), got shape {masses.shape}")
    radii = _per_joint(radius, n, "radius")
    lo = _per_joint(lower, n, "lower joint limit")
    hi = _per_joint(upper, n, "upper joint limit")
    for what, arr in (("lengths", lengths), ("masses", masses), ("radius", radii)):
        if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ValueError(f"{what} must be finite and > 0, got {arr.tolist()}")
    if np.any(lo >= hi):
        raise ValueError(f"every lower joint limit must be below the upper one: {lo} vs {hi}")
    if not name or any(c.isspace() for c in name):
        raise ValueError(f"robot name must be a non-empty word, got {name!r}")

    import yourdfpy  # ≈ 3 s to import (trimesh): only when a URDF is written
    from lxml import etree

    grey = yourdfpy.Material(
        name="grey", color=yourdfpy.Color(rgba=np.array([0.6, 0.6, 0.65, 1.0]))
    )
    links = [yourdfpy.Link(name="base_link")]
    joints = []
    for k in range(n):
        l, m, r = float(lengths[k]), float(masses[k]), float(radii[k])
        along = _origin(xyz=(l / 2, 0.0, 0.0), rpy=(0.0, math.pi / 2, 0.0))
        geom = yourdfpy.Geometry(cylinder=yourdfpy.Cylinder(radius=r, length=l))
        links.append(
            yourdfpy.Link(
                name=f"link{k + 1}",
                inertial=yourdfpy.Inertial(
                    origin=_origin(xyz=(l / 2, 0.0, 0.0)), mass=m, inertia=cylinder_inertia(m, l, r)
                ),
                visuals=[
                    yourdfpy.Visual(
                        name=f"link{k + 1}_visual",
                        origin=along,
                        geometry=geom,
                        material=yourdfpy.Material(name="grey"),
                    )
                ],
                collisions=[
                    yourdfpy.Collision(name=f"link{k + 1}_collision", origin=along, geometry=geom)
                ],
            )
        )
        joints.append(
            yourdfpy.Joint(
                name=f"joint{k + 1}",
                type="revolute",
                parent="base_link" if k == 0 else f"link{k}",
                child=f"link{k + 1}",
                origin=_origin(xyz=(0.0 if k == 0 else float(lengths[k - 1]), 0.0, 0.0)),
                axis=np.array([0.0, -1.0, 0.0]),
                limit=yourdfpy.Limit(
                    effort=float(effort),
                    velocity=float(velocity),
                    lower=float(lo[k]),
                    upper=float(hi[k]),
                ),
            )
        )
    links.append(yourdfpy.Link(name="ee"))
    joints.append(
        yourdfpy.Joint(
            name="ee_joint",
            type="fixed",
            parent=f"link{n}",
            child="ee",
            origin=_origin(xyz=(float(lengths[-1]), 0.0, 0.0)),
        )
    )
    robot = yourdfpy.Robot(name=name, links=links, joints=joints, materials=[grey])
    urdf = yourdfpy.URDF(robot=robot, build_scene_graph=False, load_meshes=False)
    # yourdfpy's write_xml_string drops keyword arguments; serialise its tree with lxml.
    body = etree.tostring(urdf.write_xml(), pretty_print=True, encoding="unicode")
    return '<?xml version="1.0"?>\n' + body
