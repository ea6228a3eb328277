"""A cheap lower bound of an edge's E⁺ from the energy balance (docs/design.md §4g).

The edge cost is E⁺ = Σ_k ∫ max(V_k i_k, 0) dt. Per joint k, from
``L di/dt = V − R i − n Ke q̇`` multiplied by i, over any interval [a, b]:

    ∫ₐᵇ V_k i_k dt = ∫ₐᵇ R i_k² dt + ½ L (i_k(b)² − i_k(a)²) + n Ke ∫ₐᵇ q̇_k i_k dt,   (1)

and the last term is ρ_k ∫ₐᵇ q̇_k τ_k dt, the joint's mechanical work times ρ_k = Ke/Kt,
with τ_k = n Kt i_k = (M q̈ + C q̇ + G)_k + n²B q̇_k (M with the rotor inertia).

``mode="per_joint"`` (the default with feed-forward). For every split of [0, T] into
pieces I_p, ∫ max(f, 0) ≥ Σ_p max(∫_{I_p} f, 0) per joint (the integral of a positive
part is at least the positive part of the integral, piece by piece), so

    E⁺ ≥ Σ_k Σ_p max(∫_{I_p} V_k i_k dt, 0),

nothing cancels between joints or between the pieces. The pieces are the two halves
of the quintic, whose acceleration changes sign at T/2: the power that speeds a joint
up and the power given back while it slows down fall into different halves, and only
the positive ones count. On each piece, (1) is evaluated with ∫ R i² ≥ R Σ_j (∫ i φ_j
dt)² (Bessel on Legendre polynomials φ_j orthonormal on the piece; j = 0 is
Cauchy–Schwarz, R (∫ i dt)²/|I_p|). The charges ∫ i φ_j dt, the work ∫ q̇_k τ_k dt and
the current at T/2 are taken along the quintic reference, i = τ_ff/(n Kt) (RNEA at
Gauss–Legendre nodes on each half); i(0), i(T) are the holding currents at the nodes.
The sum over joints and halves is multiplied by 1 − ``margin`` (``MARGIN``).

*Proven*: E⁺ ≥ Σ max(∫ V i, 0) per joint and piece, identity (1), the Bessel step.
*Estimated*: the charges, the work and i(T/2) are the reference's, not the simulated
motion's — equal within the tracking error. With feed-forward that error is small
(measured: the reference's own E⁺ within 1.3 % of the simulated one; a joint's estimate
at most 0.35 % of the edge's E⁺ above that joint's E⁺) unless the supply voltage clips:
a joint whose reference voltage reaches ``SATURATION_FRACTION`` of its limit at a node
lags, and its halves were measured up to 11 % above its E⁺. Such a joint gets the
one-piece version, max(∫₀ᵀ V_k i_k dt, 0) with the same estimates over the whole edge,
where the work given back while slowing down cancels against the work put in (no
violation measured). The bound is therefore not proven (``proven = False``); the lazy
planner checks every evaluated edge against it and corrects a violation
(:mod:`mpd_pin.planning.lazy`).

``mode="sum"`` (the default without feed-forward, and the model of earlier versions):
E⁺ ≥ Σ_k ∫ V_k i_k, where with one ρ on every joint the work terms sum to ρ times the
mechanical power, whose integral over a rest-to-rest edge is

    ρ (ΔKE + ΔPE + Σ_k n²B ∫ q̇_k² dt) ≥ ρ (ΔPE + Σ_k n²B Δq_k² / T)

(ΔKE ≥ 0 from rest; Cauchy–Schwarz on the friction); the copper term as above on one
piece, the inductor with the holding currents at both ends. The arm's potential energy
enters once for all joints, so a joint that lowers the arm cancels one that lifts it: on
motors where gravity dominates (the ``sized`` preset) this bound is mostly near 0. The
energy identity, E⁺ ≥ ∫ V i, ΔKE ≥ 0, both Cauchy–Schwarz steps and the PE term (to the
arrival tolerance, subtracted as a margin) are exact inequalities; the charges are the
reference's (estimated), and with Ke/Kt differing between joints the smallest ratio is
used for the mechanical term, which is then not a proven bound either.
``rigorous=True`` (the default for a drive without feed-forward, whose motion can lag
far behind the reference) keeps only the proven terms of this mode: ρ (ΔPE + friction −
margin) − Σ ½ L i(0)², a bound for every feasible edge when Ke/Kt is the same on all
joints.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin

from .motor import Drive

__all__ = ["EnergyBound", "MODES", "node_potential"]

#: Gauss–Legendre nodes per edge (``per_joint``: half of them on each half of the edge).
QUADRATURE_POINTS = 8
#: Legendre moments of the current in the copper bound (1: Cauchy–Schwarz on ∫ i dt).
DEFAULT_MOMENTS = 1
#: The bound's models: per joint and half-edge (default with feed-forward), or the
#: energy balance summed over the joints (default without).
MODES = ("per_joint", "sum")
#: ``per_joint``: the estimate is multiplied by 1 − MARGIN, a guard for the difference
#: between the reference and the simulated motion (docs/design.md §4g).
MARGIN = 0.02
#: ``per_joint``: a joint whose feed-forward voltage reaches this fraction of its supply
#: limit at a quadrature node is bounded over the whole edge instead of per half.
SATURATION_FRACTION = 0.9


class EnergyBound:
    """Lower bound (J) of Σ_k E⁺_k for rest-to-rest quintic edges of ``drive``.

    ``bound(Q0, Q1, durations) -> (K,)``, vectorised over edges; the terms are
    :meth:`parts`. ``mode`` is ``"per_joint"`` or ``"sum"`` (see the module docstring;
    default: ``"sum"`` when ``rigorous``, else ``"per_joint"``). ``arrival_tolerance``
    (rad) widens the ``sum`` mode's PE and friction terms to any end state within that
    distance of the end node (the feasibility rule of docs/design.md §4e).
    """

    def __init__(self, drive: Drive, *, arrival_tolerance: float = 0.01,
                 moments: int = DEFAULT_MOMENTS, points: int = QUADRATURE_POINTS,
                 rigorous: bool | None = None, mode: str | None = None,
                 margin: float = MARGIN) -> None:
        self.drive = drive
        #: only the proven terms: no copper estimate, the inductor at −½ L i(0)² (the
        #: default without feed-forward, where the reference says little about the current)
        self.rigorous = (not drive.feedforward) if rigorous is None else bool(rigorous)
        if mode is None:
            mode = "sum" if self.rigorous else "per_joint"
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        if mode == "per_joint" and self.rigorous:
            raise ValueError("rigorous=True keeps only the proven terms of mode='sum'; "
                             "mode='per_joint' rests on the reference motion")
        #: "per_joint" or "sum"
        self.mode = mode
        if not 0.0 <= float(margin) < 1.0:
            raise ValueError(f"margin must be in [0, 1), got {margin!r}")
        #: ``per_joint``: the estimate is scaled by 1 − margin (a guard on the reference)
        self.margin = float(margin) if mode == "per_joint" else 0.0
        #: pieces of [0, T] bounded separately (2: the halves; 1 in ``sum`` mode)
        self.pieces = 2 if mode == "per_joint" else 1
        self.tol = float(arrival_tolerance)
        if int(moments) < 1:
            raise ValueError(f"moments must be ≥ 1, got {moments!r}")
        self.moments = int(moments)
        if int(points) < self.pieces:
            raise ValueError(f"points must be ≥ {self.pieces} in mode {mode!r}, got {points!r}")
        x, w = np.polynomial.legendre.leggauss(int(points) // self.pieces)
        local = 0.5 * (x + 1.0)
        # nodes on τ ∈ [0, 1], piece after piece, and their weights within a piece
        self._tau = np.concatenate([(p + local) / self.pieces for p in range(self.pieces)])
        self._w = 0.5 * w
        # orthonormal Legendre polynomials on a piece at its nodes, times the weights
        self._phi = np.stack([
            np.sqrt(2 * j + 1) * np.polynomial.legendre.legval(x, [0] * j + [1])
            for j in range(self.moments)
        ]) * self._w
        ratio = drive.Ke / drive.Kt
        #: ρ = Ke/Kt used for the ``sum`` mode's mechanical term (the smallest over the joints)
        self.rho = float(ratio.min())
        #: True when every joint has the same Ke/Kt (the mechanical term sums exactly)
        self.uniform_ratio = bool(np.allclose(ratio, ratio[0], rtol=1e-12, atol=0.0))
        #: True only for the rigorous terms with one Ke/Kt on every joint; otherwise the
        #: bound is an estimate (tracking error), checked at run time
        self.proven = self.rigorous and self.uniform_ratio
        self._gmax = _gravity_torque_bound(drive.arm.model)

    def describe(self) -> dict:
        """Plain data for result files."""
        out = {
            "model": "energy-balance",
            "mode": self.mode,
            "pieces": self.pieces,
            "quadrature_points": int(self._tau.size),
            "current_moments": self.moments,
            "ke_over_kt": self.rho,
            "uniform_ke_over_kt": self.uniform_ratio,
            "rigorous": self.rigorous,
            "proven": self.proven,
        } | ({} if self.drive.supply.is_default else {"supply": self.drive.supply.describe()})
        if self.mode == "per_joint":
            out["margin"] = self.margin
            out["saturation_fraction"] = SATURATION_FRACTION
        return out

    def parts(self, Q0: np.ndarray, Q1: np.ndarray, durations: np.ndarray) -> dict:
        """The bound's terms (J).

        ``sum`` mode: ``copper``, ``inductor`` (K, nq) and ``mechanical`` (K,) (ρ·(ΔPE +
        friction) less the tolerance margin); the bound is max(0, their sum).
        ``per_joint`` mode: ``copper``, ``inductor``, ``mechanical`` (ρ_k × the joint's
        work), each (pieces, K, nq), per half-edge; ``saturating`` (K, nq) bool, the
        joints bounded over the whole edge; ``joint`` (K, nq), each joint's bound (≥ 0),
        which sum to the edge's.
        """
        Q0 = np.asarray(Q0, float)
        Q1 = np.asarray(Q1, float)
        T = np.asarray(durations, float)
        if self.mode == "per_joint":
            return self._per_joint_parts(Q0, Q1, T)
        d = self.drive
        K, nq = Q0.shape
        DQ = Q1 - Q0
        i0 = _gravity(d, Q0) / d.torque_per_amp  # the initial holding current (exact)
        if self.rigorous:  # ∫ R i² ≥ 0 and ½ L i(T)² ≥ 0
            copper = np.zeros((K, nq))
            inductor = -0.5 * d.L * i0**2
        else:
            # ∫ i φ_j dt (A·√s), (moments, K, nq); Bessel: ∫ i² dt ≥ Σ_j (∫ i φ_j dt)²
            tau_r, _, _ = self._reference(Q0, DQ, T)
            charge = self._charges(tau_r, T)[:, 0] / d.torque_per_amp
            copper = d.R * (charge**2).sum(axis=0)
            i1 = _gravity(d, Q1) / d.torque_per_amp
            inductor = 0.5 * d.L * (i1**2 - i0**2)
        pe = _potential(d, Q1) - _potential(d, Q0)
        move = np.maximum(np.abs(DQ) - self.tol, 0.0)
        friction = (d.damping * move**2).sum(axis=1) / T
        margin = self.tol * self._gmax.sum()  # |PE(q(T)) − PE(q¹)| ≤ tol Σ max|G_k|
        mechanical = self.rho * (pe + friction - margin)
        return {"copper": copper, "inductor": inductor, "mechanical": mechanical}

    def __call__(self, Q0: np.ndarray, Q1: np.ndarray, durations: np.ndarray, *,
                 potential: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """(K,) lower bound (J) of each edge's cost, ≥ 0: E⁺ summed over joints, or with a
        shared bus (``drive.supply``) the supply energy, reweighted by the node potential
        when it regenerates (``potential`` = (φ at Q0, φ at Q1), J; computed if not
        given). See :meth:`_bus_bound`."""
        if len(Q0) == 0:
            return np.zeros(0)
        p = self.parts(Q0, Q1, durations)
        if not self.drive.supply.is_default:
            return self._bus_bound(p, Q0, Q1, potential)
        if self.mode == "per_joint":
            return p["joint"].sum(axis=1)
        total = (p["copper"] + p["inductor"]).sum(axis=1) + p["mechanical"]
        return np.maximum(total, 0.0)

    def _bus_bound(self, p: dict, Q0: np.ndarray, Q1: np.ndarray,
                   potential: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """The shared bus (docs/design.md §3i). Per piece I_p of the edge, S_p estimates
        ∫_{I_p} P dt = Σ_k ∫_{I_p} V_k i_k dt by (1) summed over the joints; since
        ∫ max(±P, 0) ≥ Σ_p max(±S_p, 0) and B⁺ − η B⁻ = ∫ P + (1 − η) B⁻,

            B⁺ − η B⁻ ≥ Σ_p [max(S_p, 0) − η max(−S_p, 0)],

        plus φ(u) − φ(v) with regeneration; × (1 − margin), clipped at 0 (the reweighted
        cost is ≥ 0). In ``sum`` mode the one piece is the summed energy balance."""
        eta = self.drive.supply.regeneration
        if self.mode == "per_joint":
            S = (p["copper"] + p["inductor"] + p["mechanical"]).sum(axis=2)  # (pieces, K)
        else:
            S = ((p["copper"] + p["inductor"]).sum(axis=1) + p["mechanical"])[None]
        c = (np.maximum(S, 0.0) - eta * np.maximum(-S, 0.0)).sum(axis=0)
        if self.drive.supply.needs_potential:
            if potential is None:
                potential = (node_potential(self.drive, Q0), node_potential(self.drive, Q1))
            c = c + (potential[0] - potential[1])
        return (1.0 - self.margin) * np.maximum(c, 0.0)

    # ------------------------------------------------------------------ per joint
    def _per_joint_parts(self, Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray) -> dict:
        d = self.drive
        P = self.pieces
        K, nq = Q0.shape
        DQ = Q1 - Q0
        tau_r, vel, volts = self._reference(Q0, DQ, T, breaks=True)
        m = self._tau.size
        amps = tau_r / d.torque_per_amp  # i along the reference, (m + P + 1, K, nq)
        i_b = amps[m:]  # at τ = 0, 1/P, …, 1 (at τ = 0, 1 the holding currents: q̇ = q̈ = 0)
        i_n = amps[:m].reshape(P, m // P, K, nq)
        v_n = vel[:m].reshape(P, m // P, K, nq)
        charge = self._charges(amps[:m], T)  # (moments, P, K, nq), A·√s
        copper = d.R * (charge**2).sum(axis=0)
        inductor = 0.5 * d.L * (i_b[1:] ** 2 - i_b[:-1] ** 2)
        dt = (self._w[:, None] * (T / P))[None, :, :, None]  # (1, m/P, K, 1) s
        mechanical = d.emf_per_rad_s * (dt * v_n * i_n).sum(axis=1)  # ρ_k ∫ q̇ τ dt
        pieces = np.maximum(copper + inductor + mechanical, 0.0).sum(axis=0)
        saturating = np.zeros((K, nq), dtype=bool)
        if volts is not None:
            saturating = (np.abs(volts) >= SATURATION_FRACTION * d.v_max).any(axis=0)
        if saturating.any():  # one piece over the whole edge: R (∫ i dt)²/T, the sums
            whole = (d.R * (charge[0].sum(axis=0) * np.sqrt(T / P)[:, None]) ** 2
                     / T[:, None]
                     + 0.5 * d.L * (i_b[-1] ** 2 - i_b[0] ** 2) + mechanical.sum(axis=0))
            pieces = np.where(saturating, np.maximum(whole, 0.0), pieces)
        return {"copper": copper, "inductor": inductor, "mechanical": mechanical,
                "saturating": saturating, "joint": (1.0 - self.margin) * pieces}

    # ------------------------------------------------------------------ reference
    def _reference(self, Q0: np.ndarray, DQ: np.ndarray, T: np.ndarray, breaks: bool = False):
        """τ_ff (N·m) and q̇ (rad/s) along the quintic at the nodes (then, with ``breaks``,
        at the piece boundaries), each (m, K, nq); V_ff (V) there too when the drive has a
        voltage limit and ``breaks`` (else None)."""
        from .tracking import feedforward_tables

        d = self.drive
        K, nq = Q0.shape
        tau = self._tau
        if breaks:
            tau = np.concatenate([tau, np.linspace(0.0, 1.0, self.pieces + 1)])
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        sd = 30.0 * tau**2 * (1.0 - tau) ** 2  # ds/dτ
        sdd = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * tau**2)  # d²s/dτ²
        m = tau.size
        Tm = T[None, :, None]
        Qr = Q0[None] + DQ[None] * s[:, None, None]  # (m, K, nq)
        Vr = DQ[None] * (sd[:, None, None] / Tm)
        Ar = DQ[None] * (sdd[:, None, None] / Tm**2)
        if breaks and d.saturated:  # the voltage too: τ̇ for L di/dt
            sddd = 60.0 * (1.0 - 6.0 * tau + 6.0 * tau**2)
            Jr = DQ[None] * (sddd[:, None, None] / Tm**3)
            volts, amps = feedforward_tables(d, Qr, Vr, Ar, Jr)
            return amps * d.torque_per_amp, Vr, volts
        flat = (m * K, nq)
        tau_r = _rnea(d, Qr.reshape(flat), Vr.reshape(flat), Ar.reshape(flat)).reshape(m, K, nq)
        tau_r += d.damping * Vr
        return tau_r, Vr, None

    def _charges(self, values: np.ndarray, T: np.ndarray) -> np.ndarray:
        """∫_{I_p} x φ_j dt of x at the nodes ((m, K, nq) → (moments, pieces, K, nq)), by
        Gauss–Legendre on each piece I_p of length T/P, φ_j(t) = P̃_j(u)/√|I_p| with u the
        position in the piece (φ_0 = 1/√|I_p|: ∫ x dt over √|I_p|, i.e. Cauchy–Schwarz)."""
        P = self.pieces
        m, K, nq = values.shape
        x = values.reshape(P, m // P, K, nq)
        return np.tensordot(self._phi, x, axes=(1, 1)) * np.sqrt(T / P)[None, None, :, None]


def _threads() -> int:
    return int(os.cpu_count() or 1)


def _pool(drive: Drive) -> pin.ModelPool:
    cached = drive.__dict__.get("_bound_pool")
    if cached is None or cached[1] is not drive.model:
        cached = (pin.ModelPool(drive.model, _threads()), drive.model)
        drive.__dict__["_bound_pool"] = cached
    return cached[0]


def _rnea(drive: Drive, Q: np.ndarray, V: np.ndarray, A: np.ndarray) -> np.ndarray:
    """RNEA (with the rotor armature) of B configurations, (B, nq) each → (B, nq) N·m."""
    if Q.shape[0] == 0:
        return np.zeros_like(Q)
    out = pin.rneaInParallel(
        _threads(), _pool(drive), np.asfortranarray(Q.T), np.asfortranarray(V.T),
        np.asfortranarray(A.T),
    )
    return np.ascontiguousarray(np.asarray(out).T)


def _gravity(drive: Drive, Q: np.ndarray) -> np.ndarray:
    """G(q) for B configurations, (B, nq) N·m."""
    Z = np.zeros_like(Q)
    return _rnea(drive, Q, Z, Z)


def _potential(drive: Drive, Q: np.ndarray) -> np.ndarray:
    """Potential energy (J) of B configurations, (B,)."""
    model = drive.model
    data = model.createData()
    return np.array([pin.computePotentialEnergy(model, data, q) for q in Q])


def node_potential(drive: Drive, Q: np.ndarray) -> np.ndarray:
    """φ(q) = ρ PE(q) + Σ_k ½ L_k i_hold,k(q)² (J) for each row of ``Q`` (n, nq), rad.

    From L di/dt = V − R i − n Ke q̇, summed over joints, a rest-to-rest edge u → v has

        ∫ P dt = Σ_k ∫ R i_k² + ½ L_k (i_k(T)² − i_k(0)²) + Σ_k ρ_k ∫ q̇_k τ_k dt,

    and with one ρ = Ke/Kt on every joint the last sum is ρ (ΔKE + ΔPE + friction) ≥
    ρ ΔPE. The supply energy B⁺ − η B⁻ = ∫ P + (1 − η) B⁻ ≥ ∫ P, and i(0) is the
    holding current at u, so c(u→v) ≥ φ(v) − φ(u) up to ½ L (i(T)² − i_hold(v)²), the
    end current's tracking residual (checked on every evaluated edge,
    :mod:`mpd_pin.planning.supply_costs`). Here beside the bound, which needs the same
    gravity torque and potential energy (:mod:`mpd_pin.dynamics.supply` stays free of
    Pinocchio). Where Ke/Kt differs between joints the smallest
    ratio is used and the check is all that stands behind it (docs/design.md §3i).
    """
    Q = np.atleast_2d(np.asarray(Q, float))
    if Q.shape[0] == 0:
        return np.zeros(0)
    rho = float(np.min(drive.Ke / drive.Kt))
    i_hold = _gravity(drive, Q) / drive.torque_per_amp
    return rho * _potential(drive, Q) + (0.5 * drive.L * i_hold**2).sum(axis=1)


def _is_prismatic(model: pin.Model, j: int) -> bool:
    return model.joints[j].shortname().startswith(("JointModelP", "JointModelPrismatic"))


def _extension(model: pin.Model, j: int) -> float:
    """The farthest (m) prismatic joint ``j`` moves its child from its placement:
    max(|lower|, |upper|) (inf without limits); 0 for any other joint."""
    if not _is_prismatic(model, j):
        return 0.0
    i = model.joints[j].idx_q
    lo, hi = float(model.lowerPositionLimit[i]), float(model.upperPositionLimit[i])
    return max(abs(lo), abs(hi)) if np.isfinite(lo) and np.isfinite(hi) else np.inf


def _gravity_torque_bound(model: pin.Model) -> np.ndarray:
    """(nq,) upper bound of |G_k(q)| over all q (N·m, N for a prismatic joint): g · Σ over
    the bodies moved by joint k of mass × (distance from joint k to the body's centre of
    mass, bounded by the chain of joint placements plus the farthest extension of every
    prismatic joint on the way; 1 for a prismatic joint), by the triangle inequality. For a
    revolute joint the placements from joint k's origin on bound the distance to its axis
    too."""
    g = float(np.linalg.norm(model.gravity.linear))
    nj = model.njoints
    out = np.zeros(model.nv)
    for k in range(1, nj):
        idx = model.joints[k].idx_v
        if model.joints[k].nv != 1:
            continue
        prismatic = _is_prismatic(model, k)
        total = 0.0
        for b in range(k, nj):
            # walk from body b up to joint k, summing placement lengths
            reach, j, ok = 0.0, b, False
            while j > 0:
                if j == k:
                    ok = True
                    break
                reach += float(np.linalg.norm(model.jointPlacements[j].translation))
                reach += _extension(model, j)  # a prismatic joint between k and b slides
                j = model.parents[j]
            if ok:  # a force for a prismatic joint: |G_k| ≤ g Σ m
                inertia = model.inertias[b]
                arm = 1.0 if prismatic else reach + float(np.linalg.norm(inertia.lever))
                total += inertia.mass * arm
        out[idx] = g * total
    return out
