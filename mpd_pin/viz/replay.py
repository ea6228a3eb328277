"""Self-contained meshcat recording of a planned motion (docs/design.md §7–8: ``replay.html``).

:func:`write_replay` starts a private meshcat server on loopback, loads the arm's
*visual* geometry (primitives or meshes, through Pinocchio's ``MeshcatVisualizer``),
draws the world (obstacles grey, hazards translucent red, hidden obstacles orange
and shown only from their reveal time), optional end-effector paths as lines, and
records one ``meshcat.animation.Animation`` keyframe per sample. The page written
by meshcat's ``static_html`` inlines the three.js viewer and every scene command
(msgpack, base64), so it opens offline with no server and fetches nothing.

Keyframes and samples
---------------------
Sample ``k`` (time ``times[k]``, s) becomes keyframe ``floor((times[k] - times[0]) · f + ½)``
of a clip whose frame rate is ``f`` (frames/s); the browser plays it in real time
(frame / f seconds). ``f`` is ``fps`` when that already gives every sample its own
frame, otherwise the smallest whole frame rate ≥ ``ceil(1 / min Δt)`` that does
(see :func:`keyframe_indices`), so there is always exactly one keyframe per sample
and the displayed time of a sample is within ½ frame of its recorded time.
A recording of a single sample is a still picture (no animation).

Each visual geometry object ``g`` is the scene node ``/meshcat/arm/visuals/<g.name>``;
its keyframes are ``data.oMg[g]`` from ``pin.updateGeometryPlacements`` (position
and quaternion tracks; a non-unit mesh scale adds a constant ``scale`` track).
A hidden obstacle's node ``/meshcat/world/<obstacles|hazards>/<name>`` gets a
boolean ``visible`` track: off at frame 0, on from the frame of its reveal time
(rounded like a sample's time).

Traces, markers, legend and clock
---------------------------------
Paths named in ``grow`` (one point per sample: the travelled end-effector trace) are split
into about :data:`GROW_SEGMENTS` line segments ``/meshcat/paths/<name>/<NNN>``, each hidden at
frame 0 and shown from the frame of its last sample, so the trace grows behind the arm; other
paths (plans known at t = 0) are one line ``/meshcat/paths/<name>``. Spheres
``/meshcat/markers/start`` and ``/markers/goal`` mark the end effector at the first and last
sample. meshcat draws no text, so the page carries an HTML caption (:mod:`.replay_page`): the
title, a clock (elapsed time, s, read from the viewer's animator while it plays) and one
legend row per trace and marker, naming its scene node and colour.

The page
--------
meshcat's static page starts one ``fetch`` per scene command and they finish in no
set order; the page is rewritten to decode them in its own script and apply them one
after the other in one task, the animation last, so it starts once the scene (and the
Panda's ~10 MB of meshes) is built and no late static pose can undo its final frame.
No fetch is left pending, so a headless browser's virtual time cannot run past the
scene's loading (with fetches it did, in about 1 run in 4). Planar motions (x–z plane)
are shown through an orthographic camera looking along +y, like the 2-D plots;
others through meshcat's perspective camera from the front-right, above. The
server (``python -m meshcat.servers.zmqserver``, loopback only) is killed with its
process group and reaped before :func:`write_replay` returns, also on errors.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import signal
import subprocess
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

with warnings.catch_warnings():  # meshcat's server module imports a deprecated zmq event loop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    from meshcat.animation import Animation
import zmq
from pinocchio.visualize import MeshcatVisualizer

from ..world import Box, Cylinder, Hazard, Polygon, Sphere, World
from .replay_page import LegendRow, decorate, sequence_commands

if TYPE_CHECKING:
    from ..arm.model import Arm

__all__ = [
    "write_replay", "keyframe_indices", "obstacle_node", "path_node", "segment_bounds",
    "ARM_NODE", "WORLD_NODE", "PATHS_NODE", "MARKERS_NODE",
]

#: Scene paths (below meshcat's root ``/meshcat``) of the arm, the world, the paths and the
#: start/goal markers.
ARM_NODE = "arm"
WORLD_NODE = "world"
PATHS_NODE = "paths"
MARKERS_NODE = "markers"

OBSTACLE_COLOR = 0x8E9AA8  # blue-grey
HIDDEN_COLOR = 0xF08C00  # orange: obstacles unknown at planning time
HAZARD_COLOR = 0xE01010  # red, translucent
HAZARD_OPACITY = 0.35
PATH_COLORS = (0xFFD21F, 0x2EE6A8, 0xFF5FD2, 0x5FB4FF, 0xFFFFFF)
START_COLOR = 0x2A9D8F  # as in path.png
GOAL_COLOR = 0xE63946
MARKER_RADIUS = 0.03  # m
#: A growing trace is drawn as about this many segments, each shown from the frame the motion
#: reaches its end.
GROW_SEGMENTS = 100

_SERVER_TIMEOUT_MS = 120_000  # a dead server raises instead of hanging the caller
_TAN_HALF_FOV = math.tan(math.radians(75.0) / 2.0)  # meshcat's default camera: 75° vertical


# ----------------------------------------------------------------- keyframes
def keyframe_indices(times: np.ndarray, fps: float = 30.0) -> tuple[np.ndarray, float]:
    """Keyframe index of every sample and the frame rate used (frames/s).

    ``times`` (s) must be strictly increasing. The index of sample k is
    ``floor((times[k] - times[0]) · f + ½)``; ``f = fps`` if that makes the
    indices strictly increasing, else the smallest whole number ≥ ``ceil(1/min Δt)``
    that does.
    """
    t = np.asarray(times, dtype=float)
    rel = t - t[0]

    def frames(f: float) -> np.ndarray:
        return np.floor(rel * f + 0.5).astype(np.int64)

    f = float(fps)
    idx = frames(f)
    if len(t) > 1 and np.any(np.diff(idx) <= 0):
        f = max(f, float(math.ceil(1.0 / float(np.min(np.diff(t))) - 1e-9)))
        idx = frames(f)
        while np.any(np.diff(idx) <= 0):  # only rounding at the boundary: at most a few steps
            f += 1.0
            idx = frames(f)
    return idx, f


def _reveal_frame(t_reveal: float, t0: float, f: float) -> int:
    """Frame of a reveal at ``t_reveal`` (s): the samples' rounding, possibly outside the clip."""
    return int(math.floor((t_reveal - t0) * f + 0.5))


