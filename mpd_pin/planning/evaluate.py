"""Evaluating roadmap edges: collision certificates and simulated energies, on demand or
all at once (docs/design.md §4e, §4g).

The one place where a roadmap's edges become known:

* :func:`certify_pairs` — the straight joint-space edges of node pairs checked by the
  collision checker (certified or discrete, docs/design.md §4d), in chunks with a bar;
* :func:`feasibility` and :func:`evaluate_edges` — edges simulated in one batch and the
  infeasible ones (effort limit, not arriving) refused (§4e);
* :func:`complete_checks` and :func:`complete_roadmap` — a roadmap loaded with unchecked or
  unevaluated edges finished eagerly.

:mod:`mpd_pin.planning.roadmap` builds roadmaps with these; :mod:`mpd_pin.planning.lazy`
calls them edge by edge as the search asks. Neither imports the other's internals.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..dynamics.simulate import edge_outcomes
from ..progress import bar, tqdm_class
from .options import RoadmapOptions
from .resume import PartialCosts
from .roadmap_data import Roadmap

__all__ = ["SMALL_BATCH", "certify_pairs", "feasibility", "evaluate_edges", "edge_target",
           "complete_checks", "complete_roadmap"]

#: Rounds of at most this many edges run in this process on one thread, whatever the
#: executor: measured on the planar 3-link arm, a 4-edge batch took 30 ms on 1 thread
#: against 85 ms on 2 (16 edges: 46 vs 95 ms, 64: 102 vs 147 ms), and lazy rounds sent to
#: a LocalCluster ran at 0.33–1.2× the in-process speed (docs/design.md §4h).
SMALL_BATCH = 128


def certify_pairs(checker, nodes: np.ndarray, pairs: np.ndarray, resolution: float,
                  progress=None) -> np.ndarray:
    """(P,) bool: whether the straight edge of each node pair ``pairs`` (P, 2) is free at
    ``resolution`` rad (the shorter way round on continuous joints, docs/design.md §1d).
    ``progress(done)`` follows the checker's chunks (``edges_free(..., progress=)``; the
    same answers as one batch)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if not len(pairs):
        return np.zeros(0, dtype=bool)
    Q0 = nodes[pairs[:, 0]]
    Q1 = checker.arm.edge_target(Q0, nodes[pairs[:, 1]])
    if progress is None:
        return np.asarray(checker.edges_free(Q0, Q1, resolution), dtype=bool)
    return np.asarray(checker.edges_free(Q0, Q1, resolution, progress=progress), dtype=bool)


def feasibility(out, options: RoadmapOptions, model) -> tuple[np.ndarray, np.ndarray]:
    """Rules (b), (c) of docs/design.md §4e on ``EdgeOutcomes`` of K edges: ``(over,
    missed)``, (K,) bool — effort limit exceeded, end farther than ``arrival_tolerance``."""
    K = np.asarray(out.energy).shape[0]
    over = np.zeros(K, dtype=bool)
    if options.effort_limits and K:
        lim = np.asarray(model.effortLimit, dtype=float)
        lim = np.where(np.isfinite(lim) & (lim > 0), lim, np.inf)
        over = np.any(out.peak_torque > lim * (1.0 + 1e-12), axis=1)
    missed = np.zeros(K, dtype=bool)
    if K:
        missed = np.max(np.abs(out.end_error), axis=1) > options.arrival_tolerance
    return over, missed


def edge_target(cost: Any, Q0: np.ndarray, Q1: np.ndarray) -> np.ndarray:
    """Where the edges Q0 → Q1 of ``cost``'s arm end: the shorter way round on continuous
    joints (§1d)."""
    arm = getattr(getattr(cost, "drive", None), "arm", None)
    target = getattr(arm, "edge_target", None)
    return target(Q0, Q1) if callable(target) else np.asarray(Q1, dtype=float)


def evaluate_edges(
    cost, roadmap: Roadmap, ids: np.ndarray, options: RoadmapOptions, progress=None,
) -> np.ndarray:
    """Simulate the roadmap edges ``ids`` (one batch through ``cost.outcomes``) and write
    the E⁺ per joint (J) of the feasible ones into ``roadmap.energy`` (and their bus
    energies into ``roadmap.bus``); the refused ones
    stay NaN and are counted in ``roadmap.edge_counts``. Returns the (len(ids),) bool mask
    of the refused edges (docs/design.md §4e, §4g)."""
    ids = np.asarray(ids, dtype=np.int64)
    if ids.size == 0:
        return np.zeros(0, dtype=bool)
    model = cost.drive.arm.model
    nodes = roadmap.nodes
    Q0, Q1, T = nodes[roadmap.src[ids]], nodes[roadmap.dst[ids]], roadmap.durations[ids]
    if ids.size <= SMALL_BATCH and hasattr(cost, "drive") and hasattr(cost, "dt"):
        # a LazySP round in this process on one thread, also with a cluster (round trips
        # do not pay for a few edges, docs/design.md §4h); the same rows (§4g)
        out = edge_outcomes(cost.drive, Q0, edge_target(cost, Q0, Q1), T, cost.dt, threads=1,
                            progress=progress)
    else:  # the executor seam; the shorter way round is taken inside outcomes (§1d)
        out = cost.outcomes(Q0, Q1, T, progress=progress)
    return _enter(roadmap, ids, out, options, model)


