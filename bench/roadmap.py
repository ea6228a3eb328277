"""Roadmap build phases (issue: world, collision and roadmap).

Prints the time of each phase — sampling, neighbours, edge checks, edge
energies — for a 1000-node, k = 10 roadmap of the 3-link arm with two
obstacles, and the share of the total spent in edge energies.

With ``--repeats N`` the roadmap is built N times and the fastest build's phases
are printed (the machine may be shared).

Usage: python bench/roadmap.py [--nodes 1000] [--k 10] [--repeats 1]
"""

from __future__ import annotations

import argparse
from functools import partial

import numpy as np

import mpd_pin as mp
from common import best_of
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost
from mpd_pin.planning.roadmap import RoadmapOptions, build_roadmap
from mpd_pin.world import Box, Cylinder, World


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=1000)
    ap.add_argument("--k", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=1, help="builds; the fastest is printed")
    args = ap.parse_args()
    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(9.0), kp=40.0, kd=4.0)
    world = World((Box.planar((0.0, 0.8), 0.2, 0.4, name="divider"),
                   Cylinder.planar((-0.6, -0.3), 0.12, name="post")))
    checker = CollisionChecker(arm, world)
    options = RoadmapOptions(num_nodes=args.nodes, k=args.k, seed=0, duration=1.0, dt=5e-3)
    start, goal = np.array([0.3, 0.6, 0.4]), np.array([2.6, -0.5, -0.4])
    cost = EnergyCost(drive, options.dt)
    build = partial(build_roadmap, cost, checker, start, goal, options, show_progress=False)
    total, rm = best_of(build, args.repeats)
    print(f"3-link arm, 2 obstacles: {rm.num_nodes} nodes, {rm.num_edges} directed edges, "
          f"k = {args.k}, T = 1 s, dt = 5 ms")
    for phase, sec in rm.timings.items():
        print(f"  {phase:<14} {sec:8.3f} s  ({100 * sec / total:5.1f} %)")
    print(f"  {'total':<14} {total:8.3f} s")
    print(f"share of edge energies: {100 * rm.timings['edge_energies'] / total:.1f} %  "
          f"({rm.num_edges / rm.timings['edge_energies']:.0f} edges/s)")


if __name__ == "__main__":
    main()
