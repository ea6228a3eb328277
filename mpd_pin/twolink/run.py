"""End-to-end run of a ``dynamic2link`` scenario: plan, write ``result.json`` and the plots.

``mpd-pin run env1 --out DIR`` dispatches here (scenario kind
``"dynamic2link"``). Files written in DIR:

* ``result.json`` — see :func:`run_dynamic_scenario`;
* ``fcs.png`` — FCS maps (elbow down / up / both) at selected samples, with the D* and
  the PSO paths (paper Fig. 5 / 11);
* ``paths.png`` — D* vs PSO end-effector paths and the PSO cost curve (Fig. 7 / 13);
* ``dstar_motion.png``, ``pso_motion.png`` — arm snapshots (Figs. 6, 8 / 12, 14);
* ``joint_angles.png``, ``joint_changes.png`` — Figs. 9–10 / 15–16;
* ``obstacles.png`` — obstacle motion (Fig. 4).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..app.results import to_jsonable, write_json
from ..app.timing import PhaseClock
from .ik import BRANCHES
from .planner import DynamicPlanResult, plan_dynamic
from .scenario import DynamicScenario, parse_dynamic_scenario

__all__ = [
    "run_dynamic_scenario",
    "result_dict",
    "default_fcs_samples",
    "capsule_clearance",
    "peak_joint_speed",
]


def default_fcs_samples(res: DynamicPlanResult, n: int = 5) -> list[int]:
    """Start, the first stop/backward events, and the last sample (at most ``n``)."""
    K = res.motion.points.shape[0] - 1
    picks = [0]
    for e in res.dstar.events:
        if e["type"] in ("stop", "backward") and e["sample"] not in picks:
            picks.append(int(e["sample"]))
        if len(picks) >= n - 1:
            break
    if len(picks) < n - 1:
        extra = np.linspace(0, K, n - len(picks) + 1).round().astype(int).tolist()
        for k in extra:
            if k not in picks and len(picks) < n - 1:
                picks.append(k)
    if K not in picks:
        picks.append(K)
    return sorted(set(picks))


def _snapshot_samples(K: int, events: list[dict], n: int = 8) -> list[int]:
    picks = set(np.linspace(0, K, n).round().astype(int).tolist())
    for e in events:
        if e["type"] == "backward" and len(picks) < n + 3:
            picks.add(int(e["sample"]))
    return sorted(k for k in picks if 0 <= k <= K)


def _segment_distance(c: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance (m) from points c to segments a–b, all (..., 2), broadcast."""
    ab = b - a
    den = np.maximum(np.einsum("...i,...i->...", ab, ab), 1e-300)
    t = np.clip(np.einsum("...i,...i->...", c - a, ab) / den, 0.0, 1.0)
    return np.linalg.norm(c - (a + t[..., None] * ab), axis=-1)


def link_radius(res: DynamicPlanResult) -> float:
    """Largest radius (m) of the arm's collision cylinders/capsules (0 if it has none)."""
    radii = [
        float(go.geometry.radius)
        for go in res.problem.arm.collision_model.geometryObjects
        if hasattr(go.geometry, "radius")
    ]
    return max(radii, default=0.0)


#: Sub-intervals per sample interval of the independent capsule diagnostic in result.json.
CAPSULE_SUBSTEPS = 20


