"""The time series of a motion, for files, plots and replay (docs/design.md §9d).

Both executions are re-simulated with the batched integrator recording every RK4 step
(:func:`~mpd_pin.dynamics.tracking.integrate_tables`), except an optimised motion, whose
pricing simulation recorded its series (``MotionEnergy.recorded``, the same computation):
the stop-and-go edges in one batch
(rows never mix, so each equals :func:`~mpd_pin.dynamics.simulate.edge_outcomes` for that
edge), each non-stop piece at its chosen duration. A timed motion (execution "timed",
:mod:`mpd_pin.motion.timed`) keeps its segment durations in ``piece_durations``: its knot
times are rebuilt from them, t = [0, cumsum], and its spline simulated at the step
:func:`~mpd_pin.motion.timed.timed_step` gives. One time base:
t = 0 at the start, each later piece's first sample dropped (the previous piece's end
stands for it), as :func:`mpd_pin.app.verify.simulate_path` does for roadmap paths.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.simulate import step_count
from .nonstop import simulate_nonstop
from .outcome import MotionEnergy
from .spline import unit_knots, via_spline
from .timed import knot_times, timed_spline, timed_step

__all__ = ["motion_series"]


def _stop_edges(drive: Drive, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray, dt: float):
    """(t, q, v, i, V, energy_t, bus_energy_t, via times) of each rest-to-rest quintic edge,
    one batch."""
    import os

    from ..dynamics.simulate import integrate_batch

    N = np.array([step_count(float(x), dt) for x in T], dtype=np.int64)
    _, rec = integrate_batch(drive, Q0, Q1, T, N, dt, int(os.cpu_count() or 1), record=True)
    for k, n in enumerate(N.tolist()):
        t = np.arange(n + 1) * dt
        yield (t, rec.q[: n + 1, k], rec.v[: n + 1, k], rec.i[: n + 1, k], rec.V[: n + 1, k],
               rec.energy_t[: n + 1, k], rec.bus_energy_t[: n + 1, k], np.array([0.0, t[-1]]))


def _pieces(drive: Drive, m: MotionEnergy, dt: float):
    """(t, q, v, i, V, energy_t, bus_energy_t, via times) of each piece of ``m``, each from
    t = 0."""
    W = m.waypoints
    if m.execution == "stop":
        P = np.asarray(m.pieces)
        yield from _stop_edges(drive, W[P[:, 0]], W[P[:, 1]],
                               np.asarray(m.piece_durations, float), dt)
        return
    if m.curve is not None:  # an optimised motion follows its own spline (§9g)
        T = float(m.piece_durations[0])
        rec = m.recorded  # the simulation that priced it, when kept at this duration
        if rec is None or rec.q.shape[0] != step_count(T, dt) + 1:
            _, rec = simulate_nonstop(drive, m.curve, np.array([T]), dt, record=True)
        t = np.arange(rec.q.shape[0]) * dt
        yield (t, rec.q[:, 0], rec.v[:, 0], rec.i[:, 0], rec.V[:, 0], rec.energy_t[:, 0],
               rec.bus_energy_t[:, 0], m.curve.knots * (T / m.curve.unit_duration))
        return
    if m.execution == "timed":  # one piece; piece_durations are its segment durations
        knots = knot_times(m.piece_durations)
        T = float(knots[-1])
        h = timed_step(T, dt)
        vs = timed_spline(W, knots)
        _, rec = simulate_nonstop(drive, vs, np.array([T]), h, record=True)
        t = np.arange(rec.q.shape[0]) * h
        yield (t, rec.q[:, 0], rec.v[:, 0], rec.i[:, 0], rec.V[:, 0], rec.energy_t[:, 0],
               rec.bus_energy_t[:, 0], knots)
        return
    vlim = np.asarray(drive.arm.model.velocityLimit, dtype=float)
    vlim = np.where(np.isfinite(vlim) & (vlim > 0), vlim, 1.0)
    for (a, b), T in zip(m.pieces, m.piece_durations, strict=True):
        vs = via_spline(W[a : b + 1], unit_knots(W[a : b + 1], vlim))
        _, rec = simulate_nonstop(drive, vs, np.array([float(T)]), dt, record=True)
        n = rec.q.shape[0]
        t = np.arange(n) * dt
        yield (t, rec.q[:, 0], rec.v[:, 0], rec.i[:, 0], rec.V[:, 0], rec.energy_t[:, 0],
               rec.bus_energy_t[:, 0], vs.knots * (float(T) / vs.unit_duration))


def motion_series(drive: Drive, m: MotionEnergy, dt: float) -> dict[str, np.ndarray]:
    """t (s), q (rad), v (rad/s), i (A), V (V), energy_t (cumulative E⁺ per joint, J),
    bus_energy_t (cumulative [B⁺, B⁻] of the shared bus, J, docs/design.md §3i),
    piece_energy (E⁺ per joint of each piece, J) and node_times (s, when the motion passes
    each waypoint) of the motion ``m`` (RK4 step ``dt`` s)."""
    cols: dict[str, list] = {k: [] for k in ("t", "q", "v", "i", "V", "energy_t",
                                              "bus_energy_t")}
    t0, e0, b0 = 0.0, np.zeros(drive.nq), np.zeros(2)
    node_times = [0.0]
    per_piece = []
    for k, (t, q, v, i, V, et, bt, knots) in enumerate(_pieces(drive, m, dt)):
        s = 0 if k == 0 else 1
        for key, arr in zip(cols, (t0 + t, q, v, i, V, e0 + et, b0 + bt), strict=True):
            cols[key].append(arr[s:])
        node_times.extend((t0 + knots[1:]).tolist())
        per_piece.append(et[-1])
        t0 += float(t[-1])
        e0 = e0 + et[-1]
        b0 = b0 + bt[-1]
    out = {k: np.concatenate(v) for k, v in cols.items()}
    out["piece_energy"] = np.array(per_piece)
    out["node_times"] = np.array(node_times)
    return out
