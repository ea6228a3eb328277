"""Occupancy analysis (paper 000 §4): random configurations and the workspace they reach.

:func:`occupancy_analysis` samples configurations uniformly within the joint
limits (seeded ``numpy.random.Generator``), computes the position of a frame
(the end effector) and whether each configuration is collision-free, and bins
the positions into a 2-D grid on a plane (the arm's x–z plane by default):

* a cell is *reachable* if any sample's frame position falls in it;
* a cell is *free* if a collision-free sample's position falls in it.

For a 3-D arm the grid is the projection of the reached positions onto the
chosen plane. :meth:`Occupancy.plot` draws both sets of cells and the
obstacles' cross-sections with the plane y = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from ..collision import CollisionChecker
from ..world import Hazard, World

__all__ = ["Occupancy", "occupancy_analysis", "default_frame", "PLANES"]

#: Grid planes: name -> indices of the two world axes used (first is horizontal in plots).
PLANES: dict[str, tuple[int, int]] = {"xz": (0, 2), "xy": (0, 1), "yz": (1, 2)}


def default_frame(arm: Arm) -> str:
    """The end-effector frame: ``"ee"`` for the planar arms, else the model's last frame."""
    if arm.model.existFrame("ee"):
        return "ee"
    return arm.model.frames[len(arm.model.frames) - 1].name


@dataclass(eq=False)
class Occupancy:
    """Result of :func:`occupancy_analysis`.

    Attributes: ``samples`` (N, nq) configurations; ``points`` (N, 3) frame
    positions (m); ``free`` (N,) collision-free flags; ``edges`` the grid cell
    edges (m) along the plane's two axes; ``reached`` and ``reached_free``
    sample counts per cell, shape (n_u, n_v) (index [i, j] = cell
    ``edges[0][i]..edges[0][i+1]`` × ``edges[1][j]..edges[1][j+1]``).
    """

    samples: np.ndarray
    points: np.ndarray
    free: np.ndarray
    frame: str
    plane: str
    edges: tuple[np.ndarray, np.ndarray]
    reached: np.ndarray
    reached_free: np.ndarray
    world: World | None = None
    include_hidden: bool = False
    arm_name: str = field(default="arm")

    # ----------------------------------------------------------- grids
    @property
    def reachable(self) -> np.ndarray:
        """Boolean grid: cells reached by any sample."""
        return self.reached > 0

    @property
    def free_cells(self) -> np.ndarray:
        """Boolean grid: cells reached by a collision-free sample."""
        return self.reached_free > 0

    @property
    def cell_size(self) -> float:
        """Side of a (square) cell (m)."""
        return float(self.edges[0][1] - self.edges[0][0])

    @property
    def cell_area(self) -> float:
        """Area of one cell (m²)."""
        return self.cell_size**2

    @property
    def grid_area(self) -> float:
        """Area covered by the grid (m²)."""
        (u, v) = self.edges
        return float((u[-1] - u[0]) * (v[-1] - v[0]))

    @property
    def reachable_fraction(self) -> float:
        """Fraction of the grid's cells that are reachable."""
        return float(self.reachable.mean())

    @property
    def free_fraction(self) -> float:
        """Fraction of the grid's cells reached by a collision-free sample."""
        return float(self.free_cells.mean())

    @property
    def reachable_area(self) -> float:
        """Area (m²) of the reachable cells."""
        return float(self.reachable.sum()) * self.cell_area

    @property
    def free_area(self) -> float:
        """Area (m²) of the cells reached collision-free."""
        return float(self.free_cells.sum()) * self.cell_area

    @property
    def free_sample_fraction(self) -> float:
        """Fraction of the sampled configurations that are collision-free."""
        return float(self.free.mean()) if self.free.size else 0.0

    # ------------------------------------------------------------ plot
    def plot(self, ax: Any = None, *, show_obstacles: bool = True, title: str | None = None):
        """Draw reachable vs free cells and the obstacles; returns the matplotlib Axes.

        Cells reached only in collision are orange, cells reached collision-free
        green. Obstacles are grey patches (hazards red, hidden ones dashed), drawn
        as their cross-section with the plane y = 0 (only for the x–z plane).
        Each patch's ``gid`` is the obstacle's name.
        """
        import matplotlib.pyplot as plt
        from matplotlib.colors import ListedColormap
        from matplotlib.patches import Patch
        from matplotlib.patches import Polygon as PolygonPatch

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 6))
        status = np.zeros(self.reached.shape, dtype=int)
        status[self.reachable] = 1
        status[self.free_cells] = 2
        cmap = ListedColormap(["white", "#f4a259", "#5b9e6b"])
        u, v = self.edges
        ax.pcolormesh(u, v, status.T, cmap=cmap, vmin=0, vmax=2, shading="flat")
        handles = [
            Patch(color="#5b9e6b", label="reached collision-free"),
            Patch(color="#f4a259", label="reached only in collision"),
        ]
        if show_obstacles and self.world is not None and self.plane == "xz":
            for item in self.world:
                shape = item.shape if isinstance(item, Hazard) else item
                section = shape.section_xz()
                if section is None:
                    continue
                hazard = isinstance(item, Hazard)
                known = self.include_hidden or self.world.is_known(item.name)
                patch = PolygonPatch(
                    section,
                    closed=True,
                    facecolor="#d1495b" if hazard else "#6c757d",
                    edgecolor="black",
                    alpha=0.55 if known else 0.25,
                    linestyle="-" if known else "--",
                    gid=item.name,
                    label=item.name,
                )
                ax.add_patch(patch)
            handles.append(Patch(color="#6c757d", alpha=0.55, label="obstacle"))
            if self.world.hazards:
                handles.append(Patch(color="#d1495b", alpha=0.55, label="hazard (No Enter)"))
        names = {0: "x", 1: "y", 2: "z"}
        a, b = PLANES[self.plane]
        ax.set_xlabel(f"{names[a]} (m)")
        ax.set_ylabel(f"{names[b]} (m)")
        ax.set_aspect("equal")
        ax.set_xlim(u[0], u[-1])
        ax.set_ylim(v[0], v[-1])
        ax.legend(handles=handles, loc="upper right", fontsize="small")
        ax.set_title(
            title
            or f"{self.arm_name}: {len(self.samples)} samples, reachable "
            f"{self.reachable_area:.3f} m², free {self.free_area:.3f} m²"
        )
        return ax


