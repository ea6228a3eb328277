"""One call that plans a scenario: :func:`plan`, which is ``mpd_pin.plan`` (docs/design.md
§8b).

It sits above both ways in — :mod:`mpd_pin.app.kinds` (a built-in name or a ``.toml``
file, of any kind) and :mod:`mpd_pin.app.planner` (the :class:`EnergyPlanner` that runs
the query) — so that neither of them imports the other.
"""

from __future__ import annotations

import os
from typing import Any

from .kinds import load_scenario
from .planned import Plan
from .planner import EnergyPlanner, configure
from .scenario import EnergyScenario

__all__ = ["plan"]


def plan(scenario: EnergyScenario | str | os.PathLike, *, seed: int | None = None,
         cache: str | os.PathLike | None = None, show_progress: bool = True,
         **settings: Any) -> Plan:
    """Plan a scenario — an :class:`~mpd_pin.app.scenario.EnergyScenario`, a built-in name
    or a ``.toml`` path — exactly as ``mpd-pin run`` does: a
    :class:`~mpd_pin.app.planned.Plan` (energies J). ``seed`` and ``settings`` (the
    keywords of :func:`~mpd_pin.app.planner.configure`: planner, evaluation, collision,
    execution, refine, max_duration (s), scheduler, num_nodes) override the scenario's;
    ``cache`` is a roadmap ``.npz`` to reuse or write.
    :class:`~mpd_pin.NoMotionWithinDuration` when no motion runs within ``max_duration``.
    """
    if isinstance(scenario, (str, os.PathLike)):
        scenario = load_scenario(scenario)
    scn = configure(scenario, seed=seed, **settings)
    with EnergyPlanner.from_scenario(scn, cache=cache, show_progress=show_progress) as p:
        return p.plan(scn.start, scn.goal)
