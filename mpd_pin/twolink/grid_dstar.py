"""D* on the 8-connected grid of end-effector cells, per elbow branch (paper 002 §5).

The search space is the set of (cell, branch) *states* of a
:class:`~mpd_pin.twolink.fcs.FreeCartesianSpace`: the end effector on a grid
cell with the elbow up or down. A state has an edge to each reachable state
on one of its 8 neighbouring cells, on either branch, provided the joint
angles change by at most ``max_joint_step`` (rad, max over the two joints) —
so branch switches (elbow up ↔ down) only appear where both branches nearly
coincide, near the outer circle of the workspace, and stay continuous in joint
space; the same test keeps q1 from jumping across its ±π limit. The same-cell
switch (c, up) ↔ (c, down) is an edge too when it passes that test.

How many switches that leaves depends on the step. With the default step of
the arm's velocity limits (10 rad/s × Ts = 0.1 rad for the built-in arm) the
two branches are within 0.1 rad only for r > 0.9997 m, and q2 changes too fast
near the rim (dq2/dr → ∞ at r = l1 + l2) for any grid move to get there: on the
0.025 m grid of env1/env2 the only branch-changing edges are same-cell
switches on the cells exactly on the rim, which no other edge reaches. So the
velocity-limited D* motion never switches the elbow — a task that needs a
switch has no path and ends in :class:`~mpd_pin.twolink.planner.TrappedError`
rather than a jump. A larger ``max_joint_step`` (0.5 rad on a 0.05 m grid, say,
which exceeds the URDF's velocity limits) makes switches reachable near the
rim, continuous in joint space by the same test (both checked in
``tests/test_twolink_dstar.py``).
Edge costs are the end-effector displacement (m): the step for a side move,
step·√2 for a diagonal one, 0 for a same-cell switch (paper 002 eq. 7 with g
the path length so far and h the straight-line distance to the goal), plus an
optional ``switch_penalty`` (m) on every branch-changing edge so that, among
paths of equal length, D* does not switch the elbow for nothing.

The package's :class:`~mpd_pin.search.DStarLite` searches from the goal
(Koenig & Likhachev's incremental D*). The obstacles of one motion sample
(paper 002: "the closed list is changing dynamically over motion samples to
save the obstacle nodes in the current motion sample only") block the states
that are not free at that sample. As in the paper ("obstacles having a huge
cost function") an edge *into* a blocked state gets ``blocked_cost`` (m,
default 1000) added rather than being removed, so a path exists whenever the
goal is reachable at all and the arm can advance along its free part while
an obstacle sits on the rest (the executor then stops before a blocked state);
``blocked_cost = inf`` removes such edges instead. :meth:`GridDStar.set_free`
applies the difference between two samples as a batch of edge-cost changes,
which D* Lite repairs incrementally.

All goal states lead to one extra node (``goal_node``) by edges of cost 0,
so "the goal with either elbow" is a single search goal.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from ..search import DStarLite, Graph, NoPathError
from .fcs import FreeCartesianSpace

__all__ = ["GridDStar", "build_state_graph"]

# (di, dj) offsets of the 8-connected neighbourhood, then the same cell (branch switch).
_OFFSETS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1), (0, 0)]


def build_state_graph(
    fcs: FreeCartesianSpace,
    max_joint_step: float,
    goal_states: Iterable[int],
    switch_penalty: float = 0.0,
) -> tuple[Graph, np.ndarray, np.ndarray, np.ndarray]:
    """The (cell, branch) state graph plus a goal node; returns (graph, src, dst, base_cost).

    Node ids: the states of ``fcs`` (``branch·num_cells + cell``), then
    ``goal_node = 2·num_cells``. ``base_cost`` is each edge's unblocked cost (m):
    the end-effector displacement, plus ``switch_penalty`` (m) on edges that
    change the elbow branch.
    """
    if not (math.isfinite(max_joint_step) and max_joint_step > 0):
        raise ValueError(f"max_joint_step must be finite and > 0 (rad), got {max_joint_step!r}")
    if not (math.isfinite(switch_penalty) and switch_penalty >= 0):
        raise ValueError(f"switch_penalty must be finite and ≥ 0 (m), got {switch_penalty!r}")
    grid = fcs.grid
    nx, nz, nc = grid.nx, grid.nz, grid.num_cells
    q = fcs.q_states.reshape(2, nz, nx, 2)
    ok = fcs.reachable.reshape(2, nz, nx)
    side = float(grid.step)
    diag = math.hypot(grid.step, grid.step)
    src_l, dst_l, cost_l = [], [], []
    I, J = np.meshgrid(np.arange(nz), np.arange(nx), indexing="ij")
    for di, dj in _OFFSETS:
        i0 = slice(max(0, -di), nz - max(0, di))
        j0 = slice(max(0, -dj), nx - max(0, dj))
        i1 = slice(max(0, di), nz - max(0, -di))
        j1 = slice(max(0, dj), nx - max(0, -dj))
        c = 0.0 if (di == 0 and dj == 0) else (diag if (di and dj) else side)
        for b0 in (0, 1):
            for b1 in (0, 1):
                if di == 0 and dj == 0 and b0 == b1:
                    continue
                jump = np.abs(q[b1][i1, j1] - q[b0][i0, j0]).max(axis=-1)
                m = ok[b0][i0, j0] & ok[b1][i1, j1] & (jump <= max_joint_step)
                cells0 = (I[i0, j0] * nx + J[i0, j0])[m]
                cells1 = (I[i1, j1] * nx + J[i1, j1])[m]
                src_l.append(b0 * nc + cells0)
                dst_l.append(b1 * nc + cells1)
                cost_l.append(np.full(cells0.size, c + (switch_penalty if b0 != b1 else 0.0)))
    goal_node = 2 * nc
    goals = np.array(sorted(set(int(s) for s in goal_states)), dtype=np.int64)
    src_l.append(goals)
    dst_l.append(np.full(goals.size, goal_node, dtype=np.int64))
    cost_l.append(np.zeros(goals.size))
    src = np.concatenate(src_l).astype(np.int64)
    dst = np.concatenate(dst_l).astype(np.int64)
    cost = np.concatenate(cost_l)
    return Graph.from_arrays(2 * nc + 1, src, dst, cost), src, dst, cost


class GridDStar:
    """Incremental D* (the package's D* Lite) over (cell, branch) states, one snapshot at a time.

    ``free`` is the initial occupancy: a (2·num_cells,) bool array (True =
    the state is free in the current motion sample), e.g.
    ``fcs.free_states(0)``. ``goal_states``: the acceptable goal states.
    """

    def __init__(
        self,
        fcs: FreeCartesianSpace,
        start_state: int,
        goal_states: Iterable[int],
        free: np.ndarray,
        *,
        max_joint_step: float = 0.5,
        switch_penalty: float = 0.0,
        blocked_cost: float = 1000.0,
    ) -> None:
        if not blocked_cost > 0:
            raise ValueError(f"blocked_cost must be > 0 (m), got {blocked_cost!r}")
        self.blocked_cost = float(blocked_cost)
        self.fcs = fcs
        self.goal_states = frozenset(int(s) for s in goal_states)
        if not self.goal_states:
            raise ValueError("no goal state")
        self.graph, src, dst, base = build_state_graph(
            fcs, max_joint_step, self.goal_states, switch_penalty
        )
        self.goal_node = 2 * fcs.grid.num_cells
        self._base = {}  # (u, v) -> unblocked cost, only for edges into states
        for u, v, c in zip(src.tolist(), dst.tolist(), base.tolist(), strict=True):
            if v != self.goal_node:
                self._base[(u, v)] = c
        pts = fcs.grid.points()
        nc = fcs.grid.num_cells
        goal_cell = next(iter(self.goal_states)) % nc
        xs = [float(x) for x in pts[:, 0]] * 2 + [float(pts[goal_cell, 0])]
        zs = [float(z) for z in pts[:, 1]] * 2 + [float(pts[goal_cell, 1])]
        self._xs, self._zs = xs, zs
        if len({s % nc for s in self.goal_states}) != 1:
            raise ValueError("all goal states must be on one cell")
        free = np.asarray(free, dtype=bool)
        # Block the initially occupied states before the first search (cheap: no search yet).
        blocked = np.flatnonzero(~free[: 2 * nc])
        g = self.graph
        for v in blocked.tolist():
            for u in g.predecessors(v).tolist():
                g.set_cost(u, v, self._blocked(self._base[(u, v)]))
        self._free = free[: 2 * nc].copy()
        self.planner = DStarLite(self.graph, int(start_state), self.goal_node, self.heuristic)
        self.updates = 0

    def _blocked(self, cost: float) -> float:
        return cost + self.blocked_cost

    def heuristic(self, a: int, b: int) -> float:
        """Straight-line distance (m) between the cells of two nodes (admissible, consistent).

        Shrunk by a relative 1e-9 so that rounding can never make it exceed an edge cost.
        """
        return (1.0 - 1e-9) * math.hypot(self._xs[a] - self._xs[b], self._zs[a] - self._zs[b])

    def successors(self, state: int) -> list[int]:
        """States one move (or a same-cell branch switch) away from ``state``."""
        return [v for v in self.graph.successors(int(state)).tolist() if v != self.goal_node]

    def set_free(self, free: np.ndarray) -> int:
        """Make ``free`` the current snapshot; returns the number of states that changed."""
        free = np.asarray(free, dtype=bool)[: len(self._free)]
        changed = np.flatnonzero(free != self._free)
        if changed.size == 0:
            return 0
        g = self.graph
        changes = []
        for v in changed.tolist():
            open_ = bool(free[v])
            for u in g.predecessors(v).tolist():
                c = self._base[(u, v)]
                changes.append((u, v, c if open_ else self._blocked(c)))
        self.planner.update_edges(changes)
        self._free = free.copy()
        self.updates += len(changes)
        return int(changed.size)

    def plan_from(self, state: int) -> list[int]:
        """Cheapest state path (start first, goal state last) from ``state``; NoPathError if none.

        With a finite ``blocked_cost`` the path may cross states blocked in the
        current snapshot (as few as possible); :meth:`is_blocked` tells.
        """
        self.planner.move_start(int(state))
        if int(state) in self.goal_states:
            return [int(state)]
        nodes = self.planner.plan().nodes
        if nodes[-1] != self.goal_node:  # pragma: no cover - D* Lite always ends at the goal
            raise NoPathError("D* path does not end at the goal")
        return nodes[:-1]

    def is_blocked(self, state: int) -> bool:
        """True if ``state`` is blocked in the current snapshot."""
        return not bool(self._free[int(state)])

    def cost_to_goal(self, state: int) -> float:
        """D* Lite's g(state): remaining cost (m) in the current snapshot (inf if cut off).

        Includes ``blocked_cost`` for every blocked state on the way.
        """
        return self.planner.g(int(state))
