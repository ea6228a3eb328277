"""Run every built-in scenario with the mpd-pin command and print the results tables of
docs/guide.md ("Results of the built-in scenarios").

Usage: python scripts/results_table.py [--out out/] [names...]

Each scenario runs as ``mpd-pin run NAME --out OUT/NAME --quiet``, one after the
other; the tables are read back from the result.json files the command wrote.

Paper-000 scenarios (the counterpart of paper 000's Tables 8–11): E⁺ per joint
and in total (J), path length in nodes and in rad, the E⁺ of the shortest joint-space
path planned the same way and the percentage the energy-optimal path saves against
it (``comparison`` of result.json, docs/design.md §7c), roadmap size, and CPU seconds as the
command measured them (``cpu_seconds_per_phase``: ``time.process_time`` of the
mpd-pin process, all its threads) for the roadmap, the search (with hazard
re-planning and sensing/repair) and the whole run, plus the run's wall-clock
seconds. Paper-002 scenarios: path lengths, motion samples, stop and backward
events, the command's wall-clock total and the CPU seconds of the mpd-pin
process measured here (``resource.getrusage(RUSAGE_CHILDREN)``, imports
included). The last line names the machine.

Each paper-000 case (case1–case4, Table 7 motor behind 9:1) is also run with the
``sized`` motors (docs/design.md §3g) — the same scenario with its ``[motor]`` table
replaced by ``preset = "sized"`` (written to ``OUT/NAME_sized.toml``) — and printed as
the row ``NAME (sized)`` beside it; ``--no-sized`` skips these runs.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import subprocess
import sys
from pathlib import Path

from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data


def _child_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _margin(m: float | None) -> str:
    """A hazard margin (m); ``null`` in result.json is +∞ (no hazard to keep clear of)."""
    return "unbounded" if m is None else f"{m:+.3f} m"


def energy_row(name: str, r: dict) -> str:
    per_joint = " / ".join(f"{e:.4g}" for e in r["energy_per_joint"])
    cpu, wall = r["cpu_seconds_per_phase"], r["seconds_per_phase"]
    size = f"{r['roadmap']['num_nodes']} / {r['roadmap']['num_edges']}"
    cmp = r["comparison"]
    short = cmp["shortest_path"]
    saved = cmp["energy_saved_percent"]
    notes = []
    if "execution" in r:
        notes.append(f"{len(r['execution']['replans'])} replan(s)")
        b = cmp["before_obstacle"]
        notes.append(
            f"executed motions compared; plans before the obstacle: "
            f"{b['optimal']['total_energy']:.4g} vs {b['shortest_path']['total_energy']:.4g} J, "
            f"{b['energy_saved_percent']:.1f} % saved"
        )
    if "hazard_replanning" in r:
        h = r["hazard_replanning"]
        notes.append(
            f"first path {h['first_total_energy']:.4g} J too close ({_margin(h['first_margin'])}),"
            f" re-planned ({_margin(h['final_margin'])})"
            if h["first_path"] != h["final_path"]
            else f"clearances kept ({_margin(h['final_margin'])})"
        )
    return (
        f"| {name} | {r['arm']} | {per_joint} | {r['total_energy']:.4g} | "
        f"{r['path']['length_nodes']} | {r['path']['length_rad']:.3f} | "
        f"{short['total_energy']:.4g} | {short['length_nodes']} | {short['length_rad']:.3f} | "
        f"{'n/a' if saved is None else f'{saved:.1f}'} | {size} | "
        f"{cpu['roadmap']:.2f} | {1e3 * cpu['search']:.1f} | {cpu['total']:.2f} | "
        f"{wall['total']:.2f} | {'; '.join(notes)} |"
    )


def dynamic_row(name: str, r: dict, process_cpu: float) -> str:
    counts = r.get("event_counts") or {}
    stops = counts.get("stop", sum(1 for e in r["events"] if e.get("type") == "stop"))
    backward = counts.get("backward", sum(1 for e in r["events"] if e.get("type") == "backward"))
    return (
        f"| {name} | {r['path_length_dstar']:.4f} | {r['path_length_pso']:.4f} | "
        f"{len(r['samples'])} | {stops} | {backward} | {r['timings']['total']:.2f} | "
        f"{process_cpu:.2f} |"
    )


#: Paper-000 cases also run with the sized motors.
PAPER_CASES = ("case1", "case2", "case3", "case4")


def sized_variant(name: str, out_dir: Path) -> Path:
    """``OUT/NAME_sized.toml``: the built-in scenario ``name`` with its ``[motor]`` table
    replaced by ``preset = "sized"`` (everything else, comments included, as it is)."""
    text = builtin_scenarios()[name].read_text(encoding="utf-8")
    motor = re.compile(r"^\[motor\][^\n]*\n(?:(?!\[).*\n)*", re.M)
    if not motor.search(text):
        raise SystemExit(f"{name}: no [motor] table to replace")
    text = motor.sub('[motor]            # sized from the URDF limits (docs/design.md §3g)\n'
                     'preset = "sized"\n\n', text, count=1)
    text = re.sub(r'^name = "([^"]*)"', r'name = "\1_sized"', text, count=1, flags=re.M)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}_sized.toml"
    path.write_text(text, encoding="utf-8")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*")
    ap.add_argument("--out", default="out")
    ap.add_argument("--no-sized", action="store_true",
                    help="skip the runs of case1-4 with the sized motors")
    args = ap.parse_args()
    names = args.names or list(builtin_scenarios())
    runs = []  # (row label, scenario argument, output folder, kind)
    for name in names:
        kind = load_scenario_data(builtin_scenarios()[name]).get("kind", "energy")
        runs.append((name, name, Path(args.out) / name, kind))
        if name in PAPER_CASES and not args.no_sized:
            variant = sized_variant(name, Path(args.out))
            runs.append((f"{name} (sized)", str(variant), Path(args.out) / f"{name}_sized", kind))
    energy_rows, dynamic_rows = [], []
    failed = 0
    for label, scenario, out, kind in runs:
        cpu0 = _child_cpu()
        res = subprocess.run([sys.executable, "-m", "mpd_pin", "run", scenario, "--out",
                              str(out), "--quiet"], capture_output=True, text=True)
        process_cpu = _child_cpu() - cpu0
        if res.returncode != 0:
            print(f"{label}: FAILED: {res.stderr.strip()}", file=sys.stderr)
            failed += 1
            continue
        r = json.loads((out / "result.json").read_text())
        if kind == "energy":
            energy_rows.append(energy_row(label, r))
        else:
            dynamic_rows.append(dynamic_row(label, r, process_cpu))
    if energy_rows:
        print("| scenario | arm | E⁺ per joint (J) | total (J) | path nodes | path (rad) | "
              "shortest path E⁺ (J) | shortest nodes | shortest (rad) | saved (%) | "
              "roadmap nodes / edges | CPU roadmap (s) | CPU search (ms) | CPU total (s) | "
              "wall total (s) | notes |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        print("\n".join(energy_rows))
    if dynamic_rows:
        print()
        print("| scenario | D* path (m) | D*+PSO path (m) | motion samples | stops | backward | "
              "wall total (s) | CPU process (s) |")
        print("|---|---|---|---|---|---|---|---|")
        print("\n".join(dynamic_rows))
    print()
    print(f"Measured on {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, {platform.system()} {platform.release()}.")
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
