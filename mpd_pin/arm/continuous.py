"""Continuous joints: angles in [−π, π], edges the shorter way round (docs/design.md §1d).

A URDF ``continuous`` joint is planned as one angle per joint in [−π, π] rad (nodes,
start, goal, files). The edge u → v moves such a joint to the *unwrapped* target
``q_u + wrap(q_v − q_u)`` with ``wrap(x) = (x + π) mod 2π − π`` in [−π, π), so it turns
by at most π; every other joint moves to ``q_v`` itself. Neighbours are found with the
periodic distance on those joints (a ``cKDTree`` with ``boxsize`` 2π on them).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["wrap_angle", "edge_target", "periodic_difference", "nearest_neighbours"]

TWO_PI = 2.0 * np.pi


def wrap_angle(x: np.ndarray) -> np.ndarray:
    """``x`` (rad) wrapped into [−π, π): ``(x + π) mod 2π − π``."""
    return np.mod(np.asarray(x, dtype=float) + np.pi, TWO_PI) - np.pi


def _mask(periodic: np.ndarray | None, nq: int) -> np.ndarray | None:
    if periodic is None:
        return None
    mask = np.asarray(periodic, dtype=bool)
    if mask.shape != (nq,):
        raise ValueError(f"periodic mask must have {nq} entries, got shape {mask.shape}")
    return mask if mask.any() else None


def edge_target(Q0: np.ndarray, Q1: np.ndarray, periodic: np.ndarray | None) -> np.ndarray:
    """The end the edge ``Q0 → Q1`` moves to (rad; (nq,) or (K, nq) like ``Q1``): ``Q1``,
    except on the ``periodic`` joints (bool mask, (nq,)) ``Q0 + wrap(Q1 − Q0)``.

    Without periodic joints ``Q1`` is returned as it is (the same array), so the edges
    of arms without continuous joints are bit-identical to straight ones. Idempotent:
    ``edge_target(Q0, edge_target(Q0, Q1))`` equals ``edge_target(Q0, Q1)``.
    """
    Q1 = np.asarray(Q1, dtype=float)
    mask = _mask(periodic, Q1.shape[-1])
    if mask is None:
        return Q1
    Q0 = np.asarray(Q0, dtype=float)
    out = np.array(Q1, dtype=float, copy=True)
    out[..., mask] = Q0[..., mask] + wrap_angle(Q1[..., mask] - Q0[..., mask])
    return out


def periodic_difference(
    Q0: np.ndarray, Q1: np.ndarray, periodic: np.ndarray | None
) -> np.ndarray:
    """``edge_target(Q0, Q1) − Q0`` (rad): the joint moves of the edges ``Q0 → Q1``."""
    return edge_target(Q0, Q1, periodic) - np.asarray(Q0, dtype=float)


def nearest_neighbours(
    nodes: np.ndarray, k: int, periodic: np.ndarray | None = None
) -> np.ndarray:
    """(n, k + 1) indices of each node's ``k + 1`` nearest nodes (itself included), by
    the joint-space Euclidean distance with the ``periodic`` joints measured round the
    circle (``cKDTree`` ``boxsize`` = 2π on them; their values are shifted by π and
    wrapped into [0, 2π), which changes no distance)."""
    nodes = np.asarray(nodes, dtype=float)
    mask = _mask(periodic, nodes.shape[1])
    if mask is None:
        tree = cKDTree(nodes)
    else:
        pts = nodes.copy()
        pts[:, mask] = np.mod(pts[:, mask] + np.pi, TWO_PI)
        pts[:, mask] = np.where(pts[:, mask] >= TWO_PI, 0.0, pts[:, mask])
        tree = cKDTree(pts, boxsize=np.where(mask, TWO_PI, 0.0))
        nodes = pts
    _, nbr = tree.query(nodes, k=k + 1)
    return np.asarray(nbr).reshape(nodes.shape[0], k + 1)
