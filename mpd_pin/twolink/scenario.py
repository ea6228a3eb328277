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
from ..app.config import ConfigError, Table, check_array
from ..app.limits import BOUNDS, INT_LIMITS, Bound, position_bound, size_bound
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


def _pair(t: Table, key: str, default: Any = ..., bound: Bound | None = None,
          labels: tuple[str, str] = ("x", "z")) -> tuple[float, float]:
    v = t.vector(key, default, length=2, bound=bound, labels=labels)
    return (float(v[0]), float(v[1]))


def _points(t: Table, pos: Bound) -> tuple[tuple[float, float], ...]:
    pts = t.raw("points")
    if not isinstance(pts, list) or len(pts) < 2:
        raise ConfigError(f"{t.path}.points: expected at least two [x, z] pairs")
    if len(pts) > INT_LIMITS["polyline_points"]:
        raise ConfigError(f"{t.path}.points: at most {INT_LIMITS['polyline_points']} points, "
                          f"got {len(pts)}")
    out = []
    for i, p in enumerate(pts):
        if not isinstance(p, list) or len(p) != 2:
            raise ConfigError(f"{t.path}.points[{i}]: expected an [x, z] pair, got {p!r}")
        x, z = check_array(f"{t.path}.points[{i}]", p, pos, ("x", "z"))
        out.append((x, z))
    return tuple(out)


def _obstacle(t: Table, index: int, arm: Arm) -> MovingObstacle:
    pos, size = position_bound(arm), size_bound(arm)
    name = t.string("name", f"obstacle{index}")
    radius = t.number("radius", positive=True, bound=size)

    def speed() -> float:
        return t.number("speed", positive=True, bound=BOUNDS["speed"])

    def delay() -> float:
        return t.number("delay", 0.0, nonnegative=True, bound=BOUNDS["delay"])

    def phase() -> float:
        return t.number("phase", 0.0, nonnegative=True, bound=BOUNDS["phase"])

    motion = t.string("motion", choices=MOTIONS)
    try:
        if motion == "static":
            traj = static(_pair(t, "center", bound=pos))
        elif motion == "straight":
            traj = straight(_pair(t, "start", bound=pos), _pair(t, "end", bound=pos), speed(),
                            delay=delay())
        elif motion == "back_and_forth":
            traj = back_and_forth(_pair(t, "a", bound=pos), _pair(t, "b", bound=pos), speed(),
                                  delay=delay(), phase=phase())
        elif motion == "square":
            traj = square(
                _pair(t, "center", bound=pos),
                t.number("side", positive=True, bound=size),
                speed(),
                clockwise=t.boolean("clockwise", False),
                delay=delay(),
                phase=phase(),
            )
        else:
            traj = PolylineTrajectory(
                _points(t, pos), speed(), t.string("mode", "once", choices=MODES), delay(),
                phase(),
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
    top = INT_LIMITS["max_samples"]
    if not isinstance(val, list) or not all(
        isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= top for v in val
    ):
        raise ConfigError(
            f"{t.path}.{key}: expected a list of sample indices in [0, {top}], got {val!r}"
        )
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

    pos, size, gap = position_bound(arm), size_bound(arm), size_bound(arm, zero=True)
    g = top.table("grid")
    gx = _pair(g, "x", [-1.0, 1.0], bound=pos, labels=("min", "max"))
    gz = _pair(g, "z", [-1.0, 1.0], bound=pos, labels=("min", "max"))
    step = g.number("step", 0.05, positive=True, bound=size)
    g.done()
    try:
        grid = Grid(gx[0], gx[1], gz[0], gz[1], step)
    except ValueError as exc:
        raise ConfigError(f"grid: {exc}") from None

    m = top.table("motion")
    ts = m.number("sample_time", 0.01, positive=True, bound=BOUNDS["sample_time"])
    margin = m.number("margin", 0.03, nonnegative=True, bound=gap)
    max_joint_step = m.number("max_joint_step", None, positive=True,
                              bound=BOUNDS["max_joint_step"])
    substeps = m.integer("substeps", 4, minimum=1, maximum=INT_LIMITS["substeps"])
    switch_penalty = m.number("switch_penalty", 0.05, nonnegative=True, bound=gap)
    max_samples = m.integer("max_samples", 400, minimum=1, maximum=INT_LIMITS["max_samples"])
    lookahead = m.integer("lookahead", 5, minimum=1, maximum=INT_LIMITS["lookahead"])
    m.done()

    task = top.table("task", required=True)
    start = _pair(task, "start", bound=pos)
    goal = _pair(task, "goal", bound=pos)
    start_branch = task.string("start_branch", "up", choices=("up", "down"))
    goal_branch = task.string("goal_branch", "any", choices=("up", "down", "any"))
    task.done()

    p = top.table("pso")
    particles = p.integer("particles", 30, minimum=1, maximum=INT_LIMITS["particles"])
    iterations = p.integer("iterations", 60, minimum=0, maximum=INT_LIMITS["iterations"])
    via = p.integer("via_points", 15, minimum=1, maximum=INT_LIMITS["via_points"])
    c1, c2, w = (p.number(c, d, nonnegative=True, bound=BOUNDS["pso_coefficient"])
                 for c, d in (("c1", 1.0), ("c2", 3.0), ("w", 1.0)))
    k = p.number("k", 0.2, positive=True)
    seed_val = p.raw("seed", 1)
    if seed_val is not None and (isinstance(seed_val, bool) or not isinstance(seed_val, int)
                                 or not 0 <= seed_val <= INT_LIMITS["seed"]):
        raise ConfigError(
            f"pso.seed: expected an integer in [0, {INT_LIMITS['seed']}], got {seed_val!r}"
        )
    spline_bc = p.string("spline_bc", "clamped", choices=("clamped", "natural", "not-a-knot"))
    p.done()
    if not 0.1 <= k <= 1.0:
        raise ConfigError(f"pso.k: the velocity clamp factor must be in [0.1, 1], got {k}")

    pl = top.table("plots")
    fcs_samples = _samples(pl, "fcs_samples")
    snapshot_samples = _samples(pl, "snapshot_samples")
    pl.done()

    obstacles = [_obstacle(t, i, arm) for i, t in enumerate(top.tables("obstacles"))]
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
