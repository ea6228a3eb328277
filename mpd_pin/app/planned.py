"""A plan as a value: what one query computed, its result.json record and its files
(docs/design.md §8b).

:class:`Plan` is returned by :func:`mpd_pin.plan` and :meth:`mpd_pin.EnergyPlanner.plan`.
It holds everything a run computed in memory — the roadmap path (MPD* Lite), the motion
the arm runs, the shortest-path comparison, the motion's time series — and writes the
files of ``mpd-pin run`` only when asked (:meth:`Plan.save`). :meth:`Plan.to_dict` is
result.json: after :meth:`Plan.save` it is exactly the file written.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from .config import ConfigError
from .motion_step import RunMotion, path_supply_energy
from .outputs import (
    make_figures,
    result_record,
    roadmap_timings,
    timing_record,
    write_plots,
    write_replay_html,
    write_result,
)
from .plan import PlanResult, Setup, path_length
from .results import to_jsonable
from .scenario import EnergyScenario
from .timing import PhaseClock
from .trajectory import joint_trajectory, write_trajectory_csv, write_trajectory_json
from .verify import Verification

__all__ = ["Plan", "PlanParts", "RoadmapPath", "check_output_dir", "plan_and_save"]

P = TypeVar("P")
R = TypeVar("R")


def check_output_dir(out_dir: Path) -> bool:
    """Create ``out_dir`` if needed and check a file can be written in it (removed again).
    Returns whether it was created here. Raises :class:`ConfigError` (one line) if not."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {str(out_dir)!r} exists and is not a directory")
    created = not out_dir.exists()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".mpd-pin-probe.", dir=out_dir)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        if created and out_dir.is_dir():
            try:
                out_dir.rmdir()
            except OSError:
                pass
        reason = exc.strerror or type(exc).__name__
        raise ConfigError(f"--out {str(out_dir)!r} cannot be written ({reason})") from None
    return created


def plan_and_save(out_dir: Path, plan: Callable[[], P], save: Callable[[P], R], *,
                  outcome: type[BaseException] | tuple[type[BaseException], ...] = (),
                  save_outcome: Callable[[Any], None] | None = None) -> R:
    """The outer steps of every run that writes a folder (``mpd-pin run``, a cycle,
    :meth:`Plan.save`): check ``out_dir`` (:func:`check_output_dir`: created if needed and
    probed, a ConfigError before any work), ``plan()``, then ``save(planned)``, whose
    value is returned. A planning ``outcome`` raised by ``plan()`` (an answer all the same:
    ``NoMotionWithinDuration``, ``CycleTimeTooShort``) has its files written by
    ``save_outcome(exc)`` and is raised again; on any failure a folder created here and
    still empty is removed again."""
    out_dir = Path(out_dir)
    created = check_output_dir(out_dir)
    try:
        try:
            planned = plan()
        except outcome as exc:
            if save_outcome is not None:
                save_outcome(exc)
            raise
        return save(planned)
    except BaseException:
        if created and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()
        raise


@dataclass(frozen=True)
class RoadmapPath:
    """The MPD* Lite optimum on the roadmap, stop-and-go: ``nodes`` (roadmap node ids),
    ``configurations`` (n, nq) rad, ``energy_per_joint`` (nq,) E⁺ J, ``total_energy`` J
    (the supply energy, docs/design.md §3i),
    ``length_rad`` (Σ‖Δq‖₂, rad)."""

    nodes: list[int]
    configurations: np.ndarray
    energy_per_joint: np.ndarray
    total_energy: float
    length_rad: float


@dataclass
class PlanParts:
    """What one query computed, in the order of the run's phases: the input of
    :class:`Plan` (built by :meth:`mpd_pin.app.planner.EnergyPlanner.plan`)."""

    scenario: EnergyScenario
    setup: Setup
    result: PlanResult
    check: Verification
    shortest: PlanResult
    shortest_check: Verification
    motion: RunMotion
    moved: Verification
    comparison: dict[str, Any]
    clock: PhaseClock
    cache: dict[str, Any]
    trajectory_rate: float
    show_progress: bool = False


