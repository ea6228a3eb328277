"""How a roadmap's edges are priced for the search when the supply is not the paper's
(docs/design.md §3i): the supply energy, reweighted by a node potential so that the
searches see costs >= 0 even when regeneration makes some edges pay back.

* :func:`attach_supply` sets a roadmap's supply and potential: the physical φ(q) =
  ρ PE(q) + Σ ½ L i_hold(q)² (:func:`~mpd_pin.dynamics.bound.node_potential`), plus, when
  every edge is evaluated, Johnson's shift (:func:`johnson_shift`);
* :func:`reweighted` gives c + φ(src) − φ(dst) and refuses a real negative
  (:class:`NegativeCostError`; a lazy run then evaluates every edge, ``app/plan.py``).
  Both are defined with the :class:`~mpd_pin.planning.roadmap_data.Roadmap` whose
  :meth:`~mpd_pin.planning.roadmap_data.Roadmap.edge_costs` applies them, and named here
  too.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.bound import node_potential
from ..dynamics.supply import supply_energy
from .roadmap_data import NegativeCostError, Roadmap, reweighted

__all__ = ["NegativeCostError", "attach_supply", "johnson_shift", "reweighted"]


def attach_supply(roadmap: Roadmap, drive) -> Roadmap:
    """``roadmap`` priced with ``drive.supply``: sets :attr:`Roadmap.supply` and, when the
    supply regenerates, the node potential (docs/design.md §3i). In place; returned."""
    supply = drive.supply
    roadmap.supply = supply
    if roadmap.bus is None and not supply.is_default:
        raise ValueError("this roadmap file holds no shared-bus energies (written before "
                         "them); delete it to rebuild")
    roadmap.potential = None
    if supply.needs_potential:
        phi = node_potential(drive, roadmap.nodes)
        known = roadmap.evaluated
        if known.all() and roadmap.num_edges:  # every cost known: make them all >= 0 exactly
            c = supply_energy(supply, roadmap.energy, roadmap.bus_energies())
            phi = phi + johnson_shift(c + phi[roadmap.src] - phi[roadmap.dst], roadmap.src,
                                      roadmap.dst, roadmap.num_nodes)
        roadmap.potential = phi
    return roadmap


def johnson_shift(reduced: np.ndarray, src: np.ndarray, dst: np.ndarray, n: int) -> np.ndarray:
    """ψ (n,) J with ``reduced`` + ψ(src) − ψ(dst) >= 0 on every edge (Johnson's
    reweighting: ψ is the Bellman–Ford distance from a virtual node joined to every node at
    cost 0); all 0 when no cost is negative. ValueError on a negative cycle: motors that
    return more than a closed motion took (docs/design.md §3i)."""
    reduced = np.asarray(reduced, float)
    with np.errstate(invalid="ignore"):
        if not np.any(reduced < 0):
            return np.zeros(n)
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import NegativeCycleError, bellman_ford

    ok = np.isfinite(reduced)
    rows = np.r_[src[ok], np.full(n, n)]
    cols = np.r_[dst[ok], np.arange(n)]
    # built from (data, (i, j)): an explicit 0 stays an edge; the roadmap has no duplicates
    G = csr_matrix((np.r_[reduced[ok], np.zeros(n)], (rows, cols)), shape=(n + 1, n + 1))
    try:
        dist = bellman_ford(G, directed=True, indices=n)
    except NegativeCycleError:
        raise ValueError("a closed motion on this roadmap returns more energy than it takes "
                         "(a negative cycle): the motors' Ke/Kt differ between joints; use "
                         "regeneration = 0 or motors with one Ke/Kt") from None
    return np.asarray(dist[:n], float)
