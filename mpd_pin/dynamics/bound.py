"""A cheap lower bound of an edge's E⁺ from the energy balance (docs/design.md §4g).

Per joint k, from ``L di/dt = V − R i − n Ke q̇`` multiplied by i:

    ∫ V_k i_k dt = ∫ R i_k² dt + ½ L (i_k(T)² − i_k(0)²) + n Ke ∫ q̇_k i_k dt,

and E⁺_k = ∫ max(V_k i_k, 0) ≥ ∫ V_k i_k. The motor torque at the joint is
τ_k = n Kt i_k = (M q̈ + C q̇ + G)_k + n²B q̇_k (M with the rotor inertia), so with
ρ = Ke/Kt the same on every joint the back-EMF terms sum to ρ times the mechanical
power, whose integral over a rest-to-rest edge is

    ρ (ΔKE + ΔPE + Σ_k n²B ∫ q̇_k² dt) ≥ ρ (ΔPE + Σ_k n²B Δq_k² / T)

(ΔKE ≥ 0 from rest; Cauchy–Schwarz on the friction). The copper loss is bounded by
Cauchy–Schwarz, ∫ R i² ≥ R (∫ i dt)² / T, and ∫ i_k dt comes from the joint's impulse
balance ∫ τ_k dt = Δp_k − ∫ ∂T/∂q_k dt + ∫ G_k dt + n²B Δq_k, evaluated along the quintic
reference (``∫ τ_ff dt``: RNEA at Gauss–Legendre nodes, Δp = 0 rest to rest). The
inductor term uses the holding currents at both ends.

What is proven and what is estimated: the energy identity, E⁺ ≥ ∫ V i, ΔKE ≥ 0, both
Cauchy–Schwarz steps and the PE term (to the arrival tolerance, subtracted as a
margin) are exact inequalities. ∫ i dt along the *simulated* motion equals the
reference value only up to the tracking error, and i(T) is the holding current only
up to it; with Ke/Kt differing between joints the smallest ratio is used for the
mechanical term, which is then not a proven bound either. :class:`EnergyBound`
therefore says ``proven = False``, and the lazy planner checks every evaluated edge
against its bound and corrects violations (:mod:`mpd_pin.planning.lazy`).
``rigorous=True`` (the default for a drive without feed-forward, whose motion can lag
far behind the reference) keeps only the proven terms: ρ (ΔPE + friction − margin)
− Σ ½ L i(0)², a bound for every feasible edge when Ke/Kt is the same on all joints.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin

from .motor import Drive

__all__ = ["EnergyBound"]

#: Gauss–Legendre nodes on τ ∈ [0, 1] for the current moments along the quintic.
QUADRATURE_POINTS = 8
#: Legendre moments of the current in the copper bound (1: Cauchy–Schwarz on ∫ i dt).
DEFAULT_MOMENTS = 1


class EnergyBound:
    """Lower bound (J) of Σ_k E⁺_k for rest-to-rest quintic edges of ``drive``.

    ``bound(Q0, Q1, durations) -> (K,)``, vectorised over edges; the per-joint parts are
    :meth:`parts`. ``arrival_tolerance`` (rad) widens the PE and friction terms to any end
    state within that distance of the end node (the feasibility rule of docs/design.md §4e).
    """

    def __init__(self, drive: Drive, *, arrival_tolerance: float = 0.01,
                 moments: int = DEFAULT_MOMENTS, points: int = QUADRATURE_POINTS,
                 rigorous: bool | None = None) -> None:
        self.drive = drive
        #: only the proven terms: no copper estimate, the inductor at −½ L i(0)² (the
        #: default without feed-forward, where the reference says little about the current)
        self.rigorous = (not drive.feedforward) if rigorous is None else bool(rigorous)
        self.tol = float(arrival_tolerance)
        if int(moments) < 1:
            raise ValueError(f"moments must be ≥ 1, got {moments!r}")
        self.moments = int(moments)
        x, w = np.polynomial.legendre.leggauss(int(points))
        self._tau = 0.5 * (x + 1.0)
        self._w = 0.5 * w
        # orthonormal Legendre polynomials on τ ∈ [0, 1] at the nodes, times the weights
        self._phi = np.stack([
            np.sqrt(2 * j + 1) * np.polynomial.legendre.legval(x, [0] * j + [1])
            for j in range(self.moments)
        ]) * self._w
        ratio = drive.Ke / drive.Kt
        #: ρ = Ke/Kt used for the mechanical term (the smallest over the joints)
        self.rho = float(ratio.min())
        #: True when every joint has the same Ke/Kt (the mechanical term sums exactly)
        self.uniform_ratio = bool(np.allclose(ratio, ratio[0], rtol=1e-12, atol=0.0))
        #: True only for the rigorous terms with one Ke/Kt on every joint; otherwise the
        #: bound is an estimate (tracking error), checked at run time
        self.proven = self.rigorous and self.uniform_ratio
        self._gmax = _gravity_torque_bound(drive.arm.model)

    def describe(self) -> dict:
        """Plain data for result files."""
        return {
            "model": "energy-balance",
            "quadrature_points": int(self._tau.size),
            "current_moments": self.moments,
            "ke_over_kt": self.rho,
            "uniform_ke_over_kt": self.uniform_ratio,
            "rigorous": self.rigorous,
            "proven": self.proven,
        }

    def parts(self, Q0: np.ndarray, Q1: np.ndarray, durations: np.ndarray) -> dict:
        """The bound's terms (J), each (K, nq) except ``mechanical`` (K,): ``copper``,
        ``inductor``, ``mechanical`` (ρ·(ΔPE + friction) less the tolerance margin)."""
        d = self.drive
        Q0 = np.asarray(Q0, float)
        Q1 = np.asarray(Q1, float)
        T = np.asarray(durations, float)
        K, nq = Q0.shape
        DQ = Q1 - Q0
        i0 = _gravity(d, Q0) / d.torque_per_amp  # the initial holding current (exact)
        if self.rigorous:  # ∫ R i² ≥ 0 and ½ L i(T)² ≥ 0
            copper = np.zeros((K, nq))
            inductor = -0.5 * d.L * i0**2
        else:
            # ∫ i φ_j dt (A·√s), (moments, K, nq); Bessel: ∫ i² dt ≥ Σ_j (∫ i φ_j dt)²
            charge = self._moments(Q0, DQ, T) / d.torque_per_amp
            copper = d.R * (charge**2).sum(axis=0)
            i1 = _gravity(d, Q1) / d.torque_per_amp
            inductor = 0.5 * d.L * (i1**2 - i0**2)
        pe = _potential(d, Q1) - _potential(d, Q0)
        move = np.maximum(np.abs(DQ) - self.tol, 0.0)
        friction = (d.damping * move**2).sum(axis=1) / T
        margin = self.tol * self._gmax.sum()  # |PE(q(T)) − PE(q¹)| ≤ tol Σ max|G_k|
        mechanical = self.rho * (pe + friction - margin)
        return {"copper": copper, "inductor": inductor, "mechanical": mechanical}

    def __call__(self, Q0: np.ndarray, Q1: np.ndarray, durations: np.ndarray) -> np.ndarray:
        """(K,) lower bound (J) of each edge's E⁺ summed over joints, ≥ 0."""
        if len(Q0) == 0:
            return np.zeros(0)
        p = self.parts(Q0, Q1, durations)
        total = (p["copper"] + p["inductor"]).sum(axis=1) + p["mechanical"]
        return np.maximum(total, 0.0)

    def _moments(self, Q0: np.ndarray, DQ: np.ndarray, T: np.ndarray) -> np.ndarray:
        """∫₀ᵀ τ_ff φ_j dt, (moments, K, nq), along the quintic by Gauss–Legendre in
        τ = t/T, with φ_j(t) = P̃_j(t/T)/√T orthonormal on [0, T] (φ_0 = 1/√T: the
        impulse ∫ τ dt over √T, i.e. Cauchy–Schwarz)."""
        d = self.drive
        K, nq = Q0.shape
        tau = self._tau
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        sd = 30.0 * tau**2 * (1.0 - tau) ** 2  # ds/dτ
        sdd = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * tau**2)  # d²s/dτ²
        m = tau.size
        Qr = Q0[None] + DQ[None] * s[:, None, None]  # (m, K, nq)
        Vr = DQ[None] * (sd[:, None, None] / T[None, :, None])
        Ar = DQ[None] * (sdd[:, None, None] / (T**2)[None, :, None])
        flat = (m * K, nq)
        tau_r = _rnea(d, Qr.reshape(flat), Vr.reshape(flat), Ar.reshape(flat)).reshape(m, K, nq)
        tau_r += d.damping * Vr
        return np.tensordot(self._phi, tau_r, axes=(1, 0)) * np.sqrt(T)[None, :, None]


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


