"""Stage 3 — the world: obstacle shapes, hazard zones and hidden obstacles (docs/design.md §4).

Plain data, no collision logic: :mod:`mpd_pin.collision` turns a :class:`World` into
Coal geometry.
"""

from .scene import Hazard, World, shape_from_dict
from .shapes import Box, Cylinder, Obstacle, Polygon, Sphere, geometry_object

__all__ = [
    "Box", "Cylinder", "Hazard", "Obstacle", "Polygon", "Sphere", "World",
    "geometry_object", "shape_from_dict",
]
