"""Fixed and per-edge cost of one batch of edge simulations (issue 24 item 4).

One call of ``edge_outcomes`` (feed-forward tables by the batched RNEA, then RK4 through
``abaInParallel``) on K edges of T = 1 s at dt = 5 ms (200 steps), for

* the Panda with motors sized from its URDF (``sized_motors``: stiff currents, 24 V),
  kp = 20 V/rad, kd = 1 V·s/rad, feed-forward;
* paper 000's case 1: the planar 3-link arm, the paper's motor behind 9:1, kp = 40, kd = 4.

Prints the CPU time (``time.process_time``: all threads of this process, robust to other
load on a shared machine, unlike wall time) of one batch for K = 1, 4, 16, 128 (median of
``--reps`` batches after one warm-up batch of the same size), and the least-squares fit
cost ≈ fixed + per_edge · K. ``--json FILE`` saves the numbers; ``--before FILE`` prints
the ratio of this run to a saved one, e.g. to compare with an unchanged checkout:

    PYTHONPATH=/path/to/old/checkout python bench/rk4_batch.py --json before.json
    python bench/rk4_batch.py --before before.json

``--instructions`` also counts instructions with ``valgrind --tool=callgrind`` (repeatable
under load): for each K a fresh interpreter runs set-up and a warm-up batch uncounted
(``--instr-atstart=no``), then reads callgrind's counter (``callgrind_control -e``) before
and after 1 and 2 more batches; the difference of the two differences is one batch. It
takes minutes (instrumented code runs ~50x slower); ``--instr-sizes`` picks the K.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np

import mpd_pin as mp
from mpd_pin.dynamics.simulate import edge_outcomes

T_EDGE, DT = 1.0, 5e-3
SIZES = (1, 4, 16, 128)
ARMS = ("panda", "case1")


def setup(name: str, K: int, seed: int = 0):
    """(drive, Q0, Q1) of ``K`` random edges inside the joint limits."""
    if name == "panda":
        arm = mp.Arm.from_example_robot_data("panda")
        drive = mp.Drive(arm, mp.sized_motors(arm), kp=20.0, kd=1.0)
    elif name == "case1":
        drive = mp.Drive(mp.builtin_arm("planar_3link"), mp.PAPER_MOTOR.with_gear_ratio(9.0),
                         kp=40.0, kd=4.0)
    else:
        raise SystemExit(f"unknown arm {name!r}: one of {', '.join(ARMS)}")
    rng = np.random.default_rng(seed)
    lo, hi = drive.arm.lower_limits, drive.arm.upper_limits
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    Q0 = mid + half * rng.uniform(-0.6, 0.6, (K, drive.nq))
    Q1 = np.clip(Q0 + rng.normal(0.0, 0.3, Q0.shape), lo, hi)
    return drive, Q0, Q1


def batch_cpu_ms(drive, Q0, Q1, reps: int) -> list[float]:
    """CPU ms of each of ``reps`` batches (after one warm-up batch)."""
    edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
    out = []
    for _ in range(reps):
        t0 = time.process_time()
        edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
        out.append(1e3 * (time.process_time() - t0))
    return out


def fit(sizes, costs) -> tuple[float, float]:
    """Least-squares (fixed, per_edge) of cost ≈ fixed + per_edge · K."""
    A = np.column_stack([np.ones(len(sizes)), np.asarray(sizes, dtype=float)])
    (fixed, per_edge), *_ = np.linalg.lstsq(A, np.asarray(costs, dtype=float), rcond=None)
    return float(fixed), float(per_edge)


def _callgrind(*args: str) -> str:
    """Run ``callgrind_control ARGS <this process>`` (waits until callgrind has answered)."""
    proc = subprocess.run(["callgrind_control", *args, str(os.getpid())], capture_output=True,
                          text=True, check=True)
    return proc.stdout


def _instructions_so_far() -> int:
    """Instructions callgrind has counted in this process so far, all threads."""
    return sum(int(n.replace(",", "")) for n in
               re.findall(r"^\s*Th\s+\d+\s+([\d,]+)", _callgrind("-e", "Ir"), re.M))


def count_in_this_process(name: str, K: int) -> int:
    """Instructions of one batch, in a process run by callgrind with --instr-atstart=no:
    set-up and a warm-up batch uncounted, then readings c0, (1 batch) c1, (2 batches) c2;
    (c2 − c1) − (c1 − c0) is one batch, the cost of a reading cancels."""
    drive, Q0, Q1 = setup(name, K)
    edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
    _callgrind("-i", "on")
    c0 = _instructions_so_far()
    edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
    c1 = _instructions_so_far()
    edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
    edge_outcomes(drive, Q0, Q1, T_EDGE, DT)
    c2 = _instructions_so_far()
    _callgrind("-i", "off")
    return (c2 - c1) - (c1 - c0)


def count_instructions(name: str, K: int) -> int:
    """Instructions (callgrind) of one batch of ``K`` edges, in a fresh interpreter."""
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no",
           "--callgrind-out-file=/dev/null", sys.executable, __file__, "--count-only", name,
           str(K)]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    found = re.findall(r"^INSTRUCTIONS (\d+)$", proc.stdout, re.M)
    if proc.returncode != 0 or not found:
        raise RuntimeError(f"valgrind failed ({proc.returncode}): {proc.stderr[-800:]}")
    return int(found[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=7, help="timed batches per size (median)")
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)), help="edges per batch")
    ap.add_argument("--arms", default=",".join(ARMS))
    ap.add_argument("--json", help="save the numbers to this file")
    ap.add_argument("--before", help="numbers saved by an earlier run, to print ratios")
    ap.add_argument("--instructions", action="store_true",
                    help="also count instructions per batch with callgrind")
    ap.add_argument("--instr-sizes", default="1,16,128")
    ap.add_argument("--count-only", nargs=2, metavar=("ARM", "K"),
                    help=argparse.SUPPRESS)  # the process callgrind counts
    args = ap.parse_args()
    if args.count_only:
        print(f"INSTRUCTIONS {count_in_this_process(args.count_only[0], int(args.count_only[1]))}")
        return
    sizes = [int(x) for x in args.sizes.split(",")]
    before = json.loads(open(args.before).read()) if args.before else {}
    print(f"edge_outcomes, T = {T_EDGE} s, dt = {DT} s ({round(T_EDGE / DT)} RK4 steps), "
          f"threads = {os.cpu_count()}, mpd_pin from {os.path.dirname(mp.__file__)}")
    print(f"CPU ms per batch: median of {args.reps} (min in brackets)")
    saved: dict = {}
    for name in args.arms.split(","):
        rec: dict = {"sizes": sizes, "median_ms": [], "min_ms": []}
        for K in sizes:
            drive, Q0, Q1 = setup(name, K)
            ms = batch_cpu_ms(drive, Q0, Q1, args.reps)
            rec["median_ms"].append(float(np.median(ms)))
            rec["min_ms"].append(float(np.min(ms)))
        rec["fixed_ms"], rec["per_edge_ms"] = fit(sizes, rec["median_ms"])
        old = before.get(name)
        print(f"{name}:")
        for k, K in enumerate(sizes):
            line = f"  K = {K:4d}: {rec['median_ms'][k]:9.2f} ms  [{rec['min_ms'][k]:8.2f}]"
            if old and K in old["sizes"]:
                was = old["median_ms"][old["sizes"].index(K)]
                line += f"   before {was:9.2f} ms, after/before {rec['median_ms'][k] / was:5.2f}"
            print(line)
        line = f"  fit: fixed {rec['fixed_ms']:.2f} ms + {rec['per_edge_ms']:.3f} ms per edge"
        if old:
            line += (f"   (before {old['fixed_ms']:.2f} + {old['per_edge_ms']:.3f}; after/before "
                     f"fixed {rec['fixed_ms'] / old['fixed_ms']:.2f}, "
                     f"per edge {rec['per_edge_ms'] / old['per_edge_ms']:.2f})")
        print(line)
        if args.instructions:
            isizes = [int(x) for x in args.instr_sizes.split(",")]
            counts = [count_instructions(name, K) for K in isizes]
            rec["instr_sizes"], rec["instructions"] = isizes, counts
            rec["instr_fixed"], rec["instr_per_edge"] = fit(isizes, counts)
            print("  instructions per batch (callgrind): " + ", ".join(
                f"K = {K}: {c / 1e6:.1f} M" for K, c in zip(isizes, counts, strict=True)))
            line = (f"  fit: fixed {rec['instr_fixed'] / 1e6:.1f} M + "
                    f"{rec['instr_per_edge'] / 1e6:.2f} M per edge")
            if old and "instr_fixed" in old:
                line += (f"   (before {old['instr_fixed'] / 1e6:.1f} M + "
                         f"{old['instr_per_edge'] / 1e6:.2f} M; after/before fixed "
                         f"{rec['instr_fixed'] / old['instr_fixed']:.2f}, per edge "
                         f"{rec['instr_per_edge'] / old['instr_per_edge']:.2f})")
            print(line)
        saved[name] = rec
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(saved, fh, indent=1)


if __name__ == "__main__":
    main()
