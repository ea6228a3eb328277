"""Probabilistic roadmap with directed electrical-energy edge costs (docs/design.md §4).

Nodes are seeded uniform random collision-free configurations inside the joint
limits, plus the start and the goal. Each node is joined to its k nearest
neighbours in joint space (scipy ``cKDTree``); an undirected candidate edge is
kept if the checker finds the whole straight joint-space edge collision-free (its
edge mode: certified by default, or discrete at ``resolution``). Both directions of
every kept edge are then simulated with the motor-augmented ODE through one batched
interface, :class:`EnergyCost`, so that lazy evaluation or remote executors can
replace it without touching the search: cost(u→v) = Σ_joints E⁺ (paper 000, Fig. 1),
for the directed edges that are feasible — timed within the URDF velocity limits,
within the effort limits, and arriving at their end node (docs/design.md §4e).

This module is the roadmap's construction (:func:`build_roadmap`) and its stages
(:func:`check_endpoint`, :func:`neighbour_pairs`, :func:`free_pairs`,
:func:`candidate_edges`, :func:`cost_edges`), which later queries reuse
(:mod:`mpd_pin.planning.queries`). The roadmap as data (:class:`Roadmap`, its ``.npz``
files) is :mod:`mpd_pin.planning.roadmap_data`, named here too. The options and the edge
duration rule are in
:mod:`mpd_pin.planning.options`; certifying and simulating edges, eagerly here or as a
lazy search asks (:mod:`mpd_pin.planning.lazy`), in :mod:`mpd_pin.planning.evaluate`.
With lazy collision checking (``check_edges=False``) the edge checks are left to the
search too (docs/design.md §4g).
"""

from __future__ import annotations

import os
import shutil

import numpy as np

from ..arm.continuous import nearest_neighbours
from ..dynamics.cost import EnergyCost
from .evaluate import certify_pairs, complete_checks, complete_roadmap, feasibility
from .options import RoadmapOptions
from .resume import PartialCosts, partial_dir
from .roadmap_data import EDGE_COUNTS, ROADMAP_FORMAT, Roadmap, npz_path
from .supply_costs import attach_supply

__all__ = ["RoadmapOptions", "Roadmap", "build_roadmap", "ROADMAP_FORMAT", "COLLISIONS",
           "EDGE_COUNTS", "feasibility", "npz_path", "check_endpoint", "neighbour_pairs",
           "free_pairs", "candidate_edges", "cost_edges"]

#: Values of ``[roadmap] collision`` (docs/design.md §4g): edges certified when the search
#: needs them (lazy, the default) or all before it (eager).
COLLISIONS = ("lazy", "eager")

#: New directed edges from :func:`candidate_edges` or :func:`cost_edges`: src, dst (E,)
#: node ids, durations (E,) s, energy (E, nq) E⁺ J, counts (of :data:`EDGE_COUNTS`),
#: bus (E, 2) [B⁺, B⁻] J.
EdgeRows = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, int], np.ndarray]


# --------------------------------------------------------------------------- building
def _sample_free(checker, lower, upper, n, rng, max_attempts, progress=None) -> np.ndarray:
    """n uniform samples within [lower, upper] that the checker finds free."""
    out: list[np.ndarray] = []
    have, drawn = 0, 0
    batch = max(64, 2 * n)
    while have < n:
        if drawn >= max_attempts * max(n, 1):
            raise ValueError(
                f"only {have} of {n} random configurations were collision-free after {drawn} "
                "draws; the free space is too small (check obstacles and joint limits)"
            )
        Q = rng.uniform(lower, upper, size=(batch, lower.size))
        drawn += batch
        ok = np.asarray(checker.is_free_batch(Q), dtype=bool)
        out.append(Q[ok])
        have += int(ok.sum())
        if progress is not None:
            progress(min(have, n))
    return np.concatenate(out, axis=0)[:n] if n else np.zeros((0, lower.size))


