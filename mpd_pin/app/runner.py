"""Run a paper-000 scenario end to end: roadmap, plan, replanning, verification, outputs.

:func:`run_energy_scenario` writes into ``out_dir``:

* ``result.json`` — energies per joint and total (J), the path (node ids and
  configurations), roadmap size, time per phase — wall-clock seconds
  (``seconds_per_phase``) and CPU seconds of this process, all its threads
  (``cpu_seconds_per_phase``, :func:`time.process_time`) — replans, hazard
  re-planning, and a verification of the path energy by :func:`simulate_edge`;
* ``path.png``, ``joint_angles.png``, ``energy.png`` (paper Figs. 12–17);
* ``replay.html`` — a self-contained meshcat recording of the motion.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..collision.checker import CollisionChecker, edge_configurations
from ..dynamics import EnergyCost
from ..dynamics.simulate import simulate_edge
from ..planning.execution import execute, penalised_cost, plan_avoiding_hazards
from ..planning.roadmap import Roadmap, build_roadmap
from ..search import PLANNERS
from .results import to_jsonable
from .scenario import EnergyScenario
from .timing import PhaseClock

__all__ = [
    "run_energy_scenario",
    "PLANNERS",
    "simulate_path",
    "replay_indices",
    "penalised_roadmap",
    "PhaseClock",
]



def simulate_path(drive, roadmap: Roadmap, path: list[int], dt: float) -> dict[str, np.ndarray]:
    """Simulate every edge of ``path`` with :func:`simulate_edge` and concatenate the series.

    Returns t (s), q (rad), energy_t (cumulative E⁺ per joint, J), energy per
    edge (E⁺ per joint, J) and the node times (s).
    """
    nq = drive.nq
    ids = roadmap.edge_ids(path)
    ts, qs, es = [np.zeros(1)], [roadmap.nodes[path[0]][None]], [np.zeros((1, nq))]
    per_edge = []
    t0, e0 = 0.0, np.zeros(nq)
    node_times = [0.0]
    for e in ids:
        sim = simulate_edge(
            drive,
            roadmap.nodes[roadmap.src[e]],
            roadmap.nodes[roadmap.dst[e]],
            float(roadmap.durations[e]),
            dt,
        )
        ts.append(t0 + sim.t[1:])
        qs.append(sim.q[1:])
        es.append(e0 + sim.energy_t[1:])
        per_edge.append(sim.energy)
        t0 += float(sim.t[-1])
        e0 = e0 + sim.energy
        node_times.append(t0)
    return {
        "t": np.concatenate(ts),
        "q": np.concatenate(qs),
        "energy_t": np.concatenate(es),
        "edge_energy": np.array(per_edge).reshape(len(ids), nq),
        "node_times": np.array(node_times),
    }


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


def penalised_roadmap(roadmap: Roadmap, pairs, penalty: float, floor: float = 0.0) -> Roadmap:
    """A copy of ``roadmap`` in which the edges between the undirected node pairs ``pairs``
    (both directions) cost what :func:`~mpd_pin.execution.plan_avoiding_hazards` makes them
    cost: ``penalised_cost(cost, penalty, floor)`` (∞ removes them). Each such edge's
    per-joint energies are scaled (or, for a zero-cost edge, raised evenly) so that their
    sum is the penalised cost. Only for planning: report energies from the original."""
    pen = {(min(u, v), max(u, v)) for u, v in pairs}
    energy = np.array(roadmap.energy, dtype=float, copy=True)
    nq = energy.shape[1]
    for e, (u, v) in enumerate(zip(roadmap.src.tolist(), roadmap.dst.tolist(), strict=True)):
        if (min(u, v), max(u, v)) not in pen:
            continue
        cost = float(energy[e].sum())
        target = float(penalised_cost(cost, penalty, floor))
        if not math.isfinite(target):
            energy[e] = math.inf
        elif cost > 0.0:
            energy[e] *= target / cost
        else:
            energy[e] += target / nq
    return replace(roadmap, energy=energy)


def straight_line_configurations(roadmap: Roadmap, nodes: list[int], resolution: float):
    """Configurations along the straight joint-space edges through ``nodes`` (the geometric
    path the quintic reference follows), ``resolution`` rad apart."""
    Q = [roadmap.nodes[nodes[0]][None]]
    for u, v in zip(nodes[:-1], nodes[1:], strict=True):
        Q.append(edge_configurations(roadmap.nodes[u], roadmap.nodes[v], resolution)[1:])
    return np.concatenate(Q)


def run_energy_scenario(
    scn: EnergyScenario,
    out_dir: Path,
    *,
    show_progress: bool = True,
    cache: Path | None = None,
    replay: bool = True,
) -> dict[str, Any]:
    """Plan ``scn`` and write result.json, the plots and replay.html into ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..viz.plots import plot_arm_path, plot_cumulative_energy, plot_joint_angles

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    clock = PhaseClock()
    with clock.phase("roadmap"):
        drive = scn.drive()
        world = scn.world
        world.reset()
        checker = CollisionChecker(scn.arm, world)
        cost = EnergyCost(drive, scn.options.dt)
        roadmap = build_roadmap(
            cost, checker, scn.start, scn.goal, scn.options, cache=cache,
            show_progress=show_progress,
        )
    planner_cls = PLANNERS[scn.planner]
    result: dict[str, Any] = {
        "scenario": scn.name,
        "description": scn.description,
        "arm": scn.arm.name,
        "joint_names": scn.arm.joint_names,
        "motor": [asdict(m) for m in scn.motor]
        if isinstance(scn.motor, list)
        else asdict(scn.motor),
        "controller": {"kp": scn.kp, "kd": scn.kd, "feedforward": scn.feedforward},
        "roadmap": {
            "num_nodes": roadmap.num_nodes,
            "num_edges": roadmap.num_edges,
            "options": asdict(scn.options),
            "key": roadmap.key,
        },
        "planner": scn.planner,
        "start": scn.start,
        "goal": scn.goal,
        "world": world.to_dict(),
    }

    hazard = None
    other_paths: dict[str, list[int]] = {}  # name → node ids, drawn for comparison
    plan_map = roadmap  # what the planner sees: hazard penalties applied; energies from roadmap
    with clock.phase("search"):
        if any(h.clearance > 0 for h in world.hazards):
            hazard = plan_avoiding_hazards(
                roadmap,
                checker,
                resolution=scn.options.resolution,
                penalty=scn.hazard_penalty,
                planner=planner_cls,
            )
            result["hazard_replanning"] = hazard.to_dict()
            if hazard.first_path != hazard.final_path:
                other_paths["cheapest path (too close to a hazard)"] = hazard.first_path
            if hazard.penalised:  # plan on with the offending edges removed/penalised
                plan_map = penalised_roadmap(
                    roadmap, hazard.penalised, hazard.penalty, hazard.penalty_floor
                )
        if world.hidden_names():
            run = execute(
                plan_map,
                checker,
                sensor_range=float(scn.sensor_range),
                resolution=scn.options.resolution,
                planner=planner_cls,
            )
            path = run.travelled
            result["execution"] = run.to_dict()
            # The planner's costs may carry hazard penalties; energies are the roadmap's own.
            travelled_energy = roadmap.path_energy(run.travelled)
            result["execution"]["energy_per_joint"] = travelled_energy
            result["execution"]["total_energy"] = float(travelled_energy.sum())
            if run.initial_path != run.travelled:
                other_paths["initial plan (before the new obstacle)"] = run.initial_path
            result["search"] = {
                "initial_plan_seconds": run.initial_plan_seconds,
                "expansions": run.initial_expansions,
            }
        else:
            p = planner_cls(plan_map.graph(), roadmap.start, roadmap.goal)
            ts = time.perf_counter()
            plan = p.plan()
            result["search"] = {
                "initial_plan_seconds": time.perf_counter() - ts,
                "expansions": p.stats.expansions,
                "edge_evaluations": p.stats.edge_evaluations,
            }
            # With hazards the path is the re-planned one (penalised costs); else the plan.
            path = list(hazard.final_path) if hazard is not None else list(plan.nodes)

    energy = roadmap.path_energy(path)  # unpenalised E⁺ per joint (J)

    with clock.phase("verification"):
        series = simulate_path(drive, roadmap, path, scn.options.dt)
    result["path"] = {
        "nodes": [int(n) for n in path],
        "configurations": roadmap.nodes[path],
        "length_nodes": len(path),
        "node_times": series["node_times"],  # s: the arm is at nodes[k] at node_times[k]
    }
    result["energy_per_joint"] = energy
    result["total_energy"] = float(energy.sum())
    recomputed = series["edge_energy"].sum(axis=0)
    result["verification"] = {
        "energy_per_joint_simulate_edge": recomputed,
        "max_relative_difference": float(
            np.max(np.abs(recomputed - energy) / np.maximum(np.abs(energy), 1e-300))
        )
        if len(path) > 1
        else 0.0,
        "duration": float(series["t"][-1]),
    }

    with clock.phase("plots"):
        names = scn.arm.joint_names
        figs = {
            "path.png": plot_arm_path(
                scn.arm,
                world,
                roadmap.nodes[path],
                Q_motion=series["q"],
                other_paths={k: roadmap.nodes[v] for k, v in other_paths.items()},
                title=f"{scn.name}: {result['total_energy']:.4g} J, {len(path)} nodes",
            ),
            "joint_angles.png": plot_joint_angles(
                series["t"], series["q"], names, node_times=series["node_times"]
            ),
            "energy.png": plot_cumulative_energy(series["t"], series["energy_t"], names),
        }
        for fname, fig in figs.items():
            fig.savefig(out_dir / fname, dpi=110)
            plt.close(fig)

    if replay:
        from ..viz.plots import ee_trace
        from ..viz.replay import write_replay

        with clock.phase("replay"):
            reveal = {}
            if "execution" in result:
                t_nodes = series["node_times"]  # the arm is at travelled[step] at t_nodes[step]
                for ev in result["execution"]["replans"]:
                    for name in ev["revealed"]:
                        reveal[name] = float(t_nodes[min(ev["step"], len(t_nodes) - 1)])
            idx = replay_indices(len(series["t"]), REPLAY_SAMPLES)
            t_rep, q_rep = series["t"][idx], series["q"][idx]
            lines = {  # plans not followed (straight joint-space edges), then the motion
                f"end effector ({name})": ee_trace(
                    scn.arm, straight_line_configurations(roadmap, nodes, scn.options.resolution)
                )
                for name, nodes in other_paths.items()
            }
            lines["end effector (travelled)"] = ee_trace(scn.arm, q_rep)  # drawn last: on top
            write_replay(
                scn.arm,
                world,
                t_rep,
                q_rep,
                out_dir / "replay.html",
                reveal_times=reveal,
                paths=lines,
                title=scn.name,
            )
            result["replay"] = {
                "samples": len(idx),
                "sample_indices": idx,  # into the simulated motion (step dt)
                "times": t_rep,
                "reveal_times": reveal,
                "paths": list(lines),
            }
    clock.finish()
    # Wall-clock seconds per phase; the roadmap's own sub-phases (wall-clock) beside them.
    wall = {f"roadmap_{k}": v for k, v in roadmap.timings.items()}
    wall["roadmap_total"] = clock.wall["roadmap"]
    wall.update({k: v for k, v in clock.wall.items() if k != "roadmap"})
    result["seconds_per_phase"] = wall
    # CPU seconds of this process (all its threads) per phase and in total.
    result["cpu_seconds_per_phase"] = dict(clock.cpu)
    result["cpu_seconds_total"] = clock.cpu["total"]
    result["outputs"] = sorted(p.name for p in out_dir.iterdir())
    with open(out_dir / "result.json", "w", encoding="utf-8") as f:
        json.dump(to_jsonable(result), f, indent=1)
    return result
