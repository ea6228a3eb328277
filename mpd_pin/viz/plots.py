"""Matplotlib figures of a planned motion (paper 000 Figs. 12–17).

* :func:`plot_arm_path` — the arm at every path node over the obstacles, with
  the end-effector trace (x–z plane for planar arms; a 3-D view otherwise, where
  boxes, cylinders, spheres and extruded polygons are drawn as shaded solids);
* :func:`plot_joint_angles` — joint angles (rad) against time (s), for both papers
  (paper 002's figures in :mod:`mpd_pin.twolink.plots` use it too);
* :func:`plot_cumulative_energy` — E⁺ per joint (J) accumulated against time (s).

All functions return a ``matplotlib.figure.Figure`` and never call ``show``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..world import Box, Cylinder, Hazard, Polygon, Sphere, World

__all__ = [
    "draw_world_xz",
    "draw_world_3d",
    "shape_faces",
    "arm_points",
    "ee_trace",
    "is_planar_xz",
    "plot_arm_path",
    "plot_joint_angles",
    "plot_cumulative_energy",
]

OBSTACLE_COLOR = "#6c757d"
HAZARD_COLOR = "#d1495b"
HIDDEN_COLOR = "#7b2cbf"


def _drawn_items(world: World | None, show_hidden: bool):
    """(item, its shape, hidden now, colour) for each obstacle/hazard to draw."""
    for item in world or ():
        hidden = not world.is_known(item.name)
        if hidden and not show_hidden:
            continue
        if isinstance(item, Hazard):
            yield item, item.shape, hidden, HAZARD_COLOR
        else:
            yield item, item, hidden, HIDDEN_COLOR if item.hidden else OBSTACLE_COLOR


def draw_world_xz(ax, world: World | None, *, show_hidden: bool = True) -> list:
    """Draw obstacles and hazards as their cross-sections with the plane y = 0.

    Obstacles grey, hazards red, obstacles not yet known dashed purple. Each
    patch's ``gid`` is the obstacle's name. Returns the patches.
    """
    from matplotlib.patches import Polygon as PolygonPatch

    patches = []
    for item, shape, hidden, color in _drawn_items(world, show_hidden):
        section = shape.section_xz()
        if section is None:
            continue
        patch = PolygonPatch(
            section,
            closed=True,
            facecolor=color,
            edgecolor="black",
            alpha=0.3 if hidden else 0.6,
            linestyle="--" if hidden else "-",
            gid=item.name,
        )
        ax.add_patch(patch)
        patches.append(patch)
        cx, cz = section.mean(axis=0)
        ax.annotate(item.name, (cx, cz), ha="center", va="center", fontsize=7)
    return patches


def shape_faces(shape, n: int = 24) -> list[np.ndarray]:
    """The surface of an obstacle shape as planar polygons in world coordinates (m).

    Boxes: their 6 faces; cylinders: ``n`` side quads and the two end caps;
    extruded polygons: side quads and the two caps; spheres: quads of an
    ``n`` × ``n/2`` latitude–longitude grid. Each face is a (k, 3) array.
    """
    if isinstance(shape, Sphere):
        lon = np.linspace(0.0, 2.0 * np.pi, n + 1)
        lat = np.linspace(-np.pi / 2.0, np.pi / 2.0, n // 2 + 1)
        r, c = shape.radius, np.array(shape.position)

        def pt(a, b):
            return c + r * np.array([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)])

        return [
            np.array([pt(lon[i], lat[j]), pt(lon[i + 1], lat[j]),
                      pt(lon[i + 1], lat[j + 1]), pt(lon[i], lat[j + 1])])
            for i in range(n)
            for j in range(n // 2)
        ]
    if isinstance(shape, Box):
        h = np.array(shape.size) / 2.0
        faces = []
        for axis in range(3):
            u, v = [a for a in range(3) if a != axis]
            for side in (-1.0, 1.0):
                quad = np.zeros((4, 3))
                quad[:, axis] = side * h[axis]
                quad[:, u] = np.array([-1, 1, 1, -1]) * h[u]
                quad[:, v] = np.array([-1, -1, 1, 1]) * h[v]
                faces.append(quad)
    elif isinstance(shape, Cylinder):
        a = 2.0 * np.pi * np.arange(n) / n
        ring = np.column_stack([shape.radius * np.cos(a), shape.radius * np.sin(a)])
        half = shape.length / 2.0
        bottom = np.column_stack([ring, np.full(n, -half)])
        top = np.column_stack([ring, np.full(n, half)])
        faces = [bottom, top] + [
            np.array([bottom[k], bottom[(k + 1) % n], top[(k + 1) % n], top[k]]) for k in range(n)
        ]
    elif isinstance(shape, Polygon):
        v = np.array(shape.vertices_xz)
        half = shape.thickness / 2.0
        m = len(v)
        front = np.column_stack([v[:, 0], np.full(m, -half), v[:, 1]])
        back = np.column_stack([v[:, 0], np.full(m, half), v[:, 1]])
        faces = [front, back] + [
            np.array([front[k], front[(k + 1) % m], back[(k + 1) % m], back[k]]) for k in range(m)
        ]
    else:
        raise TypeError(f"cannot draw a {type(shape).__name__}")
    R, p = shape.rotation_matrix, np.array(shape.position)
    return [f @ R.T + p for f in faces]


def _uniform_faces(faces: list[np.ndarray]) -> np.ndarray:
    """Faces as one (F, k, 3) array, shorter ones padded by repeating their last vertex
    (the same polygon). Matplotlib 3.11 pads a ragged list with ``np.empty`` and
    autoscales on the padding, which intermittently gives NaN/inf axis limits."""
    k = max(len(f) for f in faces)
    return np.stack([np.concatenate([f, np.repeat(f[-1:], k - len(f), axis=0)]) for f in faces])


def draw_world_3d(ax, world: World | None, *, show_hidden: bool = True) -> list:
    """Draw obstacles and hazards as shaded solids on a 3-D axes (``projection="3d"``).

    Obstacles grey, hazards translucent red, obstacles not yet known translucent
    purple with dashed edges. Each collection's ``gid`` is the obstacle's name.
    Returns the ``Poly3DCollection`` objects.
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    out = []
    for item, shape, hidden, color in _drawn_items(world, show_hidden):
        if isinstance(item, Hazard):
            alpha = 0.25
        elif item.hidden:
            alpha = 0.25 if hidden else 0.6
        else:
            alpha = 0.55
        width = {Sphere: 0.0, Cylinder: 0.2}.get(type(shape), 0.6)  # curved: faint facets
        coll = Poly3DCollection(
            _uniform_faces(shape_faces(shape)),
            facecolors=color,
            edgecolors="black" if width else "none",
            linewidths=width,
            linestyles="--" if hidden else "-",
            alpha=alpha,
        )
        coll.set_gid(item.name)
        ax.add_collection3d(coll)
        out.append(coll)
        x, y, z = shape.position
        ax.text(x, y, z, item.name, fontsize=7)
    return out


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


