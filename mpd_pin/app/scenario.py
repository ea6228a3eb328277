"""Scenario files (TOML): arm, motors, controller, world, roadmap and task (docs/design.md §7).

A scenario of ``kind = "energy"`` (the default; paper 000) looks like::

    name = "case1"
    description = "3-link arm, start and goal on either side of an obstacle"

    [arm]                      # exactly one of: builtin, urdf, example_robot_data
    builtin = "planar_3link"   # robots/*.urdf; urdf = "path/relative/to/this/file.urdf"

    [motor]                    # preset "paper" (Table 7) or "servo", any field overridden
    preset = "paper"
    gear_ratio = 5.0           # R, L, Kt, Ke, B, J, v_max also accepted; each constant
                               # may be one number or an array with one value per joint
    # ... or one table per joint (exactly nq of them) instead of [motor]:
    # [[motors]]
    # preset = "servo"
    # gear_ratio = 100.0

    [controller]
    kp = 40.0                  # V/rad, scalar or one per joint
    kd = 4.0                   # V·s/rad
    feedforward = true

    [roadmap]                  # RoadmapOptions fields, and:
    evaluation = "lazy"        # or "eager": simulate every edge before searching
    collision = "lazy"         # or "eager": collision-check every edge before searching
    num_nodes = 150
    k = 10
    seed = 1
    duration = 1.0             # s
    dt = 0.005                 # s
    # duration_rule = "distance" times each edge by its largest joint move instead, within
    # [min_duration, max_edge_duration] (s, one edge; [motion] max_duration is the motion's)

    [[obstacles]]              # planar shapes in the arm's x–z plane (m, rad) ...
    type = "box"               # box | cylinder | sphere | polygon
    center = [0.0, 0.9]
    width = 0.3
    height = 0.4
    # ... or 3-D ones: size = [sx, sy, sz], position = [x, y, z], rpy = [r, p, y]
    hidden = false             # hidden obstacles are revealed by the sensor

    [[hazards]]                # "No Enter" zones: a shape and a clearance (m)
    type = "polygon"
    vertices = [[0.2, 0.5], [0.5, 0.5], [0.35, 0.8]]
    clearance = 0.1

    [sensor]
    range = 0.15               # m

    [limits]                   # fill/override URDF joint limits (rad/s, N·m), by joint name
    joint2 = { velocity = 2.0, effort = 30.0 }

    [supply]                   # how the drives are fed (docs/design.md §3i)
    bus = "per_joint"          # or "shared": one DC bus feeding every drive
    regeneration = 0.0         # η in [0, 1], share of braking energy returned (shared only)

    [motion]                   # the returned motion (docs/design.md §9)
    execution = "auto"         # or "stop" (rest at every waypoint) / "nonstop"
    refine = true              # shortcut the roadmap paths where the energy drops
    optimize = true            # then optimise the motion as a whole (docs/design.md §9g)
    max_duration = 20.0        # s; longest motion allowed (default: no limit)

    [run]
    verify = false             # re-simulate the roadmap paths with simulate_edge (§7c)

    [task]
    start = [0.6, 0.3, 0.2]    # rad; or start_ee = [x, z] (planar) / [x, y, z], solved by IK
    goal = [2.4, -0.3, -0.2]
    # with start_ee / goal_ee, which IK solution: start_seed = [...] / goal_seed = [...]
    # (rad: the solution nearest to this posture), elbow = "up" | "down" (the elbow joint
    # above or below the shoulder-target line; elbow_joint = "name", default the 2nd joint)

Scenarios of ``kind = "dynamic2link"`` (paper 002) are read by
:mod:`mpd_pin.twolink.scenario`; :mod:`mpd_pin.app.kinds` maps each kind to its parser
and runner (:func:`~mpd_pin.app.kinds.load_scenario` reads a file of any kind).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ..arm.model import Arm
from ..dynamics.motor import DCMotor, Drive
from ..dynamics.sizing import check_holding
from ..dynamics.supply import BUSES, PER_JOINT, Supply
from ..motion.refine import MotionOptions
from ..planning.roadmap import COLLISIONS, RoadmapOptions
from ..search.registry import DEFAULT_PLANNER, PLANNERS
from ..world import Box, Cylinder, Hazard, Polygon, Sphere, World
from .arm_source import arm_from_table
from .config import ConfigError, Table, check_array
from .limits import (
    BOUNDS,
    Bound,
    apply_joint_limits,
    check_joint_limits,
    joint_bounds,
    position_bound,
    size_bound,
)
from .scenario_files import builtin_scenarios, load_scenario_data, resolve_scenario
from .scenario_motors import gain, motor_tables, motors_from_tables

__all__ = [
    "EnergyScenario",
    "load_scenario_data",
    "parse_energy_scenario",
    "builtin_scenarios",
    "resolve_scenario",
]

#: Values of ``[roadmap] evaluation`` (docs/design.md §4g); the first is the default.
EVALUATIONS = ("lazy", "eager")



@dataclass
class EnergyScenario:
    """A parsed paper-000 scenario: everything needed to plan, nothing built yet but the arm."""

    kind: ClassVar[str] = "energy"

    name: str
    description: str
    arm: Arm
    motor: DCMotor | list[DCMotor]  # one for every joint, or one per joint
    kp: float | list[float]
    kd: float | list[float]
    feedforward: bool
    world: World
    options: RoadmapOptions
    start: np.ndarray
    goal: np.ndarray
    sensor_range: float | None = None
    hazard_penalty: float = math.inf
    planner: str = DEFAULT_PLANNER
    source: str = ""
    #: where edge energies run: None (this process), "local[:N]", a scheduler address, or
    #: (from Python) a distributed.Client / concurrent.futures.Executor (docs/design.md §4h)
    scheduler: Any = None
    extra: dict[str, Any] = field(default_factory=dict)
    #: "lazy" (simulate only the edges the search needs) or "eager" (docs/design.md §4g)
    evaluation: str = "lazy"
    #: the returned motion: execution, refinement, duration limit (docs/design.md §9)
    motion: MotionOptions = field(default_factory=MotionOptions)
    #: "lazy" (certify the edges the search needs) or "eager" (docs/design.md §4g)
    collision: str = "lazy"
    #: how the drives are fed: per joint (paper 000) or a shared DC bus (§3i)
    supply: Supply = PER_JOINT
    #: ``[run] verify``: re-simulate the roadmap paths with the reference ``simulate_edge``
    #: (docs/design.md §7c; off by default: the batched integrator's series is used)
    verify: bool = False
    #: ``[payloads.NAME]``: the parts a cycle's legs may carry (:class:`~mpd_pin.Payload`)
    payloads: dict[str, Any] = field(default_factory=dict)
    #: ``[cycle]``: its legs and cycle time (:class:`~mpd_pin.app.cycle.CycleSpec`), or None
    cycle: Any = None

    def drive(self) -> Drive:
        return Drive(self.arm, self.motor, self.kp, self.kd, feedforward=self.feedforward,
                     supply=self.supply)


# --------------------------------------------------------------------------- parts
#: Upper bounds of the roadmap parameters: far above the paper's roadmaps (150–250 nodes,
#: k = 10) and what a workstation plans in minutes, low enough that a typo fails
#: with a clear message instead of a MemoryError or a run of days.
LIMITS = {
    "num_nodes": 50_000,  # random samples
    "k": 100,  # neighbours per node
    "max_attempts": 100_000,  # draws per requested sample
    "seed": 2**63 - 1,
    "steps_per_edge": 100_000,  # RK4 steps (duration / dt) of the longest edge
    "duration": 60.0,  # s per edge
    "min_resolution": 1e-3,  # rad
}


def _options(t: Table) -> RoadmapOptions:
    """``[roadmap]`` as :class:`RoadmapOptions` (the TOML key ``max_edge_duration`` is the
    field ``max_duration``: the longest *edge* of the distance rule, s — not ``[motion]
    max_duration``, the whole motion's; the old key is still read, with a
    ``FutureWarning`` naming both)."""
    import warnings

    d = RoadmapOptions()
    kw: dict[str, Any] = {}
    old, new = t.key_path("max_duration"), t.key_path("max_edge_duration")
    if t.has("max_duration") and t.has("max_edge_duration"):
        raise ConfigError(f"{old}: the old name of {new}; give only max_edge_duration")
    if t.has("max_duration"):  # the old key: read, with one warning naming both keys
        warnings.warn(f"{old} is renamed {new} (the longest roadmap edge, s; [motion] "
                      "max_duration is the whole motion's): read as max_edge_duration; "
                      "rename the key", FutureWarning, stacklevel=2)
    edge_key = "max_duration" if t.has("max_duration") else "max_edge_duration"
    for name in ("num_nodes", "k", "seed", "max_attempts"):
        kw[name] = t.integer(
            name, getattr(d, name), minimum=0 if name != "k" else 1, maximum=LIMITS[name]
        )
    kw["resolution"] = t.number(
        "resolution", d.resolution, positive=True, minimum=LIMITS["min_resolution"],
        bound=BOUNDS["resolution"],
    )
    for name in ("duration", "joint_speed", "duration_quantum", "min_duration", "max_duration"):
        upper = LIMITS["duration"] if name != "joint_speed" else None
        key = edge_key if name == "max_duration" else name  # TOML key of the field
        kw[name] = t.number(key, getattr(d, name), positive=True, maximum=upper,
                            bound=BOUNDS["joint_speed" if name == "joint_speed" else "duration"])
    kw["dt"] = t.number("dt", d.dt, positive=True, bound=BOUNDS["dt"])
    kw["duration_rule"] = t.string("duration_rule", d.duration_rule, choices=("fixed", "distance"))
    kw["velocity_limits"] = t.boolean("velocity_limits", d.velocity_limits)
    kw["effort_limits"] = t.boolean("effort_limits", d.effort_limits)
    kw["arrival_tolerance"] = t.number(
        "arrival_tolerance", d.arrival_tolerance, bound=BOUNDS["arrival_tolerance"]
    )
    t.done()
    longest = kw["duration"] if kw["duration_rule"] == "fixed" else kw["max_duration"]
    if longest / kw["dt"] > LIMITS["steps_per_edge"]:
        which = "duration" if kw["duration_rule"] == "fixed" else edge_key
        raise ConfigError(
            f"{t.path}.dt: {which} / dt = {longest:g} s / {kw['dt']:g} s exceeds "
            f"{LIMITS['steps_per_edge']} RK4 steps per edge"
        )
    try:
        return RoadmapOptions(**kw)
    except ValueError as exc:  # named by the TOML key (field max_duration: edge_key)
        text = re.sub(r"\bmax_duration\b", edge_key, str(exc))
        raise ConfigError(f"{t.path}: {text}") from None


@dataclass(frozen=True)
class _Lims:
    """Position, size and angle ranges of one arm's scenario (app/limits.py)."""

    pos: Bound
    size: Bound
    gap: Bound  # clearances, ranges: 0 allowed

    @classmethod
    def of(cls, arm: Arm) -> _Lims:
        return cls(position_bound(arm), size_bound(arm), size_bound(arm, zero=True))


