"""Run a paper-000 scenario end to end: plan → verify → write (docs/design.md §7).

:func:`run_energy_scenario` is ``mpd-pin run`` for energy scenarios: one query of an
:class:`~mpd_pin.app.planner.EnergyPlanner` (the Python API, docs/design.md §8b), then
:meth:`~mpd_pin.app.planned.Plan.save`. The phases, timed one by one
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
  ``joint_angles.png``, ``energy.png``, ``energy_duration.png`` (``plots``; skipped with
  ``plots=False``, ``--no-plots``), ``replay.html`` (``replay``; skipped with
  ``replay=False``, ``--no-replay``) and ``result.json`` (its layout is described in
  :mod:`mpd_pin.app.outputs`).

The output folder is created and probed for writing first: one that cannot be written is
a :class:`~mpd_pin.app.config.ConfigError` before any work, and a folder this run created
is removed again.

When no motion runs within ``max_duration`` (:class:`~mpd_pin.errors.NoMotionWithinDuration`,
a planning outcome) the files are still written, for the fastest motion found, with
result.json's ``feasible`` false and its ``reason``; then the exception is raised again
(``.result``: result.json as written), and ``mpd-pin run`` exits with status 3.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import NoMotionWithinDuration
from .planned import check_output_dir, plan_and_save
from .planner import EnergyPlanner
from .scenario import EnergyScenario
from .trajectory import DEFAULT_TRAJECTORY_RATE

__all__ = ["run_energy_scenario", "check_output_dir"]


def run_energy_scenario(
    scn: EnergyScenario,
    out_dir: Path,
    *,
    show_progress: bool = True,
    cache: Path | None = None,
    replay: bool = True,
    plots: bool = True,
    trajectory_rate: float = DEFAULT_TRAJECTORY_RATE,
) -> dict[str, Any]:
    """Plan ``scn`` and write result.json, trajectory.csv/json (``trajectory_rate`` Hz), the
    plots (with ``plots``; matplotlib is imported only then) and replay.html (with
    ``replay``; meshcat likewise) into ``out_dir``; ``cache`` is a roadmap
    ``.npz`` to reuse or create (an interrupted build resumes). Edge energies run where
    ``scn.scheduler`` says (:func:`~mpd_pin.dynamics.remote.open_compute`; connected first,
    so an unreachable cluster fails before any work; docs/design.md §4h). Returns the
    result as written to result.json (plain JSON data, ``None`` for each non-finite
    number)."""
    out_dir = Path(out_dir)
    # a bad trajectory rate is refused here, by the planner, before any work
    planner = EnergyPlanner.from_scenario(scn, cache=cache, show_progress=show_progress,
                                          trajectory_rate=trajectory_rate)
    # The cluster first (docs/design.md §4h): one that cannot be reached fails before any work.
    with planner:
        if getattr(scn, "cycle", None) is not None:  # [cycle]: the legs, cycle.json (issue 33)
            from .cycle import run_cycle

            return run_cycle(planner, scn, out_dir, replay=replay, plots=plots)

        def save_outcome(exc: NoMotionWithinDuration) -> None:  # its files, then why
            exc.result = exc.plan.save(out_dir, replay=replay, plots=plots)

        return plan_and_save(out_dir, lambda: planner.plan(scn.start, scn.goal),
                             lambda plan: plan.save(out_dir, replay=replay, plots=plots),
                             outcome=NoMotionWithinDuration, save_outcome=save_outcome)