def capsule_clearance(
    res: DynamicPlanResult, q: np.ndarray, *, link_radius: float, substeps: int = CAPSULE_SUBSTEPS
) -> dict[str, float]:
    """Clearance (m) of capsule links (radius ``link_radius``) to the discs, plain 2-D geometry.

    The motion between two samples is taken as the joints interpolated
    linearly while the obstacles follow their trajectories. Returns
    ``{"samples", "between_samples", "certified_between"}``: the smallest
    clearance at the motion samples; at ``substeps − 1`` instants between each
    pair of samples; and a lower bound valid at *every* instant in between:
    over a sub-interval every point of the links moves at most
    δ_arm = (l1 + l2)|Δq1| + l2|Δq2| and a disc centre at most speed × Δt,
    and the clearance is 1-Lipschitz in both, so with clearances c_a, c_b at
    the two ends and L = δ_arm + δ_obs it is at least (c_a + c_b − L)/2 (or
    min(c_a, c_b) when |c_a − c_b| > L) anywhere in the sub-interval.
    The planner checks the samples and its own ``substeps``; this is the
    independent diagnostic in between.
    """
    scene = res.problem.scene
    if len(scene) == 0 or len(q) == 0:
        return {"samples": math.inf, "between_samples": math.inf, "certified_between": math.inf}
    n = int(substeps)
    q = np.asarray(q, dtype=float)
    f = np.arange(n) / n
    qq = (q[:-1, None, :] + f[None, :, None] * (q[1:] - q[:-1])[:, None, :]).reshape(-1, 2)
    qq = np.vstack([qq, q[-1:]])
    t = np.concatenate([(np.arange(len(q) - 1)[:, None] + f[None, :]).ravel(), [len(q) - 1]])
    t = t * scene.ts
    at_sample = np.concatenate([np.tile(f == 0, len(q) - 1), [True]])
    elbow = res.kin.elbow(qq)[:, None, :]
    ee = res.kin.fk(qq)[:, None, :]
    c = scene.centers(t)  # (M, n_obs, 2)
    d = np.minimum(
        _segment_distance(c, np.zeros_like(elbow), elbow), _segment_distance(c, elbow, ee)
    )
    clear = d - scene.radii[None, :] - link_radius  # (M, n_obs)
    out = {"samples": float(clear[at_sample].min())}
    if len(q) < 2:
        out["between_samples"] = out["certified_between"] = math.inf
        return out
    out["between_samples"] = float(clear[~at_sample].min())
    dq = np.abs(np.diff(qq, axis=0))  # (M-1, 2)
    d_arm = (res.kin.l1 + res.kin.l2) * dq[:, 0] + res.kin.l2 * dq[:, 1]
    speeds = np.array([ob.trajectory.speed for ob in scene.obstacles])
    L = d_arm[:, None] + speeds[None, :] * np.diff(t)[:, None]  # (M-1, n_obs)
    ca, cb = clear[:-1], clear[1:]
    bound = np.where(np.abs(ca - cb) <= L, 0.5 * (ca + cb - L), np.minimum(ca, cb))
    out["certified_between"] = float(bound.min())
    return out


def peak_joint_speed(q: np.ndarray, ts: float) -> list[float]:
    """Largest |Δq_i| / Ts (rad/s) of each joint over the motion (0 for a single sample)."""
    q = np.asarray(q, dtype=float)
    if len(q) < 2:
        return [0.0] * q.shape[1]
    return [float(v) for v in np.abs(np.diff(q, axis=0)).max(axis=0) / ts]


