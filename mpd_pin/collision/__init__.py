"""Stage 4 — collision: configuration validity and motion (edge) validity through Coal.

docs/design.md §4. :class:`CollisionChecker` answers "is this configuration free?",
"how far is it from the world?" and "is this straight joint-space edge free?".
"""

from .checker import GJK_TOLERANCE, CollisionChecker, edge_configurations

__all__ = ["CollisionChecker", "GJK_TOLERANCE", "edge_configurations"]
