"""Start-up of the answering commands (issue "scale", item 5): target < 0.5 s each; and with
``--run``, ``mpd-pin run panda --no-replay`` (issue 34, item 4): target <= 3 s wall.

Runs ``python -m mpd_pin <command>`` a few times each in fresh interpreters and prints the
best wall time (the machine may be shared: the minimum is the least disturbed run), with
``python -c "import numpy"`` as the floor every command pays.

``--run`` then runs ``mpd-pin run panda --quiet --no-replay`` (and with ``--no-plots``, when
the command has it) and prints, per run: wall and CPU seconds (user + system of the child:
on a busy machine the CPU time is the steadier number), the seconds its imports took (the
depth-0 ``-X importtime`` entries of one more run, summed: every module it imported,
lazily or not) and the phases of its result.json (wall and CPU).

    python bench/startup.py [--run] [--repeats N]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMANDS = (["scenarios"], ["show", "case1"], ["--help"], ["--version"])
TARGET = 0.5  # s
RUN_TARGET = 3.0  # s, mpd-pin run panda --no-replay
RUN = ["run", "panda", "--quiet", "--no-replay"]


def best_wall(argv: list[str], repeats: int = 5) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        best = min(best, time.perf_counter() - t0)
    return best


def timed_run(argv: list[str]) -> tuple[float, float, dict]:
    """(wall s, CPU s of the child, result.json) of ``python -m mpd_pin <argv> --out DIR``."""
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "mpd_pin", *argv, "--out", tmp],
                       capture_output=True, check=True)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        result = json.loads((Path(tmp) / "result.json").read_text())
    return wall, cpu, result


def import_seconds(argv: list[str]) -> float:
    """Seconds the imports of one ``python -m mpd_pin <argv>`` took (``-X importtime``:
    the cumulative times of its depth-0 imports, summed)."""
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "mpd_pin", *argv,
                               "--out", tmp], capture_output=True, text=True, check=True)
    total_us = 0
    for line in proc.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line.split(":", 1)[1].split("|")
        if not name.startswith("  "):  # depth 0: " name" (one space after the bar)
            total_us += int(cumulative)
    return total_us / 1e6


def has_flag(flag: str) -> bool:
    proc = subprocess.run([sys.executable, "-m", "mpd_pin", "run", "--help"],
                          capture_output=True, text=True, check=True)
    return flag in proc.stdout


def bench_run(repeats: int) -> None:
    variants = [RUN] + ([RUN + ["--no-plots"]] if has_flag("--no-plots") else [])
    for argv in variants:
        runs = [timed_run(argv) for _ in range(repeats)]
        wall, cpu, result = min(runs, key=lambda r: r[0])
        imports = import_seconds(argv)
        print(f"\nmpd-pin {' '.join(argv)}: best wall {wall:.2f} s (target {RUN_TARGET:g} s, "
              f"{wall / RUN_TARGET:.2f}x), CPU {cpu:.2f} s, imports {imports:.2f} s, "
              f"load average {os.getloadavg()[0]:.1f}")
        w, c = result["seconds_per_phase"], result.get("cpu_seconds_per_phase", {})
        for name, seconds in w.items():
            cpu_s = c.get("roadmap" if name == "roadmap_total" else name)
            cpu_text = f"{cpu_s:8.2f}" if cpu_s is not None else f"{'':8}"
            print(f"  {name:<24} {seconds:8.2f} s wall {cpu_text} s CPU")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", action="store_true", help="also time mpd-pin run panda")
    parser.add_argument("--repeats", type=int, default=2, help="runs of --run (best kept)")
    args = parser.parse_args()
    floor = best_wall([sys.executable, "-c", "import numpy"])
    print(f"{'command':<24} {'best s':>8} {'/ target':>9}")
    print(f"{'(python + numpy)':<24} {floor:8.3f} {floor / TARGET:9.2f}")
    for cmd in COMMANDS:
        t = best_wall([sys.executable, "-m", "mpd_pin", *cmd])
        print(f"{'mpd-pin ' + ' '.join(cmd):<24} {t:8.3f} {t / TARGET:9.2f}")
    if args.run:
        bench_run(args.repeats)


if __name__ == "__main__":
    main()
