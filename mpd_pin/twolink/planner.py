"""The paper-002 pipeline: FCS per sample → D* with stop and return backward → PSO smoothing.

Execution of the D* path (paper 002 §5, Fig. 2), one motion sample at a time
(sample k at t = k·Ts). The arm is at state s_k = (cell, branch), free at t_k.
A *move* u (sample k) → v (sample k+1) is valid when v is free at k+1 and the
joints, interpolated linearly from q_u to q_v, are free at the ``substeps − 1``
inner sub-steps against the obstacles at t = (k + j/substeps)·Ts (same
collision margin; staying put is a move too, while the obstacles move).

1. The obstacles *of the current sample* block their states (the FCS map of
   sample k); D* (:class:`~mpd_pin.twolink.grid_dstar.GridDStar`) repairs the
   shortest path from s_k to the goal.
2. Look one sample ahead, at the FCS map of sample k+1:

   * **move** — the move to the next state of the path is valid: go there;
   * **stop** — it is not (or no path exists in this snapshot) but staying
     put is: wait one sample;
   * **return backward** — the current state itself is about to be hit
     (staying is not valid): retreat to a neighbouring state (one grid move,
     or a same-cell branch switch, both within ``max_joint_step``) whose move
     is valid. A retreat goes back: only states whose cell is *not closer to
     the goal* (straight-line distance) than the current one are candidates;
     among them the one that stays free for the most of the next
     ``lookahead`` samples, then the state the arm came from, then the one
     with the least D* cost to the goal. Only if no such state is free does
     the arm escape to a neighbour closer to the goal (same ranking); the
     event then says ``"retreat": false``.

   If no neighbour is free at k+1 the arm cannot be saved by stopping or
   retreating: :class:`TrappedError` is raised (nothing colliding is ever
   returned). So is exceeding ``max_samples``.

So every sample of the D* motion is collision-free by construction (states are
checked against the obstacles of the sample at which the arm occupies them,
and the moves between them at the sub-steps), and consecutive samples differ
by at most ``max_joint_step`` in every joint.

``max_joint_step`` (rad per sample) defaults to the arm's joint velocity limit
(URDF ``<limit velocity>``, the smallest over the joints) × Ts — 10 rad/s ×
0.01 s = 0.1 rad for the built-in arm — so the motion never exceeds the joint
speed limits; a scenario may override it (``[motion] max_joint_step``).

Then PSO (:mod:`~mpd_pin.twolink.pso`) chooses via points on that motion (the
swarm starts at random via points, plus one particle with evenly spread ones);
the executed smoothed motion is the best spline found, re-checked sample by
sample and sub-step by sub-step.
If PSO finds nothing shorter than the D* motion, the D* motion itself is
executed (``pso_improved`` is False), so the smoothed path is never longer.
Path lengths are end-effector polylines through the positions at the motion
samples (m).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..app.timing import PhaseClock
from ..arm.model import Arm
from ..errors import NoPathError
from .fcs import FreeCartesianSpace, Grid
from .grid_dstar import GridDStar
from .ik import BRANCHES, TwoLinkKinematics, branch_index
from .moving import MovingScene, SampledCollisionChecker
from .pso import PSOOptions, PSOResult, SmoothedMotion, ViaPointSmoother, path_length, pso_minimize

__all__ = [
    "TrappedError",
    "DynamicProblem",
    "DStarMotion",
    "DynamicPlanResult",
    "execute_dstar",
    "plan_dynamic",
]


class TrappedError(NoPathError):
    """Neither moving, stopping nor returning backward keeps the arm collision-free."""


@dataclass
class DynamicProblem:
    """A two-link arm among moving obstacles (paper 002).

    ``start``/``goal``: end-effector points (x, z) (m), snapped to the nearest
    grid cell; ``start_branch``: ``"up"``/``"down"``; ``goal_branch``: also
    ``"any"``. ``margin`` (m): clearance the links must keep from every
    obstacle at every sample and sub-step (≥ the link radius makes the
    cylinder links safe as capsules too). ``max_joint_step`` (rad): largest
    joint change between two samples; None (default) takes the arm's joint
    velocity limits × Ts (:attr:`joint_step_limit`). ``substeps``: the moves
    between samples are checked at ``substeps − 1`` interpolated instants
    (1: samples only). ``switch_penalty`` (m): extra D* cost of an
    elbow-branch switch. ``max_samples``: give up after this many.
    ``lookahead``: samples looked ahead when choosing where to retreat.
    """

    arm: Arm
    scene: MovingScene
    grid: Grid
    start: tuple[float, float]
    goal: tuple[float, float]
    start_branch: str = "up"
    goal_branch: str = "any"
    margin: float = 0.03
    max_joint_step: float | None = None
    substeps: int = 4
    switch_penalty: float = 0.05
    max_samples: int = 500
    lookahead: int = 5
    pso: PSOOptions = field(default_factory=PSOOptions)
    num_via: int = 10
    spline_bc: str = "clamped"
    num_threads: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.arm, Arm):
            raise ValueError(f"arm must be an mpd_pin.Arm, got {type(self.arm).__name__}")
        if not isinstance(self.scene, MovingScene):
            raise ValueError("scene must be a MovingScene")
        if not isinstance(self.grid, Grid):
            raise ValueError("grid must be a Grid")
        if not isinstance(self.pso, PSOOptions):
            raise ValueError("pso must be a PSOOptions")
        branch_index(self.start_branch)
        if self.goal_branch != "any":
            branch_index(self.goal_branch)
        for name in ("start", "goal"):
            p = np.asarray(getattr(self, name), dtype=float)
            if p.shape != (2,) or not np.all(np.isfinite(p)):
                raise ValueError(f"{name} must be one finite (x, z) point in m")
            setattr(self, name, (float(p[0]), float(p[1])))
        checks = (
            ("margin", self.margin >= 0),
            ("max_joint_step", self.max_joint_step is None or self.max_joint_step > 0),
            ("substeps", self.substeps >= 1),
            ("switch_penalty", self.switch_penalty >= 0), ("max_samples", self.max_samples >= 1),
            ("lookahead", self.lookahead >= 1), ("num_via", self.num_via >= 1),
            ("num_threads", self.num_threads >= 1),
        )
        for name, ok in checks:
            value = getattr(self, name)
            if not ok or (value is not None and not math.isfinite(value)):
                raise ValueError(f"{name} out of range: {value!r}")
        if self.spline_bc not in ("clamped", "natural", "not-a-knot"):
            raise ValueError(f"spline_bc must be clamped, natural or not-a-knot, got "
                             f"{self.spline_bc!r}")
        self.joint_step_limit  # noqa: B018 - raises if the arm has no usable velocity limits

    @property
    def velocity_limits(self) -> np.ndarray:
        """The arm's joint velocity limits (rad/s), from its URDF."""
        return np.asarray(self.arm.model.velocityLimit, dtype=float).copy()

    @property
    def velocity_joint_step(self) -> float | None:
        """Smallest joint velocity limit × Ts (rad per sample); None without usable limits."""
        v = self.velocity_limits
        if v.size == 0 or not np.all(np.isfinite(v)) or not np.all(v > 0):
            return None
        return float(v.min()) * self.ts

    @property
    def joint_step_limit(self) -> float:
        """The joint step limit in force (rad per sample): ``max_joint_step`` or the derived one."""
        if self.max_joint_step is not None:
            return float(self.max_joint_step)
        step = self.velocity_joint_step
        if step is None:
            raise ValueError(
                f"arm {self.arm.name!r} has no finite, positive joint velocity limits "
                f"({self.velocity_limits.tolist()}); set max_joint_step"
            )
        return step

    @property
    def ts(self) -> float:
        return self.scene.ts


