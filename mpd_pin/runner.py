"""Run a paper-000 scenario end to end: roadmap, plan, replanning, verification, outputs.

:func:`run_energy_scenario` writes into ``out_dir``:

* ``result.json`` — energies per joint and total (J), the path (node ids and
  configurations), roadmap size, time per phase (wall-clock s) and total CPU
  time (s), replans, hazard
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

from .collision import CollisionChecker
from .energy import simulate_edge
from .execution import execute, plan_avoiding_hazards
from .roadmap import EnergyCost, Roadmap, build_roadmap
from .scenario import EnergyScenario
from .search import AStar, Dijkstra, DStarLite, MPDStarLite

__all__ = ["run_energy_scenario", "PLANNERS", "simulate_path"]

PLANNERS = {"mpdstar": MPDStarLite, "dstar": DStarLite, "astar": AStar, "dijkstra": Dijkstra}


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


def _json(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _json(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else ("inf" if f > 0 else "-inf" if f < 0 else "nan")
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


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

    from .plots import plot_arm_path, plot_cumulative_energy, plot_joint_angles

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cpu: dict[str, float] = {}
    t_all = time.perf_counter()
    cpu_all = time.process_time()
    drive = scn.drive()
    world = scn.world
    world.reset()
    checker = CollisionChecker(scn.arm, world)
    cost = EnergyCost(drive, scn.options.dt)
    roadmap = build_roadmap(
        cost, checker, scn.start, scn.goal, scn.options, cache=cache, show_progress=show_progress
    )
    cpu.update({f"roadmap_{k}": v for k, v in roadmap.timings.items()})
    cpu["roadmap_total"] = time.perf_counter() - t_all
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

    t0 = time.perf_counter()
    hazard = None
    other_paths: dict[str, np.ndarray] = {}
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
            other_paths["cheapest path (too close to a hazard)"] = roadmap.nodes[hazard.first_path]
        if hazard.penalised:  # plan on with the offending edges removed/penalised
            pen = {tuple(p) for p in hazard.penalised}
            mask = np.array(
                [
                    (min(u, v), max(u, v)) in pen
                    for u, v in zip(roadmap.src.tolist(), roadmap.dst.tolist(), strict=True)
                ]
            )
            factor = scn.hazard_penalty
            energy = roadmap.energy.copy()
            energy[mask] = energy[mask] * factor if math.isfinite(factor) else math.inf
            roadmap = replace(roadmap, energy=energy)
    if world.hidden_names():
        run = execute(
            roadmap,
            checker,
            sensor_range=float(scn.sensor_range),
            resolution=scn.options.resolution,
            planner=planner_cls,
        )
        path = run.travelled
        result["execution"] = run.to_dict()
        if run.initial_path != run.travelled:
            other_paths["initial plan (before the new obstacle)"] = roadmap.nodes[run.initial_path]
        result["search"] = {
            "initial_plan_seconds": run.initial_plan_seconds,
            "expansions": run.initial_expansions,
        }
    else:
        p = planner_cls(roadmap.graph(), roadmap.start, roadmap.goal)
        ts = time.perf_counter()
        plan = p.plan()
        result["search"] = {
            "initial_plan_seconds": time.perf_counter() - ts,
            "expansions": p.stats.expansions,
            "edge_evaluations": p.stats.edge_evaluations,
        }
        path = list(plan.nodes)
    cpu["search"] = time.perf_counter() - t0

    energy = roadmap.path_energy(path)
    result["path"] = {
        "nodes": [int(n) for n in path],
        "configurations": roadmap.nodes[path],
        "length_nodes": len(path),
    }
    result["energy_per_joint"] = energy
    result["total_energy"] = float(energy.sum())

    t0 = time.perf_counter()
    series = simulate_path(drive, roadmap, path, scn.options.dt)
    cpu["verification"] = time.perf_counter() - t0
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

    t0 = time.perf_counter()
    names = scn.arm.joint_names
    figs = {
        "path.png": plot_arm_path(
            scn.arm,
            world,
            roadmap.nodes[path],
            Q_motion=series["q"],
            other_paths=other_paths,
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
    cpu["plots"] = time.perf_counter() - t0

    if replay:
        from .replay import write_replay

        t0 = time.perf_counter()
        reveal = {}
        if "execution" in result:
            t_nodes = series["node_times"]  # the arm is at travelled[step] at t_nodes[step]
            for ev in result["execution"]["replans"]:
                for name in ev["revealed"]:
                    reveal[name] = float(t_nodes[min(ev["step"], len(t_nodes) - 1)])
        stride = max(1, int(round(len(series["t"]) / 600)))
        write_replay(
            scn.arm,
            world,
            series["t"][::stride],
            series["q"][::stride],
            out_dir / "replay.html",
            reveal_times=reveal,
            title=scn.name,
        )
        cpu["replay"] = time.perf_counter() - t0
    cpu["total"] = time.perf_counter() - t_all
    result["seconds_per_phase"] = cpu  # wall-clock seconds (Pinocchio batches use all cores)
    result["cpu_seconds_total"] = time.process_time() - cpu_all
    result["outputs"] = sorted(p.name for p in out_dir.iterdir())
    with open(out_dir / "result.json", "w", encoding="utf-8") as f:
        json.dump(_json(result), f, indent=1)
    return result
