"""The Python front door: :class:`EnergyPlanner` and :func:`configure` (docs/design.md
§8b); :func:`mpd_pin.plan` is :mod:`mpd_pin.app.api`.

An :class:`EnergyPlanner` is a drive (arm, motors, controller), a world and the
roadmap, search and motion options. Its first :meth:`~EnergyPlanner.plan` builds the
roadmap around that query (exactly as ``mpd-pin run`` does, so the same seed gives the
same numbers); later queries join their start and goal to the same roadmap and reuse
every collision check and simulated energy (docs/design.md §4i), which makes
multi-query use and cycles (A → B → C → A, :meth:`~EnergyPlanner.plan_legs`) cheap.

Each query runs the phases of a run (docs/design.md §7c): ``roadmap``, ``search``,
``verification``, ``comparison``, ``refinement``; the result is a
:class:`~mpd_pin.app.planned.Plan`, which writes the files only when saved.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.payload import Payload
from ..errors import NoMotionWithinDuration
from ..planning.roadmap import COLLISIONS, npz_path
from ..search.registry import PLANNERS
from ..world import World
from .config import ConfigError
from .cycle import Cycle, plan_cycle
from .legs import leg_configuration
from .motion_step import make_motion
from .outputs import add_motion_comparison, cache_record, comparison_record
from .payload_legs import PayloadLegs
from .plan import plan_path, plan_shortest, prepare, requery
from .planned import Plan, PlanParts
from .planner_options import PlannerOptions, merge_options
from .scenario import EVALUATIONS, EnergyScenario
from .timing import PhaseClock
from .trajectory import DEFAULT_TRAJECTORY_RATE
from .verify import verify_path

__all__ = ["EnergyPlanner", "configure", "check_max_duration"]


def check_max_duration(value: Any, name: str = "max_duration") -> float:
    """``value`` as the longest a motion may take (s): a real number in (0, 3600]
    (``BOUNDS["max_duration"]``, the range ``[motion] max_duration`` has in a scenario
    file), else ConfigError naming ``name``."""
    from .limits import BOUNDS

    bound = BOUNDS["max_duration"]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer,
                                                                        np.floating)):
        raise ConfigError(f"{name}: expected a number of seconds within {bound.describe()} "
                          f"(the longest the motion may take), got {value!r}")
    value = float(value)
    if not (math.isfinite(value) and bound.lo < value <= bound.hi):
        raise ConfigError(f"{name}: expected a number of seconds within {bound.describe()} "
                          f"(the longest the motion may take), got {value:g}")
    return value


def configure(scn: EnergyScenario, *, seed: int | None = None, planner: str | None = None,
              evaluation: str | None = None, execution: str | None = None,
              refine: bool | None = None, scheduler: Any = None,
              num_nodes: int | None = None, collision: str | None = None,
              max_duration: float | None = None,
              optimize: bool | None = None, verify: bool | None = None) -> EnergyScenario:
    """``scn`` with some settings replaced (None: keep the scenario's): ``[roadmap] seed``,
    ``num_nodes``, ``evaluation`` and ``collision`` ("lazy"/"eager"), ``[planner] algorithm``,
    ``[motion] execution`` ("auto"/"stop"/"nonstop"), ``refine``, ``optimize`` (the
    trajectory optimisation, docs/design.md §9g) and ``max_duration`` (s, the longest the
    motion may take), ``[compute] scheduler`` ("threads", "local[:N]", an
    address, or a Dask client), ``[run] verify`` (re-simulate the roadmap paths with the
    reference ``simulate_edge``, docs/design.md §7c). ConfigError (one line naming the
    setting) for a bad value."""
    from ..motion.energy import EXECUTIONS
    from .scenario import LIMITS

    if getattr(scn, "kind", None) != "energy":
        raise ConfigError(f"{getattr(scn, 'name', 'scenario')!r} is a "
                          f"{getattr(scn, 'kind', '?')} scenario; these settings apply to "
                          "energy scenarios (an energy roadmap)")
    options = scn.options
    if seed is not None:
        if not (isinstance(seed, (int, np.integer)) and 0 <= seed <= LIMITS["seed"]):
            raise ConfigError(f"seed: expected an integer in [0, {LIMITS['seed']}], got {seed!r}")
        options = replace(options, seed=int(seed))
    if num_nodes is not None:
        if not (isinstance(num_nodes, (int, np.integer)) and 0 <= num_nodes <= LIMITS[
                "num_nodes"]):
            raise ConfigError(f"nodes: expected an integer in [0, {LIMITS['num_nodes']}] (the "
                              f"roadmap's random samples), got {num_nodes!r}")
        options = replace(options, num_nodes=int(num_nodes))
    if planner is not None and planner not in PLANNERS:
        raise ConfigError(f"planner: {planner!r} is not one of {sorted(PLANNERS)}")
    if evaluation is not None and evaluation not in EVALUATIONS:
        raise ConfigError(f"evaluation: {evaluation!r} is not one of {list(EVALUATIONS)}")
    if collision is not None and collision not in COLLISIONS:
        raise ConfigError(f"collision: {collision!r} is not one of {list(COLLISIONS)}")
    if execution is not None and execution not in EXECUTIONS:
        raise ConfigError(f"execution: {execution!r} is not one of {list(EXECUTIONS)}")
    if max_duration is not None:
        max_duration = check_max_duration(max_duration)
    motion = scn.motion
    if optimize is not None:
        motion = replace(motion, optimize=bool(optimize))
    if execution is not None or refine is not None or max_duration is not None:
        motion = replace(motion, execution=execution or motion.execution,
                         refine=motion.refine if refine is None else bool(refine),
                         max_duration=motion.max_duration if max_duration is None
                         else max_duration)
    if isinstance(scheduler, str):
        from ..dynamics.remote import ComputeError, parse_scheduler

        try:
            kind, _ = parse_scheduler(scheduler)
        except ComputeError as exc:
            raise ConfigError(f"{exc}") from None
        scheduler = None if kind == "threads" else scheduler
    elif scheduler is None:
        scheduler = scn.scheduler
    if verify is not None:
        if not isinstance(verify, (bool, np.bool_)):
            raise ConfigError(f"verify: expected true or false, got {verify!r}")
        scn = replace(scn, verify=bool(verify))
    return replace(scn, options=options, planner=planner or scn.planner,
                   evaluation=evaluation or scn.evaluation, motion=motion, scheduler=scheduler,
                   collision=collision or scn.collision)


class EnergyPlanner:
    """Minimum-energy motions for one arm in one world; the roadmap is built once.
    Configurations are in rad (m for prismatic joints), energies E⁺ in J, times in s.

    drive: the :class:`~mpd_pin.Drive` (arm, DC motors, PD + feed-forward controller);
    world: a :class:`~mpd_pin.World` of obstacles and hazard zones (default: empty);
    roadmap: :class:`~mpd_pin.RoadmapOptions` (nodes, k, seed, edge timing, dt);
    evaluation: "lazy" (simulate the edges the search needs) or "eager";
    collision: "lazy" (collision-check the edges the search needs) or "eager" (all first;
    always with eager evaluation);
    planner: a name of ``mpd_pin.search.PLANNERS`` (default MPD* Lite);
    motion: :class:`~mpd_pin.MotionOptions` (execution, refinement, max_duration s);
    sensor_range: m, required when the world has hidden obstacles;
    hazard_penalty: ∞ removes edges too close to a hazard, else their cost factor;
    scheduler: where edge energies run ("threads", "local[:N]", a Dask address or
    client); cache: a roadmap ``.npz`` for the first query (reused or written);
    show_progress: progress bars on stderr; name: the label of results and plots;
    verify: re-simulate each query's roadmap paths with the reference ``simulate_edge``
    and record the agreement in result.json ``verification`` (docs/design.md §7c).

    The settings after ``world`` are the fields of one :class:`~mpd_pin.PlannerOptions`,
    given as ``options`` or as keywords (shorthands that replace single fields of
    ``options``): ``EnergyPlanner(drive, world, mp.PlannerOptions(verify=True),
    roadmap=...)``; :attr:`options` is what the planner uses.

    Use it as a context manager (or call :meth:`close`) when ``scheduler`` starts a
    cluster.
    """

    def __init__(self, drive: Drive, world: World | None = None,
                 options: PlannerOptions | None = None, **keywords: Any) -> None:
        opts = merge_options(options, keywords)
        if not isinstance(drive, Drive):
            raise TypeError(f"drive must be an mpd_pin.Drive, got {type(drive).__name__}")
        world = World(()) if world is None else world
        if not isinstance(world, World):
            raise TypeError(f"world must be an mpd_pin.World, got {type(world).__name__}")
        if world.hidden_names() and opts.sensor_range is None:
            raise ValueError("sensor_range (m) is required when some obstacles are hidden")
        scn = EnergyScenario(
            name=opts.name, description="", arm=drive.arm, motor=drive.motors, kp=drive.kp,
            kd=drive.kd, feedforward=drive.feedforward, world=world, options=opts.roadmap,
            start=np.zeros(drive.arm.nq), goal=np.zeros(drive.arm.nq),
            sensor_range=opts.sensor_range, hazard_penalty=float(opts.hazard_penalty),
            motion=opts.motion, source="python", supply=drive.supply,
        )
        self._init(configure(scn, planner=opts.planner, evaluation=opts.evaluation,
                             scheduler=opts.scheduler, collision=opts.collision,
                             verify=opts.verify),
                   opts.cache, opts.show_progress, opts.trajectory_rate)

    @classmethod
    def from_scenario(cls, scenario: EnergyScenario, *, cache: str | os.PathLike | None = None,
                      show_progress: bool = True,
                      trajectory_rate: float = DEFAULT_TRAJECTORY_RATE) -> EnergyPlanner:
        """A planner with the drive, world and options of a scenario
        (:func:`mpd_pin.load_scenario`)."""
        if getattr(scenario, "kind", None) != "energy":
            raise ConfigError(f"{getattr(scenario, 'name', 'scenario')!r} is a "
                              f"{getattr(scenario, 'kind', '?')} scenario; EnergyPlanner plans "
                              "energy scenarios (run the others with mpd-pin run)")
        self = cls.__new__(cls)
        self._init(scenario, cache, show_progress, trajectory_rate)
        return self

    def _init(self, scn: EnergyScenario, cache, show_progress: bool,
              trajectory_rate: float) -> None:
        if not (trajectory_rate > 0 and math.isfinite(trajectory_rate)):
            raise ConfigError(f"trajectory rate must be a number > 0 (Hz), got "
                              f"{trajectory_rate!r}")
        self.scenario = scn
        self.cache = None if cache is None else Path(cache)
        self.show_progress = bool(show_progress)
        self.trajectory_rate = float(trajectory_rate)
        self._setup = None
        self._compute = None
        #: the roadmap of the bare arm, whose nodes every leg shares; per-payload setups
        self._base = None
        self._payloads = PayloadLegs()

    # ------------------------------------------------------------------ resources
    def open(self) -> EnergyPlanner:
        """Connect where edge energies run (a cluster that cannot be reached fails here,
        before any work); :meth:`plan` does it when needed."""
        if self._compute is None:
            from ..dynamics.remote import open_compute

            self._compute = open_compute(self.scenario.scheduler)
        return self

    def close(self) -> None:
        """Release a cluster this planner started (nothing for threads)."""
        if self._compute is not None:
            self._compute.close()
            self._compute = None

    def __enter__(self) -> EnergyPlanner:
        return self.open()

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def options(self) -> PlannerOptions:
        """The :class:`~mpd_pin.PlannerOptions` this planner plans with (for a planner made
        :meth:`from_scenario`, the scenario's settings; ``scheduler`` None for threads)."""
        scn = self.scenario
        return PlannerOptions(
            roadmap=scn.options, evaluation=scn.evaluation, collision=scn.collision,
            planner=scn.planner, motion=scn.motion, sensor_range=scn.sensor_range,
            hazard_penalty=float(scn.hazard_penalty),
            scheduler=scn.scheduler,
            cache=self.cache, show_progress=self.show_progress, name=scn.name,
            trajectory_rate=self.trajectory_rate, verify=bool(scn.verify))

    @property
    def roadmap(self):
        """The roadmap (:class:`~mpd_pin.planning.roadmap.Roadmap`) of the last query, or
        None before the first."""
        return None if self._setup is None else self._setup.roadmap

    # ------------------------------------------------------------------ queries
    def plan(self, start: Any, goal: Any, *, max_duration: float | None = None,
             payload: Payload | None = None) -> Plan:
        """The minimum-energy motion from ``start`` to ``goal`` (rad, one value per joint):
        a :class:`~mpd_pin.app.planned.Plan`. ``max_duration`` (s): the longest the motion
        may take, for this query (None: the planner's ``MotionOptions.max_duration``).
        ``payload``: a :class:`~mpd_pin.Payload` (kg, m) carried on this leg, in the
        dynamics (``drive.with_payload``) and the collision checks; every leg shares the
        roadmap's nodes, its edges certified and priced per payload (docs/design.md §4i).
        ValueError for a configuration outside the limits or in collision (with the part:
        naming what it touches), ConfigError for a
        bad ``max_duration``; :class:`~mpd_pin.NoPathError` when the roadmap joins none;
        :class:`~mpd_pin.NoMotionWithinDuration` when no motion runs within
        ``max_duration`` (its ``.plan`` holds the fastest one found, ``.fastest`` its
        duration)."""
        from ..dynamics.sizing import check_holding

        base = self.scenario
        if max_duration is not None:
            base = replace(base, motion=replace(base.motion,
                                                max_duration=check_max_duration(max_duration)))
        nq = base.arm.nq
        bare = replace(base, start=leg_configuration(start, nq, "start"),
                       goal=leg_configuration(goal, nq, "goal"))
        scn = self._payloads.scenario(bare, payload)  # the arm carrying the part
        holding = Drive(scn.arm, scn.motor, scn.kp, scn.kd, feedforward=scn.feedforward)
        for what, q in (("start", scn.start), ("goal", scn.goal)):
            check_holding(holding, q, what, effort_limits=scn.options.effort_limits)
        self.open()
        clock = PhaseClock()
        with clock.phase("roadmap"):
            self._payloads.settle(self._base)
            if self._base is None:
                reused = self.cache is not None and npz_path(self.cache).exists()
                self._base = prepare(bare, cache=self.cache, show_progress=self.show_progress,
                                     compute=self._compute)
                cache = cache_record(self.cache, reused)
            else:
                self._base = requery(self._base, bare, show_progress=self.show_progress)
                cache = cache_record(None, False)
            self._setup = self._base
            if payload is not None:
                self._setup, path, reused = self._payloads.setup(
                    scn, self._base, cache=self.cache, compute=self._compute,
                    show_progress=self.show_progress)
                cache = cache_record(path, reused)
        return self._finish(scn, self._setup, clock, cache)

    def plan_legs(self, configurations: Any) -> list[Plan]:
        """One :class:`~mpd_pin.app.planned.Plan` per leg of the sequence
        ``configurations`` (m ≥ 2 configurations, rad): q0 → q1, q1 → q2, …; a cycle
        A → B → C → A is ``[A, B, C, A]``. The energy of leg k is
        ``legs[k].total_energy`` (J)."""
        Q = [np.asarray(q, dtype=float) for q in configurations]
        if len(Q) < 2:
            raise ValueError(f"plan_legs: expected at least 2 configurations, got {len(Q)}")
        return [self.plan(a, b) for a, b in zip(Q[:-1], Q[1:], strict=True)]

    def plan_cycle(self, legs: Any, *, start: Any, cycle_time: float | None = None) -> Cycle:
        """Plan a cycle: from ``start`` (rad), each :class:`~mpd_pin.Leg` moves to its
        ``goal`` carrying its ``payload`` and then waits ``dwell`` s there, on one roadmap.
        ``cycle_time`` (s): motions and dwells together, shared between the legs to
        minimise the total energy (J) on each leg's energy–time front; None: each leg
        follows its own duration rule. A :class:`~mpd_pin.app.cycle.Cycle` (``legs``,
        ``total_energy``, ``to_dict()``, ``save(dir)``); ``mp.CycleTimeTooShort`` (a
        ``NoMotionWithinDuration``) names the shortest possible cycle when ``cycle_time``
        is below it (docs/design.md §8b; :mod:`mpd_pin.app.cycle`)."""
        if cycle_time is not None:
            cycle_time = check_max_duration(cycle_time, "cycle_time")

        def check(a: np.ndarray, b: np.ndarray, part: Payload) -> None:
            self._payloads.scenario(replace(self.scenario, start=a, goal=b), part)

        return plan_cycle(self, legs, start=start, cycle_time=cycle_time,
                          name=self.scenario.name, check=check)

    def _finish(self, scn: EnergyScenario, setup, clock: PhaseClock,
                cache: dict[str, Any]) -> Plan:
        from ..progress import status

        dt = scn.options.dt
        # a lazy search shows its own bar over the rounds; an eager one a status line
        eager = self.show_progress and setup.lazy is None
        with clock.phase("search"), status("search", eager):
            result = plan_path(scn, setup)
        # the roadmap paths' series: the batched integrator's (the roadmap's own numbers),
        # or with [run] verify the reference simulate_edge's, compared (§7c, issue 34)
        ref = bool(scn.verify)
        with clock.phase("verification"), status("verification", self.show_progress and ref):
            check = verify_path(setup.drive, setup.roadmap, result.path, dt, result.energy,
                                reference=ref)
        with clock.phase("comparison"), status("shortest path", eager):
            short = plan_shortest(scn, setup)
            # the same node sequence is the same simulation: simulated once (issue 34)
            short_check = (check if list(short.path) == list(result.path)
                           and np.array_equal(short.energy, result.energy)
                           else verify_path(setup.drive, setup.roadmap, short.path, dt,
                                            short.energy, reference=ref))
            comparison = comparison_record(scn, setup, result, check, short, short_check)
        with clock.phase("refinement"):
            motion = make_motion(scn, setup, result, check, short,
                                 show_progress=self.show_progress)
            moved = motion.check()
            add_motion_comparison(comparison, motion)
        clock.finish()
        plan = Plan(PlanParts(scn, setup, result, check, short, short_check, motion, moved,
                           comparison, clock, cache, self.trajectory_rate, self.show_progress))
        if motion.failure:  # a planning outcome: the fastest motion found is over the cap
            raise NoMotionWithinDuration(motion.failure, motion.energy.duration, plan,
                                         max_duration=scn.motion.max_duration)
        return plan