@dataclass
class DStarMotion:
    """The executed D* motion: one state per motion sample, and the stop/backward events."""

    states: list[int]
    points: np.ndarray  # (K+1, 2) m
    q: np.ndarray  # (K+1, 2) rad
    branches: np.ndarray  # (K+1,) 0 up, 1 down
    events: list[dict[str, Any]]
    replans: int
    edge_updates: int

    @property
    def num_samples(self) -> int:
        return len(self.states)

    @property
    def length(self) -> float:
        return path_length(self.points)


@dataclass
class DynamicPlanResult:
    """Everything :func:`plan_dynamic` produced."""

    problem: DynamicProblem
    kin: TwoLinkKinematics
    fcs: FreeCartesianSpace
    checker: SampledCollisionChecker
    start_state: int
    goal_states: list[int]
    dstar: DStarMotion
    pso: PSOResult | None
    smoother: ViaPointSmoother | None
    motion: SmoothedMotion
    pso_improved: bool
    timings: dict[str, float]

    @property
    def path_length_dstar(self) -> float:
        return self.dstar.length

    @property
    def path_length_pso(self) -> float:
        return self.motion.length


def _resolve_endpoints(
    problem: DynamicProblem, kin: TwoLinkKinematics, fcs: FreeCartesianSpace
) -> tuple[int, list[int]]:
    """Start state and goal states; ValueError if unreachable or in collision at t = 0."""
    grid = problem.grid
    sb = branch_index(problem.start_branch)
    if problem.goal_branch == "any":
        goal_branches = [0, 1]
    else:
        goal_branches = [branch_index(problem.goal_branch)]
    cells = []
    for what, p in (("start", problem.start), ("goal", problem.goal)):
        try:
            cells.append(grid.nearest_cell(p))
        except ValueError as exc:
            raise ValueError(f"{what}: {exc}") from None
    start_cell, goal_cell = cells
    kin.ik_point(grid.point(start_cell), sb, what="start cell")  # ValueError if unreachable
    goal_states = [fcs.state(goal_cell, b) for b in goal_branches
                   if fcs.reachable[fcs.state(goal_cell, b)]]
    if not goal_states:
        kin.ik_point(grid.point(goal_cell), goal_branches[0], what="goal cell")  # raises
    if start_cell == goal_cell:
        raise ValueError("start and goal fall on the same grid cell")
    start_state = fcs.state(start_cell, sb)
    free0 = fcs.free_states(0)
    if not free0[start_state]:
        p = grid.point(start_cell)
        raise ValueError(
            f"start ({p[0]:.3f}, {p[1]:.3f}) m with elbow {BRANCHES[sb]} is in collision at t = 0 "
            f"(margin {problem.margin} m)"
        )
    if not any(free0[s] for s in goal_states):
        p = grid.point(goal_cell)
        raise ValueError(
            f"goal ({p[0]:.3f}, {p[1]:.3f}) m (elbow {problem.goal_branch}) is in collision at "
            f"t = 0 (margin {problem.margin} m)"
        )
    return start_state, goal_states


