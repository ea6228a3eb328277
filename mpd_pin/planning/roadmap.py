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

This module is the roadmap as data (:class:`Roadmap`, its ``.npz`` files) and its
construction (:func:`build_roadmap`). The options and the edge duration rule are in
:mod:`mpd_pin.planning.options`; certifying and simulating edges, eagerly here or as a
lazy search asks (:mod:`mpd_pin.planning.lazy`), in :mod:`mpd_pin.planning.evaluate`.
With lazy collision checking (``check_edges=False``) the edge checks are left to the
search too (docs/design.md §4g).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..arm.continuous import nearest_neighbours
from ..dynamics.cost import EnergyCost
from ..dynamics.supply import PER_JOINT, Supply, supply_energy
from ..search import Graph
from .evaluate import certify_pairs, complete_checks, complete_roadmap, feasibility
from .options import RoadmapOptions
from .resume import PartialCosts, atomic_savez, partial_dir
from .supply_costs import attach_supply, reweighted

__all__ = ["RoadmapOptions", "Roadmap", "build_roadmap", "ROADMAP_FORMAT", "COLLISIONS",
           "feasibility"]

#: Values of ``[roadmap] collision`` (docs/design.md §4g): edges certified when the search
#: needs them (lazy, the default) or all before it (eager).
COLLISIONS = ("lazy", "eager")

#: Keys of :attr:`Roadmap.edge_counts`, in the order of the file's ``edge_counts`` array.
EDGE_COUNTS = ("lengthened_for_velocity", "refused_effort", "refused_arrival")

#: Version of the .npz layout and of the cost model; part of every file's key.
ROADMAP_FORMAT = "mpd_pin.roadmap/2"  # 2: feasible edges only, edge_counts array


