"""Stage 4 — collision: configuration validity and motion (edge) validity through Coal.

docs/design.md §4. :class:`CollisionChecker` answers "is this configuration free?",
"how far is it from the world?" and "is this straight joint-space edge free?". It
composes :mod:`.geometry` (geometry model, pairs, the pair state that follows the
world), :mod:`.bounds` (link-motion bounds), :mod:`.validity` (configurations,
distances) and :mod:`.motion` (discrete and certified edges).
"""

from .checker import CollisionChecker
from .geometry import GJK_TOLERANCE
from .motion import bisection_order, edge_configurations

__all__ = ["CollisionChecker", "GJK_TOLERANCE", "bisection_order", "edge_configurations"]
