"""One roadmap for every payload: the nodes shared, edges and energies per payload
(docs/design.md §4i, issue 33).

The planner's roadmap of the arm without a payload is the *base*: built around the first
query and grown by every later one (:mod:`mpd_pin.planning.queries`). The roadmap of a
payload (:class:`~mpd_pin.Payload`) is derived from the base on every query that carries
it (:func:`payload_roadmap`):

* **Nodes** are the base's node array, with the same ids. A node where the part collides
  keeps its id but has no edge for that payload.
* **Edges** are the base's current edges among those nodes. A pair the base found blocked
  has left the base, and so the payload: an edge blocked without the part is blocked with
  it. A base certificate is never reused: every edge is certified again with the part
  (when the search needs it, or all at once with eager collision checks). The other way
  round is sound: an edge certified free with the part is free without it, so
  :func:`share_certificates` marks it checked in the base. A pair refused without the part
  (effort, arrival) has left the base too and is not offered with the part either.
* **Energies** are the payload's own, simulated with its drive: NaN until the search needs
  them (lazy) or all at once (eager), and reused from what this payload already knew
  (:class:`EdgeMemo`): its earlier roadmaps in this process and its roadmap file.

**Files.** A payload's edges are kept in their own file beside the base's cache
(:func:`payload_cache_path`: ``<cache stem>.payload-<digest>.npz``), a
:class:`~mpd_pin.planning.roadmap_data.Roadmap` file whose key (:func:`payload_key`)
hashes the payload's drive (the arm fingerprint with the part's inertia), its collision
checker (with the part's box), the roadmap options and the part itself, but not the nodes:
the file is a memo of edges, ``(q_src, q_dst)`` → duration and E⁺ per joint, matched by
their end configurations bit for bit, so it serves every query sequence on the same nodes.
``Roadmap.load`` refuses a file of another key (another payload, drive or world): a file
never mixes the energies of two payloads, or of a payload and the bare arm.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.cost import EnergyCost
from .evaluate import complete_checks, complete_roadmap
from .options import RoadmapOptions
from .roadmap_data import ROADMAP_FORMAT, Roadmap, npz_path
from .supply_costs import attach_supply

__all__ = ["EdgeMemo", "payload_cache_path", "payload_digest", "payload_key",
           "payload_roadmap", "share_certificates"]

Pair = tuple[bytes, bytes]


def payload_digest(part: Any) -> str:
    """SHA-256 (hex) of ``part.describe()`` (mass, com, inertia, size, frame, name)."""
    text = json.dumps(part.describe(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def payload_key(part: Any, cost: EnergyCost, checker_fingerprint: str,
                options: RoadmapOptions) -> str:
    """The key of a payload's roadmap file: SHA-256 of the format, the part, the cost
    (drive and arm fingerprint, which includes the part's inertia), the checker's
    fingerprint (with the part's box) and the roadmap options."""
    payload = {
        "format": ROADMAP_FORMAT,
        "kind": "payload edges",
        "payload": part.describe(),
        "cost": cost.describe(),
        "checker": checker_fingerprint,
        "options": asdict(options),
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def payload_cache_path(cache: str | os.PathLike, part: Any) -> Path:
    """The file of ``part``'s edges beside the base roadmap file ``cache``:
    ``<stem>.payload-<first 12 hex digits of payload_digest>.npz``."""
    base = npz_path(cache)
    return base.with_name(f"{base.stem}.payload-{payload_digest(part)[:12]}.npz")


def _rows(nodes: np.ndarray) -> list[bytes]:
    nodes = np.ascontiguousarray(nodes, dtype=float)
    return [row.tobytes() for row in nodes]


@dataclass
class EdgeMemo:
    """What one payload knows of its edges, by their end configurations (bytes of the
    float rows): ``energy`` (duration s, E⁺ per joint J, [B⁺, B⁻] J) of evaluated feasible
    edges, ``free`` edges certified collision-free with the part, ``refused`` edges
    (blocked with the part, or infeasible with its drive), ``node_free`` whether the part
    is collision-free at a node."""

    energy: dict[Pair, tuple[float, np.ndarray, np.ndarray]] = field(default_factory=dict)
    free: set[Pair] = field(default_factory=set)
    refused: set[Pair] = field(default_factory=set)
    node_free: dict[bytes, bool] = field(default_factory=dict)
    edge_counts: dict[str, int] = field(default_factory=dict)

    def absorb(self, roadmap: Roadmap, refused: np.ndarray | None = None) -> None:
        """Learn from a payload roadmap (its energies, checks, and ``refused`` (E,) bool,
        lazy evaluation's refused edges; None: none refused)."""
        keys = _rows(roadmap.nodes)
        energy = np.asarray(roadmap.energy, float)
        bus = None if roadmap.bus is None else np.asarray(roadmap.bus, float)
        known = roadmap.evaluated
        checked = roadmap.checked_mask
        bad = np.zeros(roadmap.num_edges, bool) if refused is None else np.asarray(refused)
        for e, (u, v) in enumerate(zip(roadmap.src.tolist(), roadmap.dst.tolist(),
                                       strict=True)):
            pair = (keys[u], keys[v])
            if bad[e]:
                self.refused.add(pair)
                continue
            if checked[e]:
                self.free.add(pair)
            if known[e]:
                self.energy[pair] = (float(roadmap.durations[e]), energy[e].copy(),
                                     np.full(2, np.nan) if bus is None else bus[e].copy())
        self.edge_counts = dict(roadmap.edge_counts)

    def absorb_file(self, path: Path, key: str, nq: int) -> bool:
        """Learn from the payload file ``path`` if it exists (ValueError, one line, for a
        file of another key: another payload, drive, world or options); whether it did."""
        if not path.is_file():
            return False
        loaded = Roadmap.load(path, expected_key=key, nq=nq)
        self.absorb(loaded)
        return True


def payload_roadmap(base: Roadmap, cost: EnergyCost, checker, options: RoadmapOptions, *,
                    key: str, memo: EdgeMemo, evaluate: bool, check_edges: bool,
                    show_progress: bool = False) -> Roadmap:
    """The roadmap of a payload on the nodes of ``base`` (module docstring): ``cost`` is
    the payload's drive, ``checker`` its collision checker (with the part), ``memo`` what
    it already knows (updated in place with the node checks and, when ``check_edges`` or
    ``evaluate``, the edges checked or simulated here). Start and goal are the base's.
    ``key`` becomes the roadmap's key (:func:`payload_key`)."""
    nodes = np.asarray(base.nodes, dtype=float)
    keys = _rows(nodes)
    todo = [i for i, k in enumerate(keys) if k not in memo.node_free]
    if todo:
        ok = np.asarray(checker.is_free_batch(nodes[todo]), dtype=bool)
        for i, free in zip(todo, ok.tolist(), strict=True):
            memo.node_free[keys[i]] = bool(free)
    node_ok = np.array([memo.node_free[k] for k in keys], dtype=bool)
    src, dst = np.asarray(base.src, np.int64), np.asarray(base.dst, np.int64)
    pairs = [(keys[u], keys[v]) for u, v in zip(src.tolist(), dst.tolist(), strict=True)]
    keep = node_ok[src] & node_ok[dst]
    keep &= np.array([p not in memo.refused for p in pairs], dtype=bool)
    ids = np.flatnonzero(keep)
    nq = nodes.shape[1]
    durations = np.asarray(base.durations, float)[ids]
    energy = np.full((ids.size, nq), np.nan)
    bus = np.full((ids.size, 2), np.nan)
    checked = np.zeros(ids.size, dtype=bool)
    for j, e in enumerate(ids.tolist()):
        pair = pairs[e]
        checked[j] = pair in memo.free
        hit = memo.energy.get(pair)
        if hit is not None and hit[0] == durations[j]:
            energy[j], bus[j] = hit[1], hit[2]
    roadmap = Roadmap(
        nodes=nodes, start=int(base.start), goal=int(base.goal), src=src[ids], dst=dst[ids],
        durations=durations, energy=energy, key=key,
        edge_counts={k: int(memo.edge_counts.get(k, 0)) for k in
                     ("lengthened_for_velocity", "refused_effort", "refused_arrival")},
        checked=checked, bus=bus,
    )
    if check_edges or evaluate:
        before = roadmap
        roadmap = complete_checks(roadmap, checker, options.resolution, show_progress)
        _learn_dropped(memo, before, roadmap, keys)
        roadmap.checked = None
    if evaluate:
        before = roadmap
        roadmap = complete_roadmap(cost, roadmap, options, show_progress)
        _learn_dropped(memo, before, roadmap, keys)
        roadmap.key = key
    if check_edges or evaluate:
        memo.absorb(roadmap)
    return attach_supply(roadmap, cost.drive)


def _learn_dropped(memo: EdgeMemo, before: Roadmap, after: Roadmap, keys: list[bytes]) -> None:
    """Every edge of ``before`` missing from ``after`` is refused for the payload."""
    kept = set(zip(after.src.tolist(), after.dst.tolist(), strict=True))
    for u, v in zip(before.src.tolist(), before.dst.tolist(), strict=True):
        if (u, v) not in kept:
            memo.refused.add((keys[u], keys[v]))


def share_certificates(payload: Roadmap, refused: np.ndarray | None, base: Roadmap) -> int:
    """Mark checked in ``base`` (in place) every unchecked edge that ``payload`` certified
    collision-free with the part (checked and not refused): the part only adds collision
    pairs, so such an edge is free without it. Never the other way round. Returns how many
    base edges were marked."""
    if base.checked is None or payload.num_edges == 0:
        return 0
    free = payload.checked_mask.copy()
    if refused is not None:
        free &= ~np.asarray(refused, dtype=bool)
    if not free.any():
        return 0
    pkeys, bkeys = _rows(payload.nodes), _rows(base.nodes)
    certified = {(pkeys[u], pkeys[v]) for u, v in
                 zip(payload.src[free].tolist(), payload.dst[free].tolist(), strict=True)}
    checked = np.asarray(base.checked, dtype=bool)
    marked = 0
    for e in np.flatnonzero(~checked).tolist():
        if (bkeys[int(base.src[e])], bkeys[int(base.dst[e])]) in certified:
            checked[e] = True
            marked += 1
    base.checked = checked
    return marked
