"""One spline simulated at several durations (docs/design.md §9c): the RK4 inputs of a via
spline stretched uniformly, its batched simulation, and durations on the dt grid — the core
that non-stop pricing (:mod:`mpd_pin.motion.energy`), timed trajectories
(:mod:`mpd_pin.motion.timed`) and the optimisation (:mod:`mpd_pin.motion.optimize`) share."""

from __future__ import annotations

import os

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.simulate import step_count
from ..dynamics.tracking import feedforward_tables, integrate_tables, model_pool
from .spline import ViaSpline

__all__ = ["nonstop_tables", "simulate_nonstop", "snap_steps", "fastest_by_velocity"]


def nonstop_tables(drive: Drive, vs: ViaSpline, durations: np.ndarray, dt: float):
    """The RK4 inputs of the spline ``vs`` stretched to each of ``durations`` (s, on the
    dt grid): W (nt, K, nq) V, i0 (K, nq) A, steps N (K,), and the end (K, nq) rad."""
    T = np.asarray(durations, dtype=float)
    N = np.array([step_count(x, dt) for x in T.tolist()], dtype=np.int64)
    n_max = int(N.max())
    half = np.arange(2 * n_max + 1)[:, None] * (dt / 2.0) * np.ones((1, T.size))
    Qr, Vr, Ar, Jr = vs.derivatives(half, T)
    if drive.feedforward:
        W, i_ff = feedforward_tables(drive, Qr, Vr, Ar, Jr)
        i0 = i_ff[0].copy()
    else:
        W = np.zeros_like(Qr)
        rest = np.zeros_like(Qr[:1])
        _, i_hold = feedforward_tables(drive, Qr[:1], rest, rest, rest)  # G(q0)/(n Kt)
        i0 = i_hold[0].copy()
    W += drive.kp_vec * Qr
    W += drive.kd_vec * Vr
    end = np.broadcast_to(vs.waypoints[-1], (T.size, drive.nq)).copy()
    return W, i0, N, end


def simulate_nonstop(drive: Drive, vs: ViaSpline, durations: np.ndarray, dt: float,
                      record: bool = False):
    """Outcomes (E⁺, E, end error, end velocity, peak torque; each (K, nq)) of the spline
    stretched to each duration, in one batch; with ``record`` also the series."""
    W, i0, N, end = nonstop_tables(drive, vs, durations, dt)
    threads = int(os.cpu_count() or 1)
    Q0 = np.broadcast_to(vs.waypoints[0], end.shape).copy()
    return integrate_tables(drive, Q0, end, W, i0, N, dt, threads, model_pool(drive, threads),
                            record=record)


def snap_steps(T: np.ndarray | float, dt: float) -> np.ndarray:
    """Durations rounded up to whole RK4 steps (s)."""
    return np.ceil(np.asarray(T, dtype=float) / dt - 1e-9) * dt


def fastest_by_velocity(vs: ViaSpline, vlim: np.ndarray, options, dt: float) -> float:
    """The shortest duration (s) the velocity limits ``vlim`` (rad/s) allow the spline
    ``vs``, on the dt grid and not below ``min_duration``."""
    ratio = vs.peak_speed_ratio(vlim) * 1.002 if options.velocity_limits else 0.0
    return float(snap_steps(max(ratio * vs.unit_duration, options.min_duration), dt))