def _enter(roadmap: Roadmap, ids: np.ndarray, out, options: RoadmapOptions,
           model) -> np.ndarray:
    """Write the feasible ones of the simulated edges ``ids`` (``out``: their
    ``EdgeOutcomes``) into ``roadmap.energy`` and count the refused ones; returns the
    refused mask."""
    over, missed = feasibility(out, options, model)
    refused = over | missed
    energy = np.asarray(out.energy, float)
    roadmap.energy[ids[~refused]] = energy[~refused]
    if roadmap.bus is not None:  # files from before the shared bus carry none (§3i)
        roadmap.bus[ids[~refused]] = np.asarray(out.bus_energy, float)[~refused]
    counts = roadmap.edge_counts
    counts["refused_effort"] = counts.get("refused_effort", 0) + int(over.sum())
    counts["refused_arrival"] = counts.get("refused_arrival", 0) + int((missed & ~over).sum())
    return refused


def complete_checks(roadmap: Roadmap, checker, resolution: float,
                    show_progress: bool = False) -> Roadmap:
    """``roadmap`` with its unchecked edges certified (both directions of a pair at once)
    and the blocked ones dropped: what an eager collision check would have kept."""
    unchecked = ~roadmap.checked_mask
    if not unchecked.any():
        return roadmap
    t0 = time.perf_counter()
    ids = np.flatnonzero(unchecked)
    lo = np.minimum(roadmap.src[ids], roadmap.dst[ids])
    hi = np.maximum(roadmap.src[ids], roadmap.dst[ids])
    pairs, inverse = np.unique(np.stack([lo, hi], axis=1), axis=0, return_inverse=True)
    with bar(len(pairs), "edge checks", unit="edge", enabled=show_progress) as b:
        free = certify_pairs(checker, roadmap.nodes, pairs, resolution,
                             progress=(lambda d: b.update(d - b.n)) if show_progress else None)
    drop = np.zeros(roadmap.num_edges, dtype=bool)
    drop[ids[~free[inverse.ravel()]]] = True
    done = roadmap.without_edges(drop)
    done.checked = None  # every edge left is certified
    done.pairs_checked += int(len(pairs))
    done.timings["edge_checks"] = done.timings.get("edge_checks", 0.0) + time.perf_counter() - t0
    return done


def complete_roadmap(cost, roadmap: Roadmap, options: RoadmapOptions,
                     show_progress: bool, *, resume=None, tqdm=None) -> Roadmap:
    """Evaluate the NaN edges of a loaded (lazy) roadmap, dropping the refused ones. With
    ``resume`` = (cache file, key), finished chunks are kept in ``<cache>.partial/`` as an
    eager build keeps them, and those of an interrupted completion are reused
    (:attr:`Roadmap.chunks_reused`; docs/design.md §4h). ``tqdm``: the bar class."""
    t0 = time.perf_counter()
    todo = np.flatnonzero(~roadmap.evaluated)
    reused = 0
    bar_class = tqdm or tqdm_class(show_progress)
    with bar_class(total=todo.size, desc="edge energies", unit="edge", leave=False,
                   disable=not show_progress) as b:
        progress = lambda d: b.update(d - b.n)  # noqa: E731
        if resume is None or todo.size == 0:
            refused = evaluate_edges(cost, roadmap, todo, options, progress=progress)
        else:
            nodes = roadmap.nodes
            Q0, Q1 = nodes[roadmap.src[todo]], nodes[roadmap.dst[todo]]
            T = roadmap.durations[todo]
            partial = PartialCosts(resume[0], resume[1], Q0, edge_target(cost, Q0, Q1), T)
            out = cost.outcomes(Q0, Q1, T, progress=progress, reuse=partial.load(),
                                on_chunk=partial.add)
            refused = _enter(roadmap, todo, out, options, cost.drive.arm.model)
            reused = partial.chunks_reused
    drop = np.zeros(roadmap.num_edges, dtype=bool)
    drop[todo[refused]] = True
    done = roadmap.without_edges(drop)
    done.timings["edge_energies"] = time.perf_counter() - t0
    done.chunks_reused = reused
    return done