XZ, XYZ, RPY = ("x", "z"), ("x", "y", "z"), ("roll", "pitch", "yaw")


def _planar_center(t: Table, lim: _Lims) -> list[float]:
    return t.vector("center", length=2, bound=lim.pos, labels=XZ)


def _pose(t: Table, lim: _Lims) -> dict[str, list[float]]:
    return {
        "position": t.vector("position", [0.0, 0.0, 0.0], length=3, bound=lim.pos, labels=XYZ),
        "rpy": t.vector("rpy", [0.0, 0.0, 0.0], length=3, bound=BOUNDS["angle"], labels=RPY),
    }


def _size(t: Table, key: str, lim: _Lims, default: Any = ...) -> float:
    return t.number(key, default, positive=True, bound=lim.size)


def _vertices(t: Table, lim: _Lims) -> list[list[float]]:
    verts = t.raw("vertices")
    if not isinstance(verts, list) or not all(isinstance(v, list) and len(v) == 2 for v in verts):
        raise ConfigError(f"{t.path}.vertices: expected an array of [x, z] pairs")
    return [check_array(f"{t.path}.vertices[{i}]", v, lim.pos, XZ) for i, v in enumerate(verts)]


def _shape(t: Table, lim: _Lims):
    """One obstacle/hazard shape from planar or 3-D keys, every number within ``lim``."""
    kind = t.string("type", choices=("box", "cylinder", "sphere", "polygon"))
    common = {"name": t.string("name", ""), "hidden": t.boolean("hidden", False)}
    try:
        if kind == "box":
            if t.has("center"):
                shape = Box.planar(
                    _planar_center(t, lim), _size(t, "width", lim), _size(t, "height", lim),
                    angle=t.number("angle", 0.0, bound=BOUNDS["angle"]),
                    depth=_size(t, "depth", lim, 1.0), **common,
                )
            else:
                size = t.vector("size", length=3, bound=lim.size, labels=XYZ)
                shape = Box(size=size, **_pose(t, lim), **common)
        elif kind == "cylinder":
            if t.has("center"):
                shape = Cylinder.planar(
                    _planar_center(t, lim), _size(t, "radius", lim),
                    depth=_size(t, "depth", lim, 1.0), **common,
                )
            else:
                shape = Cylinder(
                    radius=_size(t, "radius", lim), length=_size(t, "length", lim),
                    **_pose(t, lim), **common,
                )
        elif kind == "sphere":
            if t.has("center"):
                cx, cz = _planar_center(t, lim)
                pos = [cx, 0.0, cz]
            else:
                pos = t.vector("position", length=3, bound=lim.pos, labels=XYZ)
            shape = Sphere(radius=_size(t, "radius", lim), position=pos, **common)
        else:
            shape = Polygon.planar(
                _vertices(t, lim), depth=_size(t, "depth", lim, 1.0), **common
            )
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(f"{t.path}: {exc}") from None
    return shape