def check_endpoint(arm, checker, q, what: str) -> np.ndarray:
    """``q`` (rad) as a start or goal node (``what`` names it): a configuration of the arm,
    within the joint limits and collision-free, else ValueError (one line)."""
    q = arm.check_configuration(q, what)
    if not arm.within_limits(q):
        raise ValueError(
            f"{what} {np.round(q, 6).tolist()} is outside the joint limits "
            f"[{np.round(arm.lower_limits, 6).tolist()}, {np.round(arm.upper_limits, 6).tolist()}]"
        )
    if not checker.is_free(q):
        describe = getattr(checker, "describe_collision", None)  # duck-typed checkers
        detail = describe(q) if describe is not None else ""
        raise ValueError(f"{what} {np.round(q, 6).tolist()} is in collision"
                         + (f": {detail}" if detail else ""))
    return q


def _tqdm(show_progress: bool):
    """The progress-bar class (:func:`mpd_pin.progress.tqdm_class`); a module-level name
    so that tests can replace the bars of a build."""
    from ..progress import tqdm_class

    return tqdm_class(show_progress)


def _checker_fingerprint(arm, checker, checker_fingerprint: str | None) -> str:
    """ValueError unless ``checker`` checks ``arm``; the fingerprint of its free space
    (``checker_fingerprint`` if given, else ``checker.fingerprint()``)."""
    checker_arm = getattr(checker, "arm", None)
    if checker_arm is not arm and (
        not callable(getattr(checker_arm, "fingerprint", None))
        or checker_arm.fingerprint() != arm.fingerprint()
    ):
        raise ValueError(
            f"the checker's arm ({getattr(checker_arm, 'name', None)!r}) is not the arm the cost "
            f"drives ({arm.name!r}); build both from the same Arm"
        )
    if checker_fingerprint is not None:
        return checker_fingerprint
    if not callable(getattr(checker, "fingerprint", None)):
        raise ValueError(
            f"checker {type(checker).__name__} has no fingerprint(); pass "
            "checker_fingerprint= (a string that changes whenever its free space does)"
        )
    # The world as the checker sees it (known obstacles, or all with include_hidden)
    # and every setting that changes which configurations and edges are free.
    return checker.fingerprint()


def _sample_nodes(checker, arm, start, goal, options: RoadmapOptions, tqdm, show_progress):
    """Sampling: start, goal, then ``options.num_nodes`` free samples (seeded)."""
    rng = np.random.default_rng(options.seed)
    with tqdm(
        total=options.num_nodes,
        desc="sampling",
        unit="node",
        disable=not show_progress,
        leave=False,
    ) as bar:
        samples = _sample_free(
            checker,
            arm.lower_limits,
            arm.upper_limits,
            options.num_nodes,
            rng,
            options.max_attempts,
            progress=lambda h: bar.update(h - bar.n),
        )
    return np.vstack([start, goal, samples])


def neighbour_pairs(nodes: np.ndarray, k: int, periodic: np.ndarray | None = None) -> np.ndarray:
    """Connection: (P, 2) unique undirected pairs u < v joining each node to its ``k``
    nearest neighbours (joint-space Euclidean, ``cKDTree``; round the circle on the
    ``periodic`` joints, docs/design.md §1d)."""
    n = nodes.shape[0]
    k = min(k, n - 1)
    nbr = nearest_neighbours(nodes, k, periodic)
    a = np.repeat(np.arange(n), k + 1)
    b = nbr.ravel()
    keep = (b != a) & (b < n)
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    return np.unique(np.stack([lo, hi], axis=1), axis=0) if lo.size else np.zeros((0, 2), int)


def free_pairs(checker, nodes: np.ndarray, pairs: np.ndarray, resolution: float,
               tqdm=None, show_progress: bool = False) -> np.ndarray:
    """Collision filtering: the pairs whose straight edge is free at ``resolution`` rad
    (the shorter way round on continuous joints, docs/design.md §1d). With
    ``show_progress``, an "edge checks" bar of the class ``tqdm`` follows the checker's
    chunks (``edges_free(..., progress=)``; the same answers as one batch)."""
    if not len(pairs):
        return pairs[np.zeros(0, bool)]
    if not show_progress:
        return pairs[certify_pairs(checker, nodes, pairs, resolution)]
    with (tqdm or _tqdm(True))(total=len(pairs), desc="edge checks", unit="edge",
                               leave=False) as bar:
        free = certify_pairs(checker, nodes, pairs, resolution,
                             progress=lambda d: bar.update(d - bar.n))
    return pairs[free]