@dataclass
class Roadmap:
    """A costed roadmap.

    nodes: (n, nq) configurations (rad); ``start`` and ``goal`` are node ids.
    src, dst: directed edges (both directions of every collision-free pair, less the
        infeasible ones counted in ``edge_counts``).
    durations: (E,) seconds; energy: (E, nq) E⁺ per joint (J); cost = energy.sum(1).
    key: hash of everything that determined the roadmap (see :meth:`key_for`).
    timings: seconds per phase of the build.
    bus, supply, potential: the shared-bus energies and how they are priced
    (docs/design.md §3i); with the default supply the cost is the paper's Σ E⁺.
    """

    nodes: np.ndarray
    start: int
    goal: int
    src: np.ndarray
    dst: np.ndarray
    durations: np.ndarray
    energy: np.ndarray
    key: str
    timings: dict = field(default_factory=dict)
    #: directed candidate edges lengthened for the velocity limits, refused for the
    #: effort limits, refused for not arriving (see RoadmapOptions)
    edge_counts: dict = field(default_factory=dict)
    #: chunks of edge energies taken from an interrupted build's partial file (§4h)
    chunks_reused: int = 0
    #: (E,) bool: edges certified collision-free; None: every edge (an eager check).
    #: Lazy collision checking (docs/design.md §4g) leaves edges unchecked until the
    #: search needs them.
    checked: np.ndarray | None = None
    #: undirected node pairs collision-checked while building (not saved in files)
    pairs_checked: int = 0
    #: (E, 2) [B⁺, B⁻] of the shared bus per edge (J, NaN where not evaluated); None in
    #: files written before the shared bus (docs/design.md §3i)
    bus: np.ndarray | None = None
    #: how the edges are priced: the drive's supply (set by :func:`attach_supply`)
    supply: Supply = PER_JOINT
    #: (n,) node potential φ (J) of a supply with regeneration: the search runs on
    #: c + φ(src) − φ(dst) ≥ 0 (None: no reweighting)
    potential: np.ndarray | None = None

    @property
    def checked_mask(self) -> np.ndarray:
        """(E,) bool: edges certified collision-free (all of them after an eager check)."""
        if self.checked is None:
            return np.ones(self.num_edges, dtype=bool)
        return np.asarray(self.checked, dtype=bool)

    @property
    def num_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def num_edges(self) -> int:
        return int(self.src.shape[0])

    @property
    def cost(self) -> np.ndarray:
        """Directed edge costs the search uses (J): E⁺ summed over joints (the paper), or
        the supply energy, reweighted by the node potential when regeneration can make
        it negative: c + φ(src) − φ(dst), ≥ 0 (docs/design.md §3i)."""
        return self.edge_costs(np.arange(self.num_edges))

    def edge_costs(self, ids: np.ndarray) -> np.ndarray:
        """:attr:`cost` of the edges ``ids`` only (NaN where not evaluated)."""
        ids = np.asarray(ids, dtype=np.int64)
        if self.supply.is_default:
            return self.energy[ids].sum(axis=1)
        c = supply_energy(self.supply, self.energy[ids], self._bus()[ids])
        return reweighted(c, self.potential, self.src[ids], self.dst[ids])

    def _bus(self) -> np.ndarray:
        if self.bus is None:
            raise ValueError("this roadmap holds no shared-bus energies (written before "
                             "them); rebuild it to price a shared bus")
        return np.asarray(self.bus, float)

    def with_costs(self, costs: np.ndarray) -> Roadmap:
        """A copy (same nodes and edges) whose :attr:`cost` is ``costs`` (E,), carried in
        the first column of ``energy``: only for planning (distance costs, hazard
        penalties); energies are reported from the original."""
        energy = np.zeros_like(np.asarray(self.energy, dtype=float))
        energy[:, 0] = costs
        return replace(self, energy=energy, bus=None, supply=PER_JOINT, potential=None)

    def graph(self) -> Graph:
        """The search graph (directed, non-negative costs) of this roadmap."""
        return Graph.from_arrays(self.num_nodes, self.src, self.dst, self.cost)

    def edge_ids(self, path: list[int]) -> np.ndarray:
        """Row indices of the directed edges along a node path (ValueError if one is missing)."""
        lookup = {
            (int(u), int(v)): e for e, (u, v) in enumerate(zip(self.src, self.dst, strict=True))
        }
        try:
            return np.array(
                [lookup[(int(a), int(b))] for a, b in zip(path[:-1], path[1:], strict=True)],
                dtype=int,
            )
        except KeyError as exc:
            raise ValueError(f"path uses edge {exc.args[0]} which is not in the roadmap") from None

    def path_energy(self, path: list[int]) -> np.ndarray:
        """E⁺ per joint (J) of a node path: the sum of its edges' (each starts at rest)."""
        ids = self.edge_ids(path)
        return self.energy[ids].sum(axis=0) if ids.size else np.zeros(self.nodes.shape[1])

    def path_supply_energy(self, path: list[int]) -> float:
        """The energy a node path draws from :attr:`supply` (J): Σ E⁺ with a supply per
        joint, else the bus's B⁺ − η B⁻ over its edges (docs/design.md §3i)."""
        energy = self.path_energy(path)
        if self.supply.is_default:
            return float(np.sum(energy))
        return float(supply_energy(self.supply, energy, self.path_bus(path)))

    def path_bus(self, path: list[int]) -> np.ndarray:
        """[B⁺, B⁻] (J) of a node path: the sums of its edges' (docs/design.md §3i)."""
        ids = self.edge_ids(path)
        return self._bus()[ids].sum(axis=0) if ids.size else np.zeros(2)

    @property
    def evaluated(self) -> np.ndarray:
        """(E,) bool: edges whose energy is known (NaN rows: not yet evaluated, §4g)."""
        return ~np.isnan(np.asarray(self.energy, float)).any(axis=1)

    def without_edges(self, drop: np.ndarray) -> Roadmap:
        """A copy without the edges where ``drop`` (E,) is True (nodes, key, counts kept)."""
        keep = ~np.asarray(drop, dtype=bool)
        return replace(
            self, src=self.src[keep], dst=self.dst[keep], durations=self.durations[keep],
            energy=np.array(self.energy[keep], dtype=float), edge_counts=dict(self.edge_counts),
            timings=dict(self.timings),
            bus=None if self.bus is None else np.array(self.bus[keep], dtype=float),
            checked=None if self.checked is None else np.asarray(self.checked, bool)[keep],
        )

    # ------------------------------------------------------------------ files
    @staticmethod
    def key_for(
        cost: EnergyCost,
        checker_fingerprint: str,
        options: RoadmapOptions,
        start: np.ndarray,
        goal: np.ndarray,
    ) -> str:
        """SHA-256 over arm, motors, controller, dt, the collision checker's fingerprint
        (world and settings, see ``CollisionChecker.describe``), sampling options,
        start and goal."""
        payload = {
            "format": ROADMAP_FORMAT,
            "cost": cost.describe(),
            "checker": checker_fingerprint,
            "options": asdict(options),
            "start": np.asarray(start, float).tolist(),
            "goal": np.asarray(goal, float).tolist(),
        }
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()

    def _arrays(self) -> dict[str, np.ndarray]:
        return {
            "nodes": np.asarray(self.nodes, float),
            "endpoints": np.array([self.start, self.goal], dtype=np.int64),
            "src": np.asarray(self.src, np.int64),
            "dst": np.asarray(self.dst, np.int64),
            "durations": np.asarray(self.durations, float),
            "energy": np.asarray(self.energy, float),
            "edge_counts": np.array([self.edge_counts.get(k, 0) for k in EDGE_COUNTS], np.int64),
        } | ({} if self.checked is None else {"checked": self.checked_mask}) | (
            {} if self.bus is None else {"bus": np.asarray(self.bus, float)})

    @staticmethod
    def _checksum(key: str, arrays: dict[str, np.ndarray]) -> str:
        h = hashlib.sha256(key.encode())
        for name in sorted(arrays):
            a = np.ascontiguousarray(arrays[name])
            h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
            h.update(a.tobytes())
        return h.hexdigest()

    def save(self, path: str | os.PathLike) -> Path:
        """Write a ``.npz`` (no pickle) holding the arrays, the key and a checksum,
        atomically: a temporary file in the same folder, then ``os.replace``
        (docs/design.md §4h)."""
        path = npz_path(path)
        arrays = self._arrays()
        atomic_savez(
            path,
            key=np.array(self.key),
            checksum=np.array(self._checksum(self.key, arrays)),
            format=np.array(ROADMAP_FORMAT),
            **arrays,
        )
        return path

    @classmethod
    def load(
        cls, path: str | os.PathLike, expected_key: str | None = None, *, nq: int | None = None
    ) -> Roadmap:
        """Read a roadmap saved by :meth:`save` (``.npz`` appended to ``path`` as by save).

        Raises ValueError if the file cannot be read (missing, truncated, corrupt),
        is not a roadmap, was modified after it was written (checksum), holds
        inconsistent arrays (shapes, node ids, non-finite or negative values,
        configurations of other than ``nq`` joints), or was built for other
        parameters (``expected_key``).
        """
        path = Path(path)
        if not path.is_file():
            path = npz_path(path)
        try:
            f = np.load(path, allow_pickle=False)
            if not isinstance(f, np.lib.npyio.NpzFile):  # a plain .npy array
                raise ValueError("not an .npz archive")
            with f:
                data = {name: f[name] for name in f.files}
        except Exception as exc:  # BadZipFile, zlib.error, EOFError, OSError, ... on bad bytes
            raise ValueError(
                f"cannot read roadmap file {str(path)!r} ({type(exc).__name__}: {exc}); "
                "delete it to rebuild"
            ) from None
        needed = {
            "key",
            "checksum",
            "format",
            "nodes",
            "endpoints",
            "src",
            "dst",
            "durations",
            "energy",
            "edge_counts",
        }
        if not needed <= set(data):
            raise ValueError(
                f"{str(path)!r} is not a mpd_pin roadmap (missing {sorted(needed - set(data))})"
            )
        if str(data["format"]) != ROADMAP_FORMAT:
            raise ValueError(
                f"{str(path)!r} has format {str(data['format'])!r}, expected {ROADMAP_FORMAT!r}"
            )
        key = str(data["key"])
        arrays = {
            n: data[n]
            for n in ("nodes", "endpoints", "src", "dst", "durations", "energy", "edge_counts",
                      "checked", "bus")
            if n in data  # "checked": only in files of lazily checked roadmaps; "bus": §3i
        }
        if cls._checksum(key, arrays) != str(data["checksum"]):
            raise ValueError(
                f"roadmap file {str(path)!r} was modified after it was written (checksum mismatch)"
            )
        _validate_arrays(arrays, path, nq)
        if expected_key is not None and key != expected_key:
            raise ValueError(
                f"roadmap file {str(path)!r} was built with other parameters (arm, motors, "
                "controller, world, collision settings, sampling, start or goal differ); rebuild it"
            )
        return cls(
            nodes=arrays["nodes"],
            start=int(arrays["endpoints"][0]),
            goal=int(arrays["endpoints"][1]),
            src=arrays["src"],
            dst=arrays["dst"],
            durations=arrays["durations"],
            energy=arrays["energy"],
            key=key,
            edge_counts=dict(zip(EDGE_COUNTS, arrays["edge_counts"].tolist(), strict=True)),
            checked=arrays.get("checked"),
            bus=arrays.get("bus"),
        )


