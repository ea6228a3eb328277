"""The write step of a run: plots, replay.html and result.json (docs/design.md §7).

result.json (:func:`result_record`, written by :func:`~mpd_pin.app.results.write_json`,
where every non-finite number is ``null``) holds:

* ``kind`` (``"energy"``), ``scenario``, ``description``, ``arm``, ``joint_names``,
  ``planner``, ``start``, ``goal`` (rad), ``world`` (as given, before any reveal);
* ``motor`` — one ``DCMotor`` or one per joint (``v_max: null`` — no voltage limit);
  ``controller`` — ``kp``, ``kd``, ``feedforward``; ``current_model`` — which current
  integration ran (``rk4``, ``exponential`` or both, per joint: docs/design.md §3e);
* ``warnings`` — one sentence per thing a reader should know before trusting the numbers
  (:func:`run_warnings`: the paper's Table 7 motor, with a pointer to the README section);
* ``roadmap`` — ``num_nodes`` (``options.num_nodes`` samples + start + goal), ``num_edges``
  (eager: the feasible directed edges; lazy: every collision-free directed edge, every
  candidate edge with lazy collision checks),
  ``evaluation`` (``lazy``/``eager``), ``edges_evaluated`` (directed edges simulated for
  planning, reused from a cache file included), ``lazy`` (``rounds``,
  ``bound_median_ratio``, ``bound_violations``, ``bound_worst_ratio``, and when lazy the
  bound's scale and the simulation counts: docs/design.md §4g), ``evaluation_notes``,
  ``edge_counts`` (directed candidates lengthened for the velocity limits, refused for
  effort, refused for not arriving: docs/design.md §4e; lazy: among the evaluated ones),
  ``options`` (``RoadmapOptions``), ``key``, ``cache`` (``path`` of the roadmap file or
  ``null``, ``reused``: loaded from it);
* ``hazard_replanning`` (``HazardResult.to_dict``: ``penalty: null`` — ∞, edges removed;
  ``penalty_floor: null`` — unused; margins ``null`` — no hazard), ``execution``
  (``ExecutionResult.to_dict``, energies unpenalised), when they ran;
* ``search`` — the first plan's ``initial_plan_seconds``, ``expansions`` (and
  ``edge_cost_reads``, the times the search read an edge's cost, also under its old name
  ``edge_evaluations``; the edges simulated are ``roadmap.edges_evaluated``);
* ``path`` — the roadmap path (``what`` says so in words: the search's node sequence,
  stop-and-go at the roadmap's edge timing; the returned motion is ``motion``):
  ``nodes``, ``configurations`` (rad), ``length_nodes``, ``node_times`` (s: the
  arm is at ``nodes[k]`` at ``node_times[k]``); ``energy_per_joint`` and ``total_energy``
  (E⁺, J, unpenalised);
* ``path`` also has ``length_rad``: Σ over its edges of ‖Δq‖₂ (rad);
* ``comparison`` (:func:`comparison_record`, docs/design.md §7c) — the shortest joint-space
  path planned the same way on distance costs: ``basis``, ``cost``, ``planner``,
  ``shortest_path`` (``nodes``, ``length_nodes``, ``length_rad``, ``energy_per_joint``,
  ``total_energy`` — roadmap E⁺, J — and their ``*_simulate_edge`` re-simulations),
  ``energy_saved_percent`` = 100·(1 − E_opt/E_shortest) (roadmap energies; ``null`` when
  E_shortest = 0), ``energy_saved_percent_simulate_edge``; with hidden obstacles also
  ``before_obstacle`` (the two initial plans, roadmap energies);
* ``feasible`` — whether the returned motion is the answer: false when no motion runs
  within ``max_duration`` (docs/design.md §9f), ``motion`` then being the fastest one
  found and ``reason`` saying why;
* ``energy_duration`` (docs/design.md §9c, §9d) — the energy–time fronts: of the motion
  returned (``returned``) and of every candidate priced, per execution (``candidates``):
  its fastest feasible duration, the velocity limits' bound, the longest duration allowed,
  the perfect-tracking ``screen`` and the ``simulated`` points as [s, J] pairs;
* ``verification`` (``Verification.to_dict``); ``replay`` (when written);
* ``seconds_per_phase`` — wall-clock seconds per phase, the roadmap's sub-phases as
  ``roadmap_<name>`` and ``roadmap_total``; ``cpu_seconds_per_phase`` and
  ``cpu_seconds_total`` — CPU seconds of this process, all its threads
  (:class:`~mpd_pin.app.timing.PhaseClock`); ``outputs`` — the files beside result.json.

Every field, with its unit, is in the JSON Schema ``mpd_pin/schemas/result.schema.json``
(docs/design.md §7e).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.current import current_model
from ..dynamics.motor import PAPER_MOTOR, DCMotor
from ..dynamics.supply import energy_by_supply
from ..motion.series import motion_series
from ..planning.roadmap import Roadmap
from .motion_step import RunMotion, path_supply_energy, roadmap_motion, roadmap_path_record
from .plan import PlanResult, Setup, path_length
from .results import to_jsonable, write_json
from .scenario import EnergyScenario
from .timing import PhaseClock
from .verify import Verification, straight_line_configurations

__all__ = [
    "REPLAY_SAMPLES",
    "replay_indices",
    "make_figures",
    "energy_comparison",
    "write_plots",
    "write_replay_html",
    "result_record",
    "comparison_record",
    "search_record",
    "path_what",
    "write_result",
    "timing_record",
    "SHORTEST_LABEL",
    "PAPER_MOTOR_SECTION",
    "run_warnings",
    "cache_record",
]

#: The README.md section (its heading) that explains the energies of the paper's motor;
#: the warning of :func:`run_warnings` points to it.
PAPER_MOTOR_SECTION = "Energies with the paper's motor"

#: The constants that make a motor "the paper's Table 7 motor" (any gear ratio, v_max).
_PAPER_CONSTANTS = ("R", "Kt", "Ke", "B")


#: The short form of the paper motor's warning, under the titles of the figures.
PAPER_MOTOR_NOTE = f'10⁴–10⁵ J from its constants; README "{PAPER_MOTOR_SECTION}"'


def _is_paper_motor(motor: DCMotor) -> bool:
    return all(getattr(motor, c) == getattr(PAPER_MOTOR, c) for c in _PAPER_CONSTANTS)


def run_warnings(scn: EnergyScenario) -> list[str]:
    """The ``warnings`` of result.json (one sentence each, also printed by ``mpd-pin run``;
    docs/design.md §7e): today one, when some joint is driven by the paper's Table 7 motor
    (R = 1 Ω, Kt = 0.01 N·m/A, Ke = 0.02 V·s/rad, B = 0.1 N·m·s/rad, any gear ratio), whose
    constants make planar-arm moves cost 10⁴–10⁵ J."""
    motors = scn.motor if isinstance(scn.motor, list) else [scn.motor] * scn.arm.nq
    joints = [n for n, m in zip(scn.arm.joint_names, motors, strict=True) if _is_paper_motor(m)]
    if not joints:
        return []
    which = "every joint" if len(joints) == len(motors) else "joint(s) " + ", ".join(joints)
    return [
        f"the paper's Table 7 motor (Kt = 0.01 N·m/A, R = 1 Ω, B = 0.1 N·m·s/rad) drives "
        f"{which}: its constants, not the planner, make energies of 10⁴–10⁵ J for a small arm; "
        f'see README.md section "{PAPER_MOTOR_SECTION}" ([motor] preset = "sized" gives '
        f"realistic motors)"
    ]


def cache_record(cache: Path | None, reused: bool) -> dict[str, Any]:
    """``roadmap.cache`` of result.json: the roadmap file (``null``: none) and whether the
    roadmap was loaded from it (``reused``) rather than built (and saved to it)."""
    from ..planning.roadmap import npz_path

    return {"path": str(npz_path(cache)) if cache is not None else None,
            "reused": bool(reused and cache is not None)}

#: Label of the shortest joint-space path in the plots and the replay.
SHORTEST_LABEL = "shortest joint-space path"

#: At most about this many samples of the simulated motion go into replay.html.
REPLAY_SAMPLES = 600


def replay_indices(n: int, target: int = REPLAY_SAMPLES) -> np.ndarray:
    """Indices of the samples (of ``n``) recorded in the replay: every ``stride``-th one
    (``stride = max(1, round(n / target))``) and always the last, so the replay ends at
    the goal. When ``n - 1`` is not on the stride grid it replaces the last grid sample
    (the final gap is then between ``stride + 1`` and ``2·stride − 1`` samples), so no gap is
    shorter than the stride and the frame rate is not raised for it."""
    if n < 1:
        raise ValueError(f"need at least one sample, got {n}")
    stride = max(1, int(round(n / target)))
    idx = np.arange(0, n, stride)
    if idx[-1] != n - 1:
        if len(idx) > 1:
            idx[-1] = n - 1
        else:
            idx = np.array([0, n - 1])
    return idx


def make_figures(
    scn: EnergyScenario,
    setup: Setup,
    plan: PlanResult,
    check: Verification,
    shortest: tuple[PlanResult, Verification] | None = None,
    motion: RunMotion | None = None,
) -> dict[str, Any]:
    """The figures of a run by file name: ``path.png``, ``joint_angles.png``,
    ``energy.png`` (paper 000 Figs. 12–17); with
    ``shortest`` (its plan and re-simulation) the path figure overlays the shortest
    joint-space path (drawn once, named as both, when its nodes are the path's) and the
    energy figure compares like with like (:func:`energy_comparison`). ``check`` holds
    the series of what the arm runs; with a refined ``motion`` (docs/design.md §9f) the
    path figure shows its waypoints over the roadmap path, and ``energy_duration.png``
    its energy against duration."""
    import sys

    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:  # keep a backend already chosen (a notebook's)
        matplotlib.use("Agg", force=False)
    from ..viz.plots import (
        Detection,
        plot_arm_path,
        plot_cumulative_energy,
        plot_energy_duration,
        plot_joint_angles,
    )

    roadmap, series, path = setup.roadmap, check.series, plan.path
    t_nodes = series["node_times"]  # the arm is at path[step] at t_nodes[step]
    detections = [
        Detection(roadmap.nodes[ev.node], float(t_nodes[min(ev.step, len(t_nodes) - 1)]),
                  tuple(ev.revealed))
        for ev in (plan.execution.replans if plan.execution is not None else ())
    ]
    names = scn.arm.joint_names
    others = {k: roadmap.nodes[v] for k, v in plan.other_paths.items()}
    supply = setup.drive.supply
    refined = motion is not None and motion.refined is not None
    same = shortest is not None and list(shortest[0].path) == list(path)
    e_plan = path_supply_energy(roadmap, path, plan.energy)
    path_label = "arm at each path node"
    if shortest is not None and not same:
        sp = shortest[0]
        e_short = path_supply_energy(roadmap, sp.path, sp.energy)
        others[f"{SHORTEST_LABEL} ({e_short:.4g} J)"] = roadmap.nodes[sp.path]
    elif same and not refined:  # the path drawn is the shortest one too: say so, once
        path_label = f"arm at each path node (the path is also the {SHORTEST_LABEL})"
    Q_nodes = roadmap.nodes[path]
    title = f"{scn.name}: {e_plan:.4g} J, {len(path)} nodes"
    if refined:
        Q_nodes = motion.energy.waypoints
        also = f" = the {SHORTEST_LABEL}" if same else ""
        others[f"roadmap path (MPD* Lite, {e_plan:.4g} J){also}"] = roadmap.nodes[path]
        title = (f"{scn.name}: {motion.energy.total_energy:.4g} J {motion.energy.execution}, "
                 f"{len(Q_nodes)} waypoints")
    # the paper motor's warning (run_warnings) on every figure that shows its energies
    note = f"\n(the paper's Table 7 motor: {PAPER_MOTOR_NOTE})" if run_warnings(scn) else ""
    total_label, compare = energy_comparison(scn, setup, plan, shortest, motion)
    figs = {
        "path.png": plot_arm_path(
            scn.arm,
            setup.world,
            Q_nodes,
            Q_motion=series["q"],
            other_paths=others,
            node_times=t_nodes,
            detections=detections,
            title=title + note,
            path_label=path_label,
        ),
        "joint_angles.png": plot_joint_angles(
            series["t"], series["q"], names, node_times=series["node_times"]
        ),
        "energy.png": plot_cumulative_energy(
            series["t"], series["energy_t"], names, compare=compare, total_label=total_label,
            supply=None if supply.is_default else (_drawn(supply, series),
                                                   _supply_label(supply)),
            title=("cumulative electrical energy per joint" + note) if note else "",
            marks=[(d.t, "replan: " + ", ".join(repr(n) for n in d.names) + " sensed")
                   for d in detections],
        ),
    }
    fronts = _duration_fronts(motion)
    if fronts is not None:
        rows, returned, cap = fronts
        figs["energy_duration.png"] = plot_energy_duration(rows, returned, max_duration=cap,
                                                           title=scn.name + note)
    return figs


def _same_motion(a, b) -> bool:
    """Whether two :class:`~mpd_pin.motion.MotionEnergy` are one motion (same execution,
    waypoints and piece durations)."""
    if a is b:
        return True
    return (a.execution == b.execution and a.waypoints.shape == b.waypoints.shape
            and bool(np.array_equal(a.waypoints, b.waypoints))
            and bool(np.array_equal(np.asarray(a.piece_durations, float),
                                    np.asarray(b.piece_durations, float)))
            and (a.curve is None) == (b.curve is None))


def energy_comparison(
    scn: EnergyScenario,
    setup: Setup,
    plan: PlanResult,
    shortest: tuple[PlanResult, Verification] | None,
    motion: RunMotion | None,
) -> tuple[str, list[tuple[np.ndarray, np.ndarray, str]]]:
    """What ``energy.png`` compares, like with like (docs/design.md §7c, §9f): (the name of
    the figure's own total, the compared totals as (t (s), cumulative supply energy (J),
    name)).

    * a refined motion and the shortest path refined the same way
      (``RunMotion.shortest``): the returned motion against that motion (its series
      simulated here), or nothing when it is the returned motion itself, the total then
      saying so;
    * the roadmap path returned as it is (no refinement; or no ``motion``): the roadmap
      path against the shortest roadmap path (the comparison's re-simulation), or nothing
      when their nodes are the same;
    * a refined motion without a refined shortest path (none within ``max_duration``): the
      returned motion alone, and the two roadmap paths (energy optimum, simulated here
      stop-and-go, and shortest), each unrefined, against each other."""
    supply = setup.drive.supply
    if motion is not None and motion.refined is not None:
        returned = f"returned motion, {motion.energy.execution}"
        sm = motion.shortest
        if sm is not None:
            if _same_motion(sm, motion.energy):
                return (f"{returned}; the {SHORTEST_LABEL} refined the same way is this "
                        "motion"), []
            ss = motion_series(setup.drive, sm, scn.options.dt)
            return returned, [(ss["t"], _drawn(supply, ss),
                               f"{SHORTEST_LABEL} refined the same way, {sm.execution}")]
        if shortest is None:
            return returned, []
        sc = shortest[1]  # the optimum as a stop-and-go motion, its edges in one batch
        opt = motion_series(setup.drive, roadmap_motion(setup.drive, setup, plan, None),
                            scn.options.dt)  # (roadmap_motion does not read its check)
        return (f"{returned}; no {SHORTEST_LABEL} refined the same way to compare with"), [
            (opt["t"], _drawn(supply, opt), "energy-optimal roadmap path, unrefined, "
                                             "stop-and-go"),
            (sc.series["t"], _drawn(supply, sc.series),
             f"{SHORTEST_LABEL} on the roadmap, unrefined, stop-and-go")]
    optimum = "energy-optimal roadmap path, stop-and-go"
    if shortest is None:
        return optimum, []
    sp, sc = shortest
    if list(sp.path) == list(plan.path):
        return f"{optimum}; it is also the {SHORTEST_LABEL}", []
    return optimum, [(sc.series["t"], _drawn(supply, sc.series),
                      f"{SHORTEST_LABEL} on the roadmap, stop-and-go")]


def _drawn(supply, series: dict[str, np.ndarray]) -> np.ndarray:
    """The cumulative energy drawn from ``supply`` (J) along a series (§3i)."""
    if supply.is_default:
        return series["energy_t"].sum(axis=1)
    bus = series["bus_energy_t"]
    return bus[:, 0] - supply.regeneration * bus[:, 1]


def _supply_label(supply) -> str:
    eta = supply.regeneration
    return "shared bus" + (f", {eta:.0%} regenerated" if eta else "")


def write_plots(out_dir: Path, *args: Any, **kwargs: Any) -> list[str]:
    """Save the figures of :func:`make_figures` (same arguments after ``out_dir``) into
    ``out_dir`` (110 dpi) and close them; returns the file names."""
    import matplotlib.pyplot as plt

    figs = make_figures(*args, **kwargs)
    for fname, fig in figs.items():
        fig.savefig(out_dir / fname, dpi=110)
        plt.close(fig)
    return list(figs)


def _duration_fronts(motion: RunMotion | None):
    """(the candidates' fronts, the motion returned, max_duration) of result.json
    ``energy_duration``
    for ``energy_duration.png``: a refined motion with at least one non-stop front
    searched; else None."""
    if motion is None or motion.refined is None or motion.energy_duration is None:
        return None
    record = motion.energy_duration
    rows = record["candidates"]
    if not any(r["nonstop"] is not None and r["nonstop"]["screen"] for r in rows):
        return None
    return rows, record["returned"], record["max_duration"]


def write_replay_html(
    out_dir: Path,
    scn: EnergyScenario,
    setup: Setup,
    plan: PlanResult,
    check: Verification,
    shortest: PlanResult | None = None,
    motion: RunMotion | None = None,
) -> dict[str, Any]:
    """``replay.html``: about :data:`REPLAY_SAMPLES` samples of the simulated motion, hidden
    obstacles switched on when they were revealed, end-effector traces of the plans not
    followed, of the ``shortest`` joint-space path (when given) and of the motion. Returns
    the ``replay`` entry of result.json (times in s)."""
    from ..viz.plots import ee_trace
    from ..viz.replay import write_replay

    series = check.series
    reveal = {}
    if plan.execution is not None:
        t_nodes = series["node_times"]  # the arm is at travelled[step] at t_nodes[step]
        for ev in plan.execution.replans:
            for name in ev.revealed:
                reveal[name] = float(t_nodes[min(ev.step, len(t_nodes) - 1)])
    idx = replay_indices(len(series["t"]), REPLAY_SAMPLES)
    t_rep, q_rep = series["t"][idx], series["q"][idx]
    roadmap, resolution = setup.roadmap, scn.options.resolution
    lines = {  # plans not followed (straight joint-space edges), then the motion
        f"end effector ({name})": ee_trace(
            scn.arm, straight_line_configurations(roadmap, nodes, resolution, scn.arm)
        )
        for name, nodes in plan.other_paths.items()
    }
    if shortest is not None:
        lines[f"end effector ({SHORTEST_LABEL})"] = ee_trace(
            scn.arm, straight_line_configurations(roadmap, shortest.path, resolution, scn.arm)
        )
    if motion is not None and motion.refined is not None:
        lines["end effector (roadmap path)"] = ee_trace(
            scn.arm, straight_line_configurations(roadmap, plan.path, resolution, scn.arm)
        )
    lines["end effector (travelled)"] = ee_trace(scn.arm, q_rep)  # drawn last: on top
    write_replay(
        scn.arm,
        setup.world,
        t_rep,
        q_rep,
        out_dir / "replay.html",
        reveal_times=reveal,
        paths=lines,
        grow=["end effector (travelled)"],  # grows with the motion; the plans are drawn whole
        title=scn.name,
    )
    return {
        "samples": len(idx),
        "sample_indices": idx,  # into the simulated motion (step dt)
        "times": t_rep,
        "reveal_times": reveal,
        "paths": list(lines),
    }


def _roadmap_record(
    scn: EnergyScenario, setup: Setup, cache: dict[str, Any] | None
) -> dict[str, Any]:
    roadmap, lazy = setup.roadmap, setup.lazy
    counts = dict(roadmap.edge_counts)  # lengthened / refused directed candidates
    refused = counts.get("refused_effort", 0) + counts.get("refused_arrival", 0)
    if lazy is None:  # eager: the feasible edges; every candidate was simulated
        num_edges, evaluated = roadmap.num_edges, roadmap.num_edges + refused
        lazy_rec: dict[str, Any] = {"rounds": 0, "bound_median_ratio": None,
                                    "bound_violations": 0, "bound_worst_ratio": None}
    else:  # lazy: every collision-free (lazy checks: candidate) directed edge, refused included
        dropped = refused - lazy.count.refused  # refused in an earlier run, not in the arrays
        num_edges, evaluated = roadmap.num_edges + dropped, lazy.edges_evaluated + dropped
        lazy_rec = lazy.record()
    pairs = roadmap.pairs_checked + (lazy.count.pairs_checked if lazy is not None else 0)
    return {
        "num_nodes": roadmap.num_nodes,  # options.num_nodes samples + start + goal
        "num_edges": num_edges,
        "evaluation": setup.evaluation,
        "collision": setup.collision,
        "edges_checked": 2 * int(pairs),  # directed: both directions of each pair checked
        "edges_evaluated": evaluated,
        "lazy": lazy_rec,
        "evaluation_notes": list(setup.notes),
        "edge_counts": counts,
        "chunks_reused": int(roadmap.chunks_reused),  # from an interrupted build (§4h)
        "options": asdict(scn.options),
        "key": roadmap.key,
        "cache": cache if cache is not None else cache_record(None, False),
    }


def roadmap_timings(setup: Setup) -> dict[str, float]:
    """The roadmap's own sub-phases (wall-clock s): its build's timings and, for a lazy
    run, the seconds the searches spent simulating edges and bounding them (docs/design.md
    §4g). A new dict; neither the setup nor its roadmap is changed."""
    timings = dict(setup.roadmap.timings)
    if setup.lazy is not None:  # lazy: simulated during the searches
        timings["edge_energies"] = setup.lazy.count.simulate_seconds
        timings["edge_bounds"] = setup.lazy.bound_seconds
    return timings


def timing_record(timings: dict[str, float], clock: PhaseClock) -> dict[str, Any]:
    """result.json's seconds per phase (wall-clock), with the roadmap's sub-phases
    ``timings`` (:func:`roadmap_timings`) beside them, and the CPU seconds per phase."""
    wall = {f"roadmap_{k}": v for k, v in timings.items()}
    wall["roadmap_total"] = clock.wall["roadmap"]
    wall.update({k: v for k, v in clock.wall.items() if k != "roadmap"})
    return {
        "seconds_per_phase": wall,
        "cpu_seconds_per_phase": dict(clock.cpu),  # this process, all its threads
        "cpu_seconds_total": clock.cpu["total"],
    }


def result_record(
    scn: EnergyScenario,
    setup: Setup,
    plan: PlanResult,
    check: Verification,
    replay: dict[str, Any] | None,
    clock: PhaseClock,
    comparison: dict[str, Any] | None = None,
    cache: dict[str, Any] | None = None,
    motion: RunMotion | None = None,
) -> dict[str, Any]:
    """The content of result.json (see the module docstring), not yet encoded;
    ``comparison`` from :func:`comparison_record`, ``cache`` from :func:`cache_record`;
    with ``motion`` (docs/design.md §9f) the totals are the returned motion's and
    ``roadmap_path`` holds the MPD* Lite path behind it."""
    motor = scn.motor
    record: dict[str, Any] = {
        "kind": scn.kind,
        "scenario": scn.name,
        "description": scn.description,
        "warnings": run_warnings(scn),
        "arm": scn.arm.name,
        "joint_names": scn.arm.joint_names,
        "locked_joints": scn.arm.locked_joints,
        "motor": [asdict(m) for m in motor] if isinstance(motor, list) else asdict(motor),
        "controller": {"kp": scn.kp, "kd": scn.kd, "feedforward": scn.feedforward},
        "current_model": current_model(setup.drive, scn.options.dt),
        "roadmap": _roadmap_record(scn, setup, cache),
        "compute": dict(setup.compute),
        "planner": scn.planner,
        "start": scn.start,
        "goal": scn.goal,
        "world": setup.world_record,
    }
    if plan.hazard is not None:
        record["hazard_replanning"] = plan.hazard.to_dict()
    if plan.execution is not None:
        record["execution"] = plan.execution.to_dict()
    record["search"] = search_record(plan.search)
    record["path"] = {
        "what": path_what(plan, motion),
        "nodes": [int(n) for n in plan.path],
        "configurations": setup.roadmap.nodes[plan.path],
        "length_nodes": len(plan.path),
        "length_rad": path_length(setup.roadmap, plan.path, scn.arm),
        "node_times": check.series["node_times"],
    }
    record["energy_per_joint"] = plan.energy
    record["total_energy"] = path_supply_energy(setup.roadmap, plan.path, plan.energy)
    record["supply"] = setup.drive.supply.describe()
    record["energy_by_supply"] = energy_by_supply(
        check.energy_per_joint, check.bus_energy, setup.drive.supply.regeneration)
    record["feasible"] = motion is None or not motion.failure
    if motion is not None and motion.failure:
        record["reason"] = motion.failure  # the fastest motion found is over max_duration
    if motion is not None:
        record["roadmap_path"] = roadmap_path_record(setup, plan, scn.arm)
        record["motion"] = motion.record()
        if motion.energy_duration is not None:
            record["energy_duration"] = motion.energy_duration
        record["energy_per_joint"] = motion.energy.energy_per_joint
        record["total_energy"] = float(motion.energy.total_energy)
        record["energy_by_supply"] = motion.energy.energy_by_supply()
    if comparison is not None:
        record["comparison"] = comparison
    if check.checked:  # the verify step ran ([run] verify, §7c)
        record["verification"] = check.to_dict()
    if replay is not None:
        record["replay"] = replay
    record.update(timing_record(roadmap_timings(setup), clock))
    return record


def search_record(search: dict[str, Any]) -> dict[str, Any]:
    """``search`` of result.json: the first plan's counters as the planner gave them, and
    ``edge_cost_reads`` — the new name of ``edge_evaluations`` (kept for old readers): how
    many times the search read an edge's cost (the same edge counted each time, a lazy
    bound included), not how many edges were simulated (``roadmap.edges_evaluated``)."""
    out = dict(search)  # the PlanResult's own dict stays as it is
    if "edge_evaluations" in out:
        out["edge_cost_reads"] = out["edge_evaluations"]
    return out


def path_what(plan: PlanResult, motion: RunMotion | None) -> str:
    """``path.what`` of result.json: one sentence saying that ``path`` is the roadmap path
    (the search's nodes, timed stop-and-go as the roadmap's edges are) and where the
    motion the arm runs is (``motion``)."""
    kind = "travelled roadmap path (executed with sensing and repair)" if (
        plan.execution is not None) else "roadmap path"
    text = (f"the {kind}: the search's node sequence, stop-and-go, each edge at the "
            "roadmap's timing (node_times)")
    if motion is None:
        return text
    if motion.refined is None:
        return text + "; the returned motion (motion) is this path as it is"
    return (text + "; the returned motion, which the arm runs, is motion (its own waypoints "
            "and node_times)")


def _saved_percent(e_opt: float, e_short: float) -> float:
    """100·(1 − e_opt/e_short) (%); NaN (``null``) when e_short is 0."""
    return 100.0 * (1.0 - e_opt / e_short) if e_short != 0.0 else float("nan")


def _path_entry(roadmap: Roadmap, nodes: list[int], arm=None) -> dict[str, Any]:
    energy = roadmap.path_energy(nodes)
    return {
        "nodes": [int(n) for n in nodes],
        "length_nodes": len(nodes),
        "length_rad": path_length(roadmap, nodes, arm),
        "energy_per_joint": energy,
        "total_energy": path_supply_energy(roadmap, nodes, energy),
    }


def comparison_record(
    scn: EnergyScenario,
    setup: Setup,
    plan: PlanResult,
    check: Verification,
    shortest: PlanResult,
    shortest_check: Verification,
) -> dict[str, Any]:
    """``comparison`` of result.json (module docstring; docs/design.md §7c): the
    energy-optimal path ``plan`` against the shortest joint-space path ``shortest``."""
    roadmap = setup.roadmap
    if plan.execution is not None:
        basis = "executed"
    elif plan.hazard is not None:
        basis = "hazard re-planned"
    else:
        basis = "planned"
    entry = _path_entry(roadmap, shortest.path, scn.arm)
    e_opt = path_supply_energy(roadmap, plan.path, plan.energy)
    out: dict[str, Any] = {
        "basis": basis,
        "cost": "joint-space length: sum over edges of the Euclidean norm of q_dst - q_src (rad)",
        "planner": scn.planner,
        "shortest_path": entry,
        "energy_saved_percent": _saved_percent(e_opt, entry["total_energy"]),
    }
    if check.checked and shortest_check.checked:  # the verify step ran (§7c)
        entry["energy_per_joint_simulate_edge"] = shortest_check.energy_per_joint
        entry["total_energy_simulate_edge"] = shortest_check.total_energy
        out["energy_saved_percent_simulate_edge"] = _saved_percent(
            check.total_energy, entry["total_energy_simulate_edge"])
    if plan.execution is not None and shortest.execution is not None:
        opt0 = _path_entry(roadmap, plan.execution.initial_path, scn.arm)
        short0 = _path_entry(roadmap, shortest.execution.initial_path, scn.arm)
        out["before_obstacle"] = {
            "optimal": opt0,
            "shortest_path": short0,
            "energy_saved_percent": _saved_percent(
                opt0["total_energy"], short0["total_energy"]
            ),
        }
    return out


def add_motion_comparison(comparison: dict[str, Any], motion: RunMotion) -> None:
    """Add the shortest path refined and priced as the motion was (docs/design.md §9f) to
    ``comparison``: ``refined_shortest_path`` and ``motion_energy_saved_percent``."""
    if motion.shortest is None:
        return
    sm = motion.shortest
    comparison["refined_shortest_path"] = {
        "execution": sm.execution,
        "waypoints": int(sm.waypoints.shape[0]),
        "duration": float(sm.duration),
        "energy_per_joint": sm.energy_per_joint,
        "total_energy": float(sm.total_energy),
    }
    comparison["motion_energy_saved_percent"] = _saved_percent(
        float(motion.energy.total_energy), float(sm.total_energy))


def write_result(out_dir: Path, record: dict[str, Any]) -> dict[str, Any]:
    """Add ``outputs`` (the files already in ``out_dir``) to ``record`` and write it to
    ``out_dir/result.json`` atomically; returns the encoded record, as written."""
    record = {**record, "outputs": sorted(p.name for p in out_dir.iterdir())}
    doc = to_jsonable(record)
    write_json(out_dir / "result.json", doc)
    return doc
