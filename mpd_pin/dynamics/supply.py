"""How the drives are fed: one supply per joint, or one shared DC bus (docs/design.md §3i).

Paper 000 prices a motion as if every joint had its own supply that burns what its
motor gives back: E⁺ = Σ_k ∫ max(V_k i_k, 0) dt. Industrial and collaborative arms
feed all their drives from one DC bus, so a braking joint feeds one that lifts, and
the bus's surplus goes to a brake resistor (η = 0) or back to the supply with an
efficiency η. With the bus power P(t) = Σ_k V_k(t) i_k(t) (W), the energy drawn is

    per_joint:  Σ_k ∫ max(V_k i_k, 0) dt                  (paper 000, eq. 2)
    shared:     ∫ max(P, 0) dt − η ∫ max(−P, 0) dt        (B⁺ − η B⁻)

B⁺ and B⁻ are integrated as two RK4 states beside E⁺ (:mod:`mpd_pin.dynamics.tracking`).

With η > 0 an edge that lowers the arm can cost less than zero, which D* Lite, MPD*
Lite and Dijkstra do not allow. :func:`~mpd_pin.dynamics.bound.node_potential` gives
φ(q) with c(u→v) ≥ φ(v) − φ(u) for every rest-to-rest edge (docs/design.md §3i), so the
search runs on c′ = c + φ(u) − φ(v) ≥ 0; every start-to-goal path changes by the same
φ(start) − φ(goal), so the optimum is the same path. This module imports nothing of the
package (nor Pinocchio).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["BUSES", "Supply", "PER_JOINT", "supply_energy", "energy_by_supply",
           "bus_power", "supply_power"]

#: Values of ``Supply.bus``.
BUSES = ("per_joint", "shared")


@dataclass(frozen=True)
class Supply:
    """The power supply of the drives.

    bus: ``"per_joint"`` (each joint its own supply, braking energy burnt: paper 000)
        or ``"shared"`` (one DC bus feeding every drive).
    regeneration: η ∈ [0, 1], the share of the bus's braking surplus returned to the
        supply (only with ``bus="shared"``; 0: a brake resistor burns it).
    """

    bus: str = "per_joint"
    regeneration: float = 0.0

    def __post_init__(self) -> None:
        if self.bus not in BUSES:
            raise ValueError(f"supply.bus must be one of {', '.join(map(repr, BUSES))}, "
                             f"got {self.bus!r}")
        try:
            eta = float(self.regeneration)
        except (TypeError, ValueError):
            raise ValueError("supply.regeneration must be a number in [0, 1], "
                             f"got {self.regeneration!r}") from None
        if isinstance(self.regeneration, bool) or not (math.isfinite(eta) and 0.0 <= eta <= 1.0):
            raise ValueError(f"supply.regeneration must be a number in [0, 1], got "
                             f"{self.regeneration!r}")
        if self.bus == "per_joint" and eta != 0.0:
            raise ValueError(f"supply.regeneration = {eta:g} needs bus = 'shared' (a "
                             "per-joint supply burns what its motor gives back)")
        object.__setattr__(self, "regeneration", eta)

    @property
    def is_default(self) -> bool:
        """The paper's model (per-joint supplies, no regeneration)."""
        return self.bus == "per_joint"

    @property
    def needs_potential(self) -> bool:
        """Edge costs can be negative (η > 0): the search reweights them (§3i)."""
        return self.bus == "shared" and self.regeneration > 0.0

    def describe(self) -> dict:
        """result.json's ``supply``: ``{bus, regeneration}``."""
        return {"bus": self.bus, "regeneration": self.regeneration}


#: The paper's supply model, the default of every drive.
PER_JOINT = Supply()


def supply_energy(supply: Supply, energy: np.ndarray, bus_energy: np.ndarray) -> np.ndarray:
    """Energy drawn from the supply (J): ``energy`` (..., nq) is E⁺ per joint,
    ``bus_energy`` (..., 2) is (B⁺, B⁻) = (∫ max(P, 0), ∫ max(−P, 0)) (J)."""
    if supply.bus == "per_joint":
        return np.asarray(energy, float).sum(axis=-1)
    bus = np.asarray(bus_energy, float)
    return bus[..., 0] - supply.regeneration * bus[..., 1]


def energy_by_supply(energy: np.ndarray, bus_energy: np.ndarray,
                     regeneration: float) -> dict[str, float]:
    """One motion's energy (J) under each model: ``per_joint`` (Σ E⁺), ``shared``
    (B⁺, η = 0) and ``shared_regeneration`` (B⁺ − η B⁻ with the given η)."""
    e = np.asarray(energy, float).sum(axis=tuple(range(np.ndim(energy))))
    b = np.asarray(bus_energy, float).reshape(-1, 2).sum(axis=0)
    return {"per_joint": float(e), "shared": float(b[0]),
            "shared_regeneration": float(b[0] - float(regeneration) * b[1])}


def bus_power(V: np.ndarray, i: np.ndarray) -> np.ndarray:
    """P = Σ_k V_k i_k (W) over the last axis of voltages (V) and currents (A)."""
    return (np.asarray(V, float) * np.asarray(i, float)).sum(axis=-1)


def supply_power(supply: Supply, P: np.ndarray) -> np.ndarray:
    """The supply's power (W) from the joint powers ``P`` = V_k i_k (..., nq): Σ_k max(P_k, 0)
    per joint, max(Σ P, 0) − η max(−Σ P, 0) on a shared bus; its integral is the supply
    energy (the perfect-tracking screens integrate it)."""
    P = np.asarray(P, float)
    if supply.bus == "per_joint":
        return np.maximum(P, 0.0).sum(axis=-1)
    Pb = P.sum(axis=-1)
    return np.maximum(Pb, 0.0) - supply.regeneration * np.maximum(-Pb, 0.0)
