"""The plan step of a run: roadmap, then one of three searches (paper 000 §5; docs/design.md §4–§5).

:func:`prepare` builds the drive, the collision checker and the energy roadmap of a
scenario. :func:`plan_path` then finds the path, in one of three modes:

* plain — one search on the roadmap with the scenario's planner (``mpd_pin.search.PLANNERS``);
* hazards (a hazard with clearance > 0) — :func:`~mpd_pin.planning.hazards.plan_avoiding_hazards`
  re-plans until the path keeps every clearance; what follows plans on its penalised costs;
* execution (hidden obstacles) — :func:`~mpd_pin.planning.execution.execute` moves along the
  plan, senses and repairs; the path is the one travelled.

Energies are always the roadmap's own (unpenalised) E⁺.

With ``evaluation = "lazy"`` (the default, docs/design.md §4g) the roadmap is built
without costs and every search runs through :class:`~mpd_pin.planning.lazy.CostView`:
the paths it returns — planned, hazard re-planned, repaired during execution, shortest —
have all their edges simulated before they are used, and what was simulated is written
back to the cache file.

:func:`plan_shortest` plans the same scenario — same roadmap edges, obstacles, hazard
re-planning, sensing and repair, same planner — on the *distance* costs of
:func:`edge_lengths` (the usual PRM objective), for the comparison of docs/design.md §7c.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..arm import Arm
from ..collision import CollisionChecker
from ..dynamics import EnergyCost
from ..dynamics.motor import Drive
from ..errors import NoPathError
from ..planning.evaluate import complete_checks, complete_roadmap
from ..planning.execution import ExecutionResult, execute
from ..planning.hazards import HazardResult, plan_avoiding_hazards
from ..planning.lazy import CostView, LazyEdges
from ..planning.roadmap import Roadmap, build_roadmap
from ..planning.supply_costs import NegativeCostError, attach_supply
from ..search import PLANNERS
from ..world import World
from .scenario import EnergyScenario

__all__ = [
    "Setup",
    "PlanResult",
    "prepare",
    "requery",
    "plan_path",
    "plan_shortest",
    "edge_lengths",
    "path_length",
    "distance_roadmap",
    "refusal_note",
    "no_path_message",
]


@dataclass
class Setup:
    """What a scenario plans on: its drive, world, planning checker and roadmap.

    world_record: the world as given (``World.to_dict``, before any obstacle is revealed).
    evaluation: "lazy" or "eager" as run; lazy: the evaluation state (None when eager);
    cache: the roadmap file written back after a lazy search; notes: why the evaluation
    differs from the scenario's, if it does.
    """

    drive: Drive
    world: World
    checker: CollisionChecker
    roadmap: Roadmap
    world_record: dict[str, Any]
    #: result.json's ``compute``: scheduler, workers, chunk_size (docs/design.md §4h)
    compute: dict[str, Any] = field(default_factory=dict)
    evaluation: str = "eager"
    lazy: LazyEdges | None = None
    cache: Path | None = None
    notes: list[str] = field(default_factory=list)
    #: the edge-energy interface the roadmap was costed with (later queries use it too)
    cost: EnergyCost | None = None
    #: "lazy" or "eager" as run: when the roadmap's edges are collision-checked (§4g)
    collision: str = "eager"


@dataclass
class PlanResult:
    """The path found by :func:`plan_path`.

    path: node ids, start … goal (the travelled ones with hidden obstacles);
    energy: its E⁺ per joint (J) from the unpenalised roadmap;
    search: ``initial_plan_seconds`` (s), ``expansions`` (and ``edge_evaluations`` for a
    plain search) of the first plan;
    hazard / execution: the hazard re-planning and the execution, when they ran;
    other_paths: plans not followed (name → node ids), drawn for comparison.
    """

    path: list[int]
    energy: np.ndarray
    search: dict[str, float | int]
    hazard: HazardResult | None = None
    execution: ExecutionResult | None = None
    other_paths: dict[str, list[int]] = field(default_factory=dict)


def prepare(
    scn: EnergyScenario, *, cache: Path | None = None, show_progress: bool = True,
    compute: Any = None,
) -> Setup:
    """Build the drive, the planning checker (known obstacles) and the roadmap of ``scn``
    (loaded from ``cache``, a ``.npz``, when it was built with the same key); edge energies
    run on ``compute`` (an :func:`~mpd_pin.dynamics.remote.open_compute` argument, None:
    this process; docs/design.md §4h). A lazy scenario's roadmap is built without costs
    (docs/design.md §4g)."""
    drive = scn.drive()
    world = scn.world
    world.reset()
    checker = CollisionChecker(scn.arm, world)
    cost = EnergyCost(drive, scn.options.dt, executor=compute)
    evaluation = getattr(scn, "evaluation", "eager")
    notes = []
    if evaluation == "lazy" and math.isfinite(scn.hazard_penalty) and any(
        h.clearance > 0 for h in world.hazards
    ):
        evaluation = "eager"
        notes.append("a finite planner.hazard_penalty takes its floor from the mean energy of "
                     "every edge: evaluated eagerly")
    # eager evaluation simulates every edge, so it checks every edge first (§4g)
    collision = getattr(scn, "collision", "eager") if evaluation == "lazy" else "eager"
    roadmap = build_roadmap(
        cost, checker, scn.start, scn.goal, scn.options, cache=cache, show_progress=show_progress,
        evaluate=evaluation == "eager", check_edges=collision == "eager",
    )
    lazy = (LazyEdges(roadmap, cost, scn.options, progress=show_progress, checker=checker)
            if evaluation == "lazy" else None)
    return Setup(drive, world, checker, roadmap, world.to_dict(), cost.compute_record(),
                 evaluation=evaluation, lazy=lazy, cache=None if cache is None else Path(cache),
                 notes=notes, cost=cost, collision=collision)


def requery(setup: Setup, scn: EnergyScenario, *, show_progress: bool = True) -> Setup:
    """``setup`` for another query on the same roadmap: ``scn.start`` and ``scn.goal``
    joined to it (:func:`~mpd_pin.planning.queries.add_query`; docs/design.md §4i). Every
    node, edge and simulated energy is reused (lazy: the refused edges are left out); the
    world starts again from its initial map. No roadmap file is written for it."""
    from ..planning.queries import add_query

    setup.world.reset()
    lazy = setup.lazy
    base = setup.roadmap if lazy is None else lazy.roadmap.without_edges(lazy.refused)
    roadmap = add_query(base, setup.cost, setup.checker, scn.start, scn.goal, scn.options,
                        evaluate=lazy is None, check_edges=setup.collision == "eager",
                        show_progress=show_progress)
    return replace(
        setup, roadmap=roadmap, world_record=setup.world.to_dict(), cache=None,
        lazy=None if lazy is None else LazyEdges(roadmap, setup.cost, scn.options,
                                                 progress=show_progress,
                                                 checker=setup.checker),
        notes=list(setup.notes),
    )


def edge_lengths(roadmap: Roadmap, arm: Arm | None = None) -> np.ndarray:
    """(E,) joint-space length of every directed edge (rad): the Euclidean norm
    ``‖q_dst − q_src‖₂`` (docs/design.md §7c), the shorter way round on the continuous
    joints of ``arm`` (§1d)."""
    Q0, Q1 = roadmap.nodes[roadmap.src], roadmap.nodes[roadmap.dst]
    if arm is not None:
        Q1 = arm.edge_target(Q0, Q1)
    return np.linalg.norm(Q1 - Q0, axis=1)


def path_length(roadmap: Roadmap, path: list[int], arm: Arm | None = None) -> float:
    """Joint-space length of a node path (rad): Σ over its edges of ``‖Δq‖₂`` (the
    shorter way round on the continuous joints of ``arm``, §1d)."""
    if len(path) < 2:
        return 0.0
    Q0, Q1 = roadmap.nodes[list(path[:-1])], roadmap.nodes[list(path[1:])]
    if arm is not None:
        Q1 = arm.edge_target(Q0, Q1)
    return float(np.linalg.norm(Q1 - Q0, axis=1).sum())


def distance_roadmap(roadmap: Roadmap, arm: Arm | None = None) -> Roadmap:
    """A copy of ``roadmap`` (same nodes and edges) whose costs are the edge lengths (rad,
    :func:`edge_lengths` with ``arm``), carried in the first column of ``energy`` (the
    others 0), so that ``graph()``, hazard penalties and execution plan on distance. Only
    for planning: energies come from ``roadmap``."""
    return roadmap.with_costs(edge_lengths(roadmap, arm))


def plan_path(scn: EnergyScenario, setup: Setup) -> PlanResult:
    """Find the path of ``scn`` on ``setup.roadmap``: hazard re-planning first if the world
    has hazards with a clearance, then execution with sensing if it has hidden obstacles,
    else one search. A NoPathError says how many edges the roadmap refused, and why
    (:func:`refusal_note`)."""
    try:
        if setup.lazy is not None:
            try:
                return _plan_lazy(scn, setup, "energy")
            except NegativeCostError as exc:
                u, v = exc.edge
                evaluate_eagerly(setup, scn, (
                    f"the lazy search met an edge (node {u} -> node {v}, {exc.cost:.6g} J) "
                    "below the node potential's difference, which keeps costs with "
                    "regeneration >= 0 only when every joint's motor has one Ke/Kt: every "
                    "edge evaluated instead, which makes all costs >= 0 exactly "
                    "(docs/design.md §3i)"))
        return _plan_on(scn, setup, setup.roadmap)
    except NoPathError as exc:
        if setup.lazy is None:
            note = refusal_note(setup.roadmap, scn.options.arrival_tolerance)
        else:  # a lazy roadmap still holds its refused edges (§4g)
            lazy = setup.lazy
            note = refusal_note(lazy.roadmap.without_edges(lazy.refused),
                                scn.options.arrival_tolerance, simulated=lazy.count.simulated)
        text = no_path_message(str(exc), scn, setup)
        raise NoPathError(f"{text}; {note}" if note else text) from None


def evaluate_eagerly(setup: Setup, scn: EnergyScenario, why: str) -> None:
    """Make a lazy ``setup`` eager, in place: every edge of its roadmap collision-checked
    and simulated (the edges simulated so far reused, the refused ones dropped), priced
    again with every cost known — with regeneration, Johnson's shift on top of the node
    potential makes them all >= 0 exactly (docs/design.md §3i) — and the roadmap file
    rewritten; the world is back to its initial map and ``why`` joins ``setup.notes``."""
    lazy = setup.lazy
    setup.world.reset()
    roadmap = lazy.roadmap.without_edges(lazy.refused)
    roadmap = complete_checks(roadmap, setup.checker, scn.options.resolution, lazy.progress)
    roadmap = attach_supply(complete_roadmap(setup.cost, roadmap, scn.options, lazy.progress),
                            setup.drive)
    if setup.cache is not None:
        roadmap.save(setup.cache)
    setup.roadmap, setup.lazy, setup.evaluation, setup.collision = roadmap, None, "eager", "eager"
    setup.notes.append(why)


_NO_PATH = re.compile(r"no path from node (\d+) to node (\d+)")


def no_path_message(text: str, scn: EnergyScenario, setup: Setup) -> str:
    """A search's "no path from node 0 to node 1" (``text``) in the user's terms: the start
    and the goal (or the node reached on the way where the arm had to re-plan after
    sensing a hidden obstacle), what removed edges (revealed obstacles, hazard
    clearances), and what to try: more ``[roadmap] num_nodes`` or ``k``, another seed."""
    roadmap, world, opts = setup.roadmap, setup.world, scn.options

    def node(i: int) -> str:
        if i == roadmap.start:
            return "the start"
        return "the goal" if i == roadmap.goal else f"roadmap node {i} (reached on the way)"

    m = _NO_PATH.fullmatch(text.strip())
    head = f"no path from {node(int(m[1]))} to {node(int(m[2]))}" if m else text
    why = []
    revealed = sorted(world.revealed)
    if revealed:
        why.append(f"once the hidden obstacle(s) {', '.join(map(repr, revealed))} were sensed")
    if not math.isfinite(scn.hazard_penalty) and any(h.clearance > 0 for h in world.hazards):
        why.append("without the edges closer to a hazard than its clearance "
                   "([planner] hazard_penalty = inf)")
    alone = [name for name, ends in (("start", roadmap.src), ("goal", roadmap.dst))
             if not np.any(np.asarray(ends) == getattr(roadmap, name))]
    if alone:
        why.append(f"(the {' and the '.join(alone)} {'has' if len(alone) == 1 else 'have'} "
                   "no collision-free edge at all)")
    where = f" {' '.join(why)}" if why else ""
    return (f"{head}: the roadmap's edges do not connect them{where} ([roadmap] num_nodes = "
            f"{opts.num_nodes}, k = {opts.k}, seed = {opts.seed}); try more nodes or "
            "neighbours ([roadmap] num_nodes, k) or another seed ([roadmap] seed, or --seed; in "
            "Python the same fields of RoadmapOptions)")


def refusal_note(roadmap: Roadmap, tolerance: float, simulated: int | None = None) -> str:
    """Why a roadmap may lack the edges a path needs: its counts of directed edges refused
    for the effort limits and for not arriving (docs/design.md §4e), with what to try;
    "" if none was refused. ``roadmap`` holds the edges left after the refusals; with
    ``simulated`` (lazy evaluation, §4g) the note says how many edges were simulated."""
    counts = roadmap.edge_counts or {}
    effort, arrival = int(counts.get("refused_effort", 0)), int(counts.get("refused_arrival", 0))
    if effort + arrival == 0:
        return ""
    total = roadmap.num_edges + effort + arrival
    parts = []
    if effort:
        parts.append(f"{effort} because the motor torque n·Kt·i exceeded a joint's effort limit")
    if arrival:
        parts.append(f"{arrival} because the simulated motion ended more than {tolerance:g} rad "
                     "from its end node")
    lazy = "" if simulated is None else f" (lazy evaluation simulated {simulated} of them)"
    return (f"the roadmap refused {effort + arrival} of its {total} collision-free directed "
            f"edges{lazy}: {' and '.join(parts)}; try motors that can follow the edges "
            '([motor] preset = "sized") or longer edges ([roadmap] duration, or '
            'duration_rule = "distance" with a lower joint_speed)')


def plan_shortest(scn: EnergyScenario, setup: Setup) -> PlanResult:
    """The shortest joint-space path of ``scn`` (:func:`distance_roadmap` costs), planned
    exactly as :func:`plan_path` plans the energy-optimal one (same planner, hazard
    re-planning, execution with sensing from the initial map). Its ``energy`` is E⁺ per
    joint (J) from ``setup.roadmap``. The world's revealed obstacles are restored after."""
    world = setup.world
    revealed = sorted(world.revealed)
    world.reset()
    try:
        if setup.lazy is not None:
            return _plan_lazy(scn, setup, "length")
        return _plan_on(scn, setup, distance_roadmap(setup.roadmap, setup.drive.arm))
    finally:
        world.reset()
        if revealed:
            world.reveal(*revealed)