def _survival(fcs: FreeCartesianSpace, state: int, k0: int, horizon: int) -> int:
    """How many consecutive samples k0, k0+1, … (at most ``horizon``) ``state`` stays free."""
    n = 0
    for k in range(k0, k0 + horizon):
        if not fcs.free_states(k)[state]:
            break
        n += 1
    return n


def execute_dstar(
    fcs: FreeCartesianSpace,
    start_state: int,
    goal_states: list[int],
    *,
    max_joint_step: float,
    max_samples: int,
    lookahead: int = 5,
    switch_penalty: float = 0.0,
    substeps: int = 1,
    progress: Callable[[int], None] | None = None,
) -> DStarMotion:
    """Run D* sample by sample with the stop and return-backward cases (module docstring).

    ``substeps`` > 1 also checks every move between two samples at its inner
    sub-steps (:meth:`SampledCollisionChecker.is_free_between`).
    """
    grid = fcs.grid
    checker = fcs.checker
    dstar = GridDStar(fcs, start_state, goal_states, fcs.free_states(0),
                      max_joint_step=max_joint_step, switch_penalty=switch_penalty)
    goal_set = set(goal_states)
    goal_pt = grid.point(fcs.cell_branch(next(iter(goal_set)))[0])
    qs = fcs.q_states

    def goal_distance(state: int) -> float:
        return float(np.hypot(*(grid.point(fcs.cell_branch(state)[0]) - goal_pt)))

    s = int(start_state)
    states = [s]
    events: list[dict[str, Any]] = []
    k = 0
    replans = 0
    while s not in goal_set:
        if k >= max_samples:
            raise TrappedError(
                f"the arm did not reach the goal within {max_samples} motion samples "
                f"({max_samples * checker.scene.ts:.2f} s)"
            )
        free_next = fcs.free_states(k + 1)

        def valid(u: int, v: int, k: int = k, free_next: np.ndarray = free_next) -> bool:
            """Move u (sample k) → v (sample k+1): v free at k+1, free at the sub-steps."""
            if not free_next[v]:
                return False
            return substeps <= 1 or checker.is_free_between(qs[u], qs[v], k, substeps)

        try:
            path = dstar.plan_from(s)
            replans += 1
            nxt: int | None = path[1] if len(path) > 1 else None
        except NoPathError:
            nxt = None
        if nxt is not None and valid(s, nxt):
            new = nxt
            c0, b0 = fcs.cell_branch(s)
            c1, b1 = fcs.cell_branch(new)
            if b0 != b1:
                events.append({"type": "switch", "sample": k + 1,
                               "branch": BRANCHES[b1], "cell": grid.point(c1).tolist()})
        elif valid(s, s):
            new = s
            if nxt is None:
                reason = "no path in this sample"
            elif free_next[nxt]:
                reason = "move to the next cell collides between samples"
            else:
                reason = "next cell occupied"
            events.append({
                "type": "stop",
                "sample": k + 1,
                "reason": reason,
                "cell": grid.point(fcs.cell_branch(s)[0]).tolist(),
            })
        else:
            cands = [v for v in dstar.successors(s) if valid(s, v)]
            if not cands:
                p = grid.point(fcs.cell_branch(s)[0])
                raise TrappedError(
                    f"at sample {k} (t = {k * checker.scene.ts:.3f} s) an obstacle is about to "
                    f"hit the arm at ({p[0]:.3f}, {p[1]:.3f}) m and no neighbouring cell is free: "
                    "neither stopping nor returning backward can save it"
                )
            d0 = goal_distance(s)
            back = [v for v in cands if goal_distance(v) >= d0 - 1e-9]
            prev = states[-2] if len(states) > 1 else -1

            def rank(v: int, k: int = k, prev: int = prev) -> tuple:
                g = dstar.cost_to_goal(v)
                return (_survival(fcs, v, k + 1, lookahead), v == prev,
                        -g if math.isfinite(g) else -math.inf, -v)

            new = max(back or cands, key=rank)
            events.append({
                "type": "backward",
                "sample": k + 1,
                "from": grid.point(fcs.cell_branch(s)[0]).tolist(),
                "cell": grid.point(fcs.cell_branch(new)[0]).tolist(),
                "goal_distance": [d0, goal_distance(new)],
                "retreat": bool(back),
            })
        k += 1
        s = int(new)
        states.append(s)
        dstar.set_free(fcs.free_states(k))
        if progress is not None:
            progress(k)
    cells = [fcs.cell_branch(x)[0] for x in states]
    branches = np.array([fcs.cell_branch(x)[1] for x in states], dtype=np.int64)
    pts = grid.points()[cells]
    q = fcs.q_states[states]
    return DStarMotion(
        states=states,
        points=pts,
        q=q,
        branches=branches,
        events=events,
        replans=replans,
        edge_updates=dstar.updates,
    )


