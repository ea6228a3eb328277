"""Atomic files and resumable edge costing for roadmap caches (docs/design.md §4h).

* :func:`atomic_savez` — write an ``.npz`` to a temporary file in the target's folder,
  flush it to disk, then ``os.replace`` it: readers see the old file or the new one,
  never half of one; on failure the temporary file is removed.
* :class:`PartialCosts` — the sidecar folder ``<cache>.partial/`` of an eager build that
  has not finished: one atomically written ``chunk-<sha>.npz`` per finished chunk (the
  roadmap key, the rows, a digest of their inputs and their outcomes). A rerun with the
  same cache file reuses every chunk whose key and input digest match, and the folder is
  removed once the complete roadmap file is written. Its files hold no roadmap arrays
  and another format tag, so :meth:`Roadmap.load` never takes one for a roadmap.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from dataclasses import fields
from pathlib import Path

import numpy as np

from ..dynamics.simulate import EdgeOutcomes

__all__ = ["PARTIAL_FORMAT", "PartialCosts", "atomic_savez", "partial_dir"]

#: Format tag of a partial chunk file (never a roadmap's ROADMAP_FORMAT).
PARTIAL_FORMAT = "mpd_pin.roadmap-partial-chunk/2"  # 2: with bus_energy
_FIELDS = tuple(f.name for f in fields(EdgeOutcomes))


def _columns(nq: int) -> dict[str, int]:
    """Columns of each :class:`EdgeOutcomes` field for ``nq`` joints (as
    :meth:`EdgeOutcomes.zeros` lays them out)."""
    empty = EdgeOutcomes.zeros(0, nq)
    return {name: getattr(empty, name).shape[1] for name in _FIELDS}


def atomic_savez(path: str | os.PathLike, **arrays: np.ndarray) -> Path:
    """``np.savez_compressed`` to exactly ``path`` through a temporary file and
    ``os.replace`` (same folder, so the rename is atomic)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez_compressed(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def partial_dir(cache: str | os.PathLike) -> Path:
    """The sidecar folder of a roadmap cache file: ``<cache>.partial``."""
    cache = Path(cache)
    return cache.with_name(cache.name + ".partial")


def _inputs_digest(Q0: np.ndarray, Q1: np.ndarray, T: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in (Q0, Q1, T):
        a = np.ascontiguousarray(a, dtype=float)
        h.update(f"{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


class PartialCosts:
    """Finished chunks of the eager build of ``key`` into ``cache`` (see module docstring).

    ``Q0, Q1`` (K, nq) rad and ``T`` (K,) s are the build's edges; :meth:`load` returns
    what earlier runs finished, :meth:`add` saves a chunk, :meth:`remove` the folder.
    """

    def __init__(self, cache: str | os.PathLike, key: str, Q0: np.ndarray, Q1: np.ndarray,
                 T: np.ndarray) -> None:
        self.dir = partial_dir(cache)
        self.key = key
        self.Q0, self.Q1, self.T = Q0, Q1, T
        self.chunks_reused = 0

    def load(self) -> tuple[np.ndarray, EdgeOutcomes] | None:
        """``(mask, outcomes)`` of the rows earlier runs finished, or None if none; sets
        :attr:`chunks_reused`. Files of another key or inputs are deleted, unreadable
        ones ignored."""
        if not self.dir.is_dir():
            return None
        K, nq = self.Q0.shape
        mask = np.zeros(K, dtype=bool)
        zeros = EdgeOutcomes.zeros(K, nq)
        out = {name: getattr(zeros, name) for name in _FIELDS}
        for f in sorted(self.dir.glob("chunk-*.npz")):
            data = self._read(f, K, nq)
            if data is None:
                continue
            rows = data["rows"]
            mask[rows] = True
            for name in _FIELDS:
                out[name][rows] = data[name]
            self.chunks_reused += 1
        return (mask, EdgeOutcomes(**out)) if self.chunks_reused else None

    def _read(self, f: Path, K: int, nq: int) -> dict[str, np.ndarray] | None:
        try:
            with np.load(f, allow_pickle=False) as z:
                data = {n: z[n] for n in z.files}
        except Exception:  # noqa: BLE001 - unreadable: not ours to trust
            return None
        if str(data.get("format", "")) != PARTIAL_FORMAT or str(data.get("key", "")) != self.key:
            f.unlink(missing_ok=True)  # another build's leftover
            return None
        rows = data.get("rows")
        columns = _columns(nq)
        if (rows is None or rows.ndim != 1 or rows.dtype.kind not in "iu" or not rows.size
                or rows.min() < 0 or rows.max() >= K
                or any(data.get(n) is None or data[n].shape != (rows.size, columns[n])
                       for n in _FIELDS)):
            return None
        if str(data.get("inputs", "")) != _inputs_digest(
                self.Q0[rows], self.Q1[rows], self.T[rows]):
            f.unlink(missing_ok=True)
            return None
        return data

    def add(self, rows: np.ndarray, res: EdgeOutcomes) -> None:
        """Save one finished chunk (rows into the build's edges) atomically."""
        self.dir.mkdir(parents=True, exist_ok=True)
        rows = np.asarray(rows, dtype=np.int64)
        inputs = _inputs_digest(self.Q0[rows], self.Q1[rows], self.T[rows])
        atomic_savez(
            self.dir / f"chunk-{inputs[:24]}.npz",
            format=np.array(PARTIAL_FORMAT),
            key=np.array(self.key),
            inputs=np.array(inputs),
            rows=rows,
            **{name: np.asarray(getattr(res, name), dtype=float) for name in _FIELDS},
        )

    def remove(self) -> None:
        """Delete the sidecar folder (after the complete file is written)."""
        shutil.rmtree(self.dir, ignore_errors=True)
