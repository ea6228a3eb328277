"""Energy-aware shortcutting of a joint-space path (docs/design.md §9e).

Energy is not monotone in length, so a shortcut is kept only when the simulated energy
drops, never because the path got shorter. One round:

1. densify the path: its waypoints plus ``interior`` evenly spaced points inside every
   segment (so shortcuts may start and end inside edges, like OMPL's partial shortcuts);
2. every pair (i < j) of these points is a candidate straight edge, priced first by its
   perfect-tracking energy (:func:`ideal_costs`: the feed-forward's V·i, no simulation);
3. lazily (:func:`lazy_sequence`, as LazySP): the edges of the DP's answer are certified
   (:meth:`~mpd_pin.collision.CollisionChecker.edges_free`; a sub-segment of a certified
   segment needs no check) and simulated rest to rest with the roadmap's timing
   (:func:`~mpd_pin.dynamics.simulate.edge_outcomes`), refused when they collide, miss the
   effort limits or the arrival tolerance, exactly as roadmap edges are, and take their
   simulated E⁺; the DP runs again until its answer is certified and simulated throughout;
4. a dynamic programme over the ordered points keeps the cheapest subsequence from the
   first point to the last with at most as many edges as the path had:
   E*(c, j) = min_{i<j} E*(c−1, i) + E(i → j) — without the cap the cheapest answer under
   a fixed edge duration is many tiny edges, a slower motion with more stops (measured on
   quickstart: 65 waypoints, 57 s, against the roadmap path's 10 and 9 s).

Rounds repeat on the result until the energy stops falling by more than ``tol`` (relative).
Every edge of the result has passed the certified check and has its own simulated energy;
the stop-and-go energy of the result is the DP's value, exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.supply import PER_JOINT, Supply, supply_energy, supply_power

__all__ = ["ShortcutResult", "densify", "shortcut_path", "time_shortcut"]


@dataclass
class ShortcutResult:
    """The shortcut path (waypoints (m+1, nq) rad), its stop-and-go E⁺ (J) per joint,
    the supply energy of the path it started from (J), the rounds run, the pairs certified
    and the edges simulated, the bus energies [B⁺, B⁻] (J) and the supply that prices it
    (docs/design.md §3i)."""

    waypoints: np.ndarray
    energy_per_joint: np.ndarray
    initial_energy: float
    rounds: int
    pairs_checked: int
    edges_simulated: int
    bus_energy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    supply: Supply = PER_JOINT

    @property
    def total_energy(self) -> float:
        """The supply energy (J): Σ E⁺ with a supply per joint."""
        return float(supply_energy(self.supply, self.energy_per_joint, self.bus_energy))


def densify(W: np.ndarray, interior: int) -> tuple[np.ndarray, np.ndarray]:
    """The waypoints with ``interior`` evenly spaced points inside each segment, and the
    index of the segment each point lies on (its start waypoint)."""
    m = W.shape[0] - 1
    f = np.arange(interior + 1) / (interior + 1)
    pts = W[:-1, None, :] + f[None, :, None] * (W[1:] - W[:-1])[:, None, :]
    pts = pts.reshape(-1, W.shape[1])
    seg = np.repeat(np.arange(m), interior + 1)
    return np.vstack([pts, W[-1:]]), np.append(seg, m)


def segment_costs(drive: Drive, P: np.ndarray, I: np.ndarray, J: np.ndarray, options, dt: float,
                effort_on: bool, memo: dict | None = None):
    """E⁺ per joint (K, nq) of the straight edges P[I] → P[J] timed by the roadmap rule,
    whether each is feasible by the roadmap's rules (docs/design.md §4e), how many were
    simulated (the others come from ``memo``, shared with
    :func:`~mpd_pin.motion.energy.trajectory_energy`), their bus energies (K, 2) and
    their supply energies (K,) J (the cost, docs/design.md §3i)."""
    from ..planning.roadmap import feasibility
    from .energy import cached_outcomes

    Q0, Q1 = P[I], P[J]
    memo = {} if memo is None else memo
    T, _ = options.timing(Q0, Q1, drive.arm.model.velocityLimit)
    before = sum(1 for k in memo if k[0] == "outcome")
    out = cached_outcomes(drive, Q0, Q1, T, dt, memo)
    fresh = sum(1 for k in memo if k[0] == "outcome") - before
    over, missed = feasibility(out, options, drive.arm.model)
    ok = ~missed & (~over if effort_on else True)
    E, B = np.asarray(out.energy), np.asarray(out.bus_energy)
    return E, ok, fresh, B, supply_energy(drive.supply, E, B)


def _dp(n: int, I: np.ndarray, J: np.ndarray, cost: np.ndarray, max_edges: int) -> list[int]:
    """Cheapest increasing index sequence 0 → n−1 of at most ``max_edges`` edges over the
    edges (I[e] < J[e], cost[e]). The cap keeps a shortcut from buying energy with extra
    stops: under a fixed edge duration, more edges would mean a slower motion."""
    best = np.full((max_edges + 1, n), np.inf)
    best[0, 0] = 0.0
    prev = np.full((max_edges + 1, n), -1)
    fin = np.isfinite(cost)
    I, J, cost = I[fin], J[fin], cost[fin]
    for c in range(1, max_edges + 1):
        cand = best[c - 1, I] + cost
        order = np.lexsort((cand, J))  # per end point, cheapest first
        first = np.ones(order.size, dtype=bool)
        first[1:] = J[order][1:] != J[order][:-1]
        e = order[first]
        best[c, J[e]] = cand[e]
        prev[c, J[e]] = I[e]
    c = int(np.argmin(best[:, -1]))
    if not np.isfinite(best[c, -1]):
        raise ValueError("no feasible sequence through the path's own segments")
    seq = [n - 1]
    while c > 0:
        seq.append(int(prev[c, seq[-1]]))
        c -= 1
    return seq[::-1]


#: Relative accuracy trusted to the perfect-tracking screen: a lazy DP stops when the best
#: answer it could still find is not cheaper than its simulated one by more than this.
SCREEN_TOL = 5e-3


def ideal_costs(drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray,
                samples: int = 64) -> np.ndarray:
    """Perfect-tracking supply energy (J; E⁺ summed over joints with a supply per joint,
    §3i) of the rest-to-rest quintic edges Q0[k] → Q1[k] lasting T[k] s (docs/design.md
    §3f): ∫ max(V_ff·i_ff, 0) dt (or the shared bus's power) by Simpson's rule over
    ``samples`` + 1 points of normalised time — no simulation. A screen: measured
    within 0.3 % of the simulated E⁺ (rank correlation 1.0) on 60 random edges each of the
    Panda, UR5 (``sized``) and quickstart; the choices it makes are simulated after."""
    from ..dynamics.simulate import feedforward_batch

    K = Q0.shape[0]
    if K == 0:
        return np.zeros(0)
    tau = np.linspace(0.0, 1.0, samples + 1)
    tau2 = np.broadcast_to(tau[:, None], (tau.size, K))
    out = np.empty(K)
    step = max(1, (1 << 18) // (tau.size * Q0.shape[1]))  # bound the tables' memory
    for a in range(0, K, step):
        b = min(K, a + step)
        Vff, iff = feedforward_batch(drive, Q0[a:b], Q1[a:b] - Q0[a:b], tau2[:, a:b],
                                      np.asarray(T[a:b], float))
        P = supply_power(drive.supply, Vff * iff)  # (nt, k)
        w = np.ones(tau.size)
        w[1:-1:2], w[2:-1:2] = 4.0, 2.0
        out[a:b] = (w @ P) / (3.0 * samples) * np.asarray(T[a:b], float)
    return out


def lazy_sequence(drive: Drive, P: np.ndarray, I: np.ndarray, J: np.ndarray, known_free,
                  checker, options, dt: float, effort_on: bool, memo: dict, max_edges: int):
    """The cheapest sequence over the candidate edges P[I] → P[J] (I < J) of at most
    ``max_edges`` edges, lazily (LazySP): the DP runs on perfect-tracking screens
    (:func:`ideal_costs`); the edges of its answer are certified (unless ``known_free``)
    and simulated, refused ones leave, simulated ones take their true E⁺, and the DP runs
    again until its answer is certified and simulated throughout. Returns (sequence, E⁺
    per joint of its edges (m, nq), pairs certified, edges simulated, bus energies of its
    edges (m, 2))."""
    T = options.timing(P[I], P[J], drive.arm.model.velocityLimit)[0]
    cost = ideal_costs(drive, P[I], P[J], T)
    free = np.asarray(known_free, dtype=bool).copy()  # certified (or known) free
    tried = free.copy()
    done: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    index = {(int(i), int(j)): e for e, (i, j) in enumerate(zip(I, J, strict=True))}
    checked = simulated = 0
    while True:
        seq = _dp(P.shape[0], I, J, cost, max_edges)
        e = np.array([index[(a, b)] for a, b in zip(seq[:-1], seq[1:], strict=True)])
        unc = e[~tried[e]]
        if unc.size:
            ok = checker.edges_free(P[I[unc]], P[J[unc]], options.resolution)
            checked += unc.size
            tried[unc] = True
            free[unc] = ok
            cost[unc[~ok]] = np.inf
            if not ok.all():
                continue
        uns = np.array([x for x in e.tolist() if x not in done], dtype=np.int64)
        if uns.size:
            E, ok, fresh, B, C = segment_costs(drive, P, I[uns], J[uns], options, dt, effort_on,
                                             memo)
            simulated += fresh
            for r, x in enumerate(uns.tolist()):
                done[x] = (E[r], B[r])
            cost[uns] = np.where(ok, C, np.inf)
            if not ok.all():
                continue
            # the true costs may change the DP's answer: run it again, unless the best it
            # could now find is within the screen's accuracy of this simulated answer
            again = _dp(P.shape[0], I, J, cost, max_edges)
            e2 = [index[(a, b)] for a, b in zip(again[:-1], again[1:], strict=True)]
            here = cost[e].sum()
            if again == seq or cost[e2].sum() > here - SCREEN_TOL * abs(here):
                return (seq, *_rows(done, e), checked, simulated)
            continue
        return (seq, *_rows(done, e), checked, simulated)


def _rows(done: dict, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """E⁺ per joint (m, nq) and bus energies (m, 2) of the simulated edges ``e``."""
    return (np.array([done[x][0] for x in e.tolist()]),
            np.array([done[x][1] for x in e.tolist()]))


def shortcut_path(
    drive: Drive,
    waypoints: np.ndarray,
    checker,
    options,
    *,
    dt: float | None = None,
    interior: int = 3,
    max_rounds: int = 4,
    tol: float = 1e-3,
    memo: dict | None = None,
) -> ShortcutResult:
    """Shorten ``waypoints`` (a certified-free path, (m+1, nq) rad) for stop-and-go E⁺ by
    the rounds of the module docstring; ``options``: the roadmap's
    :class:`~mpd_pin.planning.roadmap.RoadmapOptions` (timing, limits, resolution).
    ``memo`` (a dict) keeps simulated edges across rounds and calls."""
    dt = float(options.dt if dt is None else dt)
    effort_on = bool(options.effort_limits)
    memo = {} if memo is None else memo
    W = np.asarray(waypoints, dtype=float)
    m = W.shape[0] - 1
    max_edges = m  # never more stops than the path had
    E0, ok0, simulated, B0, C0 = segment_costs(drive, W, np.arange(m), np.arange(1, m + 1),
                                             options, dt, effort_on, memo)
    initial = float(np.where(ok0, C0, np.inf).sum())

    def total(E: np.ndarray, B: np.ndarray) -> float:
        return float(supply_energy(drive.supply, E, B))

    current = (W, E0.sum(axis=0), B0.sum(axis=0)) if ok0.all() else None
    checked = rounds = 0
    for _ in range(max_rounds):
        P, _ = densify(W, interior)
        I, J = np.triu_indices(P.shape[0], 1)
        seq, E, B, c, fresh = lazy_sequence(drive, P, I, J, J == I + 1, checker, options, dt,
                                            effort_on, memo, max_edges)
        checked += c
        simulated += fresh
        energy, bus = E.sum(axis=0), B.sum(axis=0)
        rounds += 1
        if current is None:
            improved = True
        else:
            before = total(current[1], current[2])
            improved = total(energy, bus) < before - tol * abs(before)
        if improved:
            current = (P[seq], energy, bus)
            W = P[seq]
        if not improved or len(seq) == 2:
            break
    return ShortcutResult(current[0], current[1], initial, rounds, checked, simulated,
                          current[2], drive.supply)


def _dag_shortest(n: int, I: np.ndarray, J: np.ndarray, cost: np.ndarray) -> list[int]:
    """The cheapest increasing index sequence 0 → n−1 over the edges (I[e] < J[e], listed
    in ``np.triu_indices`` order, cost[e]); ValueError when none is finite."""
    dist = np.full(n, np.inf)
    dist[0] = 0.0
    prev = np.full(n, -1)
    start = 0
    for i in range(n - 1):
        stop = start + (n - 1 - i)  # the edges from i: a block in triu order
        if np.isfinite(dist[i]):
            j, c = J[start:stop], dist[i] + cost[start:stop]
            better = c < dist[j]
            dist[j[better]] = c[better]
            prev[j[better]] = i
        start = stop
    if not np.isfinite(dist[-1]):
        raise ValueError("no certified sequence through the path's own segments")
    seq = [n - 1]
    while seq[-1] != 0:
        seq.append(int(prev[seq[-1]]))
    return seq[::-1]


def time_shortcut(waypoints: np.ndarray, checker, options, velocity_limit: np.ndarray, *,
                  interior: int = 3, max_rounds: int = 3, tol: float = 1e-3) -> np.ndarray:
    """Shorten a certified-free path (``waypoints`` (m+1, nq) rad) for time, not energy
    (docs/design.md §9f): a round densifies it as :func:`shortcut_path` does and keeps the
    subsequence whose straight segments need the least time at the velocity limits,
    Σ max_k |Δq_k| / v_lim,k (s; the knot spacing of the non-stop spline, §9b; joints
    without a finite limit count at 1 rad/s), certifying the segments of each answer
    lazily (``checker.edges_free`` at ``options.resolution``; a failing one leaves) until
    it is certified throughout. Rounds repeat while that time falls by more than ``tol``
    (relative). Nothing is simulated: the result is a candidate for a cycle time, priced
    afterwards like every other."""
    vl = np.asarray(velocity_limit, dtype=float)
    vl = np.where(np.isfinite(vl) & (vl > 0), vl, 1.0)
    W = np.asarray(waypoints, dtype=float)

    def seconds(Q: np.ndarray) -> float:
        return float(np.sum(np.max(np.abs(np.diff(Q, axis=0)) / vl, axis=1)))

    if checker is None or W.shape[0] < 3:
        return W
    for _ in range(max_rounds):
        P, _ = densify(W, interior)
        n = P.shape[0]
        I, J = np.triu_indices(n, 1)
        # + 1 ms per segment (unit_knots' floor): of collinear points, the fewest
        cost = np.max(np.abs(P[J] - P[I]) / vl, axis=1) + 1e-3
        tried = J == I + 1  # sub-segments of the certified path
        index = {(int(i), int(j)): e for e, (i, j) in enumerate(zip(I, J, strict=True))}
        while True:
            seq = _dag_shortest(n, I, J, cost)
            e = np.array([index[(a, b)] for a, b in zip(seq[:-1], seq[1:], strict=True)])
            unc = e[~tried[e]]
            if not unc.size:
                break
            ok = checker.edges_free(P[I[unc]], P[J[unc]], options.resolution)
            tried[unc] = True
            cost[unc[~ok]] = np.inf
        new = P[seq]
        if seconds(new) >= seconds(W) * (1.0 - tol):
            break
        W = new
        if W.shape[0] == 2:
            break
    return W
