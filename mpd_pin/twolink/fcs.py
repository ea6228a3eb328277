"""Free-Cartesian-space (FCS) analysis on a workspace grid (paper 002 §4, Figs. 5 and 11).

The workspace is a Cartesian grid of end-effector cells (:class:`Grid`, nodes
every ``step`` m). A cell is *free with elbow up* at motion sample k when the
elbow-up inverse kinematics (eqs. 3–6) reaches it within the joint limits and
that configuration is collision-free against the obstacles at t = k·Ts — no
link (nor the end effector, which lies on link 2) touching an obstacle, with
the checker's security margin. Likewise for elbow down. Each cell is then in
one of four classes: up only, down only, both, neither (outside the annulus,
inside an obstacle, or a link in collision) — the colours of the paper's FCS
figures.

The inverse kinematics of the whole grid is computed once (the arm does not
change); each sample then costs one batched Coal query over the reachable
(cell, branch) configurations. Maps are cached per sample.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .ik import BRANCHES, TwoLinkKinematics
from .moving import SampledCollisionChecker

__all__ = ["Grid", "FCSMap", "FreeCartesianSpace"]


@dataclass(frozen=True)
class Grid:
    """Cartesian grid of end-effector cells: x ∈ [x_min, x_max], z ∈ [z_min, z_max], ``step`` m.

    Node (i, j) is at (x_min + j·step, z_min + i·step); cells are numbered
    row-major, ``cell = i·nx + j`` (row i along z, column j along x).
    """

    x_min: float
    x_max: float
    z_min: float
    z_max: float
    step: float

    def __post_init__(self) -> None:
        vals = [self.x_min, self.x_max, self.z_min, self.z_max, self.step]
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals):
            raise ValueError(f"grid bounds and step must be finite numbers (m), got {vals}")
        if self.step <= 0:
            raise ValueError(f"grid step must be > 0 (m), got {self.step}")
        if self.x_max <= self.x_min or self.z_max <= self.z_min:
            raise ValueError("grid needs x_min < x_max and z_min < z_max")
        if self.nx * self.nz > 4_000_000:
            raise ValueError(f"grid of {self.nx}×{self.nz} cells is too fine")

    @property
    def nx(self) -> int:
        return int(math.floor((self.x_max - self.x_min) / self.step + 1e-9)) + 1

    @property
    def nz(self) -> int:
        return int(math.floor((self.z_max - self.z_min) / self.step + 1e-9)) + 1

    @property
    def num_cells(self) -> int:
        return self.nx * self.nz

    @property
    def xs(self) -> np.ndarray:
        """x of the grid columns (m)."""
        return self.x_min + self.step * np.arange(self.nx)

    @property
    def zs(self) -> np.ndarray:
        """z of the grid rows (m)."""
        return self.z_min + self.step * np.arange(self.nz)

    def points(self) -> np.ndarray:
        """(num_cells, 2) cell positions (x, z) (m) in cell order."""
        X, Z = np.meshgrid(self.xs, self.zs)  # (nz, nx)
        return np.column_stack([X.ravel(), Z.ravel()])

    def point(self, cell: int) -> np.ndarray:
        i, j = divmod(int(cell), self.nx)
        return np.array([self.x_min + j * self.step, self.z_min + i * self.step])

    def nearest_cell(self, p: Sequence[float]) -> int:
        """The cell nearest to (x, z) (m); ValueError outside the grid (by more than step/2)."""
        x, z = float(p[0]), float(p[1])
        j = round((x - self.x_min) / self.step)
        i = round((z - self.z_min) / self.step)
        if not (0 <= j < self.nx and 0 <= i < self.nz):
            raise ValueError(
                f"point ({x:.4f}, {z:.4f}) m is outside the grid x ∈ [{self.x_min}, {self.x_max}], "
                f"z ∈ [{self.z_min}, {self.z_max}] m"
            )
        return int(i * self.nx + j)

    def neighbours(self, cell: int) -> list[int]:
        """The up to 8 cells around ``cell`` (8-connected)."""
        i, j = divmod(int(cell), self.nx)
        out = []
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di == 0 and dj == 0:
                    continue
                a, b = i + di, j + dj
                if 0 <= a < self.nz and 0 <= b < self.nx:
                    out.append(a * self.nx + b)
        return out

    def to_dict(self) -> dict:
        return {
            "x": [self.x_min, self.x_max],
            "z": [self.z_min, self.z_max],
            "step": self.step,
            "nx": self.nx,
            "nz": self.nz,
        }


@dataclass(frozen=True)
class FCSMap:
    """Free Cartesian space at one motion sample.

    ``free`` (2, nz, nx) bool: [0] elbow up, [1] elbow down (row i = z, column
    j = x, as :class:`Grid`); ``sample`` index k and time ``t`` = k·Ts (s).
    """

    sample: int
    t: float
    free: np.ndarray

    @property
    def up(self) -> np.ndarray:
        return self.free[0]

    @property
    def down(self) -> np.ndarray:
        return self.free[1]

    @property
    def both(self) -> np.ndarray:
        return self.free[0] & self.free[1]

    @property
    def either(self) -> np.ndarray:
        return self.free[0] | self.free[1]

    @property
    def classes(self) -> np.ndarray:
        """(nz, nx) int: 0 neither, 1 elbow up only, 2 elbow down only, 3 both."""
        return self.free[0].astype(np.int8) + 2 * self.free[1].astype(np.int8)

    def counts(self) -> dict[str, int]:
        c = self.classes
        return {
            "neither": int(np.sum(c == 0)),
            "up_only": int(np.sum(c == 1)),
            "down_only": int(np.sum(c == 2)),
            "both": int(np.sum(c == 3)),
        }


class FreeCartesianSpace:
    """FCS maps of ``grid`` for a two-link arm among moving obstacles (paper 002 §4).

    ``states``: a (cell, branch) pair is numbered ``branch·num_cells + cell``
    (branch 0 = up, 1 = down). ``q_states`` (2·num_cells, 2) holds their joint
    angles (rad; 0 where unreachable) and ``reachable`` their IK feasibility.
    """

    def __init__(
        self, kin: TwoLinkKinematics, grid: Grid, checker: SampledCollisionChecker
    ) -> None:
        self.kin = kin
        self.grid = grid
        self.checker = checker
        pts = grid.points()
        qs = []
        reach = []
        for b in BRANCHES:
            sol = kin.ik(pts, b)
            qs.append(sol.q)
            reach.append(sol.reachable)
        self.q_states = np.concatenate(qs, axis=0)
        self.reachable = np.concatenate(reach)
        self._reach_idx = np.flatnonzero(self.reachable)
        self._maps: dict[int, np.ndarray] = {}

    @property
    def num_states(self) -> int:
        return 2 * self.grid.num_cells

    def state(self, cell: int, branch: int) -> int:
        return int(branch) * self.grid.num_cells + int(cell)

    def cell_branch(self, state: int) -> tuple[int, int]:
        b, c = divmod(int(state), self.grid.num_cells)
        return c, b

    def free_states(self, k: int) -> np.ndarray:
        """(2·num_cells,) bool: which (cell, branch) states are free at sample ``k`` (cached)."""
        k = int(k)
        out = self._maps.get(k)
        if out is None:
            out = np.zeros(self.num_states, dtype=bool)
            idx = self._reach_idx
            out[idx] = self.checker.is_free_batch(self.q_states[idx], k)
            out.flags.writeable = False
            self._maps[k] = out
        return out

    def is_free_state(self, state: int, k: int) -> bool:
        return bool(self.free_states(k)[int(state)])

    def map_at(self, k: int) -> FCSMap:
        """The FCS map of sample ``k``."""
        f = self.free_states(k).reshape(2, self.grid.nz, self.grid.nx)
        return FCSMap(sample=int(k), t=int(k) * self.checker.scene.ts, free=f.copy())
