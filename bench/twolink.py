"""Benchmark of mpd_pin.twolink: how to check moving obstacles, and where a run's time goes.

1. One FCS map (all reachable (cell, branch) configurations of the 81×81 grid
   of env2, ~10,000 configurations, four discs) per motion sample, three ways:

   * ``rebuild``: a new World + ``CollisionChecker`` per sample, then
     ``is_free_batch`` (what :class:`mpd_pin.twolink.SampledCollisionChecker` does);
   * ``move``: ONE ``pin.GeometryModel`` (arm cylinders + obstacle cylinders with
     the same security margin and EPA settings), the obstacle placements set in
     the model per sample, then a Python loop of ``pin.computeCollisions``;
   * ``reuse``: the cached checker of a sample used again (lower bound: no build).

   All three agree but for configurations at the margin (|clearance − margin| < 1e-9 m).
2. env1 and env2 end to end (``plan_dynamic``): set-up, D* execution, PSO, and
   the number of checkers built.

Numbers vary with the machine's load; each figure is the best of three. On the
shared 2-core machine (0.025 m grids, velocity-limited joint steps, 4 sub-steps):
FCS map 32 ms (rebuild) / 38 ms (move) / 31 ms (reuse) per sample, a checker
0.7 ms; env1 2.9 s (D* 1.9, PSO 1.0; 74 samples), env2 6.5 s (D* 5.5, PSO 1.0;
102 samples), most of D* being the FCS maps and D* Lite's edge updates.

Run:  PYTHONPATH=. python bench/twolink.py
"""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
import pinocchio as pin

from common import best_of
from mpd_pin.collision import GJK_TOLERANCE, CollisionChecker
from mpd_pin.twolink import FreeCartesianSpace, SampledCollisionChecker, TwoLinkKinematics
from mpd_pin.twolink.planner import plan_dynamic
from mpd_pin.twolink.scenario import parse_dynamic_scenario
from mpd_pin.world import geometry_object


def load(name):
    path = resources.files("mpd_pin") / "scenarios" / f"{name}.toml"
    return parse_dynamic_scenario(tomllib.loads(path.read_text()))


class MovingGeometry:
    """One GeometryModel whose obstacle placements are moved in place (the alternative)."""

    def __init__(self, arm, scene, margin):
        self.model, self.data = arm.model, arm.model.createData()
        gm = pin.GeometryModel()
        for go in arm.collision_model.geometryObjects:
            gm.addGeometryObject(pin.GeometryObject(go))
        n_arm = arm.collision_model.ngeoms
        world = scene.world_at(0.0)
        self.obs_ids = [gm.addGeometryObject(geometry_object(ob, ob.name)) for ob in world]
        for a in range(n_arm):
            for o in self.obs_ids:
                gm.addCollisionPair(pin.CollisionPair(a, o))
        self.gm, self.gd = gm, gm.createData()
        for req in self.gd.collisionRequests:
            req.security_margin = margin
            req.distance_upper_bound = margin + 1e-9  # as CollisionChecker
            req.enable_contact = True
            req.gjk_tolerance = GJK_TOLERANCE
        self.scene = scene
        self.rot = world.obstacles[0].placement.rotation if world.obstacles else np.eye(3)

    def set_time(self, t):
        c = self.scene.centers(t)
        for gid, (x, z) in zip(self.obs_ids, c, strict=True):
            self.gm.geometryObjects[gid].placement = pin.SE3(self.rot, np.array([x, 0.0, z]))

    def free(self, Q):
        out = np.empty(len(Q), dtype=bool)
        for i, q in enumerate(Q):
            out[i] = not pin.computeCollisions(self.model, self.data, self.gm, self.gd, q, True)
        return out


def bench_fcs(name="env2", samples=range(0, 40, 4)):
    scn = load(name)
    prob = scn.problem
    kin = TwoLinkKinematics(prob.arm)
    fcs = FreeCartesianSpace(kin, prob.grid,
                             SampledCollisionChecker(prob.arm, prob.scene, margin=prob.margin))
    Q = fcs.q_states[fcs.reachable]
    ks = list(samples)
    print(f"1. FCS of {name}: {len(Q)} configurations per sample, {len(prob.scene)} discs, "
          f"{len(ks)} samples")

    def rebuild():
        out = []
        for k in ks:
            chk = CollisionChecker(prob.arm, prob.scene.world_at_sample(k), margin=prob.margin,
                                   num_threads=1)
            out.append(chk.is_free_batch(Q))
        return out

    mg = MovingGeometry(prob.arm, prob.scene, prob.margin)

    def move():
        out = []
        for k in ks:
            mg.set_time(k * prob.ts)
            out.append(mg.free(Q))
        return out

    cached = {k: CollisionChecker(prob.arm, prob.scene.world_at_sample(k), margin=prob.margin,
                                  num_threads=1) for k in ks}

    def reuse():
        return [cached[k].is_free_batch(Q) for k in ks]

    t_build, _ = best_of(lambda: [CollisionChecker(prob.arm, prob.scene.world_at_sample(k),
                                                   margin=prob.margin, num_threads=1)
                                  for k in ks])
    results = {}
    for label, f in (("rebuild", rebuild), ("move", move), ("reuse", reuse)):
        t, res = best_of(f)
        results[label] = res
        print(f"   {label:<8} {1e3 * t / len(ks):6.2f} ms per sample "
              f"({len(Q) * len(ks) / t:9.0f} configurations/s)")
    print(f"   building one checker: {1e3 * t_build / len(ks):.2f} ms")
    for label in ("move", "reuse"):
        diff, band = 0, 0.0
        for k, a, b in zip(ks, results["rebuild"], results[label], strict=True):
            for i in np.flatnonzero(a != b):
                diff += 1
                band = max(band, abs(cached[k].clearance(Q[i]) - prob.margin))
        print(f"   rebuild vs {label}: {diff} of {len(Q) * len(ks)} differ"
              + (f", all within {band:.1e} m of the margin" if diff else ""))


def bench_runs():
    print("2. plan_dynamic end to end (s; best of 3)")
    for name in ("env1", "env2"):
        scn = load(name)
        t, res = best_of(lambda scn=scn: plan_dynamic(scn.problem, seed=scn.seed))
        d = res.dstar  # (timings below are those of the last of the three runs)
        kinds = [e["type"] for e in d.events]
        print(f"   {name}: total {t:.2f}  " + "  ".join(f"{k} {v:.2f}"
                                                      for k, v in res.timings.items())
              + f"  | {d.num_samples} samples, stop {kinds.count('stop')}, backward "
              f"{kinds.count('backward')}, D* {res.path_length_dstar:.4f} m -> PSO "
              f"{res.path_length_pso:.4f} m, {res.checker.builds} checkers, "
              f"{res.smoother.evaluated} distinct PSO paths, {d.edge_updates} D* edge updates")


if __name__ == "__main__":
    bench_fcs()
    bench_runs()