def _visibility_keys(world: World, name: str, reveal: dict[str, int], last: int):
    """(frame, visible) keys of obstacle ``name`` over frames 0…``last``; reveal: name → frame."""
    if name not in reveal:
        known = world.is_known(name)
        return [(0, known), (last, known)] if last > 0 else [(0, known)]
    on = reveal[name]
    if on <= 0:
        keys = [(0, True), (last, True)]
    elif on > last:  # revealed after the recording ends
        keys = [(0, False), (last, False)]
    else:
        keys = [(0, False), (on, True), (last, True)]
    return list(dict(keys).items())  # one key per frame


# ---------------------------------------------------------------- validation
def _check_inputs(
    arm: Arm,
    world: World | None,
    times: Any,
    Q: Any,
    reveal_times: Mapping[str, float] | None,
    fps: Any,
    paths: Mapping[str, Any] | None,
) -> tuple[np.ndarray, np.ndarray, dict[str, float], float, dict[str, np.ndarray]]:
    try:
        t = np.asarray(times, dtype=float)
        q = np.asarray(Q, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("times and Q must be numeric arrays") from None
    if t.ndim != 1 or len(t) == 0:
        raise ValueError(f"times must be a non-empty 1-D array (s), got shape {t.shape}")
    nq = arm.model.nq
    if q.ndim != 2 or q.shape != (len(t), nq):
        raise ValueError(
            f"Q must have shape (len(times), arm.nq) = ({len(t)}, {nq}), got {q.shape}"
        )
    if not np.all(np.isfinite(t)):
        raise ValueError("times contain NaN or infinity")
    if not np.all(np.isfinite(q)):
        raise ValueError("Q contains NaN or infinity")
    if len(t) > 1 and np.any(np.diff(t) <= 0.0):
        k = int(np.argmax(np.diff(t) <= 0.0))
        raise ValueError(
            f"times must be strictly increasing: times[{k}] = {t[k]!r}, "
            f"times[{k + 1}] = {t[k + 1]!r}"
        )
    try:
        f = float(fps)
    except (TypeError, ValueError):
        raise ValueError(f"fps must be a number, got {fps!r}") from None
    if not math.isfinite(f) or f <= 0.0:
        raise ValueError(f"fps must be finite and > 0 (frames/s), got {fps!r}")
    if world is not None and not isinstance(world, World):
        raise ValueError(
            f"world must be an mpd_pin.world.World or None, got {type(world).__name__}"
        )

    reveal: dict[str, float] = {}
    for name, tr in (reveal_times or {}).items():
        if world is None or name not in world:
            raise ValueError(f"reveal_times names unknown obstacle {name!r}")
        if not world[name].hidden:
            raise ValueError(f"reveal_times names {name!r}, which is not a hidden obstacle")
        try:
            tr = float(tr)
        except (TypeError, ValueError):
            raise ValueError(f"reveal time of {name!r} must be a number, got {tr!r}") from None
        if not math.isfinite(tr):
            raise ValueError(f"reveal time of {name!r} must be finite, got {tr!r}")
        reveal[name] = tr

    lines: dict[str, np.ndarray] = {}
    for name, pts in (paths or {}).items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"path names must be non-empty strings, got {name!r}")
        try:
            p = np.asarray(pts, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"path {name!r} must be an (N, 3) array of points (m)") from None
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2:
            raise ValueError(f"path {name!r} must be an (N, 3) array with N >= 2, got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"path {name!r} contains NaN or infinity")
        lines[name] = p
    return t, q, reveal, f, lines


# ------------------------------------------------------------------- server
class _MeshcatSession:
    """A meshcat ``Visualizer`` whose private server process is always stopped on exit."""

    def __init__(self) -> None:
        self.vis = None

    def __enter__(self):
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL
            self.vis = meshcat.Visualizer()  # spawns `python -m meshcat.servers.zmqserver`
        try:
            sock = self.vis.window.zmq_socket
            sock.setsockopt(zmq.RCVTIMEO, _SERVER_TIMEOUT_MS)
            sock.setsockopt(zmq.SNDTIMEO, _SERVER_TIMEOUT_MS)
        except BaseException:
            self.close()
            raise
        return self.vis

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Kill the server (its own process group) and wait for it; close the socket."""
        if self.vis is None:
            return
        window, self.vis = self.vis.window, None
        sock = getattr(window, "zmq_socket", None)
        if sock is not None:
            sock.close(linger=0)
        proc: subprocess.Popen | None = getattr(window, "server_proc", None)
        if proc is None:
            return
        if proc.poll() is None:
            # meshcat starts the server with start_new_session=True: its pid is its group id.
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                proc.kill()
        proc.wait(timeout=30)
        for pipe in (proc.stdout, proc.stderr, proc.stdin):
            if pipe is not None:
                pipe.close()


# ---------------------------------------------------------------- geometry
def _obstacle_geometry(shape):
    """(meshcat geometry, 4×4 transform from the node frame to the geometry frame)."""
    intrinsic = np.eye(4)
    if isinstance(shape, Box):
        return mg.Box(list(shape.size)), intrinsic
    if isinstance(shape, Sphere):
        return mg.Sphere(shape.radius), intrinsic
    if isinstance(shape, Cylinder):
        # three.js cylinders lie along y, Coal's along z: rotate y onto z (Rx(+90°)).
        intrinsic[:3, :3] = pin.rpy.rpyToMatrix(math.pi / 2.0, 0.0, 0.0)
        return mg.Cylinder(shape.length, shape.radius), intrinsic
    if isinstance(shape, Polygon):
        return _prism_mesh(shape), intrinsic
    raise ValueError(f"cannot draw obstacle of type {type(shape).__name__}")


def _prism_mesh(shape: Polygon):
    """Triangle mesh of a convex polygon (local x–z) extruded along local y; flat-shaded."""
    v = np.asarray(shape.vertices_xz, dtype=float)  # counter-clockwise in (x, z)
    n, h = len(v), shape.thickness / 2.0

    def p(k: int, y: float) -> list[float]:
        return [v[k % n, 0], y, v[k % n, 1]]

    tris = []
    for k in range(1, n - 1):  # caps as fans
        tris.append([p(0, -h), p(k, -h), p(k + 1, -h)])
        tris.append([p(0, h), p(k + 1, h), p(k, h)])
    for k in range(n):  # sides: two triangles per edge
        tris.append([p(k, -h), p(k + 1, -h), p(k + 1, h)])
        tris.append([p(k, -h), p(k + 1, h), p(k, h)])
    # One vertex per triangle corner (no sharing) so the viewer's normals stay flat.
    verts = np.array(tris, dtype=float).reshape(-1, 3)
    faces = np.arange(len(verts)).reshape(-1, 3)
    return mg.TriangularMeshGeometry(verts, faces)


def _local_corners(shape) -> np.ndarray:
    """Corners (local frame, m) of a box bounding ``shape``."""
    if isinstance(shape, Box):
        h = np.array(shape.size) / 2.0
    elif isinstance(shape, Sphere):
        h = np.full(3, shape.radius)
    elif isinstance(shape, Cylinder):
        h = np.array([shape.radius, shape.radius, shape.length / 2.0])
    else:
        v = np.asarray(shape.vertices_xz)
        lo = np.array([v[:, 0].min(), -shape.thickness / 2.0, v[:, 1].min()])
        hi = np.array([v[:, 0].max(), shape.thickness / 2.0, v[:, 1].max()])
        return np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])
                         for c in (lo[2], hi[2])])
    return np.array([[sx * h[0], sy * h[1], sz * h[2]]
                     for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def _node_name(name: str) -> str:
    """A meshcat path element for ``name`` ('/' would split it into nested nodes)."""
    return name.replace("/", "_") or "_"


def obstacle_node(item: Any) -> str:
    """Scene path (below ``/meshcat``) of an obstacle or hazard of the world."""
    group = "hazards" if isinstance(item, Hazard) else "obstacles"
    return f"{WORLD_NODE}/{group}/{_node_name(item.name)}"


def _draw_world(vis, world: World, reveal: dict[str, int]) -> list[tuple[str, np.ndarray]]:
    """Add the obstacles (reveal: name → frame); returns (name, world corners) for framing."""
    boxes = []
    for item in world:
        hazard = isinstance(item, Hazard)
        shape = item.shape if hazard else item
        node = vis[obstacle_node(item)]
        geom, intrinsic = _obstacle_geometry(shape)
        if hazard:
            material = mg.MeshPhongMaterial(
                color=HAZARD_COLOR, transparent=True, opacity=HAZARD_OPACITY
            )
        elif item.hidden:
            material = mg.MeshPhongMaterial(color=HIDDEN_COLOR, transparent=True, opacity=0.85)
        else:
            material = mg.MeshPhongMaterial(color=OBSTACLE_COLOR)
        node["shape"].set_object(geom, material)
        node["shape"].set_transform(intrinsic)
        node.set_transform(shape.placement.homogeneous)
        if not _visibility_keys(world, item.name, reveal, 0)[0][1]:
            node.set_property("visible", False)  # as at frame 0
        corners = _local_corners(shape) @ shape.rotation_matrix.T + np.array(shape.position)
        boxes.append((item.name, corners))
    return boxes


# ---------------------------------------------------------------- main entry
def segment_bounds(n: int, segments: int = GROW_SEGMENTS) -> np.ndarray:
    """Sample indices 0 = b_0 < b_1 < … < b_m = n − 1 cutting a growing trace of ``n ≥ 2``
    points into m ≤ ``segments`` pieces; piece j joins points b_j … b_{j+1}."""
    stride = max(1, math.ceil((n - 1) / max(1, int(segments))))
    b = np.arange(0, n - 1, stride)
    return np.append(b, n - 1)


def path_node(name: str) -> str:
    """Scene path (below ``/meshcat``) of the line (or the segments) of the path ``name``."""
    return f"{PATHS_NODE}/{_node_name(name)}"


def _draw_paths(vis, lines: dict[str, np.ndarray], grow: set[str], frames: np.ndarray):
    """Add the path lines; a growing one as segments hidden until the motion reaches their
    end. Returns (legend rows, [(segment node, frame it appears)])."""
    legend, segments = [], []
    for i, (name, pts) in enumerate(lines.items()):
        color = PATH_COLORS[i % len(PATH_COLORS)]
        node = path_node(name)
        material = mg.LineBasicMaterial(color=color, linewidth=2)
        if name not in grow or len(frames) < 2:
            vis[node].set_object(mg.Line(mg.PointsGeometry(pts.T), material))
            legend.append(LegendRow(name, color, node, "line"))
            continue
        b = segment_bounds(len(pts))
        for j, (lo, hi) in enumerate(zip(b[:-1], b[1:], strict=True)):
            seg = f"{node}/{j:03d}"
            vis[seg].set_object(mg.Line(mg.PointsGeometry(pts[lo:hi + 1].T), material))
            vis[seg].set_property("visible", False)  # as at frame 0
            segments.append((seg, int(frames[hi])))
        legend.append(LegendRow(name, color, node, "growing line"))
    return legend, segments


def _draw_markers(vis, arm: Arm, q: np.ndarray) -> list[LegendRow]:
    """Spheres at the end effector's start and goal (its position at the first and last
    sample); returns their legend rows."""
    from .plots import ee_trace

    rows = []
    for name, p, color in zip(("start", "goal"), ee_trace(arm, q[[0, -1]]),
                              (START_COLOR, GOAL_COLOR), strict=True):
        node = f"{MARKERS_NODE}/{name}"
        vis[node].set_object(mg.Sphere(MARKER_RADIUS), mg.MeshLambertMaterial(color=color))
        T = np.eye(4)
        T[:3, 3] = p
        vis[node].set_transform(T)
        rows.append(LegendRow(f"{name} (end effector)", color, node, "marker"))
    return rows


def _animate(vis, f, frames, names, placements, scales, world, reveal_frames, segments) -> None:
    """One keyframe per sample for every visual geometry; visibility tracks of the hidden
    obstacles and of the growing trace segments."""
    anim = Animation(default_framerate=f)
    for k, frame in enumerate(frames):
        frame_vis = anim.at_frame(vis, int(frame))
        for name, M, scale in zip(names, placements[k], scales, strict=True):
            node = frame_vis[name]
            node.set_transform(M)
            if not np.allclose(scale, 1.0):
                node.set_property("scale", "vector3", [float(s) for s in scale])
    last = int(frames[-1])
    for item in world if world is not None else ():
        if item.hidden:
            for frame, visible in _visibility_keys(world, item.name, reveal_frames, last):
                anim.at_frame(vis, frame)[obstacle_node(item)].set_property(
                    "visible", "boolean", bool(visible)
                )
    for seg, on in segments:
        keys = [(0, False), (on, True), (last, True)] if on > 0 else [(0, True), (last, True)]
        for frame, visible in dict(keys).items():
            anim.at_frame(vis, frame)[seg].set_property("visible", "boolean", visible)
    vis.set_animation(anim, play=True, repetitions=1)


def write_replay(
    arm: Arm,
    world: World | None,
    times: np.ndarray,
    Q: np.ndarray,
    out_path: Path,
    *,
    reveal_times: dict[str, float] | None = None,
    fps: float = 30.0,
    paths: dict[str, np.ndarray] | None = None,
    grow: Sequence[str] = (),
    markers: bool = True,
    title: str = "",
) -> Path:
    """Write a self-contained meshcat HTML replay of the motion ``Q`` (rad) at ``times`` (s).

    ``reveal_times`` maps hidden obstacle names to the time (s, same clock as
    ``times``) at which they appear; hidden obstacles without one appear from the
    start if ``world`` already reports them known, else never (they remain in the
    scene tree, switchable in the viewer). ``fps`` (frames/s) is the minimum frame
    rate (see the module docstring for the keyframe ↔ sample mapping). ``paths``
    maps names to (N, 3) point lists (m), drawn as lines and named in the page's legend;
    the paths named in ``grow`` have one point per sample and grow with the motion (about
    :data:`GROW_SEGMENTS` segments, each shown from the frame of its last point); the others
    are drawn whole from the start (plans known at t = 0). ``markers``: spheres at the end
    effector's start and goal. The page shows a clock (elapsed time, s). The private meshcat
    server is stopped before returning, also on errors. Returns ``out_path``.
    """
    t, q, reveal, f, lines = _check_inputs(arm, world, times, Q, reveal_times, fps, paths)
    grow = set(grow)
    for name in grow:
        if name not in lines:
            raise ValueError(f"grow names {name!r}, which is not one of the paths")
        if len(lines[name]) != len(t):
            raise ValueError(f"growing path {name!r} needs one point per sample ({len(t)}), "
                             f"got {len(lines[name])}")
    out_path = Path(out_path)
    frames, f = keyframe_indices(t, f)
    reveal_frames = {name: _reveal_frame(tr, float(t[0]), f) for name, tr in reveal.items()}

    model = arm.model
    data = model.createData()
    vmodel = arm.visual_model
    vdata = vmodel.createData()

    # Geometry placements at every sample (also used to frame the camera).
    placements = []  # per sample: 4×4 pose of every visual geometry object
    joints = []  # per sample: joint origins (m), to frame the camera
    for qk in q:
        pin.forwardKinematics(model, data, qk)
        pin.updateGeometryPlacements(model, data, vmodel, vdata)
        placements.append([vdata.oMg[i].homogeneous.copy() for i in range(vmodel.ngeoms)])
        joints.append([data.oMi[j].translation.copy() for j in range(model.njoints)])

    with _MeshcatSession() as vis:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # Visual geometry only: an empty collision model keeps the meshes out of the page.
            viz = MeshcatVisualizer(model, pin.GeometryModel(), vmodel)
            viz.initViewer(viewer=vis)
            viz.loadViewerModel(rootNodeName=ARM_NODE)
        for w in caught:  # Pinocchio reports unloadable geometry as warnings: pass them on
            if issubclass(w.category, UserWarning) and "get_image" not in str(w.message):
                warnings.warn(f"replay: {w.message}", RuntimeWarning, stacklevel=2)
        viz.display(q[0])
        names = [viz.getViewerNodeName(g, pin.GeometryType.VISUAL) for g in vmodel.geometryObjects]
        scales = [np.asarray(g.meshScale, dtype=float).ravel() for g in vmodel.geometryObjects]

        boxes = _draw_world(vis, world, reveal_frames) if world is not None else []
        legend, segments = _draw_paths(vis, lines, grow, frames)
        if markers:
            legend += _draw_markers(vis, arm, q)

        _frame_camera(vis, placements, joints, boxes, lines)

        if len(t) > 1:
            _animate(vis, f, frames, names, placements, scales, world, reveal_frames, segments)
        page = vis.static_html()

    clock = (float(t[0]), float(t[-1])) if len(t) > 1 else None
    page = decorate(sequence_commands(page), title, legend, clock)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(page, encoding="utf-8")
    return out_path


def _frame_camera(vis, placements, joints, boxes, lines) -> None:
    """Centre the scene on the origin and put the camera where it sees all of it.

    meshcat's orbit camera always looks at the world origin, so the content
    (``/meshcat``, the grid and the axes) is shifted by −centre instead. A motion that
    stays in the x–z plane (planar arms) gets an orthographic camera looking along +y,
    like the 2-D plots (no perspective distortion from the 1 m deep planar obstacles);
    anything else a perspective view from the front-right, above.
    """
    arm = np.array(
        [M[:3, 3] for Ms in placements for M in Ms] + [p for ps in joints for p in ps]
    ).reshape(-1, 3)
    P = np.concatenate([arm, *(c for _, c in boxes), *lines.values(), np.zeros((1, 3))])
    planar = bool(np.all(np.abs(arm[:, 1]) < 1e-9))
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre = (lo + hi) / 2.0
    half = np.maximum((hi - lo) / 2.0, 0.05)
    if planar:
        centre[1] = 0.0
    shift = np.eye(4)
    shift[:3, 3] = -centre
    for node in ("/meshcat", "/Grid", "/Axes"):
        vis[node].set_transform(shift)

    # meshcat's camera lives in a y-up frame: (x, y, z)_camera = (X, Z, −Y)_world.
    if planar:
        h = max(half[2], half[0] / (4.0 / 3.0)) * 1.1  # half height (m) fitting a 4:3 window
        dist = float(np.abs(P[:, 1]).max()) + 5.0  # in front of the deepest obstacle face
        vis["/Cameras/default/rotated"].set_object(
            _PlacedOrthographicCamera(-h * 4.0 / 3.0, h * 4.0 / 3.0, h, -h, 0.01, dist + 50.0,
                                      position=(0.0, 0.0, dist))
        )
    else:
        direction = np.array([1.0, -1.3, 0.8])
        direction /= np.linalg.norm(direction)
        dist = float(np.linalg.norm(half)) / _TAN_HALF_FOV * 1.1 + 0.1
        X, Y, Z = direction * dist
        vis["/Cameras/default/rotated/<object>"].set_property("position", [X, Z, -Y])


class _PlacedOrthographicCamera(mg.OrthographicCamera):
    """meshcat's orthographic camera, created at ``position`` (camera frame, m).

    The position travels inside the object (three.js ``matrix``): no later command
    has to find the new camera in place (static pages run their commands asynchronously).
    """

    def __init__(self, *args: float, position: tuple[float, float, float]) -> None:
        super().__init__(*args)
        self.position = tuple(float(x) for x in position)

    def lower(self) -> dict[str, Any]:
        data = super().lower()
        T = np.eye(4)
        T[:3, 3] = self.position
        data["object"]["matrix"] = list(T.T.flatten())  # three.js matrices are column-major
        return data