def _plan_on(scn: EnergyScenario, setup: Setup, costs: Roadmap) -> PlanResult:
    """:func:`plan_path` with the planner seeing the costs of ``costs`` (a roadmap with the
    nodes and edges of ``setup.roadmap``); energies reported from ``setup.roadmap``."""
    planner = PLANNERS[scn.planner]
    roadmap, world = setup.roadmap, setup.world
    hazard = None
    other_paths: dict[str, list[int]] = {}
    plan_map = costs  # what the planner sees: hazard penalties applied
    if any(h.clearance > 0 for h in world.hazards):
        hazard = plan_avoiding_hazards(
            costs,
            setup.checker,
            resolution=scn.options.resolution,
            penalty=scn.hazard_penalty,
            planner=planner,
        )
        if costs is not roadmap:  # report energies, not the planning costs
            hazard.first_energy = roadmap.path_energy(hazard.first_path)
            hazard.final_energy = roadmap.path_energy(hazard.final_path)
        if hazard.first_path != hazard.final_path:
            other_paths["cheapest path (too close to a hazard)"] = hazard.first_path
        plan_map = hazard.planning_roadmap(costs)
    if world.hidden_names():
        run = execute(
            plan_map,
            setup.checker,
            sensor_range=float(scn.sensor_range),
            resolution=scn.options.resolution,
            planner=planner,
        )
        run.energy = roadmap.path_energy(run.travelled)  # the planner's costs may be penalised
        return _executed(run, hazard, other_paths)
    p = planner(plan_map.graph(), roadmap.start, roadmap.goal)
    ts = time.perf_counter()
    plan = p.plan()
    return _searched(roadmap, p, plan, time.perf_counter() - ts, hazard, other_paths)