def _smooth(
    problem: DynamicProblem,
    kin: TwoLinkKinematics,
    fcs: FreeCartesianSpace,
    checker: SampledCollisionChecker,
    dmotion: DStarMotion,
    goal_states: list[int],
    seed: int | None,
    progress: Callable[[str, int, int | None], None] | None,
) -> tuple[PSOResult | None, ViaPointSmoother | None, SmoothedMotion, bool]:
    """PSO over via points of the D* motion (paper 002): (PSO result, smoother, the motion
    executed, whether PSO improved on D*). Motions of fewer than 3 samples are kept as is."""
    dstar_as_motion = SmoothedMotion(
        knots=np.arange(dmotion.num_samples),
        points=dmotion.points.copy(),
        q=dmotion.q.copy(),
        branches=dmotion.branches.copy(),
        feasible=True,
        length=dmotion.length,
    )
    pso_res: PSOResult | None = None
    smoother: ViaPointSmoother | None = None
    motion = dstar_as_motion
    improved = False
    if dmotion.num_samples >= 3:
        smoother = ViaPointSmoother(
            kin,
            checker,
            dmotion.points,
            dmotion.branches,
            num_via=min(problem.num_via, dmotion.num_samples - 2),
            max_joint_step=problem.joint_step_limit,
            substeps=problem.substeps,
            goal_branches=tuple(fcs.cell_branch(g)[1] for g in goal_states),
            bc_type=problem.spline_bc,
        )
        rng = np.random.default_rng(seed)
        total = problem.pso.iterations
        pso_res = pso_minimize(
            smoother.costs,
            smoother.lower,
            smoother.upper,
            problem.pso,
            rng,
            initial=smoother.even_particle()[None, :],
            callback=(lambda it, c: progress("pso", it, total)) if progress else None,
        )
        if math.isfinite(pso_res.cost) and pso_res.cost < dmotion.length:
            cand = smoother.motion(pso_res.x)
            if not cand.feasible:  # pragma: no cover - costs() and motion() check the same
                raise RuntimeError(f"PSO's best motion failed its re-check: {cand.reason}")
            motion = cand
            improved = True
    return pso_res, smoother, motion, improved


