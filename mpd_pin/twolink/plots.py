"""Figures of the two-link dynamic planner (paper 002 Figs. 4–10; 11–16 for environment 2).

* :func:`plot_fcs_maps` — FCS maps at selected samples: elbow down, elbow up,
  both (Fig. 5: blue, red, green; white = unreachable or in collision);
* :func:`plot_paths` — D* (blue) and PSO (black) end-effector paths with the
  obstacle trajectories, and the PSO cost per iteration (Fig. 7);
* :func:`plot_arm_snapshots` — the arm and the obstacles at selected samples
  (Figs. 6 and 8);
* :func:`plot_joint_changes` — the change of the joint angles per sample (rad)
  against time (s) (Fig. 10); the joint angles themselves (Fig. 9) are drawn by
  :func:`mpd_pin.viz.plots.plot_joint_angles`, shared with paper 000;
* :func:`plot_obstacle_motion` — obstacle centre tracks (Fig. 4).

Every function returns a ``matplotlib.figure.Figure`` built with the
object-oriented API (no pyplot state, safe under the Agg backend) and never
calls ``show``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from ..viz.layout import tight
from .fcs import FreeCartesianSpace
from .ik import TwoLinkKinematics
from .moving import MovingScene

__all__ = [
    "draw_obstacles",
    "draw_arm",
    "plot_fcs_maps",
    "plot_paths",
    "plot_arm_snapshots",
    "plot_joint_changes",
    "plot_obstacle_motion",
]

DOWN_COLOR = "#1f77b4"  # blue
UP_COLOR = "#d62728"  # red
BOTH_COLOR = "#2ca02c"  # green
DSTAR_COLOR = "#1f77b4"
PSO_COLOR = "black"
OBSTACLE_COLOR = "#6c757d"


def draw_obstacles(ax, scene: MovingScene, t: float, *, alpha: float = 0.8, **kw) -> list:
    """Discs of the obstacles at time ``t`` (s). Returns the patches."""
    out = []
    c = scene.centers(float(t))
    for i, ob in enumerate(scene.obstacles):
        patch = Circle(c[i], ob.radius, color=kw.get("color", OBSTACLE_COLOR), alpha=alpha,
                       zorder=kw.get("zorder", 3))
        ax.add_patch(patch)
        out.append(patch)
    return out


def draw_arm(ax, kin: TwoLinkKinematics, q: Sequence[float], *, color: str = "k",
             alpha: float = 1.0, lw: float = 3.0) -> None:
    """The two links as a polyline base → elbow → end effector."""
    e = kin.elbow(q)
    p = kin.fk(q)
    ax.plot([0.0, e[0], p[0]], [0.0, e[1], p[1]], "-", color=color, alpha=alpha, lw=lw,
            solid_capstyle="round", zorder=4)
    ax.plot([0.0, e[0]], [0.0, e[1]], "o", color=color, alpha=alpha, ms=lw + 1, zorder=5)


def _setup_ax(ax, kin: TwoLinkKinematics, margin: float = 0.1) -> None:
    R = kin.l1 + kin.l2 + margin
    ax.set_xlim(-R, R)
    ax.set_ylim(-R, R)
    ax.set_aspect("equal")
    ax.add_patch(Circle((0, 0), kin.l1 + kin.l2, fill=False, ls=":", color="0.6", lw=0.8))


def plot_fcs_maps(
    fcs: FreeCartesianSpace,
    samples: Sequence[int],
    *,
    q: np.ndarray | None = None,
    path: np.ndarray | None = None,
    pso_path: np.ndarray | None = None,
) -> Figure:
    """Rows: the given samples; columns: elbow down, elbow up, both (paper Fig. 5 / 11).

    ``q`` (K+1, 2) rad: the arm drawn at each sample; ``path`` (K+1, 2) m: the
    (D*) end-effector path drawn on every map; ``pso_path`` (m): the smoothed
    (PSO) path too, dashed, as in the paper's "FCS for the D* path and PSO path".
    """
    samples = list(samples)
    grid = fcs.grid
    kin = fcs.kin
    scene = fcs.checker.scene
    n = max(1, len(samples))
    fig = Figure(figsize=(9, 3.0 * n + 0.6))
    axes = fig.subplots(n, 3, squeeze=False, sharex=True, sharey=True)
    h = grid.step / 2
    extent = (grid.x_min - h, grid.x_min + (grid.nx - 1) * grid.step + h,
              grid.z_min - h, grid.z_min + (grid.nz - 1) * grid.step + h)
    titles = ("elbow down", "elbow up", "both")
    colors = (DOWN_COLOR, UP_COLOR, BOTH_COLOR)
    for r, k in enumerate(samples):
        m = fcs.map_at(k)
        layers = (m.down, m.up, m.both)
        for c in range(3):
            ax = axes[r, c]
            cmap = ListedColormap(["white", colors[c]])
            ax.imshow(layers[c].astype(float), origin="lower", extent=extent, cmap=cmap,
                      vmin=0, vmax=1, interpolation="nearest")
            _setup_ax(ax, kin)
            draw_obstacles(ax, scene, m.t, alpha=0.9)
            if path is not None:
                ax.plot(path[:, 0], path[:, 1], "-", color="k", lw=0.8, alpha=0.6,
                        label="D* path")
            if pso_path is not None:
                ax.plot(pso_path[:, 0], pso_path[:, 1], "--", color="#ff7f0e", lw=1.0,
                        label="PSO path")
            if r == 0 and c == 0 and (path is not None or pso_path is not None):
                ax.legend(loc="lower left", fontsize=6)
            if q is not None and 0 <= k < len(q):
                draw_arm(ax, kin, q[k], color="k", lw=2.0)
            ax.set_title(f"{titles[c]}, sample {k} (t = {m.t:.2f} s)", fontsize=9)
            ax.tick_params(labelsize=7)
            ax.set_xlabel("x (m)", fontsize=8)
            ax.set_ylabel("z (m)", fontsize=8)
            ax.label_outer()
    fig.suptitle("Free Cartesian space (white: unreachable or in collision)")
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.5 / fig.get_figheight(),
                        top=1.0 - 0.8 / fig.get_figheight(),
                        wspace=0.05, hspace=0.18)
    return fig


def plot_paths(
    kin: TwoLinkKinematics,
    scene: MovingScene,
    dstar_points: np.ndarray,
    pso_points: np.ndarray,
    cost_curve: Sequence[float] | None,
    *,
    duration: float | None = None,
) -> Figure:
    """(a) D* (blue) vs PSO (black) end-effector paths; (b) PSO best cost per iteration."""
    fig = Figure(figsize=(11, 5))
    ax, ax2 = fig.subplots(1, 2)
    _setup_ax(ax, kin)
    T = duration if duration is not None else (len(dstar_points) - 1) * scene.ts
    tt = np.linspace(0.0, T, 200)
    tracks = scene.centers(tt)
    for i, ob in enumerate(scene.obstacles):
        ax.plot(tracks[:, i, 0], tracks[:, i, 1], "--", color=OBSTACLE_COLOR, lw=1)
        ax.add_patch(Circle(tracks[0, i], ob.radius, color=OBSTACLE_COLOR, alpha=0.35))
    ax.plot(dstar_points[:, 0], dstar_points[:, 1], "-o", color=DSTAR_COLOR, ms=2.5, lw=1.2,
            label=f"D* ({_length(dstar_points):.4f} m)")
    ax.plot(pso_points[:, 0], pso_points[:, 1], "-", color=PSO_COLOR, lw=1.8,
            label=f"PSO ({_length(pso_points):.4f} m)")
    ax.plot(*dstar_points[0], "s", color="green", ms=8, label="start")
    ax.plot(*dstar_points[-1], "*", color="red", ms=12, label="goal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.legend(fontsize=8, loc="lower left")
    ax.set_title("(a) end-effector paths (obstacles at t = 0, tracks dashed)")
    if cost_curve:
        _plot_cost_curve(ax2, cost_curve, _length(dstar_points))
    ax2.set_title("(b) PSO cost function")
    tight(fig)
    return fig


def _plot_cost_curve(ax, cost_curve: Sequence[float | None], dstar_length: float) -> None:
    """PSO best cost (m) per iteration from iteration 0 (after initialisation, §6f). While no
    particle is feasible yet the best cost is ∞ (``None`` in result.json): those iterations
    are shaded and labelled instead of leaving the curve to start later unexplained."""
    c = np.array([np.nan if v is None else v for v in cost_curve], dtype=float)
    c[~np.isfinite(c)] = np.nan
    it = np.arange(len(c))
    ax.plot(it, c, "-", color=PSO_COLOR, label="best path length so far")
    ax.axhline(dstar_length, color=DSTAR_COLOR, ls="--", lw=1, label="D* length")
    feasible = np.flatnonzero(np.isfinite(c))
    first = int(feasible[0]) if len(feasible) else len(c)
    if first > 0:
        ax.axvspan(-0.5, first - 0.5, color="0.85", zorder=0, gid="no_feasible_particle",
                   label=f"iterations 0–{first - 1}: no feasible particle (cost = ∞)")
    ax.set_xlim(-0.5, max(len(c) - 0.5, 1.0))
    ax.set_xlabel("iteration (0 = initial swarm)")
    ax.set_ylabel("best path length (m)")
    ax.legend(fontsize=8, loc="center right")


def _length(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0


def plot_arm_snapshots(
    kin: TwoLinkKinematics,
    scene: MovingScene,
    q: np.ndarray,
    samples: Sequence[int],
    *,
    points: np.ndarray | None = None,
    title: str = "",
    events: Sequence[dict] = (),
) -> Figure:
    """The arm and the obstacles at selected samples (paper Figs. 6 and 8)."""
    samples = [int(k) for k in samples if 0 <= int(k) < len(q)]
    n = max(1, len(samples))
    cols = min(4, n)
    rows = (n + cols - 1) // cols
    fig = Figure(figsize=(3.0 * cols, 3.0 * rows + 0.5))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)).ravel()
    kinds = {e["sample"]: e["type"] for e in events if e.get("type") in ("stop", "backward")}
    for ax, k in zip(axes, samples, strict=False):
        _setup_ax(ax, kin)
        draw_obstacles(ax, scene, k * scene.ts)
        if points is not None:
            ax.plot(points[: k + 1, 0], points[: k + 1, 1], "-", color="0.3", lw=1)
            ax.plot(*points[-1], "*", color="red", ms=10)
        draw_arm(ax, kin, q[k], color="#ff7f0e")
        tag = f" [{kinds[k]}]" if k in kinds else ""
        ax.set_title(f"sample {k} (t = {k * scene.ts:.2f} s){tag}", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("z (m)", fontsize=8)
        ax.label_outer()
    for ax in axes[len(samples):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.6 / fig.get_figheight(),
                        top=1.0 - 0.75 / fig.get_figheight(), wspace=0.05, hspace=0.2)
    return fig


def plot_joint_changes(ts: float, q: np.ndarray, *, title: str = "change in joint angles"
                       ) -> Figure:
    """Δq per motion sample (rad) against t (s) (paper Fig. 10)."""
    fig = Figure(figsize=(7, 4))
    ax = fig.subplots()
    dq = np.diff(q, axis=0)
    t = np.arange(1, len(q)) * ts
    for j in range(q.shape[1]):
        ax.plot(t, dq[:, j], "-o", ms=2.5, label=f"Δq{j + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("change per sample (rad)")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title)
    tight(fig)
    return fig


def plot_obstacle_motion(kin: TwoLinkKinematics, scene: MovingScene, duration: float) -> Figure:
    """Centre tracks of the obstacles over [0, duration] s, marked every 10 samples (Fig. 4)."""
    fig = Figure(figsize=(5.5, 5.8))
    ax = fig.subplots()
    _setup_ax(ax, kin)
    n = max(2, int(round(duration / scene.ts)) + 1)
    t = np.arange(n) * scene.ts
    c = scene.centers(t)
    for i, ob in enumerate(scene.obstacles):
        ax.plot(c[:, i, 0], c[:, i, 1], "-", lw=1, label=ob.name)
        ax.plot(c[::10, i, 0], c[::10, i, 1], ".", ms=4, color="0.3")
        ax.add_patch(Circle(c[0, i], ob.radius, color=OBSTACLE_COLOR, alpha=0.3))
    if scene.obstacles:
        ax.legend(fontsize=8)
    ax.set_title(f"obstacle motion over {duration:.2f} s\n(centre tracks, dots every 10 samples)")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    tight(fig)
    return fig
