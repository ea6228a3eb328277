"""The roadmap path's time series, and the opt-in verify step (docs/design.md §3, §7c).

The roadmap's edge energies come from the batched cost (:class:`~mpd_pin.dynamics.EnergyCost`).
:func:`path_series` re-runs the path's edges through that same batched integrator,
recording every RK4 step (rows never mix, so each edge's energy is the roadmap's, bit for
bit): this is what the plots, the replay and the trajectory files show. The verify step
(:func:`verify_path`, ``[run] verify``, ``--verify``, ``verify=``; off by default, issue
34) re-simulates the path instead with the independent per-edge reference
:func:`simulate_edge` and reports how far the two integrators agree.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ..arm import Arm
from ..collision import edge_configurations
from ..dynamics.motor import Drive
from ..dynamics.simulate import integrate_batch, simulate_edge, step_count
from ..dynamics.supply import PER_JOINT, Supply, supply_energy
from ..planning.roadmap import Roadmap

__all__ = ["Verification", "path_series", "simulate_path", "straight_line_configurations",
           "verify_path"]


def _reference_edges(drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray, dt: float):
    """Each edge simulated alone by the per-edge reference :func:`simulate_edge`."""
    for q0, q1, dur in zip(Q0, Q1, T.tolist(), strict=True):
        yield simulate_edge(drive, q0, q1, float(dur), dt)


def _batched_edges(drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray, dt: float):
    """Each edge's recorded series from the batched integrator, the edges of one step
    h = T/N together, as :func:`~mpd_pin.dynamics.simulate.edge_outcomes` groups them
    (rows never mix: each edge's numbers are the roadmap's)."""
    N = np.array([step_count(float(x), dt) for x in T.tolist()], dtype=np.int64)
    groups: dict[float, list[int]] = {}
    for k, (dur, n) in enumerate(zip(T.tolist(), N.tolist(), strict=True)):
        groups.setdefault(float(dur) / int(n), []).append(k)
    sims: list[SimpleNamespace | None] = [None] * len(N)
    threads = int(os.cpu_count() or 1)
    for h, members in groups.items():
        idx = np.asarray(members)
        _, rec = integrate_batch(drive, Q0[idx], Q1[idx], T[idx], N[idx], h, threads,
                                 record=True)
        for j, k in enumerate(idx.tolist()):
            n = int(N[k]) + 1
            sims[k] = SimpleNamespace(
                t=np.arange(n) * h, q=rec.q[:n, j], v=rec.v[:n, j], i=rec.i[:n, j],
                V=rec.V[:n, j], energy_t=rec.energy_t[:n, j], energy=rec.energy_t[n - 1, j],
                bus_energy_t=rec.bus_energy_t[:n, j], bus_energy=rec.bus_energy_t[n - 1, j])
    yield from sims


def path_series(
    drive: Drive, roadmap: Roadmap, path: list[int], dt: float, *, reference: bool = False
) -> dict[str, np.ndarray]:
    """The series of ``path``: its edges through the batched integrator (``reference``
    False: the roadmap's own numbers, one batch per step size) or each through the
    per-edge reference :func:`simulate_edge` (True: the verify step), concatenated.

    Returns t (s), q (rad), v (rad/s), i (A), V (V), energy_t (cumulative E⁺ per joint, J),
    energy per edge (E⁺ per joint, J), bus_energy_t and edge_bus (the same for the shared
    bus's [B⁺, B⁻], J, docs/design.md §3i) and the node times (s). One time base: t = 0 at the
    start node, each later edge's first sample dropped (the previous edge's end stands for
    it); the start sample is the first edge's (at rest, holding: i = G(q)/(n·Kt)). A
    one-node path is that holding state alone (V = R·i with feed-forward, else 0).

    Continuous joints go the shorter way round (``Arm.edge_target``) and ``q`` is
    continuous in time (unwrapped): each edge's motion is shifted by the whole turns
    (2π multiples) its start node lies from where the previous edge ended, so ``q`` of a
    continuous joint may leave [−π, π] (docs/design.md §1d). Energies are unaffected.
    """
    nq = drive.nq
    ids = roadmap.edge_ids(path)
    q_start = roadmap.nodes[path[0]]
    i_hold = drive.holding_current(q_start)
    ts, qs, es = [np.zeros(1)], [q_start[None]], [np.zeros((1, nq))]
    V_hold = drive.R * i_hold if drive.feedforward else np.zeros(nq)
    vs, cs, Vs = [np.zeros((1, nq))], [i_hold[None]], [V_hold[None]]
    per_edge, per_edge_bus, bs = [], [], [np.zeros((1, 2))]
    t0, e0, b0 = 0.0, np.zeros(nq), np.zeros(2)
    node_times = [0.0]
    turns = np.zeros(nq)  # whole turns (rad) of the unwrapped motion (§1d)
    Q0 = roadmap.nodes[roadmap.src[ids]].reshape(len(ids), nq)
    ends = roadmap.nodes[roadmap.dst[ids]].reshape(len(ids), nq)
    Q1 = drive.arm.edge_target(Q0, ends) if len(ids) else ends
    T = np.asarray(roadmap.durations[ids], dtype=float)
    edges = (_reference_edges if reference else _batched_edges)(drive, Q0, Q1, T, dt)
    for q1, end, sim in zip(Q1, ends, edges, strict=True):
        if not per_edge:  # the start sample as simulated (its voltage is the controller's)
            Vs[0] = sim.V[:1]
        ts.append(t0 + sim.t[1:])
        qs.append(sim.q[1:] + turns)
        turns = turns + (q1 - end)
        vs.append(sim.v[1:])
        cs.append(sim.i[1:])
        Vs.append(sim.V[1:])
        es.append(e0 + sim.energy_t[1:])
        per_edge.append(sim.energy)
        bs.append(b0 + sim.bus_energy_t[1:])
        per_edge_bus.append(sim.bus_energy)
        t0 += float(sim.t[-1])
        e0 = e0 + sim.energy
        b0 = b0 + sim.bus_energy
        node_times.append(t0)
    return {
        "t": np.concatenate(ts),
        "q": np.concatenate(qs),
        "v": np.concatenate(vs),
        "i": np.concatenate(cs),
        "V": np.concatenate(Vs),
        "energy_t": np.concatenate(es),
        "edge_energy": np.array(per_edge).reshape(len(ids), nq),
        "bus_energy_t": np.concatenate(bs),
        "edge_bus": np.array(per_edge_bus).reshape(len(ids), 2),
        "node_times": np.array(node_times),
    }


def simulate_path(
    drive: Drive, roadmap: Roadmap, path: list[int], dt: float
) -> dict[str, np.ndarray]:
    """:func:`path_series` with every edge through the reference :func:`simulate_edge`."""
    return path_series(drive, roadmap, path, dt, reference=True)


def straight_line_configurations(
    roadmap: Roadmap, nodes: list[int], resolution: float, arm: Arm | None = None
) -> np.ndarray:
    """Configurations (rad) along the straight joint-space edges through ``nodes`` (the
    geometric path the quintic reference follows), ``resolution`` rad apart; with ``arm``
    the shorter way round on its continuous joints (``Arm.edge_target``, §1d)."""
    Q = [roadmap.nodes[nodes[0]][None]]
    for u, v in zip(nodes[:-1], nodes[1:], strict=True):
        q0, q1 = roadmap.nodes[u], roadmap.nodes[v]
        if arm is not None:
            q1 = arm.edge_target(q0, q1)
        Q.append(edge_configurations(q0, q1, resolution)[1:])
    return np.concatenate(Q)


@dataclass
class Verification:
    """The path simulated: ``series`` (see :func:`path_series`), the recomputed
    E⁺ per joint (J) and its agreement with the roadmap's energy; the recomputed bus
    energies [B⁺, B⁻] (J) and the supply that prices them (docs/design.md §3i)."""

    series: dict[str, np.ndarray]
    energy_per_joint: np.ndarray
    max_relative_difference: float
    bus_energy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    supply: Supply = PER_JOINT
    #: True when ``series`` and the energies come from the reference :func:`simulate_edge`
    #: (the verify step); False: from the batched integrator, the roadmap's own numbers
    checked: bool = True

    @property
    def total_energy(self) -> float:
        """The recomputed supply energy (J): Σ E⁺ with a supply per joint."""
        return float(supply_energy(self.supply, self.energy_per_joint, self.bus_energy))

    @property
    def duration(self) -> float:
        """Seconds from the start to the goal."""
        return float(self.series["t"][-1])

    def to_dict(self) -> dict:
        """Plain data for result.json (``verification``): ``energy_per_joint_simulate_edge``
        (J), ``max_relative_difference`` — max over joints of |recomputed − roadmap| /
        max(|roadmap|, 1e-300), 0 for a one-node path; ``null`` only if it overflows (a
        joint with zero roadmap energy but a recomputed one above ~1.8e8 J) — and
        ``duration`` (s)."""
        out = {
            "energy_per_joint_simulate_edge": self.energy_per_joint,
            "max_relative_difference": self.max_relative_difference,
            "duration": self.duration,
        }
        if not self.supply.is_default:
            out["total_energy_simulate_edge"] = self.total_energy
        return out


def verify_path(
    drive: Drive, roadmap: Roadmap, path: list[int], dt: float, energy: np.ndarray,
    *, reference: bool = True,
) -> Verification:
    """Simulate ``path`` (RK4 step ``dt`` s) and compare its E⁺ per joint with ``energy``
    (J, the roadmap's, unpenalised): with the reference :func:`simulate_edge` (the verify
    step), or with ``reference=False`` through the batched integrator the roadmap priced
    it with (the series for files and plots; the difference is then 0 up to the order of
    the sum over edges)."""
    series = path_series(drive, roadmap, path, dt, reference=reference)
    recomputed = series["edge_energy"].sum(axis=0)
    diff = (
        float(np.max(np.abs(recomputed - energy) / np.maximum(np.abs(energy), 1e-300)))
        if len(path) > 1
        else 0.0
    )
    return Verification(series=series, energy_per_joint=recomputed, max_relative_difference=diff,
                        bus_energy=series["edge_bus"].sum(axis=0), supply=drive.supply,
                        checked=reference)
