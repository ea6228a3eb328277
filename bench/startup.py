"""Start-up of the answering commands (issue "scale", item 5): target < 0.5 s each.

Runs ``python -m mpd_pin <command>`` a few times each in fresh interpreters and prints the
best wall time (the machine may be shared: the minimum is the least disturbed run), with
``python -c "import numpy"`` as the floor every command pays.

    python bench/startup.py
"""

from __future__ import annotations

import subprocess
import sys
import time

COMMANDS = (["scenarios"], ["show", "case1"], ["--help"], ["--version"])
TARGET = 0.5  # s


def best_wall(argv: list[str], repeats: int = 5) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    floor = best_wall([sys.executable, "-c", "import numpy"])
    print(f"{'command':<24} {'best s':>8} {'/ target':>9}")
    print(f"{'(python + numpy)':<24} {floor:8.3f} {floor / TARGET:9.2f}")
    for cmd in COMMANDS:
        t = best_wall([sys.executable, "-m", "mpd_pin", *cmd])
        print(f"{'mpd-pin ' + ' '.join(cmd):<24} {t:8.3f} {t / TARGET:9.2f}")


if __name__ == "__main__":
    main()
