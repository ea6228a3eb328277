"""Plan from Python with the documented top-level names only (README "Plan from Python").

Run it in any folder: ``python python_api.py``. It

1. loads the built-in ``quickstart`` scenario, plans it, and checks the energy against
   ``mpd-pin run quickstart`` (the same computation; relative 1e-9) and the saved
   result.json against the command's;
2. builds a Panda world in Python and plans two legs on one ``EnergyPlanner``: the
   second reuses the first's roadmap, collision checks and simulated energies;
3. prices the roadmap path of a plan with ``trajectory_energy(..., execution="stop")``,
   which equals its roadmap energy (relative 1e-6).

Energies are E⁺ in joules, angles in radians, times in seconds.
"""

import json
import subprocess
import sys
from pathlib import Path

import mpd_pin as mp


def _without_times(doc):
    """result.json without the measured times (keys naming seconds differ between runs)."""
    if isinstance(doc, dict):
        return {k: _without_times(v) for k, v in doc.items() if "seconds" not in k}
    if isinstance(doc, list):
        return [_without_times(v) for v in doc]
    return doc


# 1. A built-in scenario, planned as `mpd-pin run` plans it.
scenario = mp.load_scenario("quickstart")
plan = mp.plan(scenario, show_progress=False)
print(plan)
saved = plan.save("python_out", replay=False)
cli = subprocess.run([sys.executable, "-m", "mpd_pin", "run", "quickstart", "--out", "cli_out",
                      "--no-replay", "--quiet"], capture_output=True, text=True, check=True)
doc = json.loads(Path("cli_out/result.json").read_text())
assert abs(plan.total_energy - doc["total_energy"]) <= 1e-9 * doc["total_energy"], (
    plan.total_energy, doc["total_energy"])
assert _without_times(saved) == _without_times(doc), "result.json differs from the CLI's"
assert plan.to_dict() == saved

# 2. A Panda among a table and a wall, two legs on one planner.
arm = mp.Arm.from_example_robot_data("panda")
drive = mp.Drive(arm, mp.sized_motors(arm), kp=20.0, kd=1.0)
world = mp.World([
    mp.Box(size=(0.8, 1.2, 0.04), position=(0.55, 0.0, -0.03), name="table"),
    mp.Box(size=(0.08, 0.4, 0.5), position=(0.5, 0.0, 0.25), name="wall"),
])
options = mp.RoadmapOptions(num_nodes=150, k=10, seed=7, resolution=0.05)
planner = mp.EnergyPlanner(drive, world, roadmap=options, show_progress=False)
A = [0.9, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785]
B = [-0.9, 0.3, 0.0, -2.0, 0.0, 2.3, 0.785]
C = [0.0, -0.5, 0.0, -2.6, 0.0, 2.0, 0.785]
first, second = planner.plan_legs([A, B, C])
for name, leg in (("A -> B", first), ("B -> C", second)):
    d = leg.to_dict()
    print(f"{name}: {leg.total_energy:.4g} J in {leg.motion.duration:.3g} s; roadmap "
          f"{d['roadmap']['num_nodes']} nodes, {d['cpu_seconds_per_phase']['roadmap']:.3f} "
          f"CPU-s; query {leg.seconds:.2f} s; energies simulated "
          f"{d['roadmap']['lazy']['simulated']}, reused {d['roadmap']['lazy']['reused']}")
one, two = first.to_dict(), second.to_dict()
assert two["roadmap"]["num_nodes"] == one["roadmap"]["num_nodes"] + 1  # C only: B is a node
assert two["roadmap"]["lazy"]["reused"] >= one["roadmap"]["lazy"]["simulated"]
# (the second leg's roadmap phase is cheaper too, but times are for bench/, not for asserts)

# 3. The roadmap path priced stop-and-go equals its roadmap energy.
rp = second.roadmap_path
te = mp.trajectory_energy(drive, rp.configurations, execution="stop", options=options)
assert abs(te.total_energy - rp.total_energy) <= 1e-6 * rp.total_energy, (
    te.total_energy, rp.total_energy)
print(f"roadmap path B -> C: {rp.total_energy:.6g} J; trajectory_energy stop: "
      f"{te.total_energy:.6g} J")
print("ok")