def npz_path(path: str | os.PathLike) -> Path:
    """``path`` with ``.npz`` appended unless it already ends so (as ``np.savez`` does)."""
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def _validate_arrays(arrays: dict[str, np.ndarray], path: Path, nq: int | None) -> None:
    """ValueError unless the loaded arrays form a consistent roadmap of ``nq``-joint nodes."""

    def bad(msg: str) -> ValueError:
        return ValueError(f"roadmap file {str(path)!r} is inconsistent: {msg}")

    nodes, ends = arrays["nodes"], arrays["endpoints"]
    src, dst = arrays["src"], arrays["dst"]
    durations, energy = arrays["durations"], arrays["energy"]
    if nodes.ndim != 2 or nodes.dtype.kind != "f" or nodes.shape[0] < 2:
        raise bad(f"nodes must be a float (n >= 2, nq) array, got {nodes.dtype} {nodes.shape}")
    n, dim = nodes.shape
    if nq is not None and dim != nq:
        raise bad(f"nodes have {dim} joint values, the arm has {nq}")
    if not np.all(np.isfinite(nodes)):
        raise bad("nodes contain NaN or infinity")
    for name, a, shape in (("endpoints", ends, (2,)), ("src", src, None), ("dst", dst, None)):
        if a.dtype.kind not in "iu" or a.ndim != 1 or (shape is not None and a.shape != shape):
            raise bad(f"{name} must be a 1-D integer array, got {a.dtype} {a.shape}")
        if a.size and (a.min() < 0 or a.max() >= n):
            raise bad(f"{name} has node ids outside [0, {n})")
    E = src.shape[0]
    if dst.shape != (E,) or durations.shape != (E,) or energy.shape != (E, dim):
        raise bad(
            f"{E} edges but dst {dst.shape}, durations {durations.shape}, energy {energy.shape}"
            f" (expected ({E},), ({E},), ({E}, {dim}))"
        )
    if E and np.any(src == dst):
        raise bad("self-loop edges")
    if durations.dtype.kind != "f" or not np.all(np.isfinite(durations) & (durations > 0)):
        raise bad("durations must be finite and > 0 (s)")
    # a row of NaN is an edge not yet evaluated (lazy roadmaps, docs/design.md §4f);
    # anything else must be a finite E⁺ >= 0 in every joint
    if energy.dtype.kind != "f":
        raise bad("energies must be floats (J)")
    unevaluated = np.isnan(energy).all(axis=1) if E else np.zeros(0, bool)
    known = energy[~unevaluated]
    if not np.all(np.isfinite(known) & (known >= 0)):
        raise bad("energies must be finite and >= 0 (J), or NaN in every joint (not evaluated)")
    counts = arrays["edge_counts"]
    if counts.dtype.kind not in "iu" or counts.shape != (len(EDGE_COUNTS),) or np.any(counts < 0):
        raise bad(f"edge_counts must be {len(EDGE_COUNTS)} non-negative integers")
    checked = arrays.get("checked")
    if checked is not None and (checked.dtype != bool or checked.shape != (E,)):
        raise bad("checked must be one bool per edge")
    bus = arrays.get("bus")
    if bus is not None:
        if bus.dtype.kind != "f" or bus.shape != (E, 2):
            raise bad(f"bus must be a float ({E}, 2) array (J), got {bus.dtype} {bus.shape}")
        if not np.array_equal(np.isnan(bus).any(axis=1), unevaluated):
            raise bad("bus energies must be NaN exactly where the edge is not evaluated")
        if not np.all(bus[~unevaluated] >= 0):
            raise bad("bus energies must be >= 0 (J)")


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