class Plan:
    """One planned query (module docstring). Energies are J, times s, angles rad.

    ``total_energy``: the energy the returned motion draws from the supply (Σ E⁺ per joint
    with the paper's per-joint supplies, docs/design.md §3i); ``energy_per_joint``: its E⁺
    per joint; ``path``: its
    waypoints (n, nq); ``motion``: the :class:`~mpd_pin.motion.MotionEnergy` (execution
    ``stop``/``nonstop``, ``duration``, ``stops``, …); ``roadmap_path``: the
    :class:`RoadmapPath` behind it; ``comparison``: result.json's ``comparison`` (the
    shortest joint-space path planned and refined the same way); ``series``: the motion's
    time series (``t``, ``q``, ``v``, ``i``, ``V``, ``energy_t``, …), sampled every
    ``dt``; ``fastest_duration`` (s): the least duration any feasible candidate's execution
    allows (result.json ``motion.fastest_duration``); ``feasible``: False for the plan of a
    :class:`~mpd_pin.NoMotionWithinDuration` (the fastest motion found, over
    ``max_duration``), ``reason`` then saying why.
    """

    def __init__(self, parts: PlanParts) -> None:
        self._parts = parts
        p = parts
        self.scenario = p.scenario
        self.motion = p.motion.energy
        self.total_energy = float(self.motion.total_energy)
        self.energy_per_joint = np.asarray(self.motion.energy_per_joint, dtype=float)
        self.path = np.asarray(self.motion.waypoints, dtype=float)
        self.fastest_duration = p.motion.fastest_duration
        self.feasible = not p.motion.failure
        self.reason = p.motion.failure
        roadmap = p.setup.roadmap
        self.roadmap_path = RoadmapPath(
            nodes=[int(n) for n in p.result.path],
            configurations=roadmap.nodes[p.result.path],
            energy_per_joint=np.asarray(p.result.energy, dtype=float),
            total_energy=path_supply_energy(roadmap, p.result.path, p.result.energy),
            length_rad=path_length(roadmap, p.result.path, p.scenario.arm),
        )
        self.comparison = p.comparison
        self.series = p.moved.series
        self._traj = joint_trajectory(p.scenario.arm.joint_names, p.moved.series,
                                      p.setup.drive.torque_per_amp, p.trajectory_rate)
        record = result_record(p.scenario, p.setup, p.result, p.check, None, p.clock,
                               p.comparison, cache=p.cache, motion=p.motion)
        record["trajectory"] = {
            "csv": "trajectory.csv",
            "json": "trajectory.json",
            "samples": len(p.moved.series["t"]),
            "step": p.scenario.options.dt,
            "json_rate_hz": float(p.trajectory_rate),
            "json_points": len(self._traj["points"]),
        }
        self._record = record
        self._saved: dict[str, Any] | None = None

    def __repr__(self) -> str:
        m = self.motion
        return (f"Plan({self.scenario.name!r}: {self.total_energy:.6g} J {m.execution} over "
                f"{len(self.path)} waypoints in {m.duration:.3g} s; roadmap path "
                f"{self.roadmap_path.total_energy:.6g} J over {len(self.roadmap_path.nodes)} "
                "nodes)")

    @property
    def energy_duration(self) -> dict[str, Any]:
        """The energy–time fronts (docs/design.md §9c), as result.json ``energy_duration``:
        ``returned`` — the motion returned, from the candidate named ``candidate``: its
        ``duration`` (s) and ``total_energy`` (J), ``fastest_duration`` (the fastest
        feasible motion of its geometry), ``velocity_bound``, ``longest_duration``,
        ``duration_rule``, ``screen`` (perfect-tracking E(T)) and ``simulated`` ([s, J]
        pairs); ``candidates`` — per candidate priced, the same for its ``nonstop`` and
        ``stop`` executions (None where not priced); ``max_duration`` (s or None)."""
        return to_jsonable(self._record.get("energy_duration") or {})

    @property
    def seconds(self) -> float:
        """Wall-clock seconds the query took (roadmap, search, refinement; no files)."""
        return float(self._parts.clock.wall["total"])

    def to_dict(self) -> dict[str, Any]:
        """result.json as plain JSON data (non-finite numbers ``None``): after
        :meth:`save`, the file written; before, the same without ``replay``, ``outputs``
        and the writing phases' times."""
        if self._saved is not None:
            return to_jsonable(self._saved)
        return to_jsonable(self._record)

    def figures(self) -> dict[str, Any]:
        """The matplotlib figures of the run by file name (``path.png``,
        ``joint_angles.png``, ``energy.png`` and, for a refined non-stop search,
        ``energy_duration.png``); the caller closes them."""
        p = self._parts
        return make_figures(p.scenario, p.setup, p.result, p.moved,
                            (p.shortest, p.shortest_check), motion=p.motion)

    def plot(self, which: str = "path.png"):
        """One figure of :meth:`figures` (default the arm's path), for a notebook."""
        import matplotlib.pyplot as plt

        figs = self.figures()
        if which not in figs:
            for fig in figs.values():
                plt.close(fig)
            raise ValueError(f"plot: {which!r} is not one of {sorted(figs)}")
        for name, fig in figs.items():
            if name != which:
                plt.close(fig)
        return figs[which]

    def save(self, out_dir: str | os.PathLike, *, replay: bool = True, plots: bool = True,
             show_progress: bool | None = None) -> dict[str, Any]:
        """Write the files of ``mpd-pin run`` into ``out_dir`` (created if needed):
        trajectory.csv/json, path.png, joint_angles.png, energy.png (energy_duration.png;
        with ``plots``, which imports matplotlib), replay.html (with ``replay``, which
        imports meshcat) and result.json last. Returns result.json's content.
        A folder this call created is removed again if it fails before writing a file.
        ``show_progress`` (default: the planner's) prints a status line per phase."""
        out_dir = Path(out_dir)
        shown = self._parts.show_progress if show_progress is None else bool(show_progress)
        return plan_and_save(out_dir, lambda: self,
                             lambda plan: plan._save_in(out_dir, replay, plots, shown))

    def _save_in(self, out_dir: Path, replay: bool, plots: bool,
                 shown: bool) -> dict[str, Any]:
        from ..progress import status

        # the writing phases are timed on a copy: the query's clock (``seconds``, the
        # record of to_dict() before saving) stays as the query left it, and a second save
        # times its own writing, not the first one's too
        p, clock = self._parts, self._parts.clock.copy()
        total, cpu_total = clock.wall["total"], clock.cpu["total"]
        w0, c0 = time.perf_counter(), time.process_time()
        names, kt = p.scenario.arm.joint_names, p.setup.drive.torque_per_amp
        with clock.phase("trajectory"):
            write_trajectory_csv(out_dir / "trajectory.csv", names, p.moved.series, kt)
            write_trajectory_json(out_dir / "trajectory.json", self._traj)
        if plots:
            with clock.phase("plots"), status("plots", shown):
                write_plots(out_dir, p.scenario, p.setup, p.result, p.moved,
                            (p.shortest, p.shortest_check), motion=p.motion)
        record = dict(self._record)
        if replay:
            with clock.phase("replay"), status("replay", shown):
                record["replay"] = write_replay_html(out_dir, p.scenario, p.setup, p.result,
                                                     p.moved, p.shortest, motion=p.motion)
        clock.wall["total"] = total + time.perf_counter() - w0
        clock.cpu["total"] = cpu_total + time.process_time() - c0
        record.update(timing_record(roadmap_timings(p.setup), clock))
        self._saved = write_result(out_dir, record)
        return self._saved
