"""Edge energies in-process vs on a Dask LocalCluster (issue 13; docs/design.md §4h).

Costs the directed edges of a roadmap (planar 3-link by default, or ``--arm panda``)
once in this process (all cores, pinocchio threads) and on a ``LocalCluster`` of
``--workers`` processes × 1 thread, for a sweep of chunk sizes; prints edges/s, the
ratio to in-process, checks that every energy is bit-identical, and estimates the
per-chunk overhead (the integrator's fixed cost per batch, and Dask's round trip of a
1-edge chunk); then times single small
batches (``--small``: the size of a lazy evaluation round) both ways.

Usage: python bench/cluster.py [--arm planar_3link|panda] [--edges 4000] [--workers 2]
       [--chunks 32,64,128,256,512,1024] [--repeats 2] [--small 8,32,128]
"""

from __future__ import annotations

import argparse
import logging
import math

import numpy as np

import mpd_pin as mp
from common import best_of
from mpd_pin.dynamics import EnergyCost


def edges(arm, count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` random edges between near configurations inside the joint limits (rad)."""
    rng = np.random.default_rng(seed)
    lo, hi = arm.lower_limits, arm.upper_limits
    lo = np.where(np.isfinite(lo), lo, -math.pi)
    hi = np.where(np.isfinite(hi), hi, math.pi)
    Q0 = rng.uniform(lo, hi, (count, arm.nq))
    Q1 = np.clip(Q0 + rng.uniform(-0.4, 0.4, Q0.shape), lo, hi)
    return Q0, Q1


def overhead(drive, dt, Q0, Q1, durations, client, repeats: int) -> None:
    """Per-chunk overhead: the integrator's fixed cost per batch (1 thread: 1 edge vs 256
    edges) and Dask's round trip (a 1-edge chunk on a worker vs in this process)."""
    from mpd_pin.dynamics import edge_outcomes

    def local(k: int):
        return best_of(lambda: edge_outcomes(drive, Q0[:k], Q1[:k], durations[:k], dt,
                                             threads=1), repeats)[0]

    t1, t256 = local(1), local(256)
    per_edge = (t256 - t1) / 255
    cost = EnergyCost(drive, dt, executor=client, chunk_size=1)
    t1_cl = best_of(lambda: cost(Q0[:1], Q1[:1], durations[:1]), repeats)[0]
    print(f"per chunk: integrator batch {1e3 * (t1 - per_edge):.1f} ms fixed + "
          f"{1e3 * per_edge:.2f} ms per edge (1 thread); Dask round trip "
          f"{1e3 * (t1_cl - t1):.1f} ms (1-edge chunk {1e3 * t1_cl:.1f} ms on a worker, "
          f"{1e3 * t1:.1f} ms here)")


def small_batches(drive, dt, Q0, Q1, durations, client, args) -> None:
    """Lazy evaluation's per-round batches (tens of edges): one batch in this process vs
    split over the workers (``chunk_size`` = ⌈B / workers⌉)."""
    for B in [int(b) for b in args.small.split(",")]:
        rows = slice(0, B)
        t_in, ref = best_of(lambda rows=rows: EnergyCost(drive, dt)(Q0[rows], Q1[rows],
                                                                     durations[rows]),
                            args.repeats + 1)
        cost = EnergyCost(drive, dt, executor=client, chunk_size=-(-B // args.workers))
        t_cl, got = best_of(lambda rows=rows, cost=cost: cost(Q0[rows], Q1[rows],
                                                               durations[rows]),
                            args.repeats + 1)
        print(f"batch of {B:4d} edges: in-process {t_in * 1e3:7.1f} ms, LocalCluster "
              f"{t_cl * 1e3:7.1f} ms ({t_in / t_cl:.2f}x), bit-identical: "
              f"{np.array_equal(ref, got)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arm", default="planar_3link", choices=["planar_3link", "panda"])
    ap.add_argument("--edges", type=int, default=4000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--chunks", default="32,64,128,256,512,1024")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--small", default="8,32,128",
                    help="batch sizes of lazy rounds to time (one batch each)")
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    if args.arm == "panda":
        arm = mp.Arm.from_example_robot_data("panda")
        drive = mp.Drive(arm, mp.sized_motors(arm), kp=40.0, kd=4.0)
    else:
        arm = mp.builtin_arm("planar_3link")
        drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(9.0), kp=40.0, kd=4.0)
    dt, T = 5e-3, 1.0
    Q0, Q1 = edges(arm, args.edges)
    durations = np.full(args.edges, T)
    E = args.edges
    sizes = [int(c) for c in args.chunks.split(",")]
    print(f"{args.arm}: {E} edges of {T} s at dt {dt} s, {args.repeats} repeats (best)")

    t_in, ref = best_of(lambda: EnergyCost(drive, dt)(Q0, Q1, durations), args.repeats)
    print(f"in-process (threads, chunk 1024): {E / t_in:8.0f} edges/s  ({t_in:.2f} s)")
    t_small, _ = best_of(lambda: EnergyCost(drive, dt, chunk_size=256)(Q0, Q1, durations),
                         args.repeats)
    print(f"in-process (threads, chunk 256):  {E / t_small:8.0f} edges/s  ({t_small:.2f} s)")

    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                           host="127.0.0.1", dashboard_address=":0",
                           silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        EnergyCost(drive, dt, executor=client, chunk_size=8)(Q0[:16], Q1[:16], durations[:16])
        times = []
        for c in sizes:
            cost = EnergyCost(drive, dt, executor=client, chunk_size=c)
            t, got = best_of(lambda cost=cost: cost(Q0, Q1, durations), args.repeats)
            same = np.array_equal(got, ref)
            times.append(t)
            print(f"LocalCluster {args.workers}x1, chunk {c:5d}: {E / t:8.0f} edges/s  "
                  f"({t:.2f} s, {E / t / (E / t_in):.2f}x in-process, "
                  f"{math.ceil(E / c)} chunks, bit-identical: {same})")
            if not same:
                raise SystemExit("cluster energies differ from in-process")
        overhead(drive, dt, Q0, Q1, durations, client, args.repeats + 2)
        small_batches(drive, dt, Q0, Q1, durations, client, args)
    finally:
        client.close()
        cluster.close()


if __name__ == "__main__":
    main()
