"""A timed trajectory priced as given (docs/design.md §9a, "timed").

``trajectory_energy(drive, W, execution="timed", times=t)`` runs the waypoints W
(m+1, nq) rad at the times t (m+1,) s — t[0] = 0, strictly increasing — with nothing
chosen by the package: the reference is the quintic interpolating spline in time through
(t_j, W_j) with q̇ = q̈ = 0 at both ends (:func:`~mpd_pin.motion.spline.via_spline` at the
given knot times, no stretch), simulated in one piece by the batched integrator of the
non-stop execution (:func:`~mpd_pin.motion.energy._simulate_nonstop`). Through two points
it is the rest-to-rest edge quintic of duration t[1].

The RK4 step is ``dt`` when t[-1] is a whole number of steps, else the largest step
below ``dt`` that divides t[-1] (t[-1] / ⌈t[-1]/dt⌉): the motion is simulated over exactly
[0, t[-1]].

The result is a :class:`~mpd_pin.motion.energy.MotionEnergy` with execution "timed": one
piece (0, m), no stops, ``duration`` = ``fastest`` = t[-1]; ``piece_durations`` holds the
m *segment* durations np.diff(t) (s) — the only place the times are kept, from which
:mod:`mpd_pin.motion.series` rebuilds t = [0, cumsum(piece_durations)]. It is infeasible
(``reason``) above the effort limit, beyond ``arrival_tolerance`` from the last waypoint,
above the velocity limits (when the options enforce them), longer than ``max_duration``,
or — with a ``checker`` — when its curve is not certified free; a timed motion is never
split into pieces: its timing is the input.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.simulate import step_count
from ..dynamics.supply import supply_energy
from .certify import first_failure, range_failure
from .nonstop import simulate_nonstop
from .outcome import MotionEnergy, joint_range, limit_reasons, range_reason, waypoint_array
from .screen import joint_limits
from .spline import ViaSpline, via_spline

__all__ = ["check_times", "check_timed_waypoints", "knot_times", "timed_energy",
           "timed_spline", "timed_step"]

#: Least number of samples of the spline's velocity for the velocity ratio, and per segment.
VELOCITY_SAMPLES = 4000
SAMPLES_PER_SEGMENT = 16


def check_timed_waypoints(drive: Drive, waypoints: Any) -> np.ndarray:
    """``waypoints`` as an (m+1, nq) float array, continuous joints unwrapped the shorter
    way round (docs/design.md §1d); unlike the untimed executions, repeated points are kept
    (with times, a repeated point is a dwell). ValueError naming the row (from 1) for NaN,
    a wrong shape or fewer than two points."""
    W = waypoint_array(drive, waypoints)
    if W.shape[0] < 2:
        raise ValueError(f"a timed trajectory needs at least two waypoints, got {W.shape[0]}")
    return W


def check_times(times: Any, n: int) -> np.ndarray:
    """``times`` (s) as an (n,) float array: one per waypoint, the first 0, strictly
    increasing. ValueError naming the row (counting from 1) that is wrong."""
    try:
        t = np.asarray(times, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"times must be numbers (s), one per waypoint, got {times!r}") from None
    if t.ndim != 1:
        raise ValueError(f"times must hold one time (s) per waypoint: {n} values, got shape "
                         f"{t.shape}")
    if t.size != n:
        which = (f"time row {t.size + 1} (counting from 1) is missing" if t.size < n else
                 f"time row {n + 1} (counting from 1) has no waypoint")
        raise ValueError(f"times has {t.size} values for {n} waypoints: {which}")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(f"time row {int(bad[0]) + 1} (counting from 1) is NaN or infinity")
    if t[0] != 0.0:
        raise ValueError(f"time row 1 (counting from 1) is {t[0]:g} s; a timed trajectory "
                         "starts at 0 s")
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if back.size:
        k = int(back[0]) + 1
        raise ValueError(f"time row {k + 1} (counting from 1), {t[k]:.9g} s, is not after row "
                         f"{k}, {t[k - 1]:.9g} s: times must increase strictly")
    return t


def knot_times(segment_durations: Any) -> np.ndarray:
    """The knot times t (s) of a timed motion from its ``piece_durations`` (the segment
    durations, s): [0, cumsum(...)]."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(segment_durations, dtype=float))])