def plot_arm_path(
    arm: Arm,
    world: World | None,
    Q_nodes: np.ndarray,
    *,
    Q_motion: np.ndarray | None = None,
    other_paths: dict[str, np.ndarray] | None = None,
    title: str = "",
):
    """The arm at each path node (light → dark) over the world, with the end-effector trace.

    ``Q_nodes`` (n, nq) path configurations; ``Q_motion`` (m, nq) the simulated
    motion for the trace; ``other_paths`` name → (k, nq) node configurations of
    paths drawn for comparison (e.g. the path before re-planning).
    """
    import matplotlib.pyplot as plt

    Q_nodes = np.asarray(Q_nodes, float)
    planar = is_planar_xz(arm)
    trace = ee_trace(arm, Q_motion if Q_motion is not None else Q_nodes)
    if planar:
        fig, ax = plt.subplots(figsize=(7, 6))
        draw_world_xz(ax, world)
        shades = plt.cm.Blues(np.linspace(0.35, 1.0, len(Q_nodes)))
        for q, c in zip(Q_nodes, shades, strict=True):
            p = arm_points(arm, q)
            ax.plot(p[:, 0], p[:, 2], "-o", color=c, lw=2, ms=3)
        ax.plot(trace[:, 0], trace[:, 2], "-", color="#e07a5f", lw=1.5, label="end effector")
        for (name, Qo), col in zip(
            (other_paths or {}).items(), ["#81b29a", "#f2cc8f", "#3d405b"], strict=False
        ):
            tr = ee_trace(arm, np.asarray(Qo, float))
            ax.plot(tr[:, 0], tr[:, 2], "--", color=col, lw=1.5, label=name)
            for q in np.asarray(Qo, float):
                p = arm_points(arm, q)
                ax.plot(p[:, 0], p[:, 2], ":", color=col, lw=1.2, alpha=0.8)
        ax.plot([0], [0], "ks", ms=8)
        reach = np.max(np.linalg.norm(arm_points(arm, Q_nodes[0])[:, [0, 2]], axis=1)) * 1.1
        reach = max(reach, float(np.max(np.abs(trace[:, [0, 2]]))) * 1.1)
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
        ax.legend(loc="lower right", fontsize="small")
    else:
        fig = plt.figure(figsize=(7, 6))
        ax = fig.add_subplot(projection="3d")
        ax.plot(trace[:, 0], trace[:, 1], trace[:, 2], "-", color="#e07a5f", label="end effector")
        for q in Q_nodes:
            p = arm_points(arm, q)
            ax.plot(p[:, 0], p[:, 1], p[:, 2], "-o", color="#3d5a80", alpha=0.5, ms=2)
        draw_world_3d(ax, world)
        for (name, Qo), col in zip(
            (other_paths or {}).items(), ["#81b29a", "#f2cc8f", "#3d405b"], strict=False
        ):
            tr = ee_trace(arm, np.asarray(Qo, float))
            ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], "--", color=col, lw=1.5, label=name)
        # Equal scale on all axes, framing the arm, the traces and the obstacles.
        pts = [trace, np.zeros((1, 3))]
        pts += [arm_points(arm, q) for q in Q_nodes]
        for item in world or ():
            shape = item.shape if isinstance(item, Hazard) else item
            pts += shape_faces(shape)
        P = np.concatenate(pts)
        lo, hi = P.min(axis=0), P.max(axis=0)
        centre, half = (lo + hi) / 2.0, max(float(np.max(hi - lo)) / 2.0, 1e-3) * 1.05
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1.0, 1.0, 1.0))
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.legend(loc="upper right", fontsize="small")
    ax.set_title(title or f"{arm.name}: path of {len(Q_nodes)} nodes")
    fig.tight_layout()
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
    fig.tight_layout()
    return fig


def plot_cumulative_energy(
    t: np.ndarray,
    energy_t: np.ndarray,
    joint_names: Sequence[str],
    *,
    title: str = "",
    compare: tuple[np.ndarray, np.ndarray, str] | None = None,
):
    """Cumulative E⁺ per joint (J) and their total against time (s); ``compare`` =
    (t (s), cumulative total E⁺ (J), label) of another path (e.g. the shortest joint-space
    path, docs/design.md §7c), drawn as a second total curve."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    for k, name in enumerate(joint_names):
        ax.plot(t, energy_t[:, k], label=f"{name}: {energy_t[-1, k]:.4g} J")
    total = "total (energy-optimal)" if compare is not None else "total"
    ax.plot(t, energy_t.sum(axis=1), "k--", label=f"{total}: {energy_t[-1].sum():.4g} J")
    if compare is not None:
        tc, ec, name = compare
        ec = np.asarray(ec, float)
        ax.plot(tc, ec, ":", color="#d62828", lw=2, label=f"total, {name}: {ec[-1]:.4g} J")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy drawn E⁺ (J)")
    ax.legend(fontsize="small", ncol=2)
    ax.set_title(title or "cumulative electrical energy per joint")
    fig.tight_layout()
    return fig
