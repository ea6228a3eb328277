"""Stage 1 — the arm: URDF loading and generation, built-in arms, numeric IK (docs/design.md §1).

:class:`Arm` wraps a Pinocchio model (and its collision geometry) loaded from URDF
or example-robot-data; :func:`planar_arm_urdf` writes the planar test arms;
:func:`builtin_arm` returns the arms shipped with the package.
"""

from .builtin import BUILTIN_ARMS, PlanarArmSpec, builtin_arm, builtin_arm_urdf
from .model import Arm
from .urdf import cylinder_inertia, planar_arm_urdf

__all__ = [
    "Arm", "BUILTIN_ARMS", "PlanarArmSpec", "builtin_arm", "builtin_arm_urdf",
    "cylinder_inertia", "planar_arm_urdf",
]
