"""Run a paper-000 scenario end to end: plan → verify → write (docs/design.md §7).

:func:`run_energy_scenario` is the orchestration, timed phase by phase
(:class:`~mpd_pin.app.timing.PhaseClock`):

* plan (:mod:`mpd_pin.app.plan`) — the roadmap (phase ``roadmap``), then the path: one
  search, hazard re-planning, or execution with sensing and repair (``search``);
* verify (:mod:`mpd_pin.app.verify`) — the path re-simulated edge by edge with
  :func:`simulate_edge` (``verification``);
* write (:mod:`mpd_pin.app.outputs`) — ``path.png``, ``joint_angles.png``, ``energy.png``
  (``plots``), ``replay.html`` (``replay``) and ``result.json`` (its layout is described
  in :mod:`mpd_pin.app.outputs`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .outputs import result_record, write_plots, write_replay_html, write_result
from .plan import plan_path, prepare
from .scenario import EnergyScenario
from .timing import PhaseClock
from .verify import verify_path

__all__ = ["run_energy_scenario"]


def run_energy_scenario(
    scn: EnergyScenario,
    out_dir: Path,
    *,
    show_progress: bool = True,
    cache: Path | None = None,
    replay: bool = True,
) -> dict[str, Any]:
    """Plan ``scn`` and write result.json, the plots and (with ``replay``) replay.html into
    ``out_dir``; ``cache`` is a roadmap ``.npz`` to reuse or create. Returns the result as
    written to result.json (plain JSON data, ``None`` for each non-finite number)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    clock = PhaseClock()
    with clock.phase("roadmap"):
        setup = prepare(scn, cache=cache, show_progress=show_progress)
    with clock.phase("search"):
        plan = plan_path(scn, setup)
    with clock.phase("verification"):
        check = verify_path(setup.drive, setup.roadmap, plan.path, scn.options.dt, plan.energy)
    with clock.phase("plots"):
        write_plots(out_dir, scn, setup, plan, check)
    replay_record = None
    if replay:
        with clock.phase("replay"):
            replay_record = write_replay_html(out_dir, scn, setup, plan, check)
    clock.finish()
    return write_result(out_dir, result_record(scn, setup, plan, check, replay_record, clock))