def _check_endpoint(arm, checker, q, what: str) -> np.ndarray:
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


def _neighbour_pairs(nodes: np.ndarray, k: int, periodic: np.ndarray | None = None) -> np.ndarray:
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


def _free_pairs(checker, nodes: np.ndarray, pairs: np.ndarray, resolution: float,
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


def _candidate_edges(nodes, pairs, options: RoadmapOptions, arm):
    """Both directions of every pair, timed, not simulated: src, dst, durations, NaN, counts."""
    src = np.concatenate([pairs[:, 0], pairs[:, 1]]).astype(np.int64)
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]]).astype(np.int64)
    Q1 = arm.edge_target(nodes[src], nodes[dst])  # shorter way round (§1d)
    durations, raised = options.timing(nodes[src], Q1, arm.model.velocityLimit)
    energy = np.full((src.size, nodes.shape[1]), np.nan)
    counts = {"lengthened_for_velocity": int(raised.sum()), "refused_effort": 0,
              "refused_arrival": 0}
    return src, dst, durations, energy, counts, np.full((src.size, 2), np.nan)


def _cost_edges(
    cost: EnergyCost, nodes, pairs, options: RoadmapOptions, tqdm, show_progress, *,
    resume: tuple[str | os.PathLike, str] | None = None,
):
    """Costing: both directions of every pair, timed within the velocity limits, simulated,
    and kept only if feasible (docs/design.md §4e). Returns src, dst, durations (s),
    E⁺ per joint (J) of the kept edges and the counts of :data:`EDGE_COUNTS`; with
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
    start = _check_endpoint(arm, checker, start, "start")
    goal = _check_endpoint(arm, checker, goal, "goal")
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
    pairs = _neighbour_pairs(nodes, options.k, arm.continuous_mask)
    timings["neighbours"] = time.perf_counter() - t0
    checked_pairs = len(pairs) if check_edges else 0
    if check_edges:
        t0 = time.perf_counter()
        pairs = _free_pairs(checker, nodes, pairs, options.resolution, tqdm, show_progress)
        timings["edge_checks"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if evaluate:
        src, dst, durations, energy, counts, bus = _cost_edges(
            cost, nodes, pairs, options, tqdm, show_progress,
            resume=None if cache is None else (cache, key),
        )
        timings["edge_energies"] = time.perf_counter() - t0
    else:
        src, dst, durations, energy, counts, bus = _candidate_edges(nodes, pairs, options, arm)
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