def result_dict(scn: DynamicScenario, res: DynamicPlanResult, seed: int | None) -> dict[str, Any]:
    """The result of one run (see :func:`run_dynamic_scenario`); non-finite numbers are
    left as they are (:func:`~mpd_pin.app.results.to_jsonable` writes them as null)."""
    prob = res.problem
    scene = prob.scene
    ts = scene.ts
    mot = res.motion
    d = res.dstar
    samples = []
    for k in range(len(mot.points)):
        samples.append({
            "t": k * ts,
            "q": [float(v) for v in mot.q[k]],
            "ee": [float(v) for v in mot.points[k]],
            "branch": BRANCHES[int(mot.branches[k])],
            "obstacles": scene.snapshot(k * ts),
        })
    dstar_samples = [
        {"t": k * ts, "q": [float(v) for v in d.q[k]], "ee": [float(v) for v in d.points[k]],
         "branch": BRANCHES[int(d.branches[k])]}
        for k in range(d.num_samples)
    ]
    clearances = [res.checker.clearance(mot.q[k], k) for k in range(len(mot.q))]
    r_link = link_radius(res)
    cap = capsule_clearance(res, mot.q, link_radius=r_link)
    dcap = capsule_clearance(res, d.q, link_radius=r_link)
    counts = {e: sum(1 for x in d.events if x["type"] == e) for e in ("stop", "backward", "switch")}
    pso = res.pso
    return {
        "kind": "dynamic2link",
        "name": scn.name,
        "description": scn.description,
        "warnings": [],  # as in energy results (mpd_pin/schemas/result.schema.json)
        "arm": prob.arm.name,
        "link_lengths": [res.kin.l1, res.kin.l2],
        "sample_time": ts,
        "grid": prob.grid.to_dict(),
        "margin": prob.margin,
        "max_joint_step": prob.joint_step_limit,
        "max_joint_step_source": (
            "arm velocity limits × sample_time" if prob.max_joint_step is None
            else "scenario [motion] max_joint_step"
        ),
        "velocity_limits": prob.velocity_limits.tolist(),
        "peak_joint_speed": {
            "note": "max |Δq| / Ts per joint (rad/s), against velocity_limits",
            "pso": peak_joint_speed(mot.q, ts),
            "dstar": peak_joint_speed(d.q, ts),
        },
        "substeps": prob.substeps,
        "start": res.fcs.grid.point(res.fcs.cell_branch(res.start_state)[0]).tolist(),
        "start_branch": BRANCHES[res.fcs.cell_branch(res.start_state)[1]],
        "goal": res.fcs.grid.point(res.fcs.cell_branch(res.goal_states[0])[0]).tolist(),
        "goal_branch": prob.goal_branch,
        "obstacles": [ob.to_dict() for ob in scene.obstacles],
        "num_samples": len(samples),
        "duration": (len(samples) - 1) * ts,
        "samples": samples,
        "dstar_samples": dstar_samples,
        "path_length_dstar": d.length,
        "path_length_pso": mot.length,
        "pso_improved": res.pso_improved,
        "pso_cost_curve": list(pso.cost_curve) if pso else [],
        "pso": {
            "particles": prob.pso.particles,
            "iterations": prob.pso.iterations,
            "via_points": res.smoother.num_via if res.smoother else 0,
            "c1": prob.pso.c1,
            "c2": prob.pso.c2,
            "w": prob.pso.w,
            "k": prob.pso.k,
            "seed": seed,
            "spline_bc": prob.spline_bc,
            "knots": [int(v) for v in mot.knots],
            "evaluations": pso.evaluations if pso else 0,
            "distinct_paths_evaluated": res.smoother.evaluated if res.smoother else 0,
        },
        "events": d.events,
        "event_counts": counts,
        "min_clearance": float(min(clearances)),
        "capsule_clearance": {
            "note": f"links as capsules of radius {r_link} m vs the discs (m), plain 2-D "
                    f"geometry; 'between' interpolates the joints linearly at "
                    f"{CAPSULE_SUBSTEPS - 1} instants between samples (obstacles at those "
                    "times); 'certified' bounds the clearance at every instant between "
                    "samples (run.capsule_clearance)",
            "substeps": CAPSULE_SUBSTEPS,
            **{f"{name}_{key}": val
               for name, c in (("pso", cap), ("dstar", dcap)) for key, val in c.items()},
        },
        "dstar": {"replans": d.replans, "edge_updates": d.edge_updates},
        "collision_checkers_built": res.checker.builds,
    }


def run_dynamic_scenario(
    scenario: DynamicScenario | Mapping[str, Any],
    out_dir: Path,
    *,
    seed: int | None = None,
    show_progress: bool = True,
    plots: bool = True,
) -> dict[str, Any]:
    """Plan a ``dynamic2link`` scenario (parsed, or its TOML dict), write results to ``out_dir``.

    ``seed`` overrides the scenario's ``pso.seed``. Returns the dict written to
    ``out_dir/result.json`` (by :func:`mpd_pin.app.results.write_json`: a non-finite
    number is ``null``), which holds at least: ``link_lengths`` (m),
    ``samples`` (the executed smoothed motion at every motion sample:
    ``{t (s), q (rad), ee (m), branch, obstacles: [{name, center [x, z] (m),
    radius (m)}]}``), ``path_length_dstar`` and ``path_length_pso`` (m),
    ``pso_cost_curve`` (best length per iteration, m; null while no feasible
    particle), ``events`` (the D* execution's ``stop`` / ``backward`` /
    ``switch`` events with their ``sample`` index), plus ``dstar_samples``,
    ``min_clearance`` (m, Coal, link cylinders; null without obstacles),
    ``capsule_clearance`` (m, see :func:`capsule_clearance`), ``max_joint_step`` (rad
    per sample, with its ``max_joint_step_source``), ``velocity_limits`` and
    ``peak_joint_speed`` (rad/s), and the time per phase (``setup``, ``dstar``, ``pso``,
    ``plots``, ``total``): wall-clock seconds in ``seconds_per_phase`` and, rounded to
    0.1 ms, ``timings``; CPU seconds of this process in ``cpu_seconds_per_phase``
    (docs/design.md §7). ``plots=False`` skips the PNG figures (they take most of a
    run's time).

    Raises ConfigError/ValueError for bad input and
    :class:`~mpd_pin.twolink.planner.TrappedError` (a NoPathError) when the arm
    cannot be kept collision-free.
    """
    clock = PhaseClock()
    scn = (scenario if isinstance(scenario, DynamicScenario)
           else parse_dynamic_scenario(dict(scenario)))
    use_seed = scn.seed if seed is None else int(seed)
    out_dir = Path(out_dir)
    with _progress_bars(show_progress) as progress:
        res = plan_dynamic(scn.problem, seed=use_seed, progress=progress, clock=clock)
    result = result_dict(scn, res, use_seed)
    out_dir.mkdir(parents=True, exist_ok=True)
    with clock.phase("plots"):
        result["plots"] = write_plots(scn, res, out_dir) if plots else []
    clock.finish()
    result["timings"] = {k: round(v, 4) for k, v in clock.wall.items()}
    result["seconds_per_phase"] = dict(clock.wall)
    result["cpu_seconds_per_phase"] = dict(clock.cpu)
    result = to_jsonable(result)
    write_json(out_dir / "result.json", result)
    return result


