"""What planning for a shared DC bus buys, on every built-in energy scenario
(docs/design.md §3i).

Paper 000 prices a motion as if every joint had its own supply that burns braking energy:
E⁺ = Σ_k ∫ max(V_k i_k, 0) dt (``per_joint``). One DC bus feeding every drive draws
P = Σ_k V_k i_k: ∫ max(P, 0) dt − η ∫ max(−P, 0) dt (``shared``, η = regeneration).

Each scenario is planned three times with ``mp.plan`` (the scenario's own settings, one
roadmap seed): supply ``per_joint``; ``shared`` η = 0; ``shared`` η = 0.6. The table gives

* the per-joint plan's returned motion priced under the three models (J): Σ E⁺, B⁺ and
  B⁺ − 0.6 B⁻ from the motion's bus energies [B⁺, B⁻];
* each bus plan's own ``total_energy`` (J, its returned motion on its bus) and its saving
  over the per-joint plan's motion priced on the same bus: 100 (1 − E_bus plan / E_re-priced)
  — what planning for the bus buys beyond re-pricing. A negative saving (the bus plan costs
  more on its own bus than the per-joint motion) points at a planning bug;
* whether the bus plans' MPD* Lite node paths (``roadmap_path``) differ from the per-joint
  plan's (``η=0`` / ``η=0.6``: yes/no), and whether their returned motions do (execution
  or waypoints ``plan.path``: the shortcut and the stop/non-stop choice are priced on the
  plan's supply too);
* † when the scenario's motor is the paper's Table 7 motor (result.json ``warnings``):
  its energies are those of an unrealistic motor.

Sanity line at the end: for every bus plan, ``verification.total_energy_simulate_edge``
(the roadmap path re-simulated) against ``roadmap_path.total_energy``; the worst relative
difference (target ≤ 1e-6). A scenario that raises prints the error in its row; the
tracebacks are printed after the table.

Run:  python bench/supply.py                          (several minutes on 2 shared cores)
      python bench/supply.py --quick                  (leaves out kinova, panda, ur5)
      python bench/supply.py --scenarios case1 ur5 --nodes ur5=60
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import traceback
from dataclasses import replace

import numpy as np

import mpd_pin as mp
from common import summary, target
from mpd_pin.app.scenario_files import builtin_scenarios

ETA = 0.6
SLOW = ("kinova", "panda", "ur5")
SUPPLIES = {
    "per_joint": mp.Supply("per_joint"),
    "shared": mp.Supply("shared", 0.0),
    "regen": mp.Supply("shared", ETA),
}
SANITY_TOL = 1e-6


def energy_scenarios() -> list[str]:
    """The built-in scenarios of kind ``energy`` (``mp.plan`` refuses dynamic2link)."""
    return [n for n in builtin_scenarios() if mp.load_scenario(n).kind == "energy"]


def bus_pricing(plan) -> tuple[float, float, float]:
    """The plan's returned motion under per_joint, shared η = 0 and shared η = ETA (J)."""
    d = plan.to_dict()
    by = d["energy_by_supply"]
    b_plus, b_minus = (float(b) for b in d["motion"]["bus_energy"])
    return float(by["per_joint"]), float(by["shared"]), b_plus - ETA * b_minus


def saving(e_plan: float, e_ref: float) -> float:
    """100 (e_ref − e_plan) / |e_ref| (%): positive when the plan draws less, also when a
    regenerating bus makes e_ref negative (pick_place at η = 0.6); NaN for e_ref = 0."""
    return 100.0 * (e_ref - e_plan) / abs(e_ref) if e_ref != 0.0 else math.nan


def sanity(d: dict) -> float | None:
    """|re-simulated − roadmap| / |roadmap| of the roadmap path's supply energy (None:
    not recorded, the per-joint supply)."""
    resim = d["verification"].get("total_energy_simulate_edge")
    if resim is None:
        return None
    ref = float(d["roadmap_path"]["total_energy"])
    return abs(float(resim) - ref) / max(abs(ref), 1e-300)


def _same_motion(a: tuple[str, np.ndarray], b: tuple[str, np.ndarray]) -> bool:
    """The same execution and the same waypoints (``plan.path``)."""
    return a[0] == b[0] and a[1].shape == b[1].shape and bool(np.array_equal(a[1], b[1]))


def run_one(name: str, nodes: int | None) -> dict:
    """The three plans of one scenario, as numbers for its row."""
    scn = mp.load_scenario(name)
    settings = {} if nodes is None else {"num_nodes": nodes}
    plans, secs = {}, {}
    for key, supply in SUPPLIES.items():
        t0 = time.perf_counter()
        plans[key] = mp.plan(replace(scn, supply=supply, verify=True), show_progress=False,
                             **settings)
        secs[key] = time.perf_counter() - t0
    d = {k: p.to_dict() for k, p in plans.items()}
    for key, supply in SUPPLIES.items():  # the plan was made for the supply asked for
        got = d[key]["supply"]
        if got["bus"] != supply.bus or float(got["regeneration"]) != supply.regeneration:
            raise AssertionError(f"{key} plan reports supply {got}, expected {supply}")
    nodes_of = {k: list(p.roadmap_path.nodes) for k, p in plans.items()}
    motion_of = {k: (d[k]["motion"]["execution"], np.asarray(p.path, float))
                 for k, p in plans.items()}
    return {
        "priced": bus_pricing(plans["per_joint"]),
        "shared": float(plans["shared"].total_energy),
        "regen": float(plans["regen"].total_energy),
        "changed": {k: nodes_of[k] != nodes_of["per_joint"] for k in ("shared", "regen")},
        "motion_changed": {k: not _same_motion(motion_of[k], motion_of["per_joint"])
                           for k in ("shared", "regen")},
        "paper_motor": bool(d["per_joint"]["warnings"]),
        "sanity": {k: sanity(d[k]) for k in ("shared", "regen")},
        "seconds": sum(secs.values()),
    }


