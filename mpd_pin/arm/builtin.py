"""The planar arms of the papers, as specifications that regenerate ``robots/*.urdf``.

Masses and radii are ours (the papers give none); they are listed in
``robots/README.md``. Links are uniform solid cylinders (docs/design.md §1).
"""

from __future__ import annotations

from dataclasses import dataclass

from .model import Arm
from .urdf import planar_arm_urdf

__all__ = ["PlanarArmSpec", "BUILTIN_ARMS", "builtin_arm_urdf", "builtin_arm"]


@dataclass(frozen=True)
class PlanarArmSpec:
    """Link lengths (m), masses (kg) and radius (m) of a built-in planar arm."""

    name: str
    lengths: tuple[float, ...]
    masses: tuple[float, ...]
    radius: float
    description: str

    def urdf(self) -> str:
        return planar_arm_urdf(self.lengths, self.masses, radius=self.radius, name=self.name)


BUILTIN_ARMS: dict[str, PlanarArmSpec] = {
    spec.name: spec
    for spec in (
        PlanarArmSpec(
            "planar_2link",
            (0.5, 0.5),
            (1.0, 1.0),
            0.03,
            "paper 002: two 0.5 m links (workspace radius 1 m)",
        ),
        PlanarArmSpec(
            "planar_3link",
            (0.5, 0.4, 0.3),
            (0.5, 0.4, 0.3),
            0.03,
            "paper 000 §5.1 cases 1 and 4: three links, 1 kg/m",
        ),
        PlanarArmSpec(
            "planar_4link",
            (0.3, 0.3, 0.3, 0.3),
            (0.3, 0.3, 0.3, 0.3),
            0.03,
            "paper 000 §5.1 case 2: four equal links, 1 kg/m",
        ),
        PlanarArmSpec(
            "planar_7link",
            (0.15,) * 6 + (0.5,),
            (0.15,) * 6 + (0.5,),
            0.02,
            "paper 000 §5.1 case 3: six short links and one long one, 1 kg/m",
        ),
    )
}


def builtin_arm_urdf(name: str) -> str:
    """URDF text of a built-in planar arm (identical to ``robots/<name>.urdf``)."""
    if name not in BUILTIN_ARMS:
        raise ValueError(f"unknown built-in arm {name!r}; known: {', '.join(BUILTIN_ARMS)}")
    return BUILTIN_ARMS[name].urdf()


def builtin_arm(name: str) -> Arm:
    """Load a built-in planar arm."""
    return Arm.from_urdf(builtin_arm_urdf(name), name=name)
