"""The world in a figure: obstacles, hazards and their clearance bands, drawn in the x–z
plane (planar arms) or as translucent solids in 3-D, with their names placed clear of
each other (docs/design.md §7c). :mod:`mpd_pin.viz.plots` draws the arm and its motion
over them. Every function draws into a given matplotlib axes and returns what it drew.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..world import Box, Cylinder, Hazard, Polygon, Sphere, World

__all__ = [
    "OBSTACLE_COLOR",
    "HAZARD_COLOR",
    "HIDDEN_COLOR",
    "drawn_items",
    "draw_world_xz",
    "draw_world_3d",
    "label_anchor_3d",
    "shape_faces",
    "clearance_band_xz",
    "draw_clearance_bands_xz",
]


OBSTACLE_COLOR = "#6c757d"
HAZARD_COLOR = "#d1495b"
HIDDEN_COLOR = "#7b2cbf"


def drawn_items(world: World | None, show_hidden: bool):
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
    for item, shape, hidden, color in drawn_items(world, show_hidden):
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
        cx, cz = section.mean(axis=0)  # inside its own (convex) section
        ax.annotate(item.name, (cx, cz), ha="center", va="center", fontsize=7,
                    gid=f"label:{item.name}")
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


def draw_world_3d(ax, world: World | None, *, show_hidden: bool = True,
                  zorder: float = 1.0) -> list:
    """Draw obstacles and hazards as translucent solids on a 3-D axes (``projection="3d"``).

    Obstacles grey, hazards red, obstacles not yet known purple with dashed edges; faces
    translucent with light edges, so that lines drawn over them stay visible. Each
    collection's ``gid`` is the obstacle's name, its zorder in [``zorder``, ``zorder`` +
    0.5): farther from the axes' current view first (matplotlib orders whole collections
    by zorder when ``ax.computed_zorder`` is False). Each name is written on its solid's
    top, away from the other solids (:func:`label_anchor_3d`; the text's ``gid`` is
    ``"label:<name>"``). Returns the ``Poly3DCollection`` objects.
    """
    from matplotlib.colors import to_rgba
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    items = list(drawn_items(world, show_hidden))
    eye = _view_direction(ax)
    depth = [float(np.dot(eye, shape.position)) for _, shape, _, _ in items]
    rank = {k: r for r, k in enumerate(np.argsort(depth, kind="stable"))}
    out = []
    boxes = [np.array([f.min(axis=0), f.max(axis=0)])
             for f in (np.concatenate(shape_faces(shape)) for _, shape, _, _ in items)]
    for k, (item, shape, hidden, color) in enumerate(items):
        if isinstance(item, Hazard):
            alpha = 0.2
        elif item.hidden:
            alpha = 0.15 if hidden else 0.3
        else:
            alpha = 0.25
        width = {Sphere: 0.0, Cylinder: 0.15}.get(type(shape), 0.5)  # curved: faint facets
        z = zorder + 0.5 * rank[k] / max(len(items), 1)
        coll = Poly3DCollection(
            _uniform_faces(shape_faces(shape)),
            facecolors=to_rgba(color, alpha),
            edgecolors=to_rgba(color, 0.6) if width else "none",
            linewidths=width,
            linestyles="--" if hidden else "-",
            zorder=z,
        )
        coll.set_gid(item.name)
        ax.add_collection3d(coll)
        out.append(coll)
        x, y, z = label_anchor_3d(boxes, k)  # on its top, away from the other solids
        ax.text(x, y, z, item.name, fontsize=7, color="0.25", ha="center", va="bottom",
                zorder=zorder + 0.5, gid=f"label:{item.name}")
    return out


def _box_distance(p: np.ndarray, box: np.ndarray) -> float:
    """Distance (m) of the point ``p`` to the axis-aligned box ``box`` = [lo, hi] (2, 3)."""
    return float(np.linalg.norm(np.maximum(np.maximum(box[0] - p, p - box[1]), 0.0)))


def label_anchor_3d(boxes: Sequence[np.ndarray], k: int, grid: int = 9) -> np.ndarray:
    """Where the name of solid ``k`` is written (m): on the top of its axis-aligned box
    ``boxes[k]`` (each (2, 3): [lo, hi]), at the point nearest its centre that keeps a
    margin — a tenth of the scene's largest extent — from every other solid's box (a
    label at a table's centre sat on the wall standing there); without such a point,
    the one farthest from them. Candidates: a ``grid`` × ``grid`` grid over the inner 80 %
    of the top."""
    lo, hi = boxes[k]
    top = float(hi[2])
    centre = np.array([(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, top])
    others = [b for j, b in enumerate(boxes) if j != k]
    if not others:
        return centre
    every = np.concatenate(boxes)
    margin = 0.1 * float(np.max(every.max(axis=0) - every.min(axis=0)))
    u = np.linspace(-0.4, 0.4, grid)
    xs, ys = centre[0] + u * (hi[0] - lo[0]), centre[1] + u * (hi[1] - lo[1])
    cands = np.array([[x, y, top] for x in xs for y in ys])
    cands = cands[np.argsort(np.linalg.norm(cands - centre, axis=1), kind="stable")]
    clear = np.array([min(_box_distance(c, b) for b in others) for c in cands])
    ok = np.flatnonzero(clear >= margin)
    return cands[ok[0]] if ok.size else cands[int(np.argmax(clear))]


def _view_direction(ax) -> np.ndarray:
    """Unit vector from the scene towards the viewer of a 3-D axes (its elevation and
    azimuth, degrees); +z for a 2-D axes."""
    elev, azim = getattr(ax, "elev", 90.0), getattr(ax, "azim", 0.0)
    e, a = np.radians(elev), np.radians(azim)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def clearance_band_xz(shape, clearance: float, n: int = 48) -> np.ndarray | None:
    """Cross-section (y = 0) of ``shape`` grown by ``clearance`` (m): the convex hull of its
    section's vertices offset by an ``n``-gon of radius ``clearance`` (the sections are
    convex). Counter-clockwise (M, 2) array of (x, z) (m); None if the shape misses the plane."""
    section = shape.section_xz()
    if section is None:
        return None
    a = 2.0 * np.pi * np.arange(n) / n
    disc = clearance * np.column_stack([np.cos(a), np.sin(a)])
    pts = (section[:, None, :] + disc[None, :, :]).reshape(-1, 2)
    return _convex_hull(pts)


def _convex_hull(pts: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull of 2-D points (Andrew's monotone chain)."""
    P = sorted(set(map(tuple, np.round(pts, 12))))

    def half(points):
        out: list = []
        for p in points:
            while len(out) >= 2 and (
                (out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])
            ) <= 0:
                out.pop()
            out.append(p)
        return out[:-1]

    return np.array(half(P) + half(P[::-1]))


def draw_clearance_bands_xz(ax, world: World | None) -> list:
    """Dashed outline (y = 0 section) of every hazard's clearance band — the zone grown by
    its ``clearance`` that a path may not enter (docs/design.md §5e). Each patch's ``gid``
    is ``"<name>:clearance"``; the first carries the legend label. Returns the patches."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Polygon as PolygonPatch

    out = []
    for hz in world.hazards if world is not None else ():
        band = clearance_band_xz(hz.shape, hz.clearance) if hz.clearance > 0 else None
        if band is None:
            continue
        patch = PolygonPatch(
            band, closed=True, facecolor=to_rgba(HAZARD_COLOR, 0.12), edgecolor=HAZARD_COLOR,
            linestyle="--", lw=1.2, gid=f"{hz.name}:clearance",
            label=f"hazard clearance band ({hz.clearance:g} m)" if not out else None,
        )
        ax.add_patch(patch)
        out.append(patch)
    return out
