"""The write step of a run: plots, replay.html and result.json (docs/design.md §7).

result.json (:func:`result_record`, written by :func:`~mpd_pin.app.results.write_json`,
where every non-finite number is ``null``) holds:

* ``scenario``, ``description``, ``arm``, ``joint_names``, ``planner``, ``start``, ``goal``
  (rad), ``world`` (as given, before any reveal);
* ``motor`` — one ``DCMotor`` or one per joint (``v_max: null`` — no voltage limit);
  ``controller`` — ``kp``, ``kd``, ``feedforward``; ``current_model`` — which current
  integration ran (``rk4``, ``exponential`` or both, per joint: docs/design.md §3e);
* ``roadmap`` — ``num_nodes``, ``num_edges``, ``edge_counts`` (directed candidates
  lengthened for the velocity limits, refused for effort, refused for not arriving:
  docs/design.md §4e), ``options`` (``RoadmapOptions``), ``key``;
* ``hazard_replanning`` (``HazardResult.to_dict``: ``penalty: null`` — ∞, edges removed;
  ``penalty_floor: null`` — unused; margins ``null`` — no hazard), ``execution``
  (``ExecutionResult.to_dict``, energies unpenalised), when they ran;
* ``search`` — the first plan's ``initial_plan_seconds``, ``expansions`` (and
  ``edge_evaluations``);
* ``path`` — ``nodes``, ``configurations`` (rad), ``length_nodes``, ``node_times`` (s: the
  arm is at ``nodes[k]`` at ``node_times[k]``); ``energy_per_joint`` and ``total_energy``
  (E⁺, J, unpenalised);
* ``verification`` (``Verification.to_dict``); ``replay`` (when written);
* ``seconds_per_phase`` — wall-clock seconds per phase, the roadmap's sub-phases as
  ``roadmap_<name>`` and ``roadmap_total``; ``cpu_seconds_per_phase`` and
  ``cpu_seconds_total`` — CPU seconds of this process, all its threads
  (:class:`~mpd_pin.app.timing.PhaseClock`); ``outputs`` — the files beside result.json.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.simulate import current_model
from ..planning.roadmap import Roadmap
from .plan import PlanResult, Setup
from .results import to_jsonable, write_json
from .scenario import EnergyScenario
from .timing import PhaseClock
from .verify import Verification, straight_line_configurations

__all__ = [
    "REPLAY_SAMPLES",
    "replay_indices",
    "write_plots",
    "write_replay_html",
    "result_record",
    "write_result",
]

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


def write_plots(
    out_dir: Path, scn: EnergyScenario, setup: Setup, plan: PlanResult, check: Verification
) -> None:
    """``path.png``, ``joint_angles.png``, ``energy.png`` (paper 000 Figs. 12–17)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..viz.plots import plot_arm_path, plot_cumulative_energy, plot_joint_angles

    roadmap, series, path = setup.roadmap, check.series, plan.path
    names = scn.arm.joint_names
    figs = {
        "path.png": plot_arm_path(
            scn.arm,
            setup.world,
            roadmap.nodes[path],
            Q_motion=series["q"],
            other_paths={k: roadmap.nodes[v] for k, v in plan.other_paths.items()},
            title=f"{scn.name}: {float(plan.energy.sum()):.4g} J, {len(path)} nodes",
        ),
        "joint_angles.png": plot_joint_angles(
            series["t"], series["q"], names, node_times=series["node_times"]
        ),
        "energy.png": plot_cumulative_energy(series["t"], series["energy_t"], names),
    }
    for fname, fig in figs.items():
        fig.savefig(out_dir / fname, dpi=110)
        plt.close(fig)


def write_replay_html(
    out_dir: Path, scn: EnergyScenario, setup: Setup, plan: PlanResult, check: Verification
) -> dict[str, Any]:
    """``replay.html``: about :data:`REPLAY_SAMPLES` samples of the simulated motion, hidden
    obstacles switched on when they were revealed, end-effector traces of the plans not
    followed and of the motion. Returns the ``replay`` entry of result.json (times in s)."""
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
            scn.arm, straight_line_configurations(roadmap, nodes, resolution)
        )
        for name, nodes in plan.other_paths.items()
    }
    lines["end effector (travelled)"] = ee_trace(scn.arm, q_rep)  # drawn last: on top
    write_replay(
        scn.arm,
        setup.world,
        t_rep,
        q_rep,
        out_dir / "replay.html",
        reveal_times=reveal,
        paths=lines,
        title=scn.name,
    )
    return {
        "samples": len(idx),
        "sample_indices": idx,  # into the simulated motion (step dt)
        "times": t_rep,
        "reveal_times": reveal,
        "paths": list(lines),
    }


def _roadmap_record(scn: EnergyScenario, roadmap: Roadmap) -> dict[str, Any]:
    return {
        "num_nodes": roadmap.num_nodes,
        "num_edges": roadmap.num_edges,
        "edge_counts": dict(roadmap.edge_counts),  # lengthened / refused directed candidates
        "options": asdict(scn.options),
        "key": roadmap.key,
    }


def _timing_record(roadmap: Roadmap, clock: PhaseClock) -> dict[str, Any]:
    # Wall-clock seconds per phase; the roadmap's own sub-phases (wall-clock) beside them.
    wall = {f"roadmap_{k}": v for k, v in roadmap.timings.items()}
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
) -> dict[str, Any]:
    """The content of result.json (see the module docstring), not yet encoded."""
    motor = scn.motor
    record: dict[str, Any] = {
        "scenario": scn.name,
        "description": scn.description,
        "arm": scn.arm.name,
        "joint_names": scn.arm.joint_names,
        "locked_joints": scn.arm.locked_joints,
        "motor": [asdict(m) for m in motor] if isinstance(motor, list) else asdict(motor),
        "controller": {"kp": scn.kp, "kd": scn.kd, "feedforward": scn.feedforward},
        "current_model": current_model(setup.drive, scn.options.dt),
        "roadmap": _roadmap_record(scn, setup.roadmap),
        "planner": scn.planner,
        "start": scn.start,
        "goal": scn.goal,
        "world": setup.world_record,
    }
    if plan.hazard is not None:
        record["hazard_replanning"] = plan.hazard.to_dict()
    if plan.execution is not None:
        record["execution"] = plan.execution.to_dict()
    record["search"] = plan.search
    record["path"] = {
        "nodes": [int(n) for n in plan.path],
        "configurations": setup.roadmap.nodes[plan.path],
        "length_nodes": len(plan.path),
        "node_times": check.series["node_times"],
    }
    record["energy_per_joint"] = plan.energy
    record["total_energy"] = float(plan.energy.sum())
    record["verification"] = check.to_dict()
    if replay is not None:
        record["replay"] = replay
    record.update(_timing_record(setup.roadmap, clock))
    return record


def write_result(out_dir: Path, record: dict[str, Any]) -> dict[str, Any]:
    """Add ``outputs`` (the files already in ``out_dir``) to ``record`` and write it to
    ``out_dir/result.json`` atomically; returns the encoded record, as written."""
    record = {**record, "outputs": sorted(p.name for p in out_dir.iterdir())}
    doc = to_jsonable(record)
    write_json(out_dir / "result.json", doc)
    return doc
