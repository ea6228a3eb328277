"""Stage 6 — motions: what the arm runs, priced and refined (docs/design.md §9).

:func:`trajectory_energy` prices any joint-space path stop-and-go or non-stop with the
roadmap's motor, controller and integrator; :func:`shortcut_path` shortens a path where
the simulated energy drops; :mod:`mpd_pin.motion.refine` turns roadmap paths into the
returned motion.
"""

from .energy import EXECUTIONS, PRICINGS, MotionEnergy, check_waypoints, trajectory_energy
from .refine import MotionOptions
from .shortcut import ShortcutResult, shortcut_path
from .spline import ViaSpline, via_spline

__all__ = [
    "EXECUTIONS",
    "MotionEnergy",
    "MotionOptions",
    "PRICINGS",
    "ShortcutResult",
    "ViaSpline",
    "check_waypoints",
    "shortcut_path",
    "trajectory_energy",
    "via_spline",
]
