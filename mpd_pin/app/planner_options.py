"""The settings of an :class:`~mpd_pin.EnergyPlanner`, as one value (docs/design.md §8b).

:class:`PlannerOptions` holds what ``EnergyPlanner(drive, world, options)`` needs besides
the drive and the world, in the style of an options dataclass next to a planner object
(pyroboplan). Each field is checked when the options are made, with one error naming it;
the planner's keyword arguments remain shorthands that replace single fields
(:func:`merge_options`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields, replace
from typing import Any

from ..motion.refine import MotionOptions
from ..planning.roadmap import COLLISIONS, RoadmapOptions
from ..search.registry import DEFAULT_PLANNER, PLANNERS
from .config import ConfigError
from .scenario import EVALUATIONS
from .trajectory import DEFAULT_TRAJECTORY_RATE

__all__ = ["PlannerOptions", "merge_options"]


@dataclass(frozen=True)
class PlannerOptions:
    """How an :class:`~mpd_pin.EnergyPlanner` plans (units: m, s, Hz).

    roadmap: :class:`~mpd_pin.RoadmapOptions` (nodes, k, seed, edge timing, dt);
    evaluation: "lazy" (simulate the edges the search needs) or "eager";
    collision: "lazy" (collision-check the edges the search needs) or "eager";
    planner: a name of ``mpd_pin.search.PLANNERS`` (default MPD* Lite);
    motion: :class:`~mpd_pin.MotionOptions` (execution, refinement, max_duration s);
    sensor_range: m, required when the world has hidden obstacles (None: no sensing);
    hazard_penalty: ∞ removes edges too close to a hazard, else their cost factor (≥ 1);
    scheduler: where edge energies run ("threads", "local[:N]", a Dask address or client;
    None: threads); cache: a roadmap ``.npz`` for the first query (reused or written);
    show_progress: progress bars on stderr; name: the label of results and plots;
    trajectory_rate: Hz of trajectory.json; verify: re-simulate each query's roadmap paths
    with the reference ``simulate_edge`` (docs/design.md §7c).
    """

    roadmap: RoadmapOptions = field(default_factory=RoadmapOptions)
    evaluation: str = "lazy"
    collision: str = "lazy"
    planner: str = DEFAULT_PLANNER
    motion: MotionOptions = field(default_factory=MotionOptions)
    sensor_range: float | None = None
    hazard_penalty: float = math.inf
    scheduler: Any = None
    cache: str | os.PathLike | None = None
    show_progress: bool = True
    name: str = "plan"
    trajectory_rate: float = DEFAULT_TRAJECTORY_RATE
    verify: bool = False

    def __post_init__(self) -> None:
        def bad(key: str, want: str) -> ConfigError:
            return ConfigError(f"PlannerOptions.{key}: expected {want}, "
                               f"got {getattr(self, key)!r}")

        if not isinstance(self.roadmap, RoadmapOptions):
            raise TypeError(f"roadmap must be mpd_pin.RoadmapOptions, got "
                            f"{type(self.roadmap).__name__}")
        if not isinstance(self.motion, MotionOptions):
            raise TypeError(f"motion must be mpd_pin.MotionOptions, got "
                            f"{type(self.motion).__name__}")
        if self.evaluation not in EVALUATIONS:
            raise bad("evaluation", f"one of {list(EVALUATIONS)}")
        if self.collision not in COLLISIONS:
            raise bad("collision", f"one of {list(COLLISIONS)}")
        if self.planner not in PLANNERS:
            raise bad("planner", f"one of {sorted(PLANNERS)}")
        if self.sensor_range is not None and not (
                _real(self.sensor_range) and math.isfinite(self.sensor_range)
                and self.sensor_range > 0):
            raise bad("sensor_range", "a distance > 0 (m) or None")
        if not (_real(self.hazard_penalty) and self.hazard_penalty >= 1):
            raise bad("hazard_penalty", "a cost factor ≥ 1, or inf")
        if not (_real(self.trajectory_rate) and math.isfinite(self.trajectory_rate)
                and self.trajectory_rate > 0):
            raise bad("trajectory_rate", "a rate > 0 (Hz)")
        if not isinstance(self.name, str) or not self.name:
            raise bad("name", "a non-empty string")
        for key in ("show_progress", "verify"):
            if not isinstance(getattr(self, key), bool):
                raise bad(key, "True or False")


def _real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and not math.isnan(x)


def merge_options(options: PlannerOptions | None, keywords: dict[str, Any]) -> PlannerOptions:
    """``options`` (None: the defaults) with the fields named in ``keywords`` replaced;
    TypeError naming an unknown keyword and the valid ones."""
    if options is not None and not isinstance(options, PlannerOptions):
        raise TypeError(f"options must be mpd_pin.PlannerOptions, got "
                        f"{type(options).__name__}")
    names = [f.name for f in fields(PlannerOptions)]
    unknown = sorted(set(keywords) - set(names))
    if unknown:
        raise TypeError(f"EnergyPlanner got an unexpected keyword argument {unknown[0]!r} "
                        f"(valid: {', '.join(names)})")
    base = options if options is not None else PlannerOptions()
    return replace(base, **keywords) if keywords else base
