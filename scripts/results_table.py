"""Run every built-in scenario with the mpd-pin command and print the README results tables.

Usage: python scripts/results_table.py [--out out/] [names...]
Each scenario runs as ``mpd-pin run NAME --out OUT/NAME --quiet``; the tables are
read back from the result.json files the command wrote.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from mpd_pin.scenario import builtin_scenarios, load_scenario_data


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*")
    ap.add_argument("--out", default="out")
    args = ap.parse_args()
    names = args.names or list(builtin_scenarios())
    energy_rows, dynamic_rows = [], []
    for name in names:
        out = Path(args.out) / name
        res = subprocess.run([sys.executable, "-m", "mpd_pin", "run", name, "--out", str(out),
                              "--quiet"], capture_output=True, text=True)
        if res.returncode != 0:
            print(f"{name}: FAILED: {res.stderr.strip()}", file=sys.stderr)
            continue
        r = json.loads((out / "result.json").read_text())
        kind = load_scenario_data(builtin_scenarios()[name]).get("kind", "energy")
        if kind == "energy":
            per_joint = " / ".join(f"{e:.4g}" for e in r["energy_per_joint"])
            t = r["seconds_per_phase"]
            extra = ""
            if "execution" in r:
                extra = f"{len(r['execution']['replans'])} replan(s)"
            if "hazard_replanning" in r:
                h = r["hazard_replanning"]
                extra = (f"first path {h['first_total_energy']:.4g} J too close "
                         f"({h['first_margin']:+.3f} m), re-planned ({h['final_margin']:+.3f} m)")
            energy_rows.append(
                f"| {name} | {r['arm']} | {per_joint} | {r['total_energy']:.4g} | "
                f"{r['path']['length_nodes']} | {r['roadmap']['num_nodes']} | "
                f"{t['roadmap_total']:.2f} | {1e3 * r['search']['initial_plan_seconds']:.2f} | "
                f"{t['total']:.2f} | {extra} |"
            )
        else:
            dynamic_rows.append(
                f"| {name} | {r['path_length_dstar']:.4f} | {r['path_length_pso']:.4f} | "
                f"{len(r['samples'])} | "
                f"{sum(1 for e in r['events'] if e.get('kind', e.get('type')) == 'stop')} | "
                f"{sum(1 for e in r['events'] if e.get('kind', e.get('type')) != 'stop')} |"
            )
    if energy_rows:
        print("| scenario | arm | E⁺ per joint (J) | total (J) | path nodes | roadmap nodes | "
              "roadmap (s) | search (ms) | total (s) | notes |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        print("\n".join(energy_rows))
    if dynamic_rows:
        print()
        print("| scenario | D* path (m) | D*+PSO path (m) | motion samples | stops | backward |")
        print("|---|---|---|---|---|---|")
        print("\n".join(dynamic_rows))


if __name__ == "__main__":
    main()