@contextlib.contextmanager
def _progress_bars(show: bool) -> Iterator[Callable[[str, int, int | None], None] | None]:
    """A ``progress(stage, done, total)`` callback for :func:`plan_dynamic` drawing one tqdm
    bar per stage (``None`` when ``show`` is false); the bars are closed on exit."""
    if not show:
        yield None
        return
    from tqdm.auto import tqdm

    bars: dict[str, Any] = {}

    def progress(stage: str, done: int, total: int | None) -> None:
        bar = bars.get(stage)
        if bar is None:
            for other in bars.values():  # one bar at a time: the previous stage is over
                other.close()
            desc = "D* execution (samples)" if stage == "dstar" else "PSO (iterations)"
            bar = bars[stage] = tqdm(total=total, desc=desc, leave=False)
        bar.update(done - bar.n)

    try:
        yield progress
    finally:
        for bar in bars.values():
            bar.close()


def write_plots(scn: DynamicScenario, res: DynamicPlanResult, out_dir: Path) -> list[str]:
    """Write the PNG figures of a run into ``out_dir``; returns their file names."""
    import matplotlib.pyplot as plt

    from ..viz.plots import plot_joint_angles
    from . import plots

    scene = res.problem.scene
    kin = res.kin
    ts = scene.ts
    mot = res.motion
    d = res.dstar
    K = len(mot.points) - 1
    fcs_samples = [k for k in (scn.fcs_samples or default_fcs_samples(res)) if 0 <= k <= K]
    snaps = scn.snapshot_samples
    figs = {
        "fcs.png": plots.plot_fcs_maps(res.fcs, fcs_samples, q=d.q, path=d.points,
                                       pso_path=mot.points),
        "paths.png": plots.plot_paths(
            kin, scene, d.points, mot.points, res.pso.cost_curve if res.pso else None
        ),
        "dstar_motion.png": plots.plot_arm_snapshots(
            kin, scene, d.q, snaps or _snapshot_samples(K, d.events), points=d.points,
            events=d.events, title=f"{scn.name}: D* motion (stop / return backward marked)",
        ),
        "pso_motion.png": plots.plot_arm_snapshots(
            kin, scene, mot.q, snaps or _snapshot_samples(K, []), points=mot.points,
            title=f"{scn.name}: " + ("PSO-smoothed motion (via points on the D* motion)"
                                    if res.pso_improved else
                                    "executed motion = D* motion (PSO found nothing shorter)"),
        ),
        "joint_angles.png": plot_joint_angles(
            np.arange(len(mot.q)) * ts, mot.q, ("q1", "q2"), marker="o",
            title=f"{scn.name}: joint angles of the optimised path",
        ),
        "joint_changes.png": plots.plot_joint_changes(
            ts, mot.q, title=f"{scn.name}: change in joint angles per sample"
        ),
        "obstacles.png": plots.plot_obstacle_motion(kin, scene, K * ts),
    }
    names = []
    for name, fig in figs.items():
        fig.savefig(out_dir / name, dpi=90)
        plt.close(fig)  # the shared joint-angle figure is pyplot's; no-op for the others
        names.append(name)
    return names
