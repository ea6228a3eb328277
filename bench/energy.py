"""Edge-energy throughput: one edge at a time vs batched (issue: foundation).

Prints, measured in this run, for the 3-link arm and the Panda at dt = 5 ms,
T = 1 s, with feed-forward:
* edges/s of ``simulate_edge`` (one edge at a time),
* edges/s of ``edge_energies`` with K = 1000,
* the ratio batched / one-at-a-time (target ≥ 30×),
* the ratio of batched throughput to the bound set by ``abaInParallel`` alone,
  1 / (4 · steps · seconds per configuration) (target ≥ 0.6).

Batched runs and the abaInParallel timing are each the best of three, measured
in the same run; one-at-a-time edges are timed once over ``--single`` edges.

Then, for the UR5 with motors sized from its URDF (stiff currents, L/R 0.1–0.4 ms), edges/s
of ``edge_energies`` at dt = 5 ms (exponential current update) against the servo preset at
dt = 1 ms with classical RK4 — what a datasheet motor needed before stiff currents were
handled (target ≥ 4×).

Usage: python bench/energy.py [--edges 1000] [--single 10]
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

import numpy as np
import pinocchio as pin

import mpd_pin as mp
from common import best_of

REPEATS = 3  # every throughput is the best of 3 timed runs (the machine may be shared)


def setups():
    panda_motor = mp.DCMotor(R=1.0, L=0.01, Kt=0.1, Ke=0.1, B=1e-4, J=1e-4, gear_ratio=50.0)
    yield "planar_3link", mp.Drive(
        mp.builtin_arm("planar_3link"), mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0
    )
    yield "panda", mp.Drive(mp.Arm.from_example_robot_data("panda"), panda_motor, kp=20.0, kd=1.0)


def aba_seconds_per_config(drive: mp.Drive, K: int, threads: int, repeats: int = 30) -> float:
    """Wall time of abaInParallel per configuration on an (nq, K) batch."""
    rng = np.random.default_rng(0)
    nq = drive.nq
    Q = np.asfortranarray(rng.uniform(-1, 1, (nq, K)))
    V = np.asfortranarray(rng.uniform(-1, 1, (nq, K)))
    T = np.asfortranarray(rng.uniform(-1, 1, (nq, K)))
    A = np.zeros((nq, K), order="F")
    pool = pin.ModelPool(drive.model, threads)
    pin.abaInParallel(threads, pool, Q, V, T, A)

    def calls() -> None:
        for _ in range(repeats):
            pin.abaInParallel(threads, pool, Q, V, T, A)

    return best_of(calls, REPEATS)[0] / (repeats * K)  # best of REPEATS means of ``repeats`` calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edges", type=int, default=1000)
    ap.add_argument("--single", type=int, default=10, help="edges timed one at a time")
    args = ap.parse_args()
    T, dt = 1.0, 5e-3
    steps = round(T / dt)
    threads = os.cpu_count() or 1
    print(f"T = {T} s, dt = {dt} s ({steps} RK4 steps), K = {args.edges}, threads = {threads}")
    for name, drive in setups():
        rng = np.random.default_rng(1)
        lo, hi = drive.arm.lower_limits, drive.arm.upper_limits
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        Q0 = mid + half * rng.uniform(-0.7, 0.7, (args.edges, drive.nq))
        Q1 = np.clip(Q0 + rng.normal(0, 0.4, Q0.shape), lo, hi)

        t0 = time.perf_counter()
        for k in range(args.single):
            mp.simulate_edge(drive, Q0[k], Q1[k], T, dt)
        single = args.single / (time.perf_counter() - t0)

        mp.edge_energies(drive, Q0[:8], Q1[:8], T, dt)  # warm-up (pool, imports)
        best, _ = best_of(partial(mp.edge_energies, drive, Q0, Q1, T, dt), REPEATS)
        batched = args.edges / best

        spc = aba_seconds_per_config(drive, min(args.edges, 1024), threads)
        bound = 1.0 / (4 * steps * spc)
        print(f"\n{name} (nq = {drive.nq})")
        print(f"  simulate_edge, one at a time : {single:10.1f} edges/s")
        print(f"  edge_energies, K = {args.edges:<5}    : {batched:10.1f} edges/s")
        print(f"  batched / one-at-a-time      : {batched / single:10.1f}x   (target >= 30x)")
        print(f"  abaInParallel alone          : {spc * 1e6:10.3f} us/configuration")
        print(f"  bound 1/(4*steps*s_per_conf) : {bound:10.1f} edges/s")
        print(f"  batched / bound              : {batched / bound:10.2f}    (target >= 0.6)")
    stiff_motors(args.edges)


def stiff_motors(K: int) -> None:
    """UR5: sized motors at dt = 5 ms vs the servo preset with RK4 at dt = 1 ms."""
    from mpd_pin.dynamics.current import current_model

    arm = mp.Arm.from_example_robot_data("ur5")
    rng = np.random.default_rng(2)
    lo, hi = arm.lower_limits / 2, arm.upper_limits / 2
    Q0 = rng.uniform(lo, hi, (K, arm.nq))
    Q1 = np.clip(Q0 + rng.normal(0, 0.4, Q0.shape), lo, hi)
    sized = mp.Drive(arm, mp.sized_motors(arm), kp=20.0, kd=1.0)
    servo = mp.Drive(arm, mp.SERVO_MOTOR, kp=20.0, kd=1.0)
    rates = {}
    for label, drive, dt in (("sized, dt = 5 ms", sized, 5e-3), ("servo, dt = 1 ms", servo, 1e-3)):
        model = current_model(drive, dt)["name"]
        best, _ = best_of(partial(mp.edge_energies, drive, Q0, Q1, 1.0, dt), REPEATS)
        rates[label] = K / best
        print(f"  UR5 {label} ({model:11s}): {rates[label]:10.1f} edges/s")
    ratio = rates["sized, dt = 5 ms"] / rates["servo, dt = 1 ms"]
    print(f"  5 ms / 1 ms                  : {ratio:10.2f}x   (target >= 4x)")


if __name__ == "__main__":
    main()