def _executed(run: ExecutionResult, hazard, other_paths: dict[str, list[int]]) -> PlanResult:
    """The PlanResult of an execution with sensing and repair: the travelled path."""
    if run.initial_path != run.travelled:
        other_paths["initial plan (before the new obstacle)"] = run.initial_path
    search = {
        "initial_plan_seconds": run.initial_plan_seconds,
        "expansions": run.initial_expansions,
    }
    return PlanResult(run.travelled, run.energy, search, hazard, run, other_paths)


def _searched(roadmap: Roadmap, p, plan, seconds: float, hazard,
              other_paths: dict[str, list[int]]) -> PlanResult:
    """The PlanResult of one search ``p`` (its ``plan`` took ``seconds``); with hazards the
    path is the re-planned one (penalised costs), else the plan. Energies: the roadmap's."""
    search = {
        "initial_plan_seconds": seconds,
        "expansions": p.stats.expansions,
        "edge_evaluations": p.stats.edge_evaluations,
    }
    path = list(hazard.final_path) if hazard is not None else list(plan.nodes)
    return PlanResult(path, roadmap.path_energy(path), search, hazard, None, other_paths)


def _plan_lazy(scn: EnergyScenario, setup: Setup, kind: str) -> PlanResult:
    """:func:`_plan_on` for a lazy roadmap: every search through one
    :class:`~mpd_pin.planning.lazy.CostView` of ``kind`` ("energy" or "length"); then the
    evaluated energies are written back to the cache file (docs/design.md §4g)."""
    planner = PLANNERS[scn.planner]
    roadmap, world, lazy = setup.roadmap, setup.world, setup.lazy
    view = CostView(lazy, kind)
    hazard = None
    other_paths: dict[str, list[int]] = {}
    try:
        if any(h.clearance > 0 for h in world.hazards):
            hazard = plan_avoiding_hazards(
                roadmap, setup.checker, resolution=scn.options.resolution,
                penalty=scn.hazard_penalty, planner=planner, view=view,
            )
            if hazard.first_path != hazard.final_path:
                other_paths["cheapest path (too close to a hazard)"] = hazard.first_path
        if world.hidden_names():
            run = execute(
                roadmap, setup.checker, sensor_range=float(scn.sensor_range),
                resolution=scn.options.resolution, planner=planner, view=view,
            )
            return _executed(run, hazard, other_paths)
        # focused by the bound-distance heuristic (docs/design.md §5d)
        p = view.planner(planner, roadmap.start, roadmap.goal)
        ts = time.perf_counter()
        plan = view.settle(p)
        return _searched(roadmap, view.planner_used, plan, time.perf_counter() - ts, hazard,
                         other_paths)
    finally:
        if setup.cache is not None:
            lazy.save(setup.cache)
