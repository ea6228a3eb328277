"""Perfect-tracking screens of a spline stretched in time (docs/design.md §9c, §9e).

What a motion would cost and demand with the feed-forward tracking it exactly, without a
simulation: :func:`ideal_nonstop` (the supply energy over durations, and the peak torque)
and :func:`effort_bound` (the shortest uniform stretch within the effort limits);
:func:`joint_limits` are the URDF limits they are measured against.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.supply import supply_power
from ..dynamics.tracking import feedforward_tables
from .spline import ViaSpline

__all__ = ["joint_limits", "effort_bound", "ideal_nonstop", "EFFORT_SAMPLES"]


def joint_limits(drive: Drive) -> tuple[np.ndarray, np.ndarray]:
    """(velocity limits rad/s, effort limits N·m), inf where the URDF gives none."""
    model = drive.arm.model

    def clean(x):
        x = np.asarray(x, dtype=float)
        return np.where(np.isfinite(x) & (x > 0), x, np.inf)

    return clean(model.velocityLimit), clean(model.effortLimit)


#: Points (at unit stretch) at which :func:`effort_bound` evaluates the torque.
EFFORT_SAMPLES = 4000


def effort_bound(drive: Drive, vs: ViaSpline, samples: int = EFFORT_SAMPLES) -> float:
    """The shortest duration (s) at which the perfect-tracking torque of the spline ``vs``,
    stretched uniformly, stays within the effort limits at ``samples`` points of its path
    (docs/design.md §9c); 0 without finite limits, inf when holding the arm still exceeds
    one.

    Stretched to T, with s = t_m/T, the feed-forward torque at a point of the path is
    τ(s) = a s² + b s + g: g = RNEA(q, 0, 0) holds the arm, a = RNEA(q, q', q'') − g is the
    inertial and Coriolis part (q', q'' per unit time, the armature in the model), b = n²B q'
    the viscous part. |τ_k(s)| ≤ τ_lim,k holds from s = 0 up to the first positive root of
    τ_k(s) = ±τ_lim,k; the least root over points and joints is s*, and t_m/s* the bound."""
    _, elim = joint_limits(drive)
    cols = np.isfinite(elim)
    if not cols.any():
        return 0.0
    tau = np.linspace(0.0, vs.unit_duration, samples)
    q, d1, d2 = (vs.spline(tau, nu)[:, None, :] for nu in range(3))
    zero = np.zeros_like(q)
    kt = drive.torque_per_amp
    _, i_hold = feedforward_tables(drive, q, zero, zero, zero)
    _, i_move = feedforward_tables(drive, q, d1, d2, zero)
    g = (i_hold[:, 0] * kt)[:, cols]
    b = (drive.damping * d1[:, 0])[:, cols]
    a = (i_move[:, 0] * kt)[:, cols] - g - b
    L = elim[cols]
    if np.any(np.abs(g) > L):
        return float("inf")
    s_star = np.inf
    for c in (g - L, g + L):  # τ = +τ_lim and τ = −τ_lim
        disc = b * b - 4.0 * a * c
        real = disc >= 0.0
        root = np.sqrt(np.where(real, disc, 0.0))
        # the two roots of a s² + b s + c without cancellation: p/a and c/p
        p = -0.5 * (b + np.where(b >= 0.0, root, -root))
        with np.errstate(divide="ignore", invalid="ignore"):
            for r in (p / a, c / p):
                r = np.where(real & np.isfinite(r) & (r > 0.0), r, np.inf)
                s_star = min(s_star, float(r.min()))
    return 0.0 if not np.isfinite(s_star) else float(vs.unit_duration / s_star)


def ideal_nonstop(drive: Drive, vs: ViaSpline, durations: np.ndarray, samples: int = 256
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Perfect-tracking supply energy (J; Σ E⁺ over joints with a supply per joint, §3i) of
    the spline ``vs`` stretched to each duration (s), by Simpson's rule over ``samples`` +
    1 points, and the peak feed-forward torque per joint (N·m), (K, nq) — a screen for the
    duration search (§9c)."""
    T = np.asarray(durations, dtype=float)
    tau = np.linspace(0.0, 1.0, samples + 1)
    t = tau[:, None] * T[None, :]
    Qr, Vr, Ar, Jr = vs.derivatives(t, T)
    Vff, iff = feedforward_tables(drive, Qr, Vr, Ar, Jr)
    P = supply_power(drive.supply, Vff * iff)
    w = np.ones(tau.size)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    energy = (w @ P) / (3.0 * samples) * T
    return energy, np.max(np.abs(iff), axis=0) * drive.torque_per_amp
