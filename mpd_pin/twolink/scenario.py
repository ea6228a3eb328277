"""Scenario files of ``kind = "dynamic2link"`` (paper 002), read strictly.

A scenario is a TOML table (read by :func:`mpd_pin.app.kinds.load_scenario`)::

    kind = "dynamic2link"
    name = "env1"
    description = "..."

    [arm]                      # as for every kind (mpd_pin.app.arm_source); default:
    builtin = "planar_2link"   # or urdf = "arm.urdf" (relative to this file), a planar
                               # two-link arm

    [grid]                     # end-effector cells, m
    x = [-1.0, 1.0]
    z = [-1.0, 1.0]
    step = 0.025               # one grid move per sample must fit max_joint_step

    [motion]
    sample_time = 0.01         # Ts, s (paper 002)
    margin = 0.03              # m kept between every link and every obstacle
    # max_joint_step = 0.1     # rad per motion sample; default: the arm's smallest joint
    #                          # velocity limit (URDF <limit velocity>) × sample_time
    #                          # (10 rad/s × 0.01 s = 0.1 rad for planar_2link). Setting
    #                          # it overrides the limit (result.json: max_joint_step_source).
    substeps = 4               # moves between samples checked at 3 interpolated instants
    switch_penalty = 0.05      # m added to D* costs of elbow switches
    max_samples = 400
    lookahead = 5              # samples, for choosing where to return

    [task]
    start = [0.75, 0.1]        # m (x, z), snapped to the nearest grid cell
    start_branch = "up"        # "up" | "down"
    goal = [-0.35, 0.8]
    goal_branch = "any"        # "up" | "down" | "any"

    [pso]                      # paper 002: c1 = 1, c2 = 3, w = 1, vmax = k·posmax
    particles = 30
    iterations = 60
    via_points = 15
    c1 = 1.0
    c2 = 3.0
    w = 1.0
    k = 0.2
    seed = 1
    spline_bc = "clamped"      # "clamped" | "natural" | "not-a-knot"

    [plots]                    # optional
    fcs_samples = [0, 10, 20]  # default: start, the first events, the end
    snapshot_samples = [0, 8, 15]

    [[obstacles]]              # discs in the x–z plane
    name = "o1"
    radius = 0.12              # m
    motion = "back_and_forth"  # static | straight | back_and_forth | square | polyline
    a = [-0.7, 0.6]            # m
    b = [0.7, 0.6]
    speed = 3.0                # m/s

Obstacle motions and their keys (``delay`` s ≥ 0 and ``phase`` ∈ [0, 1) optional
where listed): ``static``: ``center``; ``straight``: ``start``, ``end``,
``speed``, ``delay`` (stays at ``end``); ``back_and_forth``: ``a``, ``b``,
``speed``, ``delay``, ``phase``; ``square``: ``center``, ``side``, ``speed``,
``clockwise`` (default false), ``delay``, ``phase``; ``polyline``: ``points``,
``speed``, ``mode`` ("once" | "back_and_forth" | "loop"), ``delay``, ``phase``.

Unknown keys, wrong types and impossible values raise
:class:`~mpd_pin.config.ConfigError` (a ValueError) naming the key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from ..app.arm_source import arm_from_table
from ..app.config import ConfigError, Table
from ..arm.model import Arm
from .fcs import Grid
from .ik import link_lengths
from .moving import (
    MODES,
    MovingObstacle,
    MovingScene,
    PolylineTrajectory,
    back_and_forth,
    square,
    static,
    straight,
)
from .planner import DynamicProblem
from .pso import PSOOptions

__all__ = ["DynamicScenario", "parse_dynamic_scenario", "MOTIONS"]

#: Obstacle motion kinds accepted in ``[[obstacles]]``.
MOTIONS = ("static", "straight", "back_and_forth", "square", "polyline")


@dataclass
class DynamicScenario:
    """A parsed ``dynamic2link`` scenario: the planning problem plus run options."""

    kind: ClassVar[str] = "dynamic2link"
    name: str
    description: str
    problem: DynamicProblem
    seed: int | None
    fcs_samples: list[int] | None = None
    snapshot_samples: list[int] | None = None
    data: dict[str, Any] = field(default_factory=dict)


def _pair(t: Table, key: str, default: Any = ...) -> tuple[float, float]:
    v = t.vector(key, default, length=2)
    return (float(v[0]), float(v[1]))


def _obstacle(t: Table, index: int) -> MovingObstacle:
    name = t.string("name", f"obstacle{index}")
    radius = t.number("radius", positive=True)
    motion = t.string("motion", choices=MOTIONS)
    try:
        if motion == "static":
            traj = static(_pair(t, "center"))
        elif motion == "straight":
            traj = straight(
                _pair(t, "start"),
                _pair(t, "end"),
                t.number("speed", positive=True),
                delay=t.number("delay", 0.0, nonnegative=True),
            )
        elif motion == "back_and_forth":
            traj = back_and_forth(
                _pair(t, "a"),
                _pair(t, "b"),
                t.number("speed", positive=True),
                delay=t.number("delay", 0.0, nonnegative=True),
                phase=t.number("phase", 0.0, nonnegative=True),
            )
        elif motion == "square":
            traj = square(
                _pair(t, "center"),
                t.number("side", positive=True),
                t.number("speed", positive=True),
                clockwise=t.boolean("clockwise", False),
                delay=t.number("delay", 0.0, nonnegative=True),
                phase=t.number("phase", 0.0, nonnegative=True),
            )
        else:
            pts = t.raw("points")
            if not isinstance(pts, list) or len(pts) < 2:
                raise ConfigError(f"{t.path}.points: expected at least two [x, z] pairs")
            traj = PolylineTrajectory(
                tuple(tuple(p) for p in pts),
                t.number("speed", positive=True),
                t.string("mode", "once", choices=MODES),
                t.number("delay", 0.0, nonnegative=True),
                t.number("phase", 0.0, nonnegative=True),
            )
    except ConfigError:
        raise
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{t.path}: {exc}") from None
    t.done()
    return MovingObstacle(name, radius, traj, motion)


def _arm(t: Table, base_dir: Path | None) -> Arm:
    arm = arm_from_table(t, base_dir, default_builtin="planar_2link")
    try:
        link_lengths(arm)
    except ValueError as exc:
        raise ConfigError(f"arm: {exc} (dynamic2link scenarios need a planar two-link arm)"
                          ) from None
    return arm


def _samples(t: Table, key: str) -> list[int] | None:
    val = t.raw(key, None)
    if val is None:
        return None
    if not isinstance(val, list) or not all(
        isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in val
    ):
        raise ConfigError(f"{t.path}.{key}: expected a list of sample indices ≥ 0, got {val!r}")
    return list(val)


def parse_dynamic_scenario(
    data: dict[str, Any], *, base_dir: Path | None = None, seed: int | None = None
) -> DynamicScenario:
    """Validate a ``kind = "dynamic2link"`` scenario dict and build its problem (strict).

    ``base_dir``: the scenario file's folder, against which a relative ``[arm] urdf``
    path is resolved (``None``: the working directory); ``seed`` overrides ``pso.seed``.
    Raises :class:`~mpd_pin.config.ConfigError` for unknown keys and bad values.
    Start/goal reachability and collisions are checked by the planner (ValueError).
    """
    top = Table(data, "")
    kind = top.string("kind")
    if kind != "dynamic2link":
        raise ConfigError(f"kind: expected 'dynamic2link', got {kind!r}")
    name = top.string("name", "dynamic2link")
    description = top.string("description", "")

    arm = _arm(top.table("arm"), base_dir)

    g = top.table("grid")
    gx = _pair(g, "x", [-1.0, 1.0])
    gz = _pair(g, "z", [-1.0, 1.0])
    step = g.number("step", 0.05, positive=True)
    g.done()
    try:
        grid = Grid(gx[0], gx[1], gz[0], gz[1], step)
    except ValueError as exc:
        raise ConfigError(f"grid: {exc}") from None

    m = top.table("motion")
    ts = m.number("sample_time", 0.01, positive=True)
    margin = m.number("margin", 0.03, nonnegative=True)
    max_joint_step = m.number("max_joint_step", None, positive=True)
    substeps = m.integer("substeps", 4, minimum=1)
    switch_penalty = m.number("switch_penalty", 0.05, nonnegative=True)
    max_samples = m.integer("max_samples", 400, minimum=1)
    lookahead = m.integer("lookahead", 5, minimum=1)
    m.done()

    task = top.table("task", required=True)
    start = _pair(task, "start")
    goal = _pair(task, "goal")
    start_branch = task.string("start_branch", "up", choices=("up", "down"))
    goal_branch = task.string("goal_branch", "any", choices=("up", "down", "any"))
    task.done()

    p = top.table("pso")
    particles = p.integer("particles", 30, minimum=1)
    iterations = p.integer("iterations", 60, minimum=0)
    via = p.integer("via_points", 15, minimum=1)
    c1 = p.number("c1", 1.0, nonnegative=True)
    c2 = p.number("c2", 3.0, nonnegative=True)
    w = p.number("w", 1.0, nonnegative=True)
    k = p.number("k", 0.2, positive=True)
    seed_val = p.raw("seed", 1)
    if seed_val is not None and (isinstance(seed_val, bool) or not isinstance(seed_val, int)
                                 or seed_val < 0):
        raise ConfigError(f"pso.seed: expected an integer ≥ 0, got {seed_val!r}")
    spline_bc = p.string("spline_bc", "clamped", choices=("clamped", "natural", "not-a-knot"))
    p.done()
    if not 0.1 <= k <= 1.0:
        raise ConfigError(f"pso.k: the velocity clamp factor must be in [0.1, 1], got {k}")

    pl = top.table("plots")
    fcs_samples = _samples(pl, "fcs_samples")
    snapshot_samples = _samples(pl, "snapshot_samples")
    pl.done()

    obstacles = [_obstacle(t, i) for i, t in enumerate(top.tables("obstacles"))]
    top.done()
    try:
        scene = MovingScene(obstacles, ts)
    except ValueError as exc:
        raise ConfigError(f"obstacles: {exc}") from None

    try:
        problem = DynamicProblem(
            arm=arm,
            scene=scene,
            grid=grid,
            start=start,
            goal=goal,
            start_branch=start_branch,
            goal_branch=goal_branch,
            margin=margin,
            max_joint_step=max_joint_step,
            substeps=substeps,
            switch_penalty=switch_penalty,
            max_samples=max_samples,
            lookahead=lookahead,
            pso=PSOOptions(particles=particles, iterations=iterations, c1=c1, c2=c2, w=w, k=k),
            num_via=via,
            spline_bc=spline_bc,
        )
    except ValueError as exc:  # e.g. no velocity limits to derive max_joint_step from
        raise ConfigError(f"motion: {exc}") from None
    return DynamicScenario(
        name=name,
        description=description,
        problem=problem,
        seed=seed_val if seed is None else int(seed),
        fcs_samples=fcs_samples,
        snapshot_samples=snapshot_samples,
        data=dict(data),
    )
