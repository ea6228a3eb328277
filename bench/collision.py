"""Benchmark of mpd_pin.collision: configuration and edge checks per second, by backend.

For the 3-link planar arm with two obstacles and the Panda with two boxes:

* ``is_free`` in a Python loop (the checker's single-query path);
* a loop of ``pin.computeCollisions`` over the collision pairs, over a naive
  broad-phase manager and over a dynamic-AABB-tree broad-phase manager;
* ``pin.computeCollisionsInParallel`` with a ``GeometryPool`` and with a
  ``BroadPhaseManagerPool`` (1 thread and all threads) — the latter is
  ``is_free_batch``;
* Pinocchio's default requests (no EPA) for the cost of the exactness fix;
* edges per second of the discrete ``edges_free`` at 0.05 rad vs a loop of
  ``edge_free`` and vs checking every configuration of every edge in one flat batch;
* the certified (continuous) edge check, the default: edges per second, the
  fraction of edges each check accepts, queries per edge, certification on the
  convex hulls vs on the meshes (Panda), other resolutions;
* cost of revealing a hidden obstacle and of building a checker.

All backends are checked to agree. Numbers vary with the load of the machine;
each figure is the best of three runs.

Run:  PYTHONPATH=. python bench/collision.py
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import pinocchio as pin
from scipy.spatial import cKDTree

import mpd_pin as mp
from common import best_of
from mpd_pin.collision import CollisionChecker, bisection_order, edge_configurations
from mpd_pin.world import Box, Cylinder, World


def planar_scene() -> tuple[mp.Arm, World]:
    arm = mp.builtin_arm("planar_3link")
    world = World(
        [
            Cylinder.planar((0.55, 0.35), 0.12, name="disc"),
            Box.planar((-0.45, 0.45), 0.30, 0.20, angle=0.4, name="box"),
            Box.planar((0.0, -0.8), 0.4, 0.2, name="hidden_box", hidden=True),
        ]
    )
    return arm, world


def panda_scene() -> tuple[mp.Arm, World]:
    arm = mp.Arm.from_example_robot_data("panda")
    world = World(
        [
            Box((0.3, 0.3, 0.3), (0.5, 0.0, 0.3), name="box"),
            Box((0.2, 0.6, 0.1), (-0.4, 0.2, 0.6), name="shelf"),
            Box((0.2, 0.2, 0.2), (0.0, 0.5, 0.5), name="hidden_box", hidden=True),
        ]
    )
    return arm, world


def bench_configurations(name: str, arm: mp.Arm, world: World, K: int, threads: int) -> None:
    checker = CollisionChecker(arm, world, num_threads=threads)
    model, gm = checker.model, checker.geom_model
    rng = np.random.default_rng(0)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(K, arm.nq))
    QT = np.asfortranarray(Q.T)
    print(f"\n== {name}: {gm.ngeoms} geometries, {len(gm.collisionPairs)} pairs "
          f"({len(checker.self_pairs)} self), {K} random configurations, {threads} threads")

    rows: list[tuple[str, float, np.ndarray]] = []
    t, ref = best_of(lambda: np.array([checker.is_free(q) for q in Q]))
    rows.append((f"loop is_free (single_backend={checker.single_backend!r})", t, ref))
    print(f"   collision-free fraction {ref.mean():.3f}")

    data = model.createData()
    gd = checker.geom_data.copy()
    t, res = best_of(
        lambda: ~np.array([pin.computeCollisions(model, data, gm, gd, q, True) for q in Q])
    )
    rows.append(("loop computeCollisions (all pairs)", t, res))

    gd3 = checker.geom_data.copy()
    naive = pin.BroadPhaseManager_NaiveCollisionManager(model, gm, gd3)
    t, res = best_of(
        lambda: ~np.array([pin.computeCollisions(model, data, naive, q, True) for q in Q])
    )
    rows.append(("loop naive broad-phase manager", t, res))

    gd2 = checker.geom_data.copy()
    tree = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(model, gm, gd2)
    t, res = best_of(
        lambda: ~np.array([pin.computeCollisions(model, data, tree, q, True) for q in Q])
    )
    rows.append(("loop dynamic-AABB-tree manager", t, res))

    for nt in sorted({1, threads}):
        pool = pin.GeometryPool(model, gm, nt)
        pool.update(checker.geom_data)
        t, res = best_of(lambda pool=pool, nt=nt: ~np.asarray(
            pin.computeCollisionsInParallel(nt, pool, QT, True), dtype=bool))
        rows.append((f"GeometryPool parallel, {nt} thread(s)", t, res))
        bpool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(model, gm, nt)
        bpool.update(checker.geom_data)
        t, res = best_of(lambda bpool=bpool, nt=nt: ~np.asarray(
            pin.computeCollisionsInParallel(nt, bpool, QT, True), dtype=bool))
        rows.append((f"BroadPhaseManagerPool parallel, {nt} thread(s)", t, res))
    t, res = best_of(lambda: checker.is_free_batch(Q))
    rows.append(("is_free_batch (= broad-phase pool, all threads)", t, res))

    # Pinocchio's default requests: no EPA; faster but misses shallow penetrations.
    fast = checker.geom_data.copy()
    for k in range(len(gm.collisionPairs)):
        fast.collisionRequests[k].enable_contact = False
    bpool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(model, gm, threads)
    bpool.update(fast)
    t_fast, res_fast = best_of(lambda: ~np.asarray(
        pin.computeCollisionsInParallel(threads, bpool, QT, True), dtype=bool))

    base = rows[0][1]
    for label, t, res in rows:
        agree = "agrees" if np.array_equal(res, ref) else f"DISAGREES on {(res != ref).sum()}"
        print(f"   {label:50s} {K / t:10.0f} cfg/s  x{base / t:5.2f}  {agree}")
    print(f"   {'(no EPA: Pinocchio default requests, inexact)':50s} {K / t_fast:10.0f} cfg/s"
          f"  x{base / t_fast:5.2f}  differs on {(res_fast != ref).sum()}")

    # Revealing an obstacle, rebuilding.
    t_build, _ = best_of(lambda: CollisionChecker(arm, world, num_threads=threads))

    def reveal_cycle() -> None:
        world.reveal("hidden_box")
        checker.is_free(Q[0])
        world.reset()
        checker.is_free(Q[0])

    t_rev, _ = best_of(lambda: [reveal_cycle() for _ in range(50)])
    print(f"   build a checker: {t_build * 1e3:.2f} ms; reveal + resync: "
          f"{t_rev / 100 * 1e6:.0f} µs per change")


def bench_edges(name: str, arm: mp.Arm, world: World, K: int, threads: int,
                res: float = 0.05) -> None:
    checker = CollisionChecker(arm, world, num_threads=threads)
    rng = np.random.default_rng(1)
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, size=(K, arm.nq))
    Q1 = np.clip(Q0 + rng.uniform(-0.6, 0.6, size=Q0.shape), arm.lower_limits, arm.upper_limits)
    n_cfg = sum(len(edge_configurations(a, b, res)) for a, b in zip(Q0, Q1, strict=True))
    t_batch, ok = best_of(lambda: checker.edges_free(Q0, Q1, res, mode="discrete"))
    t_loop, ok_loop = best_of(lambda: np.array(
        [checker.edge_free(a, b, res, mode="discrete") for a, b in zip(Q0, Q1, strict=True)]))

    def flat() -> np.ndarray:
        parts = [edge_configurations(a, b, res) for a, b in zip(Q0, Q1, strict=True)]
        free = checker.is_free_batch(np.concatenate(parts))
        bounds = np.cumsum([0] + [len(p) for p in parts])
        return np.array([free[a:b].all() for a, b in zip(bounds[:-1], bounds[1:], strict=True)])

    t_flat, ok_flat = best_of(flat)
    assert np.array_equal(ok, ok_loop) and np.array_equal(ok, ok_flat)
    print(f"\n== {name}: {K} random edges (|Δq| ≤ 0.6 rad per joint), resolution {res} rad, "
          f"{n_cfg / K:.1f} configurations per edge")
    print("   discrete:")
    print(f"   edges_free (trajectory API, early exit, parallel) {K / t_batch:9.0f} edges/s"
          f"  accepts {ok.mean():.4f}")
    print(f"   loop of edge_free (early exit)                    {K / t_loop:9.0f} edges/s"
          f"  (x{t_loop / t_batch:.2f} slower)")
    print(f"   one flat is_free_batch of all configurations      {K / t_flat:9.0f} edges/s"
          f"  (x{t_flat / t_batch:.2f} slower)")
    order = bisection_order(8)
    print(f"   (check order for 9 configurations: {order.tolist()})")
    # Discrete checking misses thin overlaps between two checked configurations.
    fine = checker.edges_free(Q0[ok], Q1[ok], res / 10, mode="discrete")
    print(f"   accepted at {res} rad but colliding at {res / 10} rad: {(~fine).sum()} of "
          f"{ok.sum()} accepted edges")

    # Certified (continuous) check, the default.
    t_cert, cert = best_of(lambda: checker.edges_free(Q0, Q1, res))
    stats = checker.last_certify_stats
    n_loop = min(K, 300)
    t_cloop, cert_loop = best_of(lambda: np.array(
        [checker.edge_free(a, b, res) for a, b in zip(Q0[:n_loop], Q1[:n_loop], strict=True)]))
    assert np.array_equal(cert[:n_loop], cert_loop)
    print("   certified:")
    print(f"   edges_free (levels batched, parallel)             {K / t_cert:9.0f} edges/s"
          f"  accepts {cert.mean():.4f}  (x{t_cert / t_batch:.2f} the discrete time)")
    print(f"   loop of edge_free                                 {n_loop / t_cloop:9.0f} edges/s")
    print(f"   per edge: {stats['certify_queries'] / K:.1f} certification + "
          f"{stats['exact_queries'] / K:.1f} exact queries (at most), {stats['levels']} levels, "
          f"{stats['too_close']} too close to call")
    print(f"   accepted by discrete, rejected by certified: {(ok & ~cert).sum()}; "
          f"accepted by certified, rejected by discrete: {(cert & ~ok).sum()}")
    fine_c = checker.edges_free(Q0[cert], Q1[cert], res / 100, mode="discrete")
    print(f"   certified edges colliding at {res / 100} rad: {(~fine_c).sum()} of {cert.sum()}")
    if checker.certification_hulls:
        plain = CollisionChecker(arm, world, num_threads=threads, certify_on_hulls=False)
        t_mesh, cert_mesh = best_of(lambda: plain.edges_free(Q0, Q1, res))
        print(f"   certification on the meshes instead of their hulls: {K / t_mesh:.0f} edges/s "
              f"(x{t_mesh / t_cert:.2f} slower), {(cert != cert_mesh).sum()} edges differ")
    # Roadmap-like edges: k nearest neighbours among collision-free samples.
    free_q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(4 * K, arm.nq))
    free_q = free_q[checker.is_free_batch(free_q)][: max(K // 5, 20)]
    _, nbr = cKDTree(free_q).query(free_q, k=min(11, len(free_q)))
    pairs = np.unique(np.sort(np.stack([np.repeat(np.arange(len(free_q)), nbr.shape[1]),
                                        nbr.ravel()], axis=1), axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    A, B = free_q[pairs[:, 0]], free_q[pairs[:, 1]]
    t_rd, rd = best_of(lambda: checker.edges_free(A, B, res, mode="discrete"))
    t_rc, rc = best_of(lambda: checker.edges_free(A, B, res))
    print(f"   roadmap-like: {len(pairs)} edges between {len(free_q)} free samples (10 nearest, "
          f"mean max|Δq| {np.abs(B - A).max(axis=1).mean():.2f} rad): discrete "
          f"{len(pairs) / t_rd:.0f} edges/s accepts {rd.mean():.4f}; certified "
          f"{len(pairs) / t_rc:.0f} edges/s accepts {rc.mean():.4f} (x{t_rc / t_rd:.2f})")
    for r in (2 * res, res / 2):
        t_r, ok_r = best_of(lambda r=r: checker.edges_free(Q0, Q1, r))
        t_d, _ = best_of(lambda r=r: checker.edges_free(Q0, Q1, r, mode="discrete"))
        print(f"   resolution {r} rad: certified {K / t_r:.0f} edges/s "
              f"(accepts {ok_r.mean():.4f}), discrete {K / t_d:.0f} edges/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--quick", action="store_true", help="fewer samples")
    args = parser.parse_args()
    scale = 0.2 if args.quick else 1.0
    arm, world = planar_scene()
    bench_configurations("planar_3link + 2 obstacles", arm, world, int(20_000 * scale),
                         args.threads)
    bench_edges("planar_3link + 2 obstacles", arm, world, int(4000 * scale), args.threads)
    arm, world = panda_scene()
    bench_configurations("panda + 2 boxes", arm, world, int(4000 * scale), args.threads)
    bench_edges("panda + 2 boxes", arm, world, int(500 * scale), args.threads)


if __name__ == "__main__":
    main()
