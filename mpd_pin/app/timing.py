"""Wall-clock and CPU seconds per phase of a run (docs/design.md §7)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["PhaseClock"]


class PhaseClock:
    """Wall-clock (:func:`time.perf_counter`) and CPU (:func:`time.process_time`) seconds
    per phase. CPU time is that of this process summed over its threads (Pinocchio's
    OpenMP batches), so it can exceed the wall time; child processes (the meshcat
    server) are not included."""

    def __init__(self) -> None:
        self.wall: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self._wall0 = time.perf_counter()
        self._cpu0 = time.process_time()

    @contextmanager
    def phase(self, name: str) -> Iterator[None]:
        w, c = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.wall[name] = self.wall.get(name, 0.0) + time.perf_counter() - w
            self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - c

    def copy(self) -> PhaseClock:
        """A clock with the same phases so far and the same start, timed on apart from
        this one."""
        out = PhaseClock.__new__(PhaseClock)
        out.wall, out.cpu = dict(self.wall), dict(self.cpu)
        out._wall0, out._cpu0 = self._wall0, self._cpu0
        return out

    def finish(self) -> None:
        """Record the ``total`` since construction."""
        self.wall["total"] = time.perf_counter() - self._wall0
        self.cpu["total"] = time.process_time() - self._cpu0
