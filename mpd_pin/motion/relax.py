"""Energy-aware relaxation of a path's via points (docs/design.md §9e).

A shortcut only chooses among points already on the path. Where the energy is spent —
for real motors mostly each joint's positive mechanical work: lifting, and joints working
against each other — a nearby via point can be much cheaper. :func:`relax_path` moves the
interior via points by a seeded stochastic local search:

* a round perturbs every other interior via point (odd ones, then even ones, so the
  neighbours of each moved point stay fixed while it moves): ``samples`` Gaussian
  candidates each, σ per joint a fraction of the joint's range;
* each candidate must be free and both its edges certified free; both edges are simulated
  rest to rest with the roadmap's timing in one batch for all candidates of the half-round,
  refused by the roadmap's rules;
* a via point moves to its best candidate when that lowers the two edges' E⁺.

σ halves after a round in which nothing moved. Every accepted edge passed the certified
check and has its own simulated energy, so the result's stop-and-go energy is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.motor import Drive
from .shortcut import _edge_costs

__all__ = ["RelaxResult", "relax_path"]


@dataclass
class RelaxResult:
    """The relaxed waypoints (m+1, nq) rad, their stop-and-go E⁺ per joint (J), the E⁺ of the
    path given (J), the via points moved, and the edges simulated."""

    waypoints: np.ndarray
    energy_per_joint: np.ndarray
    initial_energy: float
    moves: int
    edges_simulated: int

    @property
    def total_energy(self) -> float:
        return float(self.energy_per_joint.sum())


def relax_path(
    drive: Drive,
    waypoints: np.ndarray,
    checker,
    options,
    *,
    rounds: int = 6,
    samples: int = 12,
    sigma: float = 0.08,
    seed: int = 0,
    memo: dict | None = None,
) -> RelaxResult:
    """Move the interior via points of ``waypoints`` (a certified-free path, rad) where the
    stop-and-go E⁺ drops (module docstring). ``sigma``: the initial step as a fraction of
    each joint's range (joints without finite limits: of 2π rad); ``seed`` makes it
    reproducible; ``options``: the roadmap's RoadmapOptions."""
    rng = np.random.default_rng(seed)
    effort_on = bool(options.effort_limits)
    dt = float(options.dt)
    memo = {} if memo is None else memo
    W = np.array(waypoints, dtype=float)
    m = W.shape[0] - 1
    lo = np.asarray(drive.arm.model.lowerPositionLimit, float)
    hi = np.asarray(drive.arm.model.upperPositionLimit, float)
    finite = np.isfinite(lo) & np.isfinite(hi)
    span = np.where(finite, hi - lo, 2 * np.pi)
    lo_c, hi_c = np.where(finite, lo, -np.inf), np.where(finite, hi, np.inf)
    E, ok, simulated = _edge_costs(drive, W, np.arange(m), np.arange(1, m + 1), options, dt,
                                   effort_on, memo)
    seg = E  # (m, nq) per edge
    initial = float(seg.sum())
    moves = 0
    step = float(sigma)
    if m < 2 or not ok.all():
        return RelaxResult(W, seg.sum(axis=0), initial, 0, simulated)
    for _ in range(rounds):
        moved = 0
        for parity in (1, 2):
            idx = np.arange(parity, m, 2)  # interior via points 1 … m−1 of this parity
            if not idx.size:
                continue
            cand = W[idx, None, :] + rng.standard_normal((idx.size, samples, W.shape[1])) * (
                step * span)
            cand = np.clip(cand, lo_c, hi_c).reshape(-1, W.shape[1])
            owner = np.repeat(idx, samples)
            free = checker.is_free_batch(cand)
            if free.any():
                prev, nxt = W[owner - 1], W[owner + 1]
                both = np.concatenate([prev[free], cand[free]]), np.concatenate(
                    [cand[free], nxt[free]])
                f_idx = np.flatnonzero(free)
                certified = checker.edges_free(both[0], both[1], options.resolution)
                n = f_idx.size
                good = certified[:n] & certified[n:]
                free[f_idx[~good]] = False
            keep = np.flatnonzero(free)
            if not keep.size:
                continue
            P = np.vstack([W[owner[keep] - 1], cand[keep], W[owner[keep] + 1]])
            k = keep.size
            I = np.concatenate([np.arange(k), k + np.arange(k)])
            J = np.concatenate([k + np.arange(k), 2 * k + np.arange(k)])
            Ec, okc, fresh = _edge_costs(drive, P, I, J, options, dt, effort_on, memo)
            simulated += fresh
            total = np.where(okc[:k] & okc[k:], Ec[:k].sum(axis=1) + Ec[k:].sum(axis=1), np.inf)
            for v in idx:
                rows = np.flatnonzero(owner[keep] == v)
                if not rows.size:
                    continue
                b = rows[np.argmin(total[rows])]
                current = seg[v - 1].sum() + seg[v].sum()
                if total[b] < current * (1.0 - 1e-9):
                    W[v] = cand[keep[b]]
                    seg[v - 1], seg[v] = Ec[b], Ec[k + b]
                    moved += 1
        moves += moved
        if not moved:
            step /= 2
    return RelaxResult(W, seg.sum(axis=0), initial, moves, simulated)