def _gravity_torque_bound(model: pin.Model) -> np.ndarray:
    """(nq,) upper bound of |G_k(q)| over all q (N·m, N for a prismatic joint): g · Σ over
    the bodies moved by joint k of mass × (distance from joint k to the body's centre of
    mass, bounded by the chain of joint placements; 1 for a prismatic joint), by the
    triangle inequality. For a revolute joint the placements from joint k's origin on
    bound the distance to its axis too."""
    g = float(np.linalg.norm(model.gravity.linear))
    nj = model.njoints
    out = np.zeros(model.nv)
    for k in range(1, nj):
        idx = model.joints[k].idx_v
        if model.joints[k].nv != 1:
            continue
        prismatic = model.joints[k].shortname().startswith(("JointModelP", "JointModelPrismatic"))
        total = 0.0
        for b in range(k, nj):
            # walk from body b up to joint k, summing placement lengths
            reach, j, ok = 0.0, b, False
            while j > 0:
                if j == k:
                    ok = True
                    break
                reach += float(np.linalg.norm(model.jointPlacements[j].translation))
                j = model.parents[j]
            if ok:  # a force for a prismatic joint: |G_k| ≤ g Σ m
                inertia = model.inertias[b]
                arm = 1.0 if prismatic else reach + float(np.linalg.norm(inertia.lever))
                total += inertia.mass * arm
        out[idx] = g * total
    return out