def candidate_edges(nodes: np.ndarray, pairs: np.ndarray, options: RoadmapOptions,
                    arm) -> EdgeRows:
    """Both directions of every pair, timed, not simulated: src, dst, durations (s), NaN
    energies, the counts of :data:`EDGE_COUNTS` and NaN bus energies (:data:`EdgeRows`)."""
    src = np.concatenate([pairs[:, 0], pairs[:, 1]]).astype(np.int64)
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]]).astype(np.int64)
    Q1 = arm.edge_target(nodes[src], nodes[dst])  # shorter way round (§1d)
    durations, raised = options.timing(nodes[src], Q1, arm.model.velocityLimit)
    energy = np.full((src.size, nodes.shape[1]), np.nan)
    counts = {"lengthened_for_velocity": int(raised.sum()), "refused_effort": 0,
              "refused_arrival": 0}
    return src, dst, durations, energy, counts, np.full((src.size, 2), np.nan)


def cost_edges(
    cost: EnergyCost, nodes: np.ndarray, pairs: np.ndarray, options: RoadmapOptions, tqdm,
    show_progress: bool, *,
    resume: tuple[str | os.PathLike, str] | None = None,
) -> EdgeRows:
    """Costing: both directions of every pair, timed within the velocity limits, simulated,
    and kept only if feasible (docs/design.md §4e). Returns src, dst, durations (s),
    E⁺ per joint (J) of the kept edges, the counts of :data:`EDGE_COUNTS` and their
    [B⁺, B⁻] bus energies (J) (:data:`EdgeRows`); with
    ``resume`` = (cache file, key), finished chunks are saved beside the cache and those of
    an interrupted build reused (docs/design.md §4h; the count in ``counts["chunks_reused"]``
    when resuming)."""
    model = cost.drive.arm.model
    src = np.concatenate([pairs[:, 0], pairs[:, 1]]).astype(np.int64)
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]]).astype(np.int64)
    Q1 = cost.drive.arm.edge_target(nodes[src], nodes[dst])  # shorter way round (§1d)
    durations, raised = options.timing(nodes[src], Q1, model.velocityLimit)
    partial = None if resume is None else PartialCosts(
        resume[0], resume[1], nodes[src], Q1, durations
    )
    reuse = None if partial is None else partial.load()
    with tqdm(
        total=src.size, desc="edge energies", unit="edge", disable=not show_progress, leave=False
    ) as bar:
        out = cost.outcomes(
            nodes[src], Q1, durations, progress=lambda d: bar.update(d - bar.n),
            reuse=reuse, on_chunk=None if partial is None else partial.add,
        )
    over, missed = feasibility(out, options, model)
    keep = ~(over | missed)
    counts = {
        "lengthened_for_velocity": int(raised.sum()),
        "refused_effort": int(over.sum()),
        "refused_arrival": int((missed & ~over).sum()),
    }
    if partial is not None:
        counts["chunks_reused"] = partial.chunks_reused
    return (src[keep], dst[keep], durations[keep], np.asarray(out.energy, float)[keep], counts,
            np.asarray(out.bus_energy, float)[keep])


#: The stages' former private names, still used by tests/test_progress.py and
#: tests/test_continuous.py (no module of the package uses them).
_neighbour_pairs, _free_pairs = neighbour_pairs, free_pairs


