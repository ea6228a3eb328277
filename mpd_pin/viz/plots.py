"""Matplotlib figures of a planned motion (paper 000 Figs. 12–17).

* :func:`plot_arm_path` — the arm at every path node over the obstacles, with
  the end-effector trace (x–z plane for planar arms; a 3-D view otherwise, where
  boxes, cylinders, spheres and extruded polygons are drawn as translucent solids
  beneath the arm's thick links, in a fixed draw order — docs/design.md §7c);
* :func:`plot_joint_angles` — joint angles (rad) against time (s), for both papers
  (paper 002's figures in :mod:`mpd_pin.twolink.plots` use it too);
* :func:`plot_cumulative_energy` — E⁺ per joint (J) accumulated against time (s), each
  total named for what it is, with the totals of the motions or paths compared to it,
  optionally with labelled vertical lines at given times (e.g. re-planning);
* :func:`plot_energy_duration` — E⁺ (J) against duration (s) of every candidate motion.

All functions return a ``matplotlib.figure.Figure`` and never call ``show``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..world import Hazard, World
from .layout import tight
from .scene import (
    HIDDEN_COLOR,
    clearance_band_xz,
    draw_clearance_bands_xz,
    draw_world_3d,
    draw_world_xz,
    drawn_items,
    shape_faces,
)

__all__ = [
    "arm_points",
    "ee_trace",
    "is_planar_xz",
    "plot_arm_path",
    "other_linestyle",
    "Detection",
    "chain_reach",
    "plot_joint_angles",
    "plot_cumulative_energy",
    "plot_energy_duration",
]

def arm_points(arm: Arm, q: np.ndarray, ee_frame: str | None = None) -> np.ndarray:
    """World positions (m) of every joint origin, then of the end-effector frame: (njoints, 3)."""
    data = arm.model.createData()
    pin.framesForwardKinematics(arm.model, data, np.asarray(q, float))
    pts = [data.oMi[j].translation.copy() for j in range(1, arm.model.njoints)]
    frame = ee_frame or ("ee" if arm.model.existFrame("ee") else None)
    if frame is not None:
        pts.append(data.oMf[arm.model.getFrameId(frame)].translation.copy())
    return np.array(pts)


def is_planar_xz(arm: Arm) -> bool:
    """True if the arm moves in the x–z plane: joint origins at y = 0, every axis along ±y."""
    data = arm.model.createData()
    q = np.random.default_rng(0).uniform(-1, 1, arm.nq)
    J = pin.computeJointJacobians(arm.model, data, q)
    origins_in_plane = all(
        abs(data.oMi[j].translation[1]) < 1e-9 for j in range(1, arm.model.njoints)
    )
    return bool(origins_in_plane and np.allclose(J[[1, 3, 5], :], 0.0, atol=1e-9))


def ee_trace(arm: Arm, Q: np.ndarray) -> np.ndarray:
    """(len(Q), 3) end-effector positions (m): the last point of :func:`arm_points`."""
    return np.array([arm_points(arm, q)[-1] for q in np.asarray(Q, float)])


class Detection(NamedTuple):
    """Where and when sensing revealed hidden obstacles during execution (docs/design.md §5e).

    ``q`` (rad) the configuration of the node the arm was at, ``t`` (s) its time along the
    motion, ``names`` the obstacles revealed there.
    """

    q: np.ndarray
    t: float
    names: tuple[str, ...]


START_COLOR = "#2a9d8f"
GOAL_COLOR = "#e63946"
TRACE_COLOR = "#e07a5f"
OTHER_COLORS = ("#81b29a", "#f2cc8f", "#3d405b")
#: Path poses: light → dark along the path (the colour bar explains it).
POSE_CMAP_RANGE = (0.35, 1.0)
#: 3-D path figure: draw order (``ax.computed_zorder`` is False). Obstacles first, in
#: [Z_WORLD, Z_WORLD + 0.5) (see :func:`draw_world_3d`), then compared paths, the arm's
#: poses, the travelled trace and base, the end markers and their labels on top.
Z_WORLD, Z_OTHERS, Z_POSES, Z_TRACE, Z_ENDS, Z_LABELS = 1.0, 3.0, 4.0, 5.0, 6.0, 8.0
#: 3-D path figure: line width (points) of the arm's links.
LINK_WIDTH_3D = 3.5


def _pose_colormap():
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    return ListedColormap(plt.cm.Blues(np.linspace(*POSE_CMAP_RANGE, 256)), name="poses")


def chain_reach(arm: Arm) -> float:
    """Upper bound of the arm's reach (m): the summed distances base joint → … → end effector
    at the neutral configuration (exact for a planar arm stretched straight)."""
    p = arm_points(arm, pin.neutral(arm.model))
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def _planar_limits(ax, arm: Arm, world: World | None, extra: list[np.ndarray]) -> None:
    """Square x–z limits containing the arm's reach disc, every obstacle and clearance band,
    and the ``extra`` (k, 2) points, with a 5 % margin."""
    base = arm_points(arm, pin.neutral(arm.model))[0][[0, 2]]
    r = chain_reach(arm)
    pts = [base + r * np.array([[-1, -1], [1, 1]]), *extra]
    for item, shape, _, _ in drawn_items(world, True):
        sec = shape.section_xz()
        if sec is not None:
            pts.append(sec)
        if isinstance(item, Hazard) and item.clearance > 0 and sec is not None:
            pts.append(clearance_band_xz(shape, item.clearance))
    P = np.concatenate(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre, half = (lo + hi) / 2.0, float(np.max(hi - lo)) / 2.0 * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)


def _time_norm(n: int, node_times: Sequence[float] | None):
    """(Normalize, colour-bar label) of the pose shading: time (s) if known, else node index."""
    from matplotlib.colors import Normalize

    if node_times is not None and len(node_times) == n and n > 1:
        t = np.asarray(node_times, float)
        return Normalize(float(t[0]), float(t[-1])), t, "time along path (s): light → dark"
    idx = np.arange(n, dtype=float)
    return Normalize(0.0, max(n - 1.0, 1.0)), idx, "node along path: light → dark"


def _mark_ends(ax, p0: np.ndarray, p1: np.ndarray, planar: bool) -> None:
    """End-effector markers labelled "start" and "goal" (3-D: also written beside them, on
    a white box above everything else)."""
    for p, label, marker, color in ((p0, "start", "o", START_COLOR), (p1, "goal", "*", GOAL_COLOR)):
        xyz = (p[0], p[2]) if planar else (p[0], p[1], p[2])
        ax.plot(*[[c] for c in xyz], marker=marker, ms=13 if marker == "*" else 10,
                color=color, mec="black", ls="none", zorder=Z_ENDS, label=label)
        if not planar:
            ax.text(*xyz, f"  {label}", fontsize=9, fontweight="bold", color=color,
                    ha="left", va="bottom", zorder=Z_LABELS, gid=f"{label}-label",
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": color,
                          "alpha": 0.85})


def _mark_detections(ax, arm: Arm, detections: Sequence[Detection], planar: bool) -> None:
    """A cross at the end effector of each node where sensing revealed obstacles, annotated
    with the obstacles and the time (s)."""
    for k, det in enumerate(detections):
        p = arm_points(arm, det.q)[-1]
        text = f"{', '.join(det.names)} detected\nat t = {det.t:.2f} s"
        label = "new obstacle detected (arm's node)" if k == 0 else None
        if planar:
            ax.plot([p[0]], [p[2]], "X", ms=12, color=HIDDEN_COLOR, mec="white", zorder=7,
                    ls="none", label=label)
            left = p[0] > float(np.mean(ax.get_xlim()))  # text towards the middle
            ax.annotate(text, (p[0], p[2]), xytext=(-14 if left else 14, -30),
                        textcoords="offset points", ha="right" if left else "left",
                        fontsize=8, color=HIDDEN_COLOR, zorder=7,
                        arrowprops={"arrowstyle": "->", "color": HIDDEN_COLOR}, gid="detection")
        else:
            ax.plot([p[0]], [p[1]], [p[2]], "X", ms=12, color=HIDDEN_COLOR, ls="none",
                    zorder=Z_ENDS + 1, label=label)
            ax.text(p[0], p[1], p[2], " " + text.replace("\n", " "), fontsize=8,
                    color=HIDDEN_COLOR, zorder=Z_LABELS, gid="detection",
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none",
                          "alpha": 0.8})


#: Dash length (points) of the compared paths' end-effector lines.
OTHER_DASH = 5.0


def other_linestyle(k: int, n: int):
    """Line style of the ``k``-th of ``n`` compared paths: dashed; with several, the dashes
    interleave (each on for one dash, off for the others' dashes, offset by ``k`` dashes),
    so where their lines coincide every colour shows instead of the last one drawn."""
    if n <= 1:
        return "--"
    return (k * OTHER_DASH, (OTHER_DASH, (n - 1) * OTHER_DASH))


def _draw_planar(ax, arm, world, Q_nodes, trace, others, colors,
                 path_label: str = "arm at each path node") -> None:
    """The x–z plane content of :func:`plot_arm_path` (poses, traces, obstacles, bands)."""
    from matplotlib.patches import Circle

    shown = min(len(others), len(OTHER_COLORS))
    draw_world_xz(ax, world)
    draw_clearance_bands_xz(ax, world)
    for k, (q, c) in enumerate(zip(Q_nodes, colors, strict=True)):
        p = arm_points(arm, q)
        ax.plot(p[:, 0], p[:, 2], "-o", color=c, lw=2, ms=3,
                label=path_label if k == 0 else None)
    ax.plot(trace[:, 0], trace[:, 2], "-", color=TRACE_COLOR, lw=1.5,
            label="end-effector trace (travelled)")
    for k, ((name, Qo), col) in enumerate(zip(others.items(), OTHER_COLORS, strict=False)):
        tr = ee_trace(arm, Qo)
        ax.plot(tr[:, 0], tr[:, 2], ls=other_linestyle(k, shown), color=col, lw=1.5,
                label=f"{name}: end effector", gid=f"other:{name}")
        for k, q in enumerate(Qo):
            p = arm_points(arm, q)
            ax.plot(p[:, 0], p[:, 2], ":", color=col, lw=1.2, alpha=0.8,
                    label=f"{name}: arm poses" if k == 0 else None)
    ax.plot([0], [0], "ks", ms=8, label="base")
    base, reach = arm_points(arm, pin.neutral(arm.model))[0], chain_reach(arm)
    ax.add_patch(Circle((base[0], base[2]), reach, fill=False, ls=":", lw=0.8, color="0.6",
                        gid="reach", label=f"reach ({reach:.2f} m)"))
    pts = [trace[:, [0, 2]]] + [arm_points(arm, q)[:, [0, 2]] for q in Q_nodes]
    pts += [ee_trace(arm, Qo)[:, [0, 2]] for Qo in others.values()]
    _planar_limits(ax, arm, world, pts)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")


def _base_position(arm: Arm) -> np.ndarray:
    """World position (m) of the link the first joint is mounted on (the arm's base)."""
    m = arm.model
    joint_frame = m.frames[m.getFrameId(m.names[1])]
    parent = m.frames[joint_frame.parentFrame]
    if parent.parentJoint != 0:  # not fixed to the world: cannot happen for a fixed-base arm
        return np.zeros(3)
    return parent.placement.translation.copy()


def _draw_3d(ax, arm, world, Q_nodes, trace, others, colors,
             path_label: str = "arm at each path node") -> None:
    """The 3-D content of :func:`plot_arm_path`, framed with equal scales on all axes.

    Matplotlib's automatic depth sort orders whole artists by one depth each, so a large
    box (a table) can be drawn over lines above it; instead the order is fixed
    (``computed_zorder`` False): translucent obstacles below every line."""
    ax.computed_zorder = False
    ax.set_proj_type("ortho")  # no perspective: heights compare across the figure
    draw_world_3d(ax, world, zorder=Z_WORLD)
    shown = min(len(others), len(OTHER_COLORS))
    for k, ((name, Qo), col) in enumerate(zip(others.items(), OTHER_COLORS, strict=False)):
        tr = ee_trace(arm, Qo)
        ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], ls=other_linestyle(k, shown), color=col,
                lw=1.5, zorder=Z_OTHERS, label=f"{name}: end effector", gid=f"other:{name}")
    for k, (q, c) in enumerate(zip(Q_nodes, colors, strict=True)):
        p = arm_points(arm, q)
        ax.plot(p[:, 0], p[:, 1], p[:, 2], "-o", color=c, lw=LINK_WIDTH_3D, ms=3.5,
                mec="white", mew=0.5, solid_capstyle="round", zorder=Z_POSES + k / len(Q_nodes),
                gid="pose", label=path_label if k == 0 else None)
    ax.plot(trace[:, 0], trace[:, 1], trace[:, 2], "-", color=TRACE_COLOR, lw=2.0,
            zorder=Z_TRACE, gid="trace", label="end-effector trace (travelled)")
    base, mount = _base_position(arm), arm.model.jointPlacements[1].translation
    ax.plot([base[0], mount[0]], [base[1], mount[1]], [base[2], mount[2]], "-",
            color="0.2", lw=LINK_WIDTH_3D + 1.5, solid_capstyle="butt", zorder=Z_TRACE,
            gid="pedestal")
    ax.plot([base[0]], [base[1]], [base[2]], "ks", ms=9, ls="none", zorder=Z_TRACE,
            gid="base", label="base")
    pts = [trace, base[None, :]]
    pts += [arm_points(arm, q) for q in Q_nodes]
    pts += [ee_trace(arm, Qo) for Qo in others.values()]
    for item in world or ():
        shape = item.shape if isinstance(item, Hazard) else item
        pts += shape_faces(shape)
    P = np.concatenate(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    # Each axis spans its own data (5 % margin, at least a tenth of the largest span) and
    # the box's sides are proportional to the spans: one metre is as long on every axis.
    span = np.maximum(hi - lo, 0.1 * max(float(np.max(hi - lo)), 1e-2)) * 1.05
    centre = (lo + hi) / 2.0
    ax.set_xlim(centre[0] - span[0] / 2, centre[0] + span[0] / 2)
    ax.set_ylim(centre[1] - span[1] / 2, centre[1] + span[1] / 2)
    ax.set_zlim(centre[2] - span[2] / 2, centre[2] + span[2] / 2)
    ax.set_box_aspect(tuple(span / span.max()))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")


def plot_arm_path(
    arm: Arm,
    world: World | None,
    Q_nodes: np.ndarray,
    *,
    Q_motion: np.ndarray | None = None,
    other_paths: dict[str, np.ndarray] | None = None,
    title: str = "",
    node_times: Sequence[float] | None = None,
    detections: Sequence[Detection] = (),
    start: np.ndarray | None = None,
    goal: np.ndarray | None = None,
    path_label: str = "arm at each path node",
):
    """The arm at each path node over the world, with the end-effector trace (docs/design.md §7c).

    ``Q_nodes`` (n, nq) path configurations (rad), shaded light → dark along the path and
    explained by a colour bar (time, s, with ``node_times`` — the arm is at node k at
    ``node_times[k]`` — else the node index); ``Q_motion`` (m, nq) the simulated motion for
    the trace; ``other_paths`` name → (k, nq) node configurations of paths drawn for
    comparison (e.g. the path before re-planning); ``detections`` where hidden obstacles were
    revealed (marked and annotated with the time). The end effector's start and goal are
    marked — at ``start``/``goal`` (rad) if given (a figure of part of a path), else at the
    first and last node; hazards' clearance bands are drawn (planar). Planar arms: axis
    limits contain the arm's reach (:func:`chain_reach`), every obstacle and every band.
    ``path_label`` names the poses in the legend (e.g. that the path is also a compared
    one). The compared paths' end-effector lines are dashed, their dashes interleaved
    (:func:`other_linestyle`) so that coinciding stretches show every colour; each line's
    ``gid`` is ``"other:<name>"``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable

    Q_nodes = np.asarray(Q_nodes, float)
    others = {k: np.asarray(v, float) for k, v in (other_paths or {}).items()}
    planar = is_planar_xz(arm)
    trace = ee_trace(arm, Q_motion if Q_motion is not None else Q_nodes)
    cmap = _pose_colormap()
    norm, tk, cbar_label = _time_norm(len(Q_nodes), node_times)
    colors = cmap(norm(tk))
    fig = plt.figure(figsize=(8, 8.6) if planar else (8, 8))
    if planar:
        ax = fig.add_subplot()
        _draw_planar(ax, arm, world, Q_nodes, trace, others, colors, path_label)
    else:
        ax = fig.add_subplot(projection="3d")
        _draw_3d(ax, arm, world, Q_nodes, trace, others, colors, path_label)
    q0 = Q_nodes[0] if start is None else np.asarray(start, float)
    q1 = Q_nodes[-1] if goal is None else np.asarray(goal, float)
    ends = arm_points(arm, q0)[-1], arm_points(arm, q1)[-1]
    _mark_ends(ax, *ends, planar)
    _mark_detections(ax, arm, detections, planar)
    cbar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.7,
                        pad=0.02 if planar else 0.1)  # 3-D: room for the z label
    cbar.set_label(cbar_label)
    if planar:  # below the axes; 3-D: below the (flat) box, where the view leaves room
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize="small")
    else:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2, fontsize="small")
    ax.set_title(title or f"{arm.name}: path of {len(Q_nodes)} nodes")
    tight(fig)
    return fig


def plot_joint_angles(
    t: np.ndarray,
    q: np.ndarray,
    joint_names: Sequence[str],
    *,
    node_times: Sequence[float] = (),
    title: str = "",
    marker: str = "",
):
    """Joint angles q (rad, (len(t), nq)) against time t (s), one line per joint named by
    ``joint_names``; vertical lines at ``node_times`` (s, the path nodes of paper 000);
    ``marker`` (a matplotlib marker, e.g. ``"o"``) marks every sample (the
    motion samples of paper 002 Figs. 9/15)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    for k, name in enumerate(joint_names):
        ax.plot(t, q[:, k], marker=marker or None, ms=2.5, label=name)
    for tn in node_times:
        ax.axvline(tn, color="0.85", lw=0.8, zorder=0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("joint angle (rad)")
    ax.legend(fontsize="small", ncol=2)
    ax.set_title(title or "joint angles along the path")
    tight(fig)
    return fig


#: Line styles and colours of the compared totals in ``energy.png``, in order.
COMPARE_STYLES = ((":", "#d62828"), ("-.", "#6a4c93"), ((0, (1, 3)), "#1982c4"))


def plot_cumulative_energy(
    t: np.ndarray,
    energy_t: np.ndarray,
    joint_names: Sequence[str],
    *,
    title: str = "",
    compare: tuple[np.ndarray, np.ndarray, str] | Sequence[tuple] | None = None,
    marks: Sequence[tuple[float, str]] = (),
    supply: tuple[np.ndarray, str] | None = None,
    total_label: str | None = None,
):
    """Cumulative E⁺ per joint (J) and their total against time (s); ``compare`` =
    (t (s), cumulative total E⁺ (J), label) of another motion or path (e.g. the shortest
    joint-space path, docs/design.md §7c), or a list of them, each drawn as another total
    curve; ``total_label`` names what the per-joint curves are (e.g. "returned motion";
    default "energy-optimal" when something is compared, else nothing), so that each total
    says what it is; ``supply`` = (cumulative
    energy drawn from a shared bus (J), label), drawn as the total the run is priced by
    (docs/design.md §3i), beside the per-joint sum; ``marks`` = (time (s), label)
    pairs, each drawn as a vertical dashed line with its label written along it (e.g. the
    times the arm re-planned). The totals' lines carry the ``gid`` ``"total"`` and
    ``"compare:<k>"``."""
    import matplotlib.pyplot as plt

    if isinstance(compare, tuple) and len(compare) == 3 and isinstance(compare[2], str):
        compare = [compare]  # one (t, e, label)
    compare = list(compare or ())
    below = bool(marks or compare)  # marks run down from the top; compared totals' names
    fig, ax = plt.subplots(figsize=(8, 5) if below else (8, 4))  # are long: legend below
    for k, name in enumerate(joint_names):
        ax.plot(t, energy_t[:, k], label=f"{name}: {energy_t[-1, k]:.4g} J")
    what = total_label if total_label is not None else ("energy-optimal" if compare else "")
    total = f"total ({what})" if what else "total"
    if supply is not None:
        drawn, name = supply
        ax.plot(t, energy_t.sum(axis=1), "--", color="0.5",
                label=f"sum of per-joint supplies: {energy_t[-1].sum():.4g} J")
        ax.plot(t, drawn, "k-", lw=2, label=f"{total}, {name}: {drawn[-1]:.4g} J", gid="total")
    else:
        ax.plot(t, energy_t.sum(axis=1), "k--", label=f"{total}: {energy_t[-1].sum():.4g} J",
                gid="total")
    for k, (tc, ec, name) in enumerate(compare):
        ec = np.asarray(ec, float)
        ls, color = COMPARE_STYLES[k % len(COMPARE_STYLES)]
        ax.plot(tc, ec, ls=ls, color=color, lw=2, label=f"total, {name}: {ec[-1]:.4g} J",
                gid=f"compare:{k}")
    for tm, text in marks:
        ax.axvline(float(tm), color=HIDDEN_COLOR, ls="--", lw=1.2, zorder=1.5, gid="mark")
        ax.annotate(text, (float(tm), 0.97), xycoords=("data", "axes fraction"),
                    xytext=(-4, 0), textcoords="offset points", rotation=90, ha="right",
                    va="top", fontsize=7, color=HIDDEN_COLOR, gid="mark",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                          "alpha": 0.8})
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy drawn E⁺ (J)")
    if below:  # below the axes, clear of the curves
        ax.legend(fontsize="small", ncol=3 if marks else 2, loc="upper center",
                  bbox_to_anchor=(0.5, -0.15))
    else:
        ax.legend(fontsize="small", ncol=2)
    ax.set_title(title or "cumulative electrical energy per joint")
    tight(fig)
    return fig


#: Colours of the candidates' fronts in ``energy_duration.png`` (cycled).
FRONT_COLORS = ("#1d3557", "#e76f51", "#2a9d8f", "#8338ec", "#f4a261", "#6c757d")
#: ``energy_duration.png``: marker size (points) of the simulated durations, in the plot and
#: in the legend alike, and the draw order: the screens' lines, the stop-and-go squares, the
#: returned motion's hollow star, then the simulated dots on top (a dot under the star, or
#: under another candidate's line, stays visible).
SIMULATED_SIZE = 8.0
Z_SCREEN, Z_STOP, Z_RETURNED, Z_SIMULATED = 2.0, 4.0, 5.0, 6.0
#: ``energy_duration.png``: the legend's words for a screen line.
SCREEN_LABEL = ("non-stop, perfect-tracking screen (an estimate: E⁺ of exact tracking, "
                "not simulated)")
SIMULATED_LABEL = "non-stop, simulated (RK4, §3)"


def plot_energy_duration(
    candidates: Sequence[dict],
    returned: dict,
    *,
    max_duration: float | None = None,
    title: str = "",
):
    """E⁺ (J) against the total duration (s) of every candidate (docs/design.md §9c):
    ``candidates`` and ``returned`` as result.json ``energy_duration`` has them. Per
    candidate (one colour) its non-stop front — the perfect-tracking screen (a line, no
    simulation) from its fastest feasible duration to the longest allowed, and the
    durations simulated (dots) — and its stop-and-go motion (a square, the roadmap
    timing); the motion returned is a hollow star over its point (the simulated dots are
    drawn above it, :data:`SIMULATED_SIZE`, :data:`Z_SIMULATED`), ``max_duration`` a
    dashed line; the legend explains the screen as an estimate. Lines and markers carry a
    ``gid``: ``screen:NAME``, ``simulated:NAME``,
    ``stop:NAME``, ``returned``, ``max_duration``."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(7, 4.6))
    handles = []
    for k, row in enumerate(candidates):
        color = FRONT_COLORS[k % len(FRONT_COLORS)]
        name = row["name"]
        shown = False
        non = row.get("nonstop")
        if non is not None and non["screen"]:
            T, E = np.array(non["screen"], dtype=float).T
            ax.plot(T, E, "-", color=color, lw=1.6, alpha=0.8, gid=f"screen:{name}",
                    zorder=Z_SCREEN)
            shown = True
        if non is not None and non["simulated"]:
            T, E = np.array(non["simulated"], dtype=float).T
            ax.plot(T, E, "o", color=color, ms=SIMULATED_SIZE, mec="white", mew=1.0,
                    gid=f"simulated:{name}", zorder=Z_SIMULATED)
            shown = True
        stop = row.get("stop")
        if stop is not None and stop["feasible"]:
            ax.plot([stop["duration"]], [stop["total_energy"]], "s", color=color, ms=8,
                    mec="white", mew=1.0, gid=f"stop:{name}", zorder=Z_STOP)
            shown = True
        if shown:
            handles.append(Line2D([], [], color=color, marker="o", lw=1.6,
                                  label=name + (" (returned)" if row.get("returned") else "")))
    if max_duration is not None:
        ax.axvline(float(max_duration), color="#6c757d", ls="--", lw=1.2, gid="max_duration",
                   zorder=1)
        handles.append(Line2D([], [], color="#6c757d", ls="--",
                              label=f"max_duration {max_duration:g} s"))
    ax.plot([returned["duration"]], [returned["total_energy"]], "*", ms=20, mfc="none",
            mec="#111111", mew=1.8, gid="returned", zorder=Z_RETURNED)
    handles += [
        Line2D([], [], color="#444444", lw=1.6, label=SCREEN_LABEL),
        Line2D([], [], color="#444444", marker="o", ms=SIMULATED_SIZE, ls="none",
               mec="white", label=SIMULATED_LABEL),
        Line2D([], [], color="#444444", marker="s", ms=8, ls="none", mec="white",
               label="stop-and-go (roadmap timing)"),
        Line2D([], [], color="#111111", marker="*", ms=14, mfc="none", ls="none",
               label=f"returned: {returned['total_energy']:.4g} J, "
                     f"{returned['duration']:.3g} s ({returned.get('candidate')}, "
                     f"{returned['execution']})"),
    ]
    ax.set_xlabel("total duration (s)")
    ax.set_ylabel("energy drawn E⁺ (J)")
    ax.legend(handles=handles, fontsize="x-small", loc="upper right")
    ax.set_title(f"{title}: energy against duration" if title else "energy against duration")
    tight(fig)
    return fig
