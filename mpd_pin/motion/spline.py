"""A non-stop reference through via points: a quintic spline in time (docs/design.md §9b).

q(t) passes through the via points q_0 … q_m at knot times 0 = t_0 < … < t_m and starts
and ends at rest with zero acceleration (q̇ = q̈ = 0 at both ends), so it joins the holding
state exactly as the rest-to-rest quintic of an edge does; with two via points it *is*
that quintic. Degree 5 keeps the jerk q⃛ — and so the feed-forward's τ̇ and V_ff —
continuous. The spline is built once on "unit" knot times and stretched to any duration
T (q_T(t) = q(t·t_m/T)), so the duration search never rebuilds it; its geometry in joint
space does not depend on T, so one collision certificate serves every duration.

Certification (:func:`arc_boxes`): on a sub-interval [a, b] of one polynomial piece the
curve lies in the convex hull of its Bernstein coefficients on [a, b], which gives a
rigorous joint-space box per sub-arc; :meth:`~mpd_pin.collision.CollisionChecker.boxes_clear`
certifies such boxes whole.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb, factorial

import numpy as np
from scipy.interpolate import make_interp_spline

__all__ = ["ViaSpline", "via_spline", "arc_boxes", "unit_knots"]

DEGREE = 5


def unit_knots(waypoints: np.ndarray, velocity_limit: np.ndarray) -> np.ndarray:
    """Knot times (s) at unit stretch: each segment takes max_k |Δq_k| / v_lim,k, the time
    it needs at the velocity limit (joints without a finite positive limit count at
    1 rad/s); a segment of zero length gets 1 ms. Cumulative, from 0."""
    vl = np.asarray(velocity_limit, dtype=float)
    vl = np.where(np.isfinite(vl) & (vl > 0), vl, 1.0)
    seg = np.max(np.abs(np.diff(waypoints, axis=0)) / vl, axis=1)
    return np.concatenate([[0.0], np.cumsum(np.maximum(seg, 1e-3))])


@dataclass(frozen=True)
class ViaSpline:
    """The unit spline (``knots`` in s at unit stretch) through ``waypoints`` (m+1, nq)."""

    waypoints: np.ndarray
    knots: np.ndarray
    spline: object  # scipy BSpline, degree 5, vector valued
    #: True for an optimised curve (docs/design.md §9g): ``spline`` is its own control
    #: polygon, and ``waypoints`` are only its points at the breakpoints
    optimised: bool = False

    @property
    def unit_duration(self) -> float:
        """t_m (s): the duration at unit stretch."""
        return float(self.knots[-1])

    def derivatives(self, t: np.ndarray, duration: float | np.ndarray) -> tuple[np.ndarray, ...]:
        """q (rad), q̇ (rad/s), q̈ (rad/s²), q⃛ (rad/s³) at times ``t`` (s) of the motion
        stretched to ``duration`` (s; a scalar, or one per column of a 2-D ``t``); at T the
        derivatives of the last piece (q⃛ ≠ 0, as for the edge quintic), past T the motion
        holds its last via point at rest. Shapes: ``t.shape + (nq,)``."""
        t = np.asarray(t, dtype=float)
        T = np.asarray(duration, dtype=float)
        scale = self.unit_duration / T  # dτ/dt
        tau = np.minimum(t * scale, self.unit_duration)
        # at t = T itself the piece's own one-sided derivatives (the jerk is not 0 there),
        # as the edge quintic is evaluated; past T the motion holds its end at rest
        moving = (t * scale <= self.unit_duration * (1.0 + 1e-12))[..., None]
        out = []
        for nu in range(4):
            d = self.spline(tau, nu)
            if nu:
                d = np.where(moving, d * (scale**nu)[..., None] if np.ndim(scale) else
                             d * scale**nu, 0.0)
            out.append(d)
        return tuple(out)

    def peak_speed_ratio(self, velocity_limit: np.ndarray, samples: int = 4000) -> float:
        """max over joints and ``samples`` points of |q̇_k| / v_lim,k at unit stretch: the
        motion stretched to T has ratio (this)·t_m/T."""
        vl = np.asarray(velocity_limit, dtype=float)
        vl = np.where(np.isfinite(vl) & (vl > 0), vl, np.inf)
        tau = np.linspace(0.0, self.unit_duration, samples)
        return float(np.max(np.abs(self.spline(tau, 1)) / vl))


def via_spline(waypoints: np.ndarray, knots: np.ndarray) -> ViaSpline:
    """The quintic interpolating spline through ``waypoints`` at ``knots`` (s) with
    q̇ = q̈ = 0 at both ends (scipy ``make_interp_spline``, k = 5)."""
    W = np.asarray(waypoints, dtype=float)
    nq = W.shape[1]
    zero = np.zeros(nq)
    bc = ([(1, zero), (2, zero)], [(1, zero), (2, zero)])
    spl = make_interp_spline(np.asarray(knots, float), W, k=DEGREE, bc_type=bc)
    return ViaSpline(W, np.asarray(knots, float), spl)


def _breakpoints(vs: ViaSpline) -> np.ndarray:
    """The distinct knots of the B-spline inside [0, t_m], ends included (s)."""
    t = np.unique(vs.spline.t)
    return t[(t >= 0.0) & (t <= vs.unit_duration)]


def arc_boxes(vs: ViaSpline, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint-space boxes (centre, half-width), each (A, nq) rad, that contain the curve on
    the sub-intervals [a_j, b_j] (unit time, each inside one polynomial piece): the
    per-joint range of the curve's degree-5 Bernstein coefficients on [a_j, b_j]."""
    a = np.asarray(a, dtype=float)
    h = np.asarray(b, dtype=float) - a
    # Taylor coefficients at a (one-sided: the piece that starts at or contains a)
    d = [vs.spline(a, r) * (h**r / factorial(r))[:, None] for r in range(DEGREE + 1)]
    coef = []
    for j in range(DEGREE + 1):
        coef.append(sum(comb(j, r) / comb(DEGREE, r) * d[r] for r in range(j + 1)))
    coef = np.stack(coef)  # (6, A, nq)
    lo, hi = coef.min(axis=0), coef.max(axis=0)
    return (lo + hi) / 2.0, (hi - lo) / 2.0


def pieces(vs: ViaSpline) -> tuple[np.ndarray, np.ndarray]:
    """The polynomial pieces [a, b] of the spline (unit time, s)."""
    bp = _breakpoints(vs)
    return bp[:-1], bp[1:]