def plan_dynamic(
    problem: DynamicProblem,
    *,
    seed: int | None = 0,
    progress: Callable[[str, int, int | None], None] | None = None,
    clock: PhaseClock | None = None,
) -> DynamicPlanResult:
    """Plan the arm's motion: D* with stop/return executed per sample, then PSO smoothing.

    ``seed`` seeds the PSO's ``numpy.random.Generator`` (same seed → same
    result). ``progress(stage, done, total)`` is called as work advances.
    Raises ValueError for unreachable or colliding start/goal, and
    :class:`TrappedError` when the arm cannot be kept safe.
    """
    clock = PhaseClock() if clock is None else clock
    with clock.phase("setup"):
        kin = TwoLinkKinematics(problem.arm)
        checker = SampledCollisionChecker(
            problem.arm, problem.scene, margin=problem.margin, num_threads=problem.num_threads
        )
        fcs = FreeCartesianSpace(kin, problem.grid, checker)
        start_state, goal_states = _resolve_endpoints(problem, kin, fcs)
    with clock.phase("dstar"):
        dmotion = execute_dstar(
            fcs,
            start_state,
            goal_states,
            max_joint_step=problem.joint_step_limit,
            max_samples=problem.max_samples,
            lookahead=problem.lookahead,
            switch_penalty=problem.switch_penalty,
            substeps=problem.substeps,
            progress=(lambda k: progress("dstar", k, None)) if progress else None,
        )
    with clock.phase("pso"):
        pso_res, smoother, motion, improved = _smooth(
            problem, kin, fcs, checker, dmotion, goal_states, seed, progress
        )
    return DynamicPlanResult(
        problem=problem,
        kin=kin,
        fcs=fcs,
        checker=checker,
        start_state=start_state,
        goal_states=goal_states,
        dstar=dmotion,
        pso=pso_res,
        smoother=smoother,
        motion=motion,
        pso_improved=improved,
        timings={k: clock.wall[k] for k in ("setup", "dstar", "pso")},
    )