def timed_spline(W: np.ndarray, t: np.ndarray) -> ViaSpline:
    """The quintic spline through ``W`` at the times ``t`` (s), at rest with zero
    acceleration at both ends; its ``unit_duration`` is t[-1], so simulated at duration
    t[-1] it runs exactly at the given times."""
    return via_spline(W, t)


def timed_step(duration: float, dt: float) -> float:
    """The RK4 step (s) for a timed motion of ``duration`` (s): ``dt`` if the duration is a
    whole number of steps (:func:`~mpd_pin.dynamics.simulate.step_count`), else
    duration / ⌈duration / dt⌉, the largest step below ``dt`` that divides it."""
    try:
        step_count(duration, dt)
        return float(dt)
    except ValueError:
        return float(duration) / max(1, math.ceil(float(duration) / float(dt) - 1e-9))


def timed_energy(drive: Drive, waypoints: Any, times: Any, *, dt: float, options: Any,
                 checker: Any = None, max_duration: float | None = None) -> MotionEnergy:
    """The :class:`~mpd_pin.motion.energy.MotionEnergy` (execution "timed") of the arm
    running ``waypoints`` (rad) at ``times`` (s) as given (module docstring). ``options``:
    a :class:`~mpd_pin.planning.roadmap.RoadmapOptions` (limits, arrival tolerance,
    certification resolution); ``dt``: the RK4 step (s, :func:`timed_step`)."""
    W = check_timed_waypoints(drive, waypoints)
    t = check_times(times, W.shape[0])
    T = float(t[-1])
    vs = timed_spline(W, t)
    h = timed_step(T, dt)
    E, _, end_err, _, peak, B = simulate_nonstop(drive, vs, np.array([T]), h)
    vlim, elim = joint_limits(drive)
    m = W.shape[0] - 1
    samples = max(VELOCITY_SAMPLES, SAMPLES_PER_SEGMENT * m + 1)
    vel = vs.peak_speed_ratio(vlim, samples)
    eff = float(np.max(peak[0] / elim))
    err = float(np.max(np.abs(end_err[0])))
    reasons = limit_reasons(options, eff, err, vel, "the last waypoint")
    if max_duration is not None and T > max_duration + 1e-9:
        reasons.append(f"takes {T:.3f} s > max_duration {max_duration:g} s")
    if checker is not None:
        fail = first_failure(checker, vs, options.resolution)
        if fail is not None:
            k = int(np.clip(np.searchsorted(t, fail, side="right") - 1, 0, m - 1))
            reasons.append(f"the curve is not collision-free at t = {fail:.3f} s (between "
                           f"waypoints {k + 1} and {k + 2}, counting from 1)")
    out = range_failure(vs, *joint_range(drive.arm))
    if out is not None:
        k = int(np.clip(np.searchsorted(t, out, side="right") - 1, 0, m - 1))
        reasons.append(f"the curve leaves the joint range at t = {out:.3f} s (between "
                       f"waypoints {k + 1} and {k + 2}, counting from 1): "
                       f"{range_reason(drive.arm, vs.spline(np.array([out])), 'the curve')}")
    energy = E[0].copy()
    bus = B[0].copy()
    total = float(supply_energy(drive.supply, energy, bus))
    feasible = not reasons
    return MotionEnergy("timed", W, energy, total, T, err, vel, eff, feasible, 0, [(0, m)],
                        np.diff(t), "; ".join(reasons),
                        energy_by_execution={"timed": total if feasible else None},
                        fastest=T, bus_energy=bus, supply=drive.supply)
