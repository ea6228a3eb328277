"""Helpers shared by the bench scripts: best-of timing, paper 000's Table 6, random graphs.

The scripts are run as ``python bench/<name>.py``, so this directory is on
``sys.path`` and they import this module as ``common``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
from scipy.spatial import cKDTree

T = TypeVar("T")

#: Paper 000, Table 6 (MATLAB seconds), shared with notebooks/04_table6_comparison.ipynb.
TABLE6_FILE = Path(__file__).resolve().parent.parent / "notebooks" / "paper000_table6.json"


#: The "target MET/MISSED" lines a bench printed, for its summary at the end.
TARGETS: list[str] = []


def target(what: str, ok: bool, detail: str) -> None:
    """Print (indented) and remember one target line: MET or MISSED, what, the numbers."""
    line = f"target {'MET' if ok else 'MISSED'}: {what} ({detail})"
    TARGETS.append(line)
    print("   " + line)


def summary(t0: float) -> None:
    """Print every target line again and the bench's total seconds since ``t0``
    (``time.perf_counter``)."""
    print("\n== Summary ==")
    for line in TARGETS:
        print("   " + line)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")


def best_of(fn: Callable[[], T], repeats: int = 3) -> tuple[float, T]:
    """Smallest wall time (s) of ``repeats`` calls of ``fn()``, and the fastest call's result.

    The machine may be shared: the minimum is the run least disturbed by other load.
    """
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fn()
        dt = time.perf_counter() - t0
        if dt < best:
            best, out = dt, res
    return best, out


def paper_table6() -> list[tuple[int, int, float, float, float]]:
    """Paper 000, Table 6: ``(nodes, best-path nodes, MPD* Lite s, D* Lite s, A* s)`` rows."""
    rows = json.loads(TABLE6_FILE.read_text(encoding="utf-8"))["rows"]
    return [tuple(row) for row in rows]


def random_geometric_arrays(
    n: int, k: int = 10, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points in [0,1]^3, k-NN edges in both directions, cost = length * U(1, 2).

    Returns ``(points, src, dst, cost)``; a pair listed from both ends appears
    twice and :class:`mpd_pin.search.Graph` keeps the cheaper one.
    """
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3))
    _, nbr = cKDTree(pts).query(pts, k + 1)
    src = np.repeat(np.arange(n), k)
    dst = nbr[:, 1:].ravel()
    src, dst = np.concatenate([src, dst]), np.concatenate([dst, src])
    cost = np.linalg.norm(pts[src] - pts[dst], axis=1) * rng.uniform(1.0, 2.0, src.size)
    return pts, src, dst, cost
