"""Graph search for mpd_pin: MPD* Lite (paper 000 §3), D* Lite, A* and Dijkstra.

Pure Python + numpy + heapq; works on any directed graph with costs >= 0
(``math.inf`` = blocked), not only roadmaps::

    from mpd_pin.search import Graph, MPDStarLite
    g = Graph(3, [(0, 1, 1.0), (1, 2, 1.0), (0, 2, 5.0)])
    p = MPDStarLite(g, start=0, goal=2)
    p.plan().nodes            # [0, 1, 2]
    p.update_edge(1, 2, math.inf)
    p.plan().nodes            # [0, 2]  (repaired incrementally)
"""

from mpd_pin.errors import NoPathError
from mpd_pin.search.base import Heuristic, Path, Planner, SearchInvariantError, SearchStats
from mpd_pin.search.best_first import AStar, Dijkstra
from mpd_pin.search.dstar_lite import DStarLite, MPDStarLite
from mpd_pin.search.graph import Graph
from mpd_pin.search.registry import DEFAULT_PLANNER, PLANNERS, planner_class

__all__ = [
    "AStar",
    "DEFAULT_PLANNER",
    "PLANNERS",
    "planner_class",
    "DStarLite",
    "Dijkstra",
    "Graph",
    "Heuristic",
    "MPDStarLite",
    "NoPathError",
    "Path",
    "Planner",
    "SearchInvariantError",
    "SearchStats",
]