def _rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None or isinstance(seed, (int, np.integer)):
        return np.random.default_rng(seed)
    raise ValueError(f"seed must be an int, a numpy Generator or None, got {seed!r}")


def frame_positions(arm: Arm, Q: np.ndarray, frame: str) -> np.ndarray:
    """World positions (K, 3) (m) of ``frame`` at each row of ``Q`` (K, nq)."""
    model = arm.model
    if not model.existFrame(frame):
        raise ValueError(f"arm {arm.name!r} has no frame {frame!r}")
    fid = model.getFrameId(frame)
    data = model.createData()
    out = np.empty((len(Q), 3))
    for k, q in enumerate(Q):
        pin.forwardKinematics(model, data, q)
        out[k] = pin.updateFramePlacement(model, data, fid).translation
    return out


def occupancy_analysis(
    arm: Arm,
    world: World | None = None,
    n_samples: int = 10_000,
    *,
    seed: int | np.random.Generator | None = 0,
    frame: str | None = None,
    cell_size: float = 0.02,
    extent: float | None = None,
    plane: str = "xz",
    checker: CollisionChecker | None = None,
    include_hidden: bool = False,
) -> Occupancy:
    """Sample ``n_samples`` configurations and map the workspace they reach (paper 000 §4).

    Parameters
    ----------
    arm, world:
        The arm and its obstacles (None: no obstacles; self-collision still counts).
    seed:
        Seed or ``numpy.random.Generator`` for the uniform joint-limit sampling.
    frame:
        Frame whose position is mapped (default :func:`default_frame`).
    cell_size:
        Grid cell side (m).
    extent:
        Half-width (m) of the square grid centred on the base; default: just
        beyond the farthest sampled position, rounded up to whole cells.
    plane:
        ``"xz"`` (planar arms), ``"xy"`` or ``"yz"``: the grid's plane.
    checker:
        A :class:`CollisionChecker` to use instead of building one.
    include_hidden:
        Treat hidden obstacles as present (ground truth) when building the checker.
    """
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)):
        raise ValueError(f"n_samples must be an integer, got {n_samples!r}")
    if n_samples < 1:
        raise ValueError(f"n_samples must be >= 1, got {n_samples}")
    cell = float(cell_size)
    if not math.isfinite(cell) or cell <= 0:
        raise ValueError(f"cell_size must be finite and > 0 (m), got {cell_size!r}")
    if plane not in PLANES:
        raise ValueError(f"plane must be one of {sorted(PLANES)}, got {plane!r}")
    frame = default_frame(arm) if frame is None else frame
    if not arm.model.existFrame(frame):
        raise ValueError(f"arm {arm.name!r} has no frame {frame!r}")
    lo, hi = arm.lower_limits, arm.upper_limits
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("occupancy sampling needs finite joint limits")
    if checker is None:
        checker = CollisionChecker(arm, world, include_hidden=include_hidden)
    elif checker.arm is not arm:
        raise ValueError("checker was built for a different arm")
    elif world is not None and world is not checker.world:
        raise ValueError("pass either world or a checker built on it, not a different world")
    else:
        world = checker.world
        include_hidden = checker.include_hidden

    rng = _rng(seed)
    samples = rng.uniform(lo, hi, size=(int(n_samples), arm.nq))
    points = frame_positions(arm, samples, frame)
    free = checker.is_free_batch(samples)

    a, b = PLANES[plane]
    uv = points[:, [a, b]]
    if extent is None:
        half = float(np.abs(uv).max()) + cell
        half = math.ceil(half / cell - 1e-9) * cell
    else:
        half = float(extent)
        if not math.isfinite(half) or half <= 0:
            raise ValueError(f"extent must be finite and > 0 (m), got {extent!r}")
    n = max(1, round(2 * half / cell))
    edges_1d = -half + cell * np.arange(n + 1)
    edges = (edges_1d, edges_1d.copy())
    reached = np.histogram2d(uv[:, 0], uv[:, 1], bins=edges)[0].astype(np.int64)
    reached_free = np.histogram2d(uv[free, 0], uv[free, 1], bins=edges)[0].astype(np.int64)
    return Occupancy(
        samples=samples,
        points=points,
        free=free,
        frame=frame,
        plane=plane,
        edges=edges,
        reached=reached,
        reached_free=reached_free,
        world=world,
        include_hidden=include_hidden,
        arm_name=arm.name,
    )
