"""How a roadmap is sampled, connected and costed: :class:`RoadmapOptions`
(docs/design.md §4e).

Edge duration rule (documented choice):

* ``duration_rule="fixed"`` — every edge takes ``duration`` seconds;
* ``duration_rule="distance"`` — ``T = clip(⌈max_k |Δq_k| / ω / quantum⌉·quantum,
  T_min, T_max)``: the largest joint move at mean speed ``ω`` rad/s, rounded up
  to a multiple of ``quantum`` seconds (itself a multiple of dt), so edges fall
  into few batches;

either raised to the velocity-limit bound when ``velocity_limits`` is set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dynamics.simulate import step_count

__all__ = ["RoadmapOptions"]


@dataclass(frozen=True)
class RoadmapOptions:
    """How a roadmap is sampled, connected and costed.

    num_nodes: random free samples (start and goal come on top).
    k: nearest neighbours per node (joint-space Euclidean).
    seed: seed of the numpy Generator that draws the samples.
    resolution: joint-space step (rad) of the edge collision check.
    duration_rule: "fixed" or "distance" (see module docstring).
    duration: edge duration (s) for the fixed rule.
    joint_speed: mean joint speed ω (rad/s) for the distance rule.
    duration_quantum, min_duration, max_duration: distance rule rounding and bounds (s).
    dt: RK4 step (s).
    max_attempts: give up sampling after this many draws per requested node.
    velocity_limits: time every edge so that its quintic reference stays within the URDF
        velocity limits, T ≥ 1.875·|Δq_k|/v_lim,k, rounded up to ``duration_quantum``
        (an edge only ever gets longer than its rule says; joints without a positive
        finite limit are not constrained).
    effort_limits: refuse an edge whose simulated motor torque n·Kt·|i| exceeds a URDF
        effort limit (N·m) at any step.
    arrival_tolerance: refuse an edge whose simulated motion ends farther than this (rad)
        from its end node in any joint: the energy of a motion that does not arrive is
        not that edge's energy (docs/design.md §3g, §4e).
    """

    num_nodes: int = 200
    k: int = 10
    seed: int = 0
    resolution: float = 0.05
    duration_rule: str = "fixed"
    duration: float = 1.0
    joint_speed: float = 1.0
    duration_quantum: float = 0.25
    min_duration: float = 0.5
    max_duration: float = 4.0
    dt: float = 5e-3
    max_attempts: int = 200
    velocity_limits: bool = True
    effort_limits: bool = True
    arrival_tolerance: float = 0.01

    def __post_init__(self) -> None:
        if int(self.num_nodes) != self.num_nodes or self.num_nodes < 0:
            raise ValueError(f"num_nodes must be a non-negative integer, got {self.num_nodes!r}")
        if int(self.k) != self.k or self.k < 1:
            raise ValueError(f"k must be a positive integer, got {self.k!r}")
        if self.duration_rule not in ("fixed", "distance"):
            raise ValueError(
                f"duration_rule must be 'fixed' or 'distance', got {self.duration_rule!r}"
            )
        for name in (
            "resolution",
            "duration",
            "joint_speed",
            "duration_quantum",
            "min_duration",
            "max_duration",
            "dt",
            "arrival_tolerance",
        ):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {val!r}")
        if self.min_duration > self.max_duration:
            raise ValueError("min_duration must not exceed max_duration")
        step_count(self.duration, self.dt)
        step_count(self.duration_quantum, self.dt)
        step_count(self.min_duration, self.dt)
        step_count(self.max_duration, self.dt)

    def durations(
        self, Q0: np.ndarray, Q1: np.ndarray, velocity_limit: np.ndarray | None = None
    ) -> np.ndarray:
        """Edge durations (s) by the chosen rule, one per row of Q0/Q1, lengthened where
        ``velocity_limits`` and the joint ``velocity_limit`` (rad/s) require it."""
        return self.timing(Q0, Q1, velocity_limit)[0]

    def timing(
        self, Q0: np.ndarray, Q1: np.ndarray, velocity_limit: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(durations (s), lengthened)``: the rule's durations, raised to the quintic's
        velocity bound 1.875·max_k |Δq_k|/v_lim,k rounded up to ``duration_quantum``;
        ``lengthened`` marks the edges the bound raised."""
        K = Q0.shape[0]
        if self.duration_rule == "fixed":
            T = np.full(K, float(self.duration))
        else:
            dist = np.max(np.abs(Q1 - Q0), axis=1) if K else np.zeros(0)
            steps = np.ceil(dist / self.joint_speed / self.duration_quantum - 1e-12)
            T = np.clip(steps * self.duration_quantum, self.min_duration, self.max_duration)
        raised = np.zeros(K, dtype=bool)
        if self.velocity_limits and velocity_limit is not None and K:
            vl = np.asarray(velocity_limit, dtype=float)
            vl = np.where(np.isfinite(vl) & (vl > 0), vl, np.inf)
            need = np.max(1.875 * np.abs(Q1 - Q0) / vl, axis=1)
            need = np.ceil(need / self.duration_quantum - 1e-9) * self.duration_quantum
            raised = need > T + 1e-12
            T = np.maximum(T, need)
        # Snap to the dt grid exactly so T/dt is whole.
        return np.round(T / self.dt) * self.dt, raised
