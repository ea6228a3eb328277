"""The edge-cost object: directed edge cost = E⁺ per joint, batched (docs/design.md §3-§4).

Roadmaps get their costs only through :class:`EnergyCost`, so a lazy evaluator or a
remote executor can replace the way edges are simulated without touching the search.
Every batch goes through the executor seam of :mod:`mpd_pin.dynamics.remote`
(docs/design.md §4h): chunks of edges, in this process or on workers, identical rows.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from typing import Any

import numpy as np

from .motor import Drive
from .remote import (
    DEFAULT_CHUNK_SIZE,
    IN_PROCESS_CHUNK_SIZE,
    Compute,
    open_compute,
    plan_chunks,
    run_chunks,
)
from .simulate import EdgeOutcomes, check_batch

__all__ = ["EnergyCost", "Reuse"]

#: ``(mask, outcomes)``: rows already known (from a partial file) and their outcomes.
Reuse = tuple[np.ndarray, EdgeOutcomes]


class EnergyCost:
    """Directed edge cost = E⁺ per joint (J) of the drive tracking the quintic reference.

    The one batched interface through which roadmaps get costs:
    ``cost(Q0, Q1, durations, progress) -> (K, nq)``. ``executor`` is where chunks of
    ``chunk_size`` edges (default 1024 in this process, 512 elsewhere) run: None (this
    process, all cores), a ``distributed.Client``, any ``concurrent.futures.Executor``,
    a scheduler string (``"local:2"``, ``"tcp://host:8786"``) or a
    :class:`~mpd_pin.dynamics.remote.Compute`
    (docs/design.md §4h). ``chunk`` bounds the integrator's own batches.
    """

    def __init__(self, drive: Drive, dt: float = 5e-3, *, executor: Any = None,
                 chunk: int = 1024, chunk_size: int | None = None):
        self.drive = drive
        self.dt = float(dt)
        self.compute: Compute = open_compute(executor)
        self.chunk = int(chunk)
        if chunk_size is None:
            local = self.compute.executor is None
            chunk_size = IN_PROCESS_CHUNK_SIZE if local else DEFAULT_CHUNK_SIZE
        if int(chunk_size) != chunk_size or chunk_size < 1:
            raise ValueError(f"chunk_size must be a positive integer, got {chunk_size!r}")
        self.chunk_size = int(chunk_size)

    @property
    def executor(self) -> Any:
        """The executor chunks are sent to (None: this process)."""
        return self.compute.executor

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

    def compute_record(self) -> dict[str, Any]:
        """result.json's ``compute``: scheduler, workers, chunk_size (edges)."""
        return self.compute.record(self.chunk_size)

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
        *,
        reuse: Reuse | None = None,
        on_chunk: Callable[[np.ndarray, EdgeOutcomes], None] | None = None,
    ) -> EdgeOutcomes:
        """Energies, end errors and peak torques of the K edges (:func:`edge_outcomes`);
        on continuous joints each edge ends at ``arm.edge_target(Q0, Q1)``, the shorter
        way round (docs/design.md §1d).

        ``reuse`` = (mask, outcomes): rows already known, not simulated again.
        ``on_chunk(rows, outcomes)`` is called as each chunk finishes (before
        ``progress(done edges)``), e.g. to save it for a resumed build.
        """
        Q0, Q1 = check_batch(self.drive, Q0, Q1)
        Q1 = self.drive.arm.edge_target(Q0, Q1)  # the shorter way round (§1d)
        K, nq = Q0.shape
        T = np.broadcast_to(np.asarray(durations, dtype=float), (K,)).copy()
        zeros = EdgeOutcomes.zeros(K, nq)  # one array per field, filled row by row
        out = [getattr(zeros, f.name) for f in fields(EdgeOutcomes)]
        todo = np.arange(K)
        if reuse is not None:
            mask, known = reuse
            mask = np.asarray(mask, dtype=bool)
            for arr, f in zip(out, fields(EdgeOutcomes), strict=True):
                arr[mask] = getattr(known, f.name)[mask]
            todo = np.flatnonzero(~mask)
        done = K - todo.size
        if progress is not None and done:
            progress(done)
        chunks = [todo[c] for c in plan_chunks(T[todo], self.dt, self.chunk_size)]
        for rows, res in run_chunks(self.compute, self.drive, Q0, Q1, T, self.dt, chunks,
                                    inner_chunk=self.chunk):
            for arr, f in zip(out, fields(EdgeOutcomes), strict=True):
                arr[rows] = getattr(res, f.name)
            if on_chunk is not None:
                on_chunk(rows, res)
            done += rows.size
            if progress is not None:
                progress(done)
        return EdgeOutcomes(*out)