def _joint_bounds(arm: Arm) -> list[Bound]:
    """Each joint's limits (± 1e-9); an angle more than 2π outside them is refused with
    the hint that angles are in radians (:func:`~mpd_pin.app.limits.joint_bounds`)."""
    return joint_bounds(arm, tol=1e-9)


def _ik_choice(t: Table, key: str, arm: Arm) -> dict[str, Any]:
    """``{key}_seed`` (a posture, rad: the IK starts there and returns the solution nearest
    to it), ``elbow`` (``"up"``/``"down"``) and ``elbow_joint`` of ``[task]`` (docs/design.md
    §7e), as keyword arguments of :func:`~mpd_pin.arm.ik.solve_position_ik`."""
    from ..arm.ik import ELBOW_SIDES

    seed = t.vector(f"{key}_seed", length=arm.nq, bound=_joint_bounds(arm)) if t.has(
        f"{key}_seed") else None
    elbow = t.string("elbow", None, choices=ELBOW_SIDES) if t.has("elbow") else None
    joint = None
    if t.has("elbow_joint"):
        joint = t.string("elbow_joint", choices=tuple(arm.joint_names))
        if elbow is None:
            raise ConfigError(f"{t.path}.elbow_joint: give elbow = \"up\" or \"down\" with it")
    return {"seed_posture": None if seed is None else np.array(seed), "elbow": elbow,
            "elbow_joint": joint}


