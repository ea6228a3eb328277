"""Stiff motor currents: the exponential current update of an RK4 stage (docs/design.md §3e).

Datasheet motors have L/R far below a 5 ms step; for those joints every RK4 stage takes
its current from the variation-of-constants formula instead of the explicit RK4 stage,
so any L/R works at any step. Used by :mod:`mpd_pin.dynamics.simulate`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .motor import Drive

__all__ = ["STIFF_LIMIT", "CurrentStep", "current_step", "current_model"]


#: A joint whose electrical pole satisfies dt·R/L above this gets the exponential current
#: update of :class:`CurrentStep`; at or below it, classical RK4 (docs/design.md §3e). 2.5 is
#: just inside RK4's real-axis stability limit (2.785), so every case classical RK4 could
#: integrate before is integrated exactly as before; measured on a planar 3-link arm with a
#: 100:1 servo, classical RK4 at dt·R/L = 1–2.4 was closer to a resolved reference (≤ 7e-5
#: relative in E⁺) than the exponential update (≤ 3.6e-4).
STIFF_LIMIT = 2.5


@dataclass(frozen=True)
class CurrentStep:
    """Coefficients of the exponential current update for one step size ``h`` (s).

    The current equation is linear in i: di/dt = λ i + N with λ = −R/L (1/s) and
    forcing N = (V − n Ke q̇)/L (A/s), where V depends on (t, q, q̇) only. Joints with
    h·R/L ≤ :data:`STIFF_LIMIT` (``stiff`` False) use classical RK4 unchanged. For the
    others, every RK4 stage first gets its (q, q̇) from the classical stage formula,
    then its current from the variation-of-constants formula with N interpolated
    linearly between the step start and the stage (docs/design.md §3e):

        i(t + c h) = e^{c z} i(t) + c h [φ₁(c z) N(t) + φ₂(c z) (N_c − N(t))],
        φ₁(z) = (e^z − 1)/z,  φ₂(z) = (e^z − 1 − z)/z²,  z = λ h,

    and the step's final current the same with c = 1 and N at the final (q, q̇). It is
    exact for a constant or linear forcing at any h·R/L, and as L/R → 0 each stage's
    current tends to the quasi-static (V − n Ke q̇)/R at that stage's own state, with
    the first-order lag −(L/R)·dN/dt·(L/R)… carried by the slope term.
    """

    stiff: np.ndarray  # (nq,) bool
    rate: np.ndarray  # R/L of the stiff joints (1/s), shape (s,)
    inv_L: np.ndarray  # 1/L of the stiff joints (1/H)
    decay_half: np.ndarray  # e^{z/2}
    decay: np.ndarray  # e^{z}
    w0_half: np.ndarray  # (h/2)(φ₁ − φ₂) at z/2: weight of N(t)
    wc_half: np.ndarray  # (h/2) φ₂ at z/2: weight of N at the stage
    w0: np.ndarray
    wc: np.ndarray

    @property
    def any(self) -> bool:
        return bool(self.stiff.any())

    def half(self, i0: np.ndarray, n0: np.ndarray, nc: np.ndarray) -> np.ndarray:
        """Current at t + h/2 (A) from i(t), N(t) and N at the stage."""
        return self.decay_half * i0 + self.w0_half * n0 + self.wc_half * nc

    def full(self, i0: np.ndarray, n0: np.ndarray, nc: np.ndarray) -> np.ndarray:
        """Current at t + h (A) from i(t), N(t) and N at the stage (or the end state)."""
        return self.decay * i0 + self.w0 * n0 + self.wc * nc


def _phi(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """φ₁(z), φ₂(z) for z ≤ −STIFF_LIMIT/2 (no cancellation at such z)."""
    ez = np.exp(z)
    return (ez - 1.0) / z, (ez - 1.0 - z) / (z * z)


def current_step(drive: Drive, h: float) -> CurrentStep:
    """:class:`CurrentStep` coefficients of ``drive`` at RK4 step ``h`` (s)."""
    rate_all = np.asarray(drive.R / drive.L, dtype=float)
    stiff = h * rate_all > STIFF_LIMIT
    rate = rate_all[stiff]
    z = -rate * h
    p1h, p2h = _phi(0.5 * z)
    p1, p2 = _phi(z)
    return CurrentStep(
        stiff=stiff,
        rate=rate,
        inv_L=1.0 / np.asarray(drive.L, dtype=float)[stiff],
        decay_half=np.exp(0.5 * z),
        decay=np.exp(z),
        w0_half=0.5 * h * (p1h - p2h),
        wc_half=0.5 * h * p2h,
        w0=h * (p1 - p2),
        wc=h * p2,
    )


def current_model(drive: Drive, dt: float) -> dict:
    """Which current integration runs at step ``dt`` (s): recorded in result files."""
    cs = current_step(drive, float(dt))
    stiff = np.flatnonzero(cs.stiff).tolist()
    return {
        "name": "rk4" if not stiff else (
            "exponential" if len(stiff) == drive.nq else "rk4+exponential"
        ),
        "stiff_joints": stiff,
        "stiff_limit_dt_R_over_L": STIFF_LIMIT,
        "electrical_time_constants_s": (drive.L / drive.R).tolist(),
    }