def build_roadmap(
    cost: EnergyCost,
    checker,
    start,
    goal,
    options: RoadmapOptions | None = None,
    *,
    checker_fingerprint: str | None = None,
    cache: str | os.PathLike | None = None,
    show_progress: bool = True,
    evaluate: bool = True,
    check_edges: bool = True,
) -> Roadmap:
    """Sample, connect, check and cost a roadmap; start is node 0, goal node 1.

    ``evaluate=False`` stops before the costing: every collision-free directed edge is
    kept, timed, with NaN energies, for lazy evaluation (docs/design.md §4g); such a
    roadmap has the same key as the evaluated one. With ``evaluate=True`` a cached file
    holding unevaluated edges has them simulated (refused ones dropped) and is saved again.
    ``check_edges=False`` (lazy collision checking, only with ``evaluate=False``) also
    skips the edge checks: every neighbour pair enters, ``checked`` all False; with
    ``check_edges=True`` a cached file's unchecked edges are certified (blocked ones
    dropped) first.

    ``checker`` is a validity checker (``arm``, ``is_free``, ``is_free_batch``,
    ``edges_free`` — with a ``progress=`` callback when ``show_progress`` —,
    ``fingerprint``) for the known world; its arm must be the cost's drive arm (the same
    object or an equal fingerprint). ``checker_fingerprint``
    overrides ``checker.fingerprint()`` in the key (it must change whenever the
    free configurations or edges do). With ``cache`` (a ``.npz`` path), a file
    built with the same key is loaded instead of rebuilding; a file with another
    key or a bad checksum raises ValueError (delete it to rebuild). While the edge
    energies of a cached build run, finished chunks are kept in ``<cache>.partial/``; an
    interrupted build run again reuses them (:attr:`Roadmap.chunks_reused`), and the
    folder is removed once the file is written (docs/design.md §4h).
    """
    import time

    if evaluate and not check_edges:
        raise ValueError("evaluate=True needs check_edges=True: only collision-free edges are "
                         "simulated")
    tqdm = _tqdm(show_progress)
    options = options or RoadmapOptions()
    arm = cost.drive.arm
    checker_fingerprint = _checker_fingerprint(arm, checker, checker_fingerprint)
    start = check_endpoint(arm, checker, start, "start")
    goal = check_endpoint(arm, checker, goal, "goal")
    key = Roadmap.key_for(cost, checker_fingerprint, options, start, goal)
    if cache is not None:
        cache = npz_path(cache)
        if cache.exists():
            loaded = Roadmap.load(cache, expected_key=key, nq=arm.nq)
            finish = check_edges and not loaded.checked_mask.all()
            if finish:
                loaded = complete_checks(loaded, checker, options.resolution, show_progress)
            if evaluate and not loaded.evaluated.all():
                # finished chunks kept beside the file: an interrupted completion resumes
                loaded = complete_roadmap(cost, loaded, options, show_progress,
                                          resume=(cache, key), tqdm=tqdm)
                finish = True
            if finish:
                loaded.save(cache)
            shutil.rmtree(partial_dir(cache), ignore_errors=True)  # done: no leftovers
            return attach_supply(loaded, cost.drive)

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    nodes = _sample_nodes(checker, arm, start, goal, options, tqdm, show_progress)
    timings["sampling"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    pairs = neighbour_pairs(nodes, options.k, arm.continuous_mask)
    timings["neighbours"] = time.perf_counter() - t0
    checked_pairs = len(pairs) if check_edges else 0
    if check_edges:
        t0 = time.perf_counter()
        pairs = free_pairs(checker, nodes, pairs, options.resolution, tqdm, show_progress)
        timings["edge_checks"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if evaluate:
        src, dst, durations, energy, counts, bus = cost_edges(
            cost, nodes, pairs, options, tqdm, show_progress,
            resume=None if cache is None else (cache, key),
        )
        timings["edge_energies"] = time.perf_counter() - t0
    else:
        src, dst, durations, energy, counts, bus = candidate_edges(nodes, pairs, options, arm)
        timings["edge_timing"] = time.perf_counter() - t0
    reused = int(counts.pop("chunks_reused", 0))

    roadmap = Roadmap(
        nodes=nodes,
        start=0,
        goal=1,
        src=src,
        dst=dst,
        durations=durations,
        energy=energy,
        key=key,
        timings=timings,
        edge_counts=counts,
        chunks_reused=reused,
        checked=None if check_edges else np.zeros(src.size, dtype=bool),
        pairs_checked=checked_pairs,
        bus=bus,
    )
    if cache is not None:
        roadmap.save(cache)
        shutil.rmtree(partial_dir(cache), ignore_errors=True)
    return attach_supply(roadmap, cost.drive)

