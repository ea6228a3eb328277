"""The ``mpd-pin`` command.

    mpd-pin --version                       the installed version
    mpd-pin scenarios                       list the built-in scenarios
    mpd-pin show NAME [--all]               print a built-in scenario's TOML (a starting point;
                                            --all: with every section and its defaults)
    mpd-pin run NAME|FILE --out DIR         plan a scenario, write result.json, plots, replay.html
        [--seed N] [--planner NAME]         (planners: mpd_pin.search.PLANNERS, listed by --help)
        [--evaluation lazy|eager]           (override [roadmap] evaluation)
        [--collision lazy|eager]            (override [roadmap] collision)
        [--nodes N] [--execution auto|stop|nonstop] [--no-refine] [--no-optimize]
        [--verify]                          (re-simulate the roadmap paths with simulate_edge)
        [--quiet] [--no-replay] [--no-plots]  (no progress; no replay.html; no figures)
        [--max-duration S]                  (override [motion] max_duration: the cycle time)
        [--cache FILE] [--scheduler ADDRESS|local[:N]]   roadmap file; Dask cluster (§4h)
    mpd-pin energy NAME|FILE PATHFILE       price a path planned elsewhere (CSV or JointTrajectory
        [--execution timed|auto|stop|nonstop]  JSON, :mod:`mpd_pin.app.pathfile`) with the
        [--out FILE] [--max-duration S]     scenario's motors (timed: its own times, the default
                                            when it has them); writes <PATHFILE stem>_energy.json

Scenario kinds are dispatched by :mod:`mpd_pin.app.kinds`; this module knows none of them.

Bad input (unknown scenario, malformed TOML or URDF, unknown keys, start or goal
in collision, no path) prints one line on stderr and exits with status 2 (or 3
when no path exists); nothing is left half-written in DIR but what was done. No motion
within ``max_duration`` is a planning outcome: DIR gets the fastest motion found, its
result.json says ``"feasible": false`` and why, and one line naming that motion's
duration ends the command with status 3.
Scenario numbers are range-checked when read (:mod:`mpd_pin.app.limits`), and the
command runs with numpy's floating-point overflow, invalid-value and divide-by-zero
warnings raised as errors (``np.errstate``; underflow is harmless and ignored; routines
that detect divergence through inf/NaN, such as ``simulate_edge``, set their own local
``errstate``), so a numerical problem that slips through ends as the internal-error line
below instead of warnings and a misleading message.
Any other exception (a bug, memory exhausted) prints one line
``mpd-pin: internal error: <type>: <message>`` and exits with status 1; Ctrl-C
prints ``mpd-pin: interrupted`` and exits with 130.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..errors import MpdPinError, NoMotionWithinDuration, NoPathError
from .config import ConfigError

__all__ = ["main"]

#: ``mpd-pin energy --execution`` choices, the default first: mpd_pin.motion.EXECUTIONS,
#: spelled out so that building the parser does not import the dynamics (a test keeps
#: the two equal).
EXECUTIONS = ("auto", "stop", "nonstop")


def _describe(path: Path) -> tuple[str, str]:
    from .kinds import scenario_kind
    from .scenario_files import load_scenario_data

    try:
        data = load_scenario_data(path)
    except ConfigError as exc:
        return "?", f"(unreadable: {exc})"
    return scenario_kind(data), str(data.get("description", ""))


def cmd_scenarios(_: argparse.Namespace) -> int:
    from .scenario_files import builtin_scenarios

    for name, path in builtin_scenarios().items():
        kind, desc = _describe(path)
        print(f"{name:<14} {kind:<13} {desc}")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    """Print the TOML text of the built-in scenario ``args.name`` as shipped (copy it to a
    file and edit it: ``mpd-pin show case1 > my_scene.toml``); with ``--all``, every
    section and each key left to its default added (:func:`mpd_pin.app.show.with_defaults`)."""
    from .scenario_files import builtin_scenarios

    scenarios = builtin_scenarios()
    if args.name not in scenarios:
        raise ConfigError(f"unknown built-in scenario {args.name!r}; the built-in scenarios are: "
                          f"{', '.join(scenarios)}")
    text = scenarios[args.name].read_text(encoding="utf-8")
    if args.all:
        from .show import with_defaults

        text = with_defaults(text, args.name)
    sys.stdout.write(text)
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """Plan a scenario (energy scenarios: :func:`mpd_pin.app.planner.configure` applies the
    overrides, :func:`~mpd_pin.app.runner.run_energy_scenario` plans and saves) and print
    its one line."""
    from .kinds import load_scenario, run_scenario, summary_line

    max_duration = _max_duration(args.max_duration)  # refused before any work
    scn = load_scenario(args.scenario, seed=args.seed, planner=args.planner)
    flags = {"--evaluation": args.evaluation, "--collision": args.collision,
             "--scheduler": args.scheduler,
             "--execution": args.execution, "--no-refine": args.no_refine or None,
             "--no-optimize": args.no_optimize or None, "--verify": args.verify or None,
             "--nodes": args.nodes, "--max-duration": max_duration}
    given = [flag for flag, value in flags.items() if value is not None]
    if given:
        if getattr(scn, "kind", None) != "energy":
            names, one = ", ".join(given), len(given) == 1
            raise ConfigError(f"{names} {'does' if one else 'do'} not apply to "
                              f"{args.scenario!r}, a {getattr(scn, 'kind', '?')} scenario (no "
                              f"energy roadmap): {names} appl{'ies' if one else 'y'} to energy "
                              "scenarios")
        from .planner import configure

        try:
            scn = configure(scn, evaluation=args.evaluation, collision=args.collision,
                            scheduler=args.scheduler,
                            execution=args.execution, refine=False if args.no_refine else None,
                            optimize=False if args.no_optimize else None,
                            verify=True if args.verify else None,
                            num_nodes=args.nodes, max_duration=max_duration)
        except ConfigError as exc:
            raise ConfigError(f"--{exc}") from None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} exists and is not a directory")
    try:
        result = run_scenario(scn, out, show_progress=not args.quiet,
                              cache=Path(args.cache) if args.cache else None,
                              replay=not args.no_replay, plots=not args.no_plots)
    except NoMotionWithinDuration as exc:  # main prints it (status 3); the files are written
        if exc.result is not None:
            exc.args = (f"{exc}; its files are in {str(out)!r} (result.json: feasible "
                        "false)",)
        raise
    print(summary_line(scn, result, out))
    return 0


def _max_duration(text: str | None) -> float | None:
    """``--max-duration`` as seconds (None: not given); ConfigError (one line naming the
    option) unless a number in (0, 3600]."""
    if text is None:
        return None
    from .limits import BOUNDS

    bound = BOUNDS["max_duration"]
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (bound.lo < value <= bound.hi):  # NaN fails too
        raise ConfigError(f"--max-duration: expected a number of seconds within "
                          f"{bound.describe()} (the longest the motion may take), got "
                          f"{text!r}")
    return value


def _energy_line(name: str, pathfile: str, motion: Any, out: Path, asked: str) -> str:
    """The one line ``mpd-pin energy`` prints (energies J, duration s) for the execution
    ``asked``: a feasible motion's energy (with both executions' energies under "auto"), or
    "infeasible: <why>" — never an energy — when it is not. One line whatever the reasons."""
    if not motion.feasible:
        ms = [motion] + ([motion.alternative] if asked == "auto" and motion.alternative
                         is not None else [])
        why = "; ".join(f"{m.execution}: {m.reason or 'infeasible'}" for m in ms)
        text = f"infeasible: {why}"
    else:
        by = motion.energy_by_execution if asked == "auto" else {}
        also = ", ".join(f"{k} {v:.4g} J" if v is not None else f"{k} infeasible"
                         for k, v in by.items())
        n = int(motion.stops)
        text = (f"{motion.total_energy:.4g} J {motion.execution}"
                f"{f' ({also})' if also else ''}, {motion.duration:.2f} s, "
                f"{n} stop{'' if n == 1 else 's'}")
    return " ".join(f"{name} {pathfile}: {text} -> {out}".split())


def _same_file(a: Path, b: Path) -> bool:
    """Whether the paths ``a`` and ``b`` name one file (symbolic or hard links included)."""
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except OSError:
        return False


def cmd_energy(args: argparse.Namespace) -> int:
    """Price the waypoints of ``args.pathfile`` on the arm, motors and known obstacles of
    ``args.scenario`` (:func:`mpd_pin.motion.trajectory_energy`) and write the JSON file:
    with the file's own times ("timed") by default when it has them, else "auto". Exit
    status 0 for a feasible motion; 3 (the JSON still written, one line on stderr saying
    why) when the motion is infeasible."""
    import math

    from ..collision import CollisionChecker
    from ..motion import trajectory_energy
    from .kinds import load_scenario
    from .pathfile import check_path, check_times, read_path_file
    from .results import write_json

    max_duration = args.max_duration
    if max_duration is not None and not (math.isfinite(max_duration) and max_duration > 0):
        raise ConfigError(f"--max-duration must be a number > 0 (s), got {max_duration!r}")
    pathfile = Path(args.pathfile)
    if args.out is not None:
        out = Path(args.out)
    else:
        out = pathfile.with_name(f"{pathfile.stem}_energy.json")
    if _same_file(out, pathfile):
        raise ConfigError(f"--out {str(out)!r} is the path file itself (give another file "
                          "name)")
    if out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a directory (give a file name)")
    scn = load_scenario(args.scenario)
    kind = getattr(scn, "kind", "?")
    if kind != "energy":
        raise ConfigError(f"energy prices paths on energy scenarios; {args.scenario!r} is a "
                          f"{kind} scenario")
    names = list(scn.arm.joint_names)
    pf = read_path_file(pathfile, names)
    execution = args.execution or ("timed" if pf.times is not None else "auto")
    times = check_times(pf) if execution == "timed" else None
    checker = CollisionChecker(scn.arm, scn.world)  # the obstacles known at the start
    check_path(pf.waypoints, scn.arm, checker, rows=pf.rows, source=str(pathfile))
    if max_duration is None:
        max_duration = scn.motion.max_duration  # [motion] max_duration (s) or None
    motion = trajectory_energy(scn.drive(), pf.waypoints, execution, options=scn.options,
                               checker=checker, max_duration=max_duration, times=times)
    if args.optimize:  # the priced motion's duration, or the cap (docs/design.md §9g)
        from ..motion.optimize import optimize_motion

        duration = max_duration if max_duration is not None else motion.duration
        try:
            motion = optimize_motion(scn.drive(), scn.world, pf.waypoints, duration,
                                     options=scn.options, checker=checker)
        except ValueError as exc:
            raise ConfigError(f"--optimize: {exc}") from None
    doc = {"scenario": scn.name, "pathfile": str(pathfile), "joint_names": names,
           **motion.to_dict(), "supply": motion.supply.describe(),
           "energy_by_supply": motion.energy_by_supply()}
    if motion.optimization is not None:
        doc["optimization"] = motion.optimization
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_json(out, doc)
    except OSError as exc:
        raise ConfigError(f"--out {str(out)!r}: cannot write: {exc.strerror or exc}") from None
    line = _energy_line(scn.name, str(pathfile), motion, out, execution)
    if not motion.feasible:
        print(f"mpd-pin: {line}", file=sys.stderr)
        return 3
    print(line)
    return 0


def _planners_help() -> str:
    from ..search.registry import DEFAULT_PLANNER, PLANNERS

    names = ", ".join(f"{n} ({c.__name__})" for n, c in PLANNERS.items())
    return (f"planners (--planner, or [planner] algorithm in an energy scenario; default "
            f"{DEFAULT_PLANNER}): {names}")


def build_parser() -> argparse.ArgumentParser:
    from ..search.registry import PLANNERS

    parser = argparse.ArgumentParser(
        prog="mpd-pin",
        description="Energy-optimal, collision-free motion planning for robot arms (MPD* Lite).",
        epilog=_planners_help(),
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"mpd-pin {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("scenarios", help="list the built-in scenarios")
    p.set_defaults(func=cmd_scenarios)
    p = sub.add_parser("show", help="print a built-in scenario's TOML (a starting point for "
                       "your own: mpd-pin show case1 > my_scene.toml)")
    p.add_argument("name", help="built-in scenario name (mpd-pin scenarios lists them)")
    p.add_argument("--all", action="store_true",
                   help="add every section and each key left to its default, marked "
                        "'# default' (energy scenarios)")
    p.set_defaults(func=cmd_show)
    p = sub.add_parser("run", help="plan a scenario and write result.json, plots and replay.html",
                       epilog=_planners_help())
    p.add_argument("scenario", help="built-in scenario name or path to a .toml file")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's random seed")
    p.add_argument("--planner", choices=list(PLANNERS), default=None,
                   help="override [planner] algorithm of an energy scenario")
    p.add_argument("--cache", default=None,
                   help="roadmap .npz to reuse (or create; an interrupted build resumes)")
    p.add_argument("--evaluation", choices=("lazy", "eager"), default=None,
                   help="override [roadmap] evaluation: simulate edges as the search needs "
                        "them (lazy) or all before it (eager)")
    p.add_argument("--collision", choices=("lazy", "eager"), default=None,
                   help="override [roadmap] collision: check edges for collision as the "
                        "search needs them (lazy) or all before it (eager)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS|local[:N]",
                   help="where edge energies run: a Dask scheduler address (tcp://host:8786), "
                        "local[:N] (a LocalCluster of N processes) or threads (this process; "
                        "the default); overrides [compute] scheduler")
    p.add_argument("--execution", choices=("auto", "stop", "nonstop"), default=None,
                   help="override [motion] execution: the cheaper of the two (auto), rest at "
                        "every waypoint (stop) or one smooth motion (nonstop)")
    p.add_argument("--no-optimize", action="store_true",
                   help="return the refined motion without optimising it as a whole "
                        "([motion] optimize = false, docs/design.md §9g)")
    p.add_argument("--no-refine", action="store_true",
                   help="return the roadmap path as it is (no energy-aware shortcuts)")
    p.add_argument("--verify", action="store_true",
                   help="re-simulate the roadmap paths edge by edge with the reference "
                        "simulate_edge and record the agreement in result.json verification "
                        "([run] verify = true, docs/design.md §7c)")
    p.add_argument("--nodes", type=int, default=None, metavar="N",
                   help="override [roadmap] num_nodes: the roadmap's random samples (more "
                        "nodes: better paths, longer runs)")
    p.add_argument("--max-duration", default=None, metavar="S", dest="max_duration",
                   help="override [motion] max_duration: the longest the motion may take (s, "
                        "the cycle time); none within it: result.json with feasible false, "
                        "the fastest motion found, and exit status 3")
    p.add_argument("--no-replay", action="store_true",
                   help="skip the meshcat replay.html (meshcat is not imported)")
    p.add_argument("--no-plots", action="store_true",
                   help="skip the PNG figures (path.png, joint_angles.png, energy.png, "
                        "energy_duration.png; matplotlib is not imported)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress bars or status lines (stderr: errors only)")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("energy", help="price a path planned elsewhere (OMPL, MoveIt): its "
                       "energy stop-and-go or non-stop on a scenario's arm and motors",
                       description="Price the waypoints of PATHFILE on the arm, motors and "
                       "known obstacles of SCENARIO (an energy scenario). PATHFILE: .csv "
                       "(a header row naming the joints and optionally t (s), columns in any "
                       "order, other columns ignored; or no header and one column per joint "
                       "in joint order) or .json (trajectory_msgs/JointTrajectory: "
                       "joint_names, points[].positions, optionally "
                       "points[].time_from_start). Prints one line and writes a JSON file; "
                       "exit status 3 when the motion is infeasible.")
    p.add_argument("scenario", help="built-in scenario name or path to a .toml file")
    p.add_argument("pathfile", help="waypoints: .csv or .json (rad, or m for prismatic joints)")
    p.add_argument("--execution", choices=(*EXECUTIONS, "timed"), default=None,
                   help="timed: the file's own times (a CSV t column, JSON time_from_start; "
                        "the default when it has them); stop: rest at every waypoint "
                        "(roadmap-timed edges); nonstop: one spline through them, duration "
                        "chosen for least energy; auto: the cheaper feasible one (the "
                        "default without times)")
    p.add_argument("--out", default=None, metavar="FILE",
                   help="JSON file to write (default: <PATHFILE stem>_energy.json beside it)")
    p.add_argument("--optimize", action="store_true",
                   help="optimise the path as a whole at its priced duration (or "
                        "--max-duration): a locally energy-optimal, certified motion "
                        "(mpd_pin.optimize_motion, docs/design.md §9g)")
    p.add_argument("--max-duration", type=float, default=None, metavar="S",
                   help="longest the whole motion may take (s); default: the scenario's "
                        "max_duration if it has one, else no limit")
    p.set_defaults(func=cmd_energy)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mpd-pin`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    import numpy as np

    try:
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            return int(args.func(args))
    except NoPathError as exc:
        print(f"mpd-pin: no path: {exc}", file=sys.stderr)
        return 3
    except NoMotionWithinDuration as exc:  # a planning outcome; result.json says why
        print(f"mpd-pin: {' '.join(str(exc).split())}", file=sys.stderr)
        return 3
    except (ConfigError, ValueError, MpdPinError) as exc:
        msg = " ".join(str(exc).split())  # exactly one line
        print(f"mpd-pin: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mpd-pin: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # last resort: a bug or an exhausted resource, still one line
        msg = " ".join(str(exc).split()) or "(no message)"
        print(f"mpd-pin: internal error: {type(exc).__name__}: {msg}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
