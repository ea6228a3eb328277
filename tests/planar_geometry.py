"""Independent exact 2-D geometry of planar arms and obstacles (pure numpy, no Coal).

Shared by the collision, roadmap and URDF tests. A planar link is a cylinder of
radius r whose axis lies in the x–z plane; planar obstacles are extruded across
the plane and symmetric about y = 0. For two convex bodies symmetric about
y = 0, overlap and distance equal those of their y = 0 cross-sections: the
link's rectangle (length l, width 2r) and the obstacle's disc or convex polygon.
Below: separating axis theorem for rectangle–polygon, closest point for
rectangle–disc, both as signed distances (m).
"""

import math

import numpy as np

from mpd_pin.world import Box, Cylinder, Sphere


def link_rectangles(Q, lengths, radius):
    """Corners (K, L, 4, 2) in (x, z), centres, unit axes and half sizes of every link."""
    Q = np.atleast_2d(Q)
    theta = np.cumsum(Q, axis=1)  # (K, L)
    u = np.stack([np.cos(theta), np.sin(theta)], axis=-1)  # along the link
    n = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)  # across
    lengths = np.asarray(lengths)
    steps = u * lengths[None, :, None]
    starts = np.concatenate([np.zeros_like(steps[:, :1]), np.cumsum(steps, axis=1)[:, :-1]], 1)
    centres = starts + steps / 2
    hl = (lengths / 2)[None, :, None]
    corners = np.stack(
        [
            centres - u * hl - n * radius,
            centres + u * hl - n * radius,
            centres + u * hl + n * radius,
            centres - u * hl + n * radius,
        ],
        axis=2,
    )
    return corners, centres, u, n, hl[..., 0]


def _edge_normals(P):
    E = np.roll(P, -1, axis=-2) - P
    N = np.stack([-E[..., 1], E[..., 0]], axis=-1)
    return N / np.linalg.norm(N, axis=-1, keepdims=True)


def _points_to_segments(P, A, B):
    """min distance from points P (K, p, 2) to segments A→B (K, e, 2): (K,)."""
    AB = B - A  # (K, e, 2)
    AP = P[:, :, None, :] - A[:, None, :, :]  # (K, p, e, 2)
    t = np.clip(np.einsum("kpei,kei->kpe", AP, AB) / np.einsum("kei,kei->ke", AB, AB)[:, None],
                0.0, 1.0)
    d = AP - t[..., None] * AB[:, None]
    return np.sqrt(np.einsum("kpei,kpei->kpe", d, d)).min(axis=(1, 2))


def sd_polygons(A, B):
    """Signed distance between convex polygons A (K, n, 2) and B (K, m, 2): (K,).

    Positive: separation distance; negative: minus the penetration depth (SAT).
    """
    axes = np.concatenate([_edge_normals(A), _edge_normals(B)], axis=1)  # (K, a, 2)
    pa = np.einsum("kai,kni->kan", axes, A)
    pb = np.einsum("kai,kmi->kam", axes, B)
    overlap = np.minimum(pa.max(-1), pb.max(-1)) - np.maximum(pa.min(-1), pb.min(-1))
    pen = overlap.min(axis=1)
    dist = np.minimum(
        _points_to_segments(A, B, np.roll(B, -1, axis=1)),
        _points_to_segments(B, A, np.roll(A, -1, axis=1)),
    )
    return np.where(pen < 0, dist, -pen)


def sd_rect_disc(centre, u, n, hl, r, c, R):
    """Signed distance between rectangles (K,) and the disc (c, R)."""
    d = c[None, :] - centre
    p = np.stack([np.abs(np.einsum("ki,ki->k", d, u)), np.abs(np.einsum("ki,ki->k", d, n))], -1)
    q = p - np.stack([hl, np.full_like(hl, r)], -1)
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    inside = np.minimum(q.max(-1), 0.0)
    return outside + inside - R


def brute_force(Q, lengths, radius, discs=(), polygons=(), self_collision=True):
    """(min signed distance to obstacles (K,), min signed distance of non-adjacent links (K,))."""
    corners, centres, u, n, hl = link_rectangles(Q, lengths, radius)
    K, L = centres.shape[:2]
    obs = np.full(K, np.inf)
    for c, R in discs:
        for i in range(L):
            obs = np.minimum(obs, sd_rect_disc(centres[:, i], u[:, i], n[:, i], hl[:, i], radius,
                                               np.asarray(c, float), R))
    for P in polygons:
        P = np.broadcast_to(np.asarray(P, float), (K, *np.shape(P)))
        for i in range(L):
            obs = np.minimum(obs, sd_polygons(corners[:, i], P))
    selfd = np.full(K, np.inf)
    if self_collision:
        for i in range(L):
            for j in range(i + 2, L):
                selfd = np.minimum(selfd, sd_polygons(corners[:, i], corners[:, j]))
    return obs, selfd


def section_2d(ob):
    """("disc", (x, z), R) or ("poly", [(x, z), ...]) of a planar shape's y = 0 cross-section,
    computed here from its parameters, not by mpd_pin."""
    if isinstance(ob, (Cylinder, Sphere)):
        return "disc", (ob.position[0], ob.position[2]), ob.radius
    if isinstance(ob, Box):
        a = -ob.rpy[1]  # Box.planar turns by angle a about -y
        c, s = math.cos(a), math.sin(a)
        w, h = ob.size[0] / 2, ob.size[2] / 2
        pts = [(-w, -h), (w, -h), (w, h), (-w, h)]
        return "poly", [(ob.position[0] + c * x - s * z, ob.position[2] + s * x + c * z)
                        for x, z in pts]
    return "poly", list(ob.vertices_xz)


def scene_2d(world, hazards=False):
    """Discs [(centre, R)] and polygons [[(x, z), ...]] of the world's obstacles (all of them,
    hidden too), or of its hazards' shapes with ``hazards=True``."""
    discs, polys = [], []
    items = [h.shape for h in world.hazards] if hazards else list(world.obstacles)
    for ob in items:
        kind, *geom = section_2d(ob)
        if kind == "disc":
            discs.append(tuple(geom))
        else:
            polys.append(geom[0])
    return discs, polys


def min_signed_distance(Q, lengths, radius, world, *, hazards=True, self_collision=True,
                        chunk=20_000):
    """Min signed distance (m) of each configuration (rows of Q) to the world's obstacles,
    its hazards' shapes (``hazards``) and between non-adjacent links (``self_collision``);
    +inf when there is nothing. Computed in chunks of ``chunk`` rows."""
    Q = np.atleast_2d(np.asarray(Q, float))
    discs, polys = scene_2d(world)
    if hazards:
        hd, hp = scene_2d(world, hazards=True)
        discs, polys = discs + hd, polys + hp
    out = np.empty(len(Q))
    for s in range(0, len(Q), chunk):
        obs, selfd = brute_force(Q[s : s + chunk], lengths, radius, discs, polys, self_collision)
        out[s : s + chunk] = np.minimum(obs, selfd)
    return out
