"""The one list of planners by name, used by scenario files, the runner and the CLI.

``PLANNERS`` maps the scenario/CLI name (``[planner] algorithm = "…"``,
``mpd-pin run --planner …``) to the planner class; every class has the
:class:`~mpd_pin.search.base.Planner` interface.
"""

from __future__ import annotations

from mpd_pin.search.base import Planner
from mpd_pin.search.best_first import AStar, Dijkstra
from mpd_pin.search.dstar_lite import DStarLite, MPDStarLite

__all__ = ["DEFAULT_PLANNER", "PLANNERS", "planner_class"]

#: name -> planner class; the first entry is the default.
PLANNERS: dict[str, type[Planner]] = {
    "mpdstar": MPDStarLite,
    "dstar": DStarLite,
    "astar": AStar,
    "dijkstra": Dijkstra,
}

DEFAULT_PLANNER = "mpdstar"


def planner_class(name: str) -> type[Planner]:
    """The planner class registered as ``name`` (ValueError naming the known ones)."""
    try:
        return PLANNERS[name]
    except KeyError:
        raise ValueError(f"unknown planner {name!r}; known: {', '.join(PLANNERS)}") from None