def _endpoint(t: Table, key: str, arm: Arm, world: World, ik_seed: int) -> np.ndarray:
    from ..arm.ik import solve_position_ik

    if t.has(key) and t.has(f"{key}_ee"):
        raise ConfigError(f"{t.path}: give {key} or {key}_ee, not both")
    if t.has(key):
        if t.has(f"{key}_seed"):
            raise ConfigError(f"{t.path}.{key}_seed: a seed posture is for {key}_ee (IK); "
                              f"{key} already gives the joint angles")
        return np.array(t.vector(key, length=arm.nq, bound=_joint_bounds(arm)))
    raw = t.raw(f"{key}_ee")
    if not isinstance(raw, list) or len(raw) not in (2, 3):
        raise ConfigError(f"{t.path}.{key}_ee: expected [x, z] or [x, y, z]")
    lim = _Lims.of(arm)
    target = t.vector(f"{key}_ee", bound=lim.pos, labels=XZ if len(raw) == 2 else XYZ)
    if len(target) == 2:
        target = [target[0], 0.0, target[1]]
    frame = t.string("ee_frame", "ee" if arm.model.existFrame("ee") else arm.model.frames[-1].name)
    if not arm.model.existFrame(frame):
        import difflib

        names = [f.name for f in arm.model.frames]
        near = difflib.get_close_matches(frame, names, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else f" (frames: {', '.join(names)})"
        raise ConfigError(f"{t.path}.ee_frame: arm {arm.name!r} has no frame {frame!r}{hint}")
    choice = _ik_choice(t, key, arm)
    try:
        return solve_position_ik(arm, frame, np.array(target), world=world, seed=ik_seed,
                                 **choice)
    except ValueError as exc:
        detail = ""
        if "in collision" in str(exc):  # name what the arm would touch there
            detail = _ik_collision(arm, frame, np.array(target), world, ik_seed, choice)
        raise ConfigError(f"{t.path}.{key}_ee: {exc}{detail}") from None


def _ik_collision(arm: Arm, frame: str, target: np.ndarray, world: World, ik_seed: int,
                  choice: dict[str, Any]) -> str:
    """When every IK solution for ``target`` collides: " (at [q]: link 'link3' touches
    obstacle 'divider')" for the solution chosen without the obstacles, else ""."""
    from ..arm.ik import solve_position_ik
    from ..collision import CollisionChecker

    try:
        q = solve_position_ik(arm, frame, target, world=None, seed=ik_seed, **choice)
    except ValueError:
        return ""
    what = CollisionChecker(arm, world).describe_collision(q)
    return f" (at {np.round(q, 4).tolist()}: {what})" if what else ""


def _compute(t: Table) -> str | None:
    """``[compute] scheduler``: "threads", "local[:N]" or an address (docs/design.md §4h)."""
    from ..dynamics.remote import ComputeError, parse_scheduler

    text = t.string("scheduler", None)
    t.done()
    try:
        kind, _ = parse_scheduler(text)
    except ComputeError as exc:
        raise ConfigError(f"{t.path}.{exc}") from None
    return None if kind == "threads" else text


def _motion(t: Table) -> MotionOptions:
    """``[motion]``: execution, refine, optimize, max_duration (docs/design.md §9)."""
    from ..motion.energy import EXECUTIONS

    execution = t.string("execution", "auto", choices=EXECUTIONS)
    refine = t.boolean("refine", True)
    optimize = t.boolean("optimize", True)
    max_duration = t.number("max_duration", None, bound=BOUNDS["max_duration"])
    t.done()
    return MotionOptions(execution=execution, refine=refine, max_duration=max_duration,
                         optimize=optimize)


def parse_energy_scenario(
    data: dict[str, Any], *, source: str = "", base_dir: Path | None = None, seed: int | None = None
) -> EnergyScenario:
    """Validate and build a ``kind = "energy"`` scenario from parsed TOML (ConfigError if bad)."""
    top = Table(data, "")
    kind = top.string("kind", "energy")
    if kind != "energy":
        raise ConfigError(f"kind: expected 'energy', got {kind!r}")
    name = top.string("name", Path(source).stem if source else "scenario")
    description = top.string("description", "")
    arm = arm_from_table(top.table("arm", required=True), base_dir)
    # [limits] (helper C): fill/override URDF velocity and effort limits, then refuse
    # the joints whose limits the roadmap or the sized motors need but lack (§7b)
    apply_joint_limits(top.table("limits"), arm)
    roadmap_t = top.table("roadmap")
    evaluation = roadmap_t.string("evaluation", "lazy", choices=EVALUATIONS)
    collision = roadmap_t.string("collision", "lazy", choices=COLLISIONS)
    options = _options(roadmap_t)
    if seed is not None:
        options = replace(options, seed=int(seed))
    sized = "sized" in {str(m.get("preset")) for m in motor_tables(top)}
    check_joint_limits(arm, velocity=options.velocity_limits or sized,
                       effort=options.effort_limits or sized)
    motor = motors_from_tables(top, arm)
    ctl = top.table("controller")
    kp = gain(ctl, "kp", 40.0, arm.nq)
    kd = gain(ctl, "kd", 4.0, arm.nq)
    ff = ctl.boolean("feedforward", True)
    ctl.done()
    obstacles = []
    lim = _Lims.of(arm)
    for t in top.tables("obstacles"):
        obstacles.append(_shape(t, lim))
        t.done()
    hazards = []
    for t in top.tables("hazards"):
        clearance = t.number("clearance", 0.0, nonnegative=True, bound=lim.gap)
        hazards.append(Hazard(_shape(t, lim), clearance))
        t.done()
    try:
        world = World(tuple(obstacles), tuple(hazards))
    except ValueError as exc:
        raise ConfigError(f"obstacles: {exc}") from None
    sensor = top.table("sensor")
    sensor_range = sensor.number("range", None, nonnegative=True, bound=lim.gap)
    sensor.done()
    if world.hidden_names() and sensor_range is None:
        raise ConfigError("sensor.range: required when some obstacles are hidden")
    planner_t = top.table("planner")
    planner = planner_t.string("algorithm", DEFAULT_PLANNER, choices=tuple(PLANNERS))
    penalty = planner_t.number("hazard_penalty", math.inf, bound=BOUNDS["hazard_penalty"])
    planner_t.done()
    task = top.table("task", required=True)
    ik_seed = task.integer("ik_seed", 0, minimum=0, maximum=LIMITS["seed"] - 1)
    start = _endpoint(task, "start", arm, world, ik_seed)
    goal = _endpoint(task, "goal", arm, world, ik_seed + 1)
    if task.has("elbow") and not (task.has("start_ee") or task.has("goal_ee")):
        raise ConfigError(f"{task.path}.elbow: chooses the IK solution of start_ee/goal_ee; "
                          "start and goal are given as joint angles")
    task.done()
    scheduler = _compute(top.table("compute"))
    motion = _motion(top.table("motion"))
    supply = _supply(top.table("supply"))
    run_t = top.table("run")
    verify = run_t.boolean("verify", False)
    run_t.done()
    cycle_fields = _cycle_tables(top, arm)  # [payloads.NAME], [cycle] (issue 33)
    top.done()
    holding = Drive(arm, motor, kp, kd, feedforward=ff)  # a motor too weak to hold (§3g)
    for what, q in (("task.start", start), ("task.goal", goal)):
        try:
            check_holding(holding, q, what, effort_limits=options.effort_limits)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    return EnergyScenario(
        name=name,
        description=description,
        arm=arm,
        motor=motor,
        kp=kp,
        kd=kd,
        feedforward=ff,
        world=world,
        options=options,
        start=start,
        goal=goal,
        sensor_range=sensor_range,
        hazard_penalty=penalty,
        planner=planner,
        source=source,
        evaluation=evaluation,
        scheduler=scheduler,
        motion=motion,
        collision=collision,
        supply=supply,
        verify=verify,
        **cycle_fields,
    )


def _supply(t: Table) -> Supply:
    """``[supply]``: ``bus`` ("per_joint" or "shared") and ``regeneration`` η ∈ [0, 1]
    (docs/design.md §3i)."""
    bus = t.string("bus", "per_joint", choices=BUSES)
    eta = t.number("regeneration", 0.0, minimum=0.0, maximum=1.0)
    t.done()
    try:
        return Supply(bus, eta)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


# ------------------------------------------------------------- payloads and cycles (issue 33)
#: The largest payload mass (kg) and centre-of-mass distance from its frame (m) accepted.
PAYLOAD_MAX_MASS = 1000.0
PAYLOAD_MAX_COM = 1.0


def _payload_table(t: Table, arm: Arm, name: str):
    """``[payloads.NAME]``: ``mass`` (kg, > 0), ``com`` (m, in the frame, within
    :data:`PAYLOAD_MAX_COM` of it), ``inertia`` (kg·m²: 6 values ixx, ixy, ixz, iyy, iyz,
    izz, or 3 rows), ``size`` (m: one number or 3), ``frame`` (default: the end-effector
    frame). ConfigError naming the key."""
    from ..dynamics.payload import Payload, payload_frame

    mass = t.number("mass", positive=True, maximum=PAYLOAD_MAX_MASS)
    com = t.vector("com", [0.0, 0.0, 0.0], length=3, labels=XYZ)
    dist = float(np.linalg.norm(com))
    if dist > PAYLOAD_MAX_COM:
        raise ConfigError(f"{t.key_path('com')}: the centre of mass is {dist:.4g} m from the "
                          f"frame, more than {PAYLOAD_MAX_COM:g} m (m, in the frame's "
                          "coordinates)")
    inertia = None
    if t.has("inertia"):
        raw = t.raw("inertia")
        rows = raw if isinstance(raw, list) and raw and all(isinstance(r, list)
                                                              for r in raw) else [raw]
        flat = [x for r in rows for x in (r if isinstance(r, list) else [r])]
        if len(flat) not in (6, 9):
            raise ConfigError(f"{t.key_path('inertia')}: expected 6 numbers (ixx, ixy, ixz, "
                              "iyy, iyz, izz; kg·m²) or 3 rows of 3")
        vals = check_array(t.key_path("inertia"), flat)
        inertia = vals if len(vals) == 6 else [vals[0:3], vals[3:6], vals[6:9]]
    size = None
    if t.has("size"):
        lim = size_bound(arm)
        size = t.numbers("size", length=3 if isinstance(t.raw("size"), list) else None,
                         bound=lim)
    frame = t.string("frame", None)
    t.done()
    try:
        part = Payload(mass=mass, com=tuple(com), inertia=inertia, size=size, frame=frame,
                       name=name)
        payload_frame(arm, part)
    except ValueError as exc:
        raise ConfigError(str(exc).replace("Payload.", f"{t.path}.", 1)) from None
    return part


def _cycle_table(t: Table, arm: Arm, payloads: dict[str, Any]):
    """``[cycle]``: ``cycle_time`` (s, optional) and ``[[cycle.legs]]`` with ``goal`` (rad),
    ``payload`` (a name of ``[payloads]``), ``dwell`` (s, ≥ 0) and ``name``."""
    from .legs import CycleSpec, Leg

    cycle_time = t.number("cycle_time", None, bound=BOUNDS["max_duration"])
    legs = []
    for k, leg in enumerate(t.tables("legs"), 1):
        goal = np.array(leg.vector("goal", length=arm.nq, bound=_joint_bounds(arm)))
        part = leg.string("payload", None, choices=tuple(payloads)) if leg.has(
            "payload") else None
        dwell = leg.number("dwell", 0.0, nonnegative=True, bound=BOUNDS["delay"])
        name = leg.string("name", f"leg {k}")
        leg.done()
        legs.append(Leg(goal=goal, payload=None if part is None else payloads[part],
                        dwell=dwell, name=name))
    t.done()
    if not legs:
        raise ConfigError(f"{t.path}.legs: a cycle needs at least one [[cycle.legs]] table")
    return CycleSpec(legs=tuple(legs), cycle_time=cycle_time)


def _cycle_tables(top: Table, arm: Arm) -> dict[str, Any]:
    """``[payloads.NAME]`` and ``[cycle]`` of a scenario (docs/design.md §7b, issue 33), as
    the :class:`EnergyScenario` fields ``payloads`` and ``cycle``."""
    table = top.table("payloads")
    payloads = {name: _payload_table(table.table(name), arm, name) for name in list(table.data)}
    table.done()
    cycle = _cycle_table(top.table("cycle"), arm, payloads) if top.has("cycle") else None
    return {"payloads": payloads, "cycle": cycle}
