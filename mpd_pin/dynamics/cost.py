"""The edge-cost object: directed edge cost = E⁺ per joint, batched (docs/design.md §3-§4).

Roadmaps get their costs only through :class:`EnergyCost`, so a lazy evaluator or a
remote executor can replace the way edges are simulated without touching the search.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields

import numpy as np

from .motor import Drive
from .simulate import EdgeOutcomes, edge_outcomes

__all__ = ["EnergyCost"]


class EnergyCost:
    """Directed edge cost = E⁺ per joint (J) of the drive tracking the quintic reference.

    The one batched interface through which roadmaps get costs:
    ``cost(Q0, Q1, durations, progress) -> (K, nq)``. ``executor`` (any
    ``concurrent.futures.Executor``) splits large batches across workers.
    """

    def __init__(self, drive: Drive, dt: float = 5e-3, *, executor=None, chunk: int = 1024):
        self.drive = drive
        self.dt = float(dt)
        self.executor = executor
        self.chunk = int(chunk)

    def describe(self) -> dict:
        """Plain data that determines the costs (hashed into roadmap keys)."""
        out = {
            "model": "quintic-rk4-E+",
            "drive": self.drive.describe(),
            "arm": self.drive.arm.fingerprint(),
            "dt": self.dt,
        }
        if self.drive.arm.continuous_joints:  # edges the shorter way round (§1d)
            out["shorter_way"] = list(self.drive.arm.continuous_joints)
        return out

    def __call__(
        self,
        Q0: np.ndarray,
        Q1: np.ndarray,
        durations: np.ndarray,
        progress: Callable[[int], None] | None = None,
    ) -> np.ndarray:
        """E⁺ per joint (J), (K, nq), of the K edges ``Q0[k] → Q1[k]``."""
        return self.outcomes(Q0, Q1, durations, progress).energy

    def outcomes(
        self,
        Q0: np.ndarray,
        Q1: np.ndarray,
        durations: np.ndarray,
        progress: Callable[[int], None] | None = None,
    ) -> EdgeOutcomes:
        """Energies, end errors and peak torques of the K edges (:func:`edge_outcomes`);
        on continuous joints each edge ends at ``arm.edge_target(Q0, Q1)``, the shorter
        way round (docs/design.md §1d)."""
        Q1 = self.drive.arm.edge_target(Q0, Q1)
        if self.executor is None or Q0.shape[0] <= self.chunk:
            return edge_outcomes(
                self.drive, Q0, Q1, durations, self.dt, chunk=self.chunk, progress=progress
            )
        parts = []
        for start in range(0, Q0.shape[0], self.chunk):
            sl = slice(start, start + self.chunk)
            parts.append(
                self.executor.submit(
                    edge_outcomes, self.drive, Q0[sl], Q1[sl], durations[sl], self.dt,
                    chunk=self.chunk,
                )
            )
        out, done = [], 0
        for fut in parts:
            res = fut.result()
            out.append(res)
            done += res.energy.shape[0]
            if progress is not None:
                progress(done)
        return EdgeOutcomes(*(
            np.concatenate([getattr(r, f.name) for r in out], axis=0) for f in fields(EdgeOutcomes)
        ))
