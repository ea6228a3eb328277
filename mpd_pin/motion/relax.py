"""Energy-aware relaxation of a path's via points (docs/design.md §9e).

A shortcut only chooses among points already on the path. Where the energy is spent —
for real motors mostly each joint's positive mechanical work: lifting, and joints working
against each other — a nearby via point can be much cheaper. :func:`relax_path` moves the
interior via points by a seeded stochastic local search:

* a round perturbs every other interior via point (odd ones, then even ones, so the
  neighbours of each moved point stay fixed while it moves): ``samples`` Gaussian
  candidates each, σ per joint a fraction of the joint's range;
* the free candidates are screened by the perfect-tracking energy of their two edges
  (:func:`~mpd_pin.motion.shortcut.ideal_costs`, no simulation); of the ``keep`` best
  that beat the via point's present two edges, the cheapest whose two edges are both
  certified free is where the via point moves;
* σ halves after a round in which nothing moved;
* after the last round the relaxed path is simulated rest to rest with the roadmap's
  timing in one batch (refused by the roadmap's rules) and kept only if its E⁺ really fell.

Every kept edge passed the certified check and has its own simulated energy, so the
result's stop-and-go energy is exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.supply import PER_JOINT, Supply, supply_energy
from .shortcut import ideal_costs, segment_costs

__all__ = ["RelaxResult", "relax_path"]


@dataclass
class RelaxResult:
    """The relaxed waypoints (m+1, nq) rad, their stop-and-go E⁺ per joint (J), the supply
    energy of the path given (J), the via points moved, the edges simulated, the bus
    energies [B⁺, B⁻] (J) and the supply that prices them (docs/design.md §3i)."""

    waypoints: np.ndarray
    energy_per_joint: np.ndarray
    initial_energy: float
    moves: int
    edges_simulated: int
    bus_energy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    supply: Supply = PER_JOINT

    @property
    def total_energy(self) -> float:
        """The supply energy (J): Σ E⁺ with a supply per joint."""
        return float(supply_energy(self.supply, self.energy_per_joint, self.bus_energy))


def relax_path(
    drive: Drive,
    waypoints: np.ndarray,
    checker,
    options,
    *,
    rounds: int = 6,
    samples: int = 32,
    keep: int = 3,
    sigma: float = 0.08,
    seed: int = 0,
    memo: dict | None = None,
) -> RelaxResult:
    """Move the interior via points of ``waypoints`` (a certified-free path, rad) where the
    stop-and-go E⁺ drops (module docstring). Each via point draws ``samples`` candidates,
    screened by their perfect-tracking energy (:func:`ideal_costs`); the ``keep`` best
    free ones are certified and simulated. ``sigma``: the initial step as a fraction of
    each joint's range (joints without finite limits: of 2π rad); ``seed`` makes it
    reproducible; ``options``: the roadmap's RoadmapOptions."""
    rng = np.random.default_rng(seed)
    effort_on = bool(options.effort_limits)
    dt = float(options.dt)
    memo = {} if memo is None else memo
    W = np.array(waypoints, dtype=float)
    m = W.shape[0] - 1
    nq = W.shape[1]
    vlim = drive.arm.model.velocityLimit
    lo = np.asarray(drive.arm.model.lowerPositionLimit, float)
    hi = np.asarray(drive.arm.model.upperPositionLimit, float)
    finite = np.isfinite(lo) & np.isfinite(hi)
    span = np.where(finite, hi - lo, 2 * np.pi)
    lo_c, hi_c = np.where(finite, lo, -np.inf), np.where(finite, hi, np.inf)
    seg, ok, simulated, bus, cost = segment_costs(drive, W, np.arange(m), np.arange(1, m + 1),
                                                options, dt, effort_on, memo)
    initial = float(cost.sum())
    moves = 0
    step = float(sigma)

    def result(W: np.ndarray, moves: int) -> RelaxResult:
        return RelaxResult(W, seg.sum(axis=0), initial, moves, simulated, bus.sum(axis=0),
                           drive.supply)

    if m < 2 or not ok.all():
        return result(W, 0)

    def screen_path(Q: np.ndarray) -> np.ndarray:
        return ideal_costs(drive, Q[:-1], Q[1:], options.timing(Q[:-1], Q[1:], vlim)[0])

    start, screen = W.copy(), screen_path(W)
    for _ in range(rounds):
        moved = 0
        for parity in (1, 2):
            idx = np.arange(parity, m, 2)  # interior via points 1 … m−1 of this parity
            if not idx.size:
                continue
            cand = W[idx, None, :] + rng.standard_normal((idx.size, samples, nq)) * (step * span)
            cand = np.clip(cand, lo_c, hi_c).reshape(-1, nq)
            owner = np.repeat(idx, samples)
            free = np.flatnonzero(checker.is_free_batch(cand))
            if not free.size:
                continue
            prev, nxt, c = W[owner[free] - 1], W[owner[free] + 1], cand[free]
            T0 = options.timing(prev, c, vlim)[0]
            T1 = options.timing(c, nxt, vlim)[0]
            both = ideal_costs(drive, np.vstack([prev, c]), np.vstack([c, nxt]),
                               np.concatenate([T0, T1]))
            e0, e1 = both[: free.size], both[free.size :]
            best = []
            for v in idx:  # the ``keep`` cheapest by the screen that beat the via point now
                rows = np.flatnonzero(owner[free] == v)
                rows = rows[e0[rows] + e1[rows] < (screen[v - 1] + screen[v]) * (1 - 1e-9)]
                best.extend(rows[np.argsort((e0 + e1)[rows])[:keep]].tolist())
            if not best:
                continue
            best = np.asarray(best, dtype=np.int64)
            k = best.size
            certified = checker.edges_free(np.vstack([prev[best], c[best]]),
                                           np.vstack([c[best], nxt[best]]), options.resolution)
            good = best[certified[:k] & certified[k:]]
            for v in idx:
                rows = good[owner[free][good] == v]
                if not rows.size:
                    continue
                b = rows[np.argmin((e0 + e1)[rows])]
                W[v] = c[b]
                screen[v - 1], screen[v] = e0[b], e1[b]
                moved += 1
        moves += moved
        if not moved:
            step /= 2
    if moves:  # the relaxed path, simulated in one batch: kept if its E⁺ really fell
        E, ok, fresh, B, C = segment_costs(drive, W, np.arange(m), np.arange(1, m + 1), options,
                                         dt, effort_on, memo)
        simulated += fresh
        if ok.all() and C.sum() < cost.sum() - 1e-9 * abs(cost.sum()):
            seg, bus = E, B
        else:
            W, moves = start, 0
    return result(W, moves)