def row(name: str, r: dict, nodes: int | None) -> str:
    label = name if nodes is None else f"{name} (n={nodes})"
    e_pj, e_sh, e_rg = r["priced"]
    s_sh, s_rg = saving(r["shared"], e_sh), saving(r["regen"], e_rg)
    yn = {True: "yes", False: "no"}
    changed = (" / ".join(yn[r["changed"][k]] for k in ("shared", "regen")) + "; motion "
               + " / ".join(yn[r["motion_changed"][k]] for k in ("shared", "regen")))
    note = "†" if r["paper_motor"] else ""
    return (f"| {label} | {e_pj:.6g} / {e_sh:.6g} / {e_rg:.6g} | {r['shared']:.6g} "
            f"({s_sh:+.2f} %) | {r['regen']:.6g} ({s_rg:+.2f} %) | {changed} | {note} |")


def parse_nodes(items: list[str]) -> dict[str, int]:
    out = {}
    for item in items:
        name, _, n = item.partition("=")
        if not n.isdigit():
            raise SystemExit(f"--nodes: expected NAME=N, got {item!r}")
        out[name] = int(n)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenarios", nargs="+", default=None,
                    help="built-in energy scenarios to plan (default: all)")
    ap.add_argument("--quick", action="store_true", help=f"leave out {', '.join(SLOW)}")
    ap.add_argument("--nodes", nargs="+", default=[], metavar="NAME=N",
                    help="roadmap samples for a scenario (default: the scenario's own)")
    args = ap.parse_args()
    every = energy_scenarios()
    names = every if args.scenarios is None else args.scenarios
    unknown = [n for n in names if n not in every]
    if unknown:
        raise SystemExit(f"not built-in energy scenarios: {', '.join(unknown)} "
                         f"(they are: {', '.join(every)})")
    if args.quick:
        names = [n for n in names if n not in SLOW]
    nodes = parse_nodes(args.nodes)

    t0 = time.perf_counter()
    lines, errors, worst = [], [], {}
    for name in names:
        print(f"planning {name} ...", file=sys.stderr, flush=True)
        try:
            r = run_one(name, nodes.get(name))
        except Exception as exc:  # noqa: BLE001 - reported in the row, the bench goes on
            errors.append((name, traceback.format_exc()))
            lines.append(f"| {name} | ERROR {type(exc).__name__}: {exc} | | | | |")
            continue
        print(f"   {name}: {r['seconds']:.0f} s for the three plans", file=sys.stderr,
              flush=True)
        lines.append(row(name, r, nodes.get(name)))
        for key, rel in r["sanity"].items():
            if rel is not None and rel >= worst.get(key, (-1.0, ""))[0]:
                worst[key] = (rel, name)
        for key, what in (("shared", "shared-bus"), ("regen", f"shared η={ETA:g}")):
            s = saving(r[key], r["priced"][1 if key == "shared" else 2])
            if not s >= -1e-9:
                target(f"{name}: {what} plan no dearer on its bus than the per-joint motion",
                       False, f"{s:+.3f} %")

    print(f"\n## Planning for the supply (η = {ETA:g} for the regenerating bus)\n")
    print(f"| scenario | per-joint plan: E per_joint / shared / shared η={ETA:g} (J) "
          f"| shared-bus plan (J) (saving) | shared η={ETA:g} plan (J) (saving) "
          f"| path changed? (η=0 / η={ETA:g}) | paper motor |")
    print("|---|---|---|---|---|---|")
    for line in lines:
        print(line)
    print("\nsaving: 100 (reference − bus plan) / |reference|, the reference being the "
          "per-joint plan's motion priced on the same bus; path changed: the MPD* Lite node "
          "path differs from the per-joint plan's; motion: the returned motion (execution or "
          "waypoints) does.")
    print("†: the paper's Table 7 motor (result.json warnings): energies of an unrealistic "
          "motor.")

    print("\n== sanity: verification.total_energy_simulate_edge vs roadmap_path.total_energy ==")
    for key, what in (("regen", f"shared η={ETA:g}"), ("shared", "shared η=0")):
        if key in worst:
            rel, name = worst[key]
            target(f"{what} plans: re-simulated roadmap path == roadmap energy (rel 1e-6)",
                   rel <= SANITY_TOL, f"worst {rel:.3g} on {name}")
        else:
            print(f"   {what}: no plan recorded total_energy_simulate_edge")
    for name, tb in errors:
        print(f"\n== error in {name} ==\n{tb}")
    summary(t0)


if __name__ == "__main__":
    main()
