"""A costed roadmap as data: :class:`Roadmap`, its edge costs and its ``.npz`` files
(docs/design.md §4, §4h).

What a roadmap *is*, apart from how it is built: the nodes, the directed edges with their
durations and energies, the costs the search sees (:meth:`Roadmap.edge_costs`, with the
shared bus's pricing and the node-potential reweighting of :func:`reweighted`,
docs/design.md §3i), and the checksummed file a build is cached in
(:meth:`Roadmap.save`, :meth:`Roadmap.load`). Building one — sampling, connecting,
checking and costing — is :mod:`mpd_pin.planning.roadmap`; evaluating its edges
:mod:`mpd_pin.planning.evaluate`; setting its supply :mod:`mpd_pin.planning.supply_costs`.
This module imports none of those, so each of them can name the type.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..dynamics.cost import EnergyCost
from ..dynamics.supply import PER_JOINT, Supply, supply_energy
from ..search import Graph
from .options import RoadmapOptions
from .resume import atomic_savez

__all__ = ["Roadmap", "ROADMAP_FORMAT", "EDGE_COUNTS", "NegativeCostError", "npz_path",
           "reweighted"]

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
        c = supply_energy(self.supply, self.energy[ids], self.bus_energies()[ids])
        return reweighted(c, self.potential, self.src[ids], self.dst[ids])

    def bus_energies(self) -> np.ndarray:
        """(E, 2) [B⁺, B⁻] of the shared bus per edge (J, float; NaN where not evaluated);
        ValueError when the roadmap holds none (a file written before the shared bus)."""
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
        return self.bus_energies()[ids].sum(axis=0) if ids.size else np.zeros(2)

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


class NegativeCostError(ValueError):
    """An evaluated edge costs less than the node potential allows: only possible with
    regeneration and motors whose Ke/Kt differ between joints, and only corrected when every
    edge is evaluated (Johnson's shift, :func:`attach_supply`; docs/design.md §3i).
    ``edge``: its (source, destination) node ids; ``cost``: its supply energy (J)."""

    def __init__(self, message: str, edge: tuple[int, int], cost: float) -> None:
        super().__init__(message)
        self.edge = edge
        self.cost = cost


def reweighted(c: np.ndarray, potential: np.ndarray | None, src: np.ndarray,
               dst: np.ndarray) -> np.ndarray:
    """c + φ(src) − φ(dst) (J), the search's cost of edges priced ``c`` (docs/design.md
    §3i); ``c`` itself without a potential. NaN (not evaluated) and ∞ stay so.

    The potential makes every cost ≥ 0 up to the end current's tracking residual; a
    reweighted cost below 0 by more than round-off (1e-9 of the terms) raises
    ValueError, since the searches need costs ≥ 0 and clipping would change the
    optimum; round-off below 0 is set to 0."""
    c = np.asarray(c, float)
    if potential is None:
        return c
    phi0, phi1 = potential[src], potential[dst]
    out = c + (phi0 - phi1)
    with np.errstate(invalid="ignore"):
        low = out < 0.0
    if low.any():
        tol = 1e-9 * (np.abs(c) + np.abs(phi0) + np.abs(phi1))
        bad = low & (out < -tol)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise NegativeCostError(
                f"an edge from node {int(src[k])} to node {int(dst[k])} costs "
                f"{float(c[k]):.6g} J, below the potential difference "
                f"{float(phi1[k] - phi0[k]):.6g} J that makes costs with regeneration "
                "non-negative (docs/design.md §3i): the motors' Ke/Kt differ between "
                "joints or the edge ends far from rest; use [roadmap] evaluation = "
                "\"eager\" (which reweights every cost exactly), regeneration = 0 or "
                "motors with one Ke/Kt", (int(src[k]), int(dst[k])), float(c[k]))
        out = np.where(low, 0.0, out)
    return out
