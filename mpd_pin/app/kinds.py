"""Scenario kinds: ``kind = "…"`` of a scenario file → its parser, runner and summary line
(docs/design.md §7).

=================  =================================================  ========================
kind               parsed into / run by                               paper
=================  =================================================  ========================
``energy``         :class:`~mpd_pin.app.scenario.EnergyScenario` /    000 (MPD* Lite, energy)
                   :func:`~mpd_pin.app.runner.run_energy_scenario`
``dynamic2link``   :class:`~mpd_pin.twolink.scenario.DynamicScenario`  002 (D* + PSO, moving
                   / :func:`~mpd_pin.twolink.run.run_dynamic_scenario`  obstacles)
=================  =================================================  ========================

:func:`load_scenario` reads a built-in name or a file of any kind; :func:`run_scenario`
runs it and :func:`summary_line` gives the line ``mpd-pin run`` prints. Each kind's
modules are imported when a scenario of that kind is parsed or run, not before (those
function-level imports point down the layering: nothing they import imports this
module). The kind names, :func:`scenario_kind` and the file reading are
:mod:`mpd_pin.app.scenario_files`, named here too.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..search.registry import PLANNERS
from .config import ConfigError
from .scenario_files import (
    DEFAULT_KIND,
    KIND_NAMES,
    load_scenario_data,
    resolve_scenario,
    scenario_kind,
)

__all__ = [
    "DEFAULT_KIND",
    "KINDS",
    "ScenarioKind",
    "load_scenario",
    "run_scenario",
    "scenario_kind",
    "summary_line",
]


@dataclass(frozen=True)
class ScenarioKind:
    """How one kind of scenario is parsed, run and summed up.

    ``parse(data, path, seed=, planner=)`` → the scenario (ConfigError if bad);
    ``run(scenario, out_dir, show_progress=, cache=, replay=, plots=)`` → the result dict written
    to ``out_dir/result.json``; ``summary(scenario, result, out_dir)`` → one line.
    """

    description: str
    parse: Callable[..., Any]
    run: Callable[..., dict[str, Any]]
    summary: Callable[[Any, dict[str, Any], Path], str]


def _parse_energy(data: dict[str, Any], path: Path, *, seed: int | None, planner: str | None):
    from .scenario import parse_energy_scenario

    scn = parse_energy_scenario(data, source=str(path), base_dir=path.parent, seed=seed)
    if planner is None:
        return scn
    if planner not in PLANNERS:
        raise ConfigError(f"planner: {planner!r} is not one of {sorted(PLANNERS)}")
    return replace(scn, planner=planner)


def _run_energy(scn, out_dir: Path, *, show_progress: bool, cache: Path | None, replay: bool,
                plots: bool):
    from .runner import run_energy_scenario

    return run_energy_scenario(scn, out_dir, show_progress=show_progress, cache=cache,
                               replay=replay, plots=plots)


def _summary_energy(scn, result: dict[str, Any], out_dir: Path) -> str:
    if getattr(scn, "cycle", None) is not None:  # a cycle's cycle.json (issue 33)
        from .cycle import cycle_summary

        return cycle_summary(scn, result, out_dir)
    per_joint = ", ".join(f"{e:.4g}" for e in result["energy_per_joint"])
    supply = result.get("supply") or {"bus": "per_joint"}
    if supply["bus"] != "per_joint":  # the total is the bus's; the joints' E⁺ would not sum
        eta = supply["regeneration"]
        per_joint = (f"shared bus{f', regeneration {eta:g}' if eta else ''}; per-joint "
                     f"supplies would draw {result['energy_by_supply']['per_joint']:.4g} J")
    cache = result["roadmap"].get("cache") or {}
    if cache.get("path"):  # the roadmap file: reused, or built and saved to it
        how = "reused from" if cache.get("reused") else "saved to"
        roadmap = f" ({how} {cache['path']})"
    else:
        roadmap = ""
    reused = result["roadmap"].get("chunks_reused", 0)
    if reused:  # an interrupted build resumed (§4h)
        roadmap += f", resumed: {reused} chunks of edge energies reused"
    warnings = "".join(f"; warning: {w}" for w in result.get("warnings", []))
    motion = result.get("motion") or {}
    if "refinement" in motion:  # a refined motion: say what it is and what it came from
        e_roadmap = result["roadmap_path"]["total_energy"]
        how = (f" {motion['execution']} over {len(motion['waypoints'])} waypoints in "
               f"{motion['duration']:.3g} s (roadmap path {e_roadmap:.6g} J over "
               f"{result['path']['length_nodes']} nodes)")
    else:
        how = f" over {result['path']['length_nodes']} nodes"
    return (f"{scn.name}: {result['total_energy']:.6g} J ({per_joint}){how}; roadmap "
            f"{result['roadmap']['num_nodes']} nodes{roadmap} -> {out_dir}/result.json{warnings}")


def _parse_dynamic(data: dict[str, Any], path: Path, *, seed: int | None, planner: str | None):
    from ..twolink.scenario import parse_dynamic_scenario

    if planner is not None:
        raise ConfigError(
            f"planner: {planner!r} does not apply to {path.stem!r}, a dynamic2link scenario "
            "(D* on the end-effector grid, then PSO; paper 002); --planner is for energy "
            "scenarios"
        )
    return parse_dynamic_scenario(data, base_dir=path.parent, seed=seed)


def _run_dynamic(scn, out_dir: Path, *, show_progress: bool, cache: Path | None, replay: bool,
                 plots: bool):
    """``cache`` and ``replay`` do not apply (no roadmap, no meshcat replay) and are ignored."""
    from ..twolink.run import run_dynamic_scenario

    return run_dynamic_scenario(scn, out_dir, show_progress=show_progress, plots=plots)


def _summary_dynamic(scn, result: dict[str, Any], out_dir: Path) -> str:
    return (f"{scn.name}: D* path {result['path_length_dstar']:.4f} m, "
            f"PSO path {result['path_length_pso']:.4f} m -> {out_dir}/result.json")


#: kind name → how it is parsed, run and summed up; the first is the default kind.
KINDS: dict[str, ScenarioKind] = {
    "energy": ScenarioKind(
        "energy-optimal path on a roadmap (paper 000)", _parse_energy, _run_energy,
        _summary_energy,
    ),
    "dynamic2link": ScenarioKind(
        "two-link arm among moving obstacles (paper 002)", _parse_dynamic, _run_dynamic,
        _summary_dynamic,
    ),
}
if tuple(KINDS) != KIND_NAMES:  # the files are checked against KIND_NAMES
    raise RuntimeError(f"KINDS {tuple(KINDS)} and scenario_files.KIND_NAMES {KIND_NAMES} differ")


def load_scenario(name_or_path: str | Path, *, seed: int | None = None,
                  planner: str | None = None) -> Any:
    """A built-in scenario name or a ``.toml`` file → the parsed scenario of its kind.

    ``seed`` overrides the scenario's seed (``[roadmap] seed`` / ``[pso] seed``);
    ``planner`` (a name of :data:`mpd_pin.search.PLANNERS`) its ``[planner] algorithm``
    (energy scenarios only). Raises ConfigError for bad input.
    """
    path = resolve_scenario(str(name_or_path))
    data = load_scenario_data(path)
    return KINDS[scenario_kind(data)].parse(data, path, seed=seed, planner=planner)


def run_scenario(scn: Any, out_dir: Path, *, show_progress: bool = True,
                 cache: Path | None = None, replay: bool = True,
                 plots: bool = True) -> dict[str, Any]:
    """Run a scenario of any kind (from :func:`load_scenario`) and write its results into
    ``out_dir``; returns the result dict. ``cache`` (roadmap .npz) and ``replay``
    (meshcat replay.html) apply to energy scenarios; ``plots=False`` skips the PNG figures
    (and matplotlib) of every kind."""
    return KINDS[scn.kind].run(scn, Path(out_dir), show_progress=show_progress, cache=cache,
                               replay=replay, plots=plots)


def summary_line(scn: Any, result: dict[str, Any], out_dir: Path) -> str:
    """The one line ``mpd-pin run`` prints for a finished run."""
    return KINDS[scn.kind].summary(scn, result, out_dir)
