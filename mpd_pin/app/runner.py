"""Run a paper-000 scenario end to end: plan → verify → write (docs/design.md §7).

:func:`run_energy_scenario` is the orchestration, timed phase by phase
(:class:`~mpd_pin.app.timing.PhaseClock`):

* plan (:mod:`mpd_pin.app.plan`) — the roadmap (phase ``roadmap``), then the path: one
  search, hazard re-planning, or execution with sensing and repair (``search``);
* verify (:mod:`mpd_pin.app.verify`) — the path re-simulated edge by edge with
  :func:`simulate_edge` (``verification``);
* compare (docs/design.md §7c) — the shortest joint-space path planned the same way on
  distance costs, and re-simulated (``comparison``);
* motion (docs/design.md §9f, :mod:`mpd_pin.app.motion_step`) — the roadmap path (and the
  shortest) refined and priced under ``[motion]``: the motion the run returns
  (``refinement``);
* write (:mod:`mpd_pin.app.outputs`, :mod:`mpd_pin.app.trajectory`) — the motion's
  ``trajectory.csv`` and ``trajectory.json`` (``trajectory``), ``path.png``,
  ``joint_angles.png``, ``energy.png``, ``energy_duration.png`` (``plots``),
  ``replay.html`` (``replay``) and ``result.json`` (its layout is described in
  :mod:`mpd_pin.app.outputs`).

The output folder is created and probed for writing first: one that cannot be written is
a :class:`~mpd_pin.app.config.ConfigError` before any work, and a folder this run created
is removed again.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

from ..dynamics.remote import Compute, open_compute
from .config import ConfigError
from .motion_step import make_motion
from .outputs import (
    add_motion_comparison,
    cache_record,
    comparison_record,
    result_record,
    write_plots,
    write_replay_html,
    write_result,
)
from .plan import plan_path, plan_shortest, prepare
from .scenario import EnergyScenario
from .timing import PhaseClock
from .trajectory import (
    DEFAULT_TRAJECTORY_RATE,
    joint_trajectory,
    write_trajectory_csv,
    write_trajectory_json,
)
from .verify import verify_path

__all__ = ["run_energy_scenario", "check_output_dir"]


def check_output_dir(out_dir: Path) -> bool:
    """Create ``out_dir`` if needed and check a file can be written in it (removed again).
    Returns whether it was created here. Raises :class:`ConfigError` (one line) if not."""
    out_dir = Path(out_dir)
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


def _cache_exists(cache: Path | None) -> bool:
    """Whether the roadmap file ``cache`` exists, so ``build_roadmap`` loads it (or refuses
    it: another key) instead of building (docs/design.md §4f)."""
    from ..planning.roadmap import npz_path

    return cache is not None and npz_path(cache).exists()


def run_energy_scenario(
    scn: EnergyScenario,
    out_dir: Path,
    *,
    show_progress: bool = True,
    cache: Path | None = None,
    replay: bool = True,
    trajectory_rate: float = DEFAULT_TRAJECTORY_RATE,
) -> dict[str, Any]:
    """Plan ``scn`` and write result.json, trajectory.csv/json (``trajectory_rate`` Hz), the
    plots and (with ``replay``) replay.html into ``out_dir``; ``cache`` is a roadmap
    ``.npz`` to reuse or create (an interrupted build resumes). Edge energies run where
    ``scn.scheduler`` says (:func:`~mpd_pin.dynamics.remote.open_compute`; connected first,
    so an unreachable cluster fails before any work; docs/design.md §4h). Returns the
    result as written to result.json (plain JSON data, ``None`` for each non-finite
    number)."""
    out_dir = Path(out_dir)
    if not (trajectory_rate > 0 and trajectory_rate < float("inf")):
        raise ConfigError(f"trajectory rate must be a number > 0 (Hz), got {trajectory_rate!r}")
    # The cluster first (docs/design.md §4h): one that cannot be reached fails before any work.
    with open_compute(scn.scheduler) as compute:
        return _run(scn, out_dir, show_progress, cache, replay, trajectory_rate, compute)


def _run(scn: EnergyScenario, out_dir: Path, show_progress: bool, cache: Path | None,
         replay: bool, trajectory_rate: float, compute: Compute) -> dict[str, Any]:
    """:func:`run_energy_scenario` once the compute is open; a folder this run created is
    removed again when the run fails before writing anything into it."""
    created = check_output_dir(out_dir)
    try:
        return _run_in(scn, out_dir, show_progress, cache, replay, trajectory_rate, compute)
    except BaseException:
        if created and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()
        raise


def _run_in(scn: EnergyScenario, out_dir: Path, show_progress: bool, cache: Path | None,
            replay: bool, trajectory_rate: float, compute: Compute) -> dict[str, Any]:
    """The phases of a run (module docstring) into the checked folder ``out_dir``."""
    clock = PhaseClock()
    dt = scn.options.dt
    with clock.phase("roadmap"):
        cache_used = _cache_exists(cache)  # loaded (reused) if it exists, else built and saved
        setup = prepare(scn, cache=cache, show_progress=show_progress, compute=compute)
    with clock.phase("search"):
        plan = plan_path(scn, setup)
    with clock.phase("verification"):
        check = verify_path(setup.drive, setup.roadmap, plan.path, dt, plan.energy)
    with clock.phase("comparison"):
        short = plan_shortest(scn, setup)
        short_check = verify_path(setup.drive, setup.roadmap, short.path, dt, short.energy)
        comparison = comparison_record(scn, setup, plan, check, short, short_check)
    with clock.phase("refinement"):
        motion = make_motion(scn, setup, plan, check, short)
        moved = motion.check()
        add_motion_comparison(comparison, motion)
    with clock.phase("trajectory"):
        names, kt = scn.arm.joint_names, setup.drive.torque_per_amp
        write_trajectory_csv(out_dir / "trajectory.csv", names, moved.series, kt)
        traj = joint_trajectory(names, moved.series, kt, trajectory_rate)
        write_trajectory_json(out_dir / "trajectory.json", traj)
    with clock.phase("plots"):
        write_plots(out_dir, scn, setup, plan, moved, (short, short_check), motion=motion)
    replay_record = None
    if replay:
        with clock.phase("replay"):
            replay_record = write_replay_html(out_dir, scn, setup, plan, moved, short,
                                              motion=motion)
    clock.finish()
    record = result_record(scn, setup, plan, check, replay_record, clock, comparison,
                           cache=cache_record(cache, cache_used), motion=motion)
    record["trajectory"] = {
        "csv": "trajectory.csv",
        "json": "trajectory.json",
        "samples": len(moved.series["t"]),
        "step": dt,
        "json_rate_hz": float(trajectory_rate),
        "json_points": len(traj["points"]),
    }
    return write_result(out_dir, record)
