"""The executor seam of edge energies: chunks of edges in-process, on any
``concurrent.futures.Executor``, or on a ``dask.distributed`` cluster (docs/design.md §4h).

* :class:`DriveSpec` — a :class:`~mpd_pin.Drive` as plain data (URDF text, locked joints,
  motor constants, gains). A worker rebuilds the drive from it once per process
  (:func:`cached_drive`, a module-level cache keyed by :attr:`DriveSpec.key`); nothing
  Pinocchio-specific is pickled. The rebuilt model's :func:`model_digest` must equal the
  sender's, else the task fails (another Pinocchio, another URDF parse).
* :func:`outcomes_task` — the task function: :func:`~mpd_pin.dynamics.edge_outcomes` of
  one chunk. It lives in this package module, so executors pickle it by reference.
* :func:`plan_chunks` — edges sorted by step and step count, cut into chunks; a row's
  result does not depend on which chunk it is in (every row is integrated alone,
  docs/design.md §3e), so chunking never changes an energy.
* :func:`open_compute` — ``None``/``"threads"`` (in this process), ``"local[:N]"`` (a
  ``LocalCluster`` of N worker processes × 1 thread), ``"tcp://host:port"`` (an existing
  scheduler), a ``distributed.Client`` or any ``concurrent.futures.Executor``.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from .motor import DCMotor, Drive
from .simulate import EdgeOutcomes, edge_outcomes, step_count

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "IN_PROCESS_CHUNK_SIZE",
    "Compute",
    "ComputeError",
    "DriveSpec",
    "cached_drive",
    "model_digest",
    "open_compute",
    "outcomes_task",
    "plan_chunks",
    "run_chunks",
]

#: Edges per task sent to workers. Chosen when a batch of the integrator cost ~28 ms plus
#: ~2 ms per planar 3-link edge (1 thread; bench/cluster.py, docs/design.md §4h): 512 edges
#: kept the fixed part near 5 %. Since the RK4 rewrite (§3e) the fixed part is ~8 ms, so
#: smaller chunks would cost less than measured then; the size was not re-tuned.
DEFAULT_CHUNK_SIZE = 512
#: Edges per chunk in this process (the integrator's own batch: no extra batches).
IN_PROCESS_CHUNK_SIZE = 1024
#: Seconds to wait for a scheduler to answer, and for its first worker.
CONNECT_TIMEOUT = 10.0


class ComputeError(ValueError):
    """A scheduler that cannot be reached or used (one line, names the address)."""


# ------------------------------------------------------------------------- plain data
def model_digest(model: pin.Model) -> str:
    """SHA-256 of the dynamics of ``model``: names, parents, joint types and placements,
    inertias, limits, gravity and armature (bit-exact)."""
    h = hashlib.sha256()
    h.update(repr((model.nq, model.nv, list(model.names), list(model.parents))).encode())
    for j in range(1, model.njoints):
        h.update(model.joints[j].shortname().encode())
        if "Unaligned" in model.joints[j].shortname():
            h.update(np.asarray(model.joints[j].extract().axis, dtype=float).tobytes())
        h.update(np.asarray(model.jointPlacements[j].homogeneous).tobytes())
        ine = model.inertias[j]
        h.update(np.array([ine.mass, *ine.lever, *ine.inertia.ravel()]).tobytes())
    for arr in (model.lowerPositionLimit, model.upperPositionLimit, model.velocityLimit,
                model.effortLimit, model.gravity.vector, model.armature):
        h.update(np.asarray(arr, dtype=float).tobytes())
    return h.hexdigest()


def _model_from_urdf(xml: str, locked: Sequence[tuple[str, float]]) -> pin.Model:
    """The dynamics model of a URDF with ``locked`` joints fixed (as ``Arm.from_urdf``)."""
    full = pin.buildModelFromXML(xml)
    if not locked:
        return full
    q0 = pin.neutral(full)
    for name, value in locked:
        q0[full.joints[full.getJointId(name)].idx_q] = value
    ids = sorted(full.getJointId(name) for name, _ in locked)
    return pin.buildReducedModel(full, ids, q0)


@dataclass(frozen=True)
class DriveSpec:
    """A drive as plain data: what a worker needs to rebuild it (docs/design.md §4h).

    urdf: the arm's URDF text (``Arm.urdf_xml``, without any payload); locked: (joint,
    value) pairs locked out of it; motors: one ``DCMotor`` field dict per joint; kp (V/rad),
    kd (V·s/rad) per joint; payload: the JSON of the carried part's ``Payload.describe()``
    ("" for none), put back on the rebuilt arm (``drive.with_payload``); digest:
    :func:`model_digest` of the arm's model (with the payload), checked after the rebuild.
    """

    name: str
    urdf: str
    locked: tuple[tuple[str, float], ...]
    motors: tuple[tuple[tuple[str, Any], ...], ...]
    kp: tuple[float, ...]
    kd: tuple[float, ...]
    feedforward: bool
    digest: str
    payload: str = ""

    @classmethod
    def of(cls, drive: Drive) -> DriveSpec:
        """The spec of ``drive``; ValueError if its arm has no URDF text or the URDF (with
        the drive's payload put back on it) does not rebuild its model bit for bit."""
        from .payload import carried_payload, payload_arm, unloaded_arm

        arm = drive.arm
        if not arm.urdf_xml:
            raise ValueError(f"arm {arm.name!r} has no URDF text (Arm.urdf_xml); it cannot be "
                             "sent to workers — build it with Arm.from_urdf")
        locked = tuple((str(k), float(v)) for k, v in arm.locked_joints.items())
        digest = model_digest(arm.model)
        part = carried_payload(arm)
        payload = "" if part is None else json.dumps(part.describe(), sort_keys=True)
        rebuilt = _model_from_urdf(arm.urdf_xml, locked)
        if part is not None:
            if model_digest(rebuilt) != model_digest(unloaded_arm(arm).model):
                raise ValueError(f"arm {arm.name!r}: its URDF text does not rebuild its model "
                                 "exactly; it cannot be sent to workers")
            rebuilt = payload_arm(_dynamics_arm(rebuilt, arm.name), _payload(payload)).model
        if model_digest(rebuilt) != digest:
            raise ValueError(f"arm {arm.name!r}: its URDF text does not rebuild its model "
                             "exactly; it cannot be sent to workers")
        return cls(
            name=arm.name,
            urdf=arm.urdf_xml,
            locked=locked,
            motors=tuple(tuple(asdict(m).items()) for m in drive.motor_list),
            kp=tuple(float(x) for x in drive.kp_vec),
            kd=tuple(float(x) for x in drive.kd_vec),
            feedforward=bool(drive.feedforward),
            digest=digest,
            payload=payload,
        )

    @property
    def key(self) -> str:
        """SHA-256 of the spec (the per-process cache key)."""
        return hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode()).hexdigest()

    def build(self) -> Drive:
        """A new :class:`Drive` (and dynamics-only :class:`Arm`, carrying the spec's payload)
        from the spec."""
        arm = _dynamics_arm(_model_from_urdf(self.urdf, self.locked), self.name)
        motors = [DCMotor(**dict(m)) for m in self.motors]
        drive = Drive(arm, motors, list(self.kp), list(self.kd), feedforward=self.feedforward)
        if self.payload:
            drive = drive.with_payload(_payload(self.payload))
        if model_digest(drive.arm.model) != self.digest:
            raise RuntimeError(f"worker rebuilt arm {self.name!r} with other dynamics than the "
                               "client (different Pinocchio version?)")
        return drive


def _dynamics_arm(model: pin.Model, name: str):
    """A dynamics-only :class:`~mpd_pin.Arm` of ``model`` (no collision or visual shapes)."""
    from ..arm.model import Arm

    return Arm(model=model, collision_model=pin.GeometryModel(),
               visual_model=pin.GeometryModel(), name=name)


def _payload(text: str):
    """The :class:`~mpd_pin.Payload` of the JSON of its ``describe()``."""
    from .payload import Payload

    d = json.loads(text)
    return Payload(mass=d["mass"], com=tuple(d["com"]), inertia=d["inertia"],
                   size=None if d["size"] is None else tuple(d["size"]), frame=d["frame"],
                   name=d["name"])


#: Drives rebuilt in this process, by DriveSpec.key (one per worker process and spec).
_DRIVES: dict[str, Drive] = {}


def cached_drive(spec: DriveSpec) -> Drive:
    """The drive of ``spec``, built on first use in this process and then reused."""
    key = spec.key
    drive = _DRIVES.get(key)
    if drive is None:
        if len(_DRIVES) >= 8:
            _DRIVES.clear()
        drive = _DRIVES[key] = spec.build()
    return drive


def outcomes_task(
    spec: DriveSpec, Q0: np.ndarray, Q1: np.ndarray, durations: np.ndarray, dt: float,
    threads: int = 1, inner_chunk: int = 1024,
) -> EdgeOutcomes:
    """The task a worker runs: :func:`edge_outcomes` of one chunk (energies in J)."""
    return edge_outcomes(cached_drive(spec), Q0, Q1, durations, dt, chunk=inner_chunk,
                         threads=threads)


def worker_versions() -> dict[str, str]:
    """Versions that must agree between client and workers for identical energies."""
    import mpd_pin

    return {"mpd_pin": mpd_pin.__version__, "pinocchio": pin.__version__,
            "numpy": np.__version__}


def plan_chunks(durations: np.ndarray, dt: float, chunk_size: int) -> list[np.ndarray]:
    """Row indices of ``durations`` (s) in chunks of at most ``chunk_size``: sorted by RK4
    step h = T/N, then N, so a chunk holds few batches of the integrator."""
    if chunk_size < 1:
        raise ValueError(f"chunk_size must be ≥ 1, got {chunk_size}")
    T = np.asarray(durations, dtype=float)
    N = np.array([step_count(t, dt) for t in T.tolist()], dtype=np.int64)
    order = np.lexsort((np.arange(T.size), N, T / np.maximum(N, 1)))
    return [order[s:s + chunk_size] for s in range(0, order.size, chunk_size)]


# ---------------------------------------------------------------------- executors
class Compute:
    """Where chunks run: ``executor`` (None: this process, a ``distributed.Client`` or a
    ``concurrent.futures.Executor``), what to report (:meth:`record`) and what to close."""

    def __init__(self, executor: Any = None, scheduler: str = "threads", workers: int = 1,
                 owned: Sequence[Any] = ()) -> None:
        self.executor = executor
        self.scheduler = scheduler
        self.workers = int(workers)
        self._owned = list(owned)

    @property
    def is_dask(self) -> bool:
        return _is_client(self.executor)

    def record(self, chunk_size: int) -> dict[str, Any]:
        """result.json's ``compute``: scheduler, workers, chunk_size (edges)."""
        return {"scheduler": self.scheduler, "workers": self.workers, "chunk_size": chunk_size}

    def close(self) -> None:
        """Close what :func:`open_compute` started (client, LocalCluster)."""
        while self._owned:
            obj = self._owned.pop()
            try:
                obj.close()
            except Exception:  # noqa: BLE001 - closing is best effort
                pass

    def __enter__(self) -> Compute:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _is_client(obj: Any) -> bool:
    """Whether ``obj`` is a Dask ``distributed.Client``: never when distributed was never
    imported (a client cannot exist without it), which spares every run its 0.5 s import."""
    if "distributed" not in sys.modules:
        return False
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - distributed is a dependency
        return False
    return isinstance(obj, Client)


def parse_scheduler(text: str | None) -> tuple[str, int | str | None]:
    """``("threads", None)``, ``("local", N)`` or ``("address", text)``; ComputeError if bad."""
    if text is None or text == "" or text == "threads":
        return "threads", None
    if not isinstance(text, str):
        raise ComputeError(f"scheduler: expected a string, got {text!r}")
    if text == "local" or text.startswith("local:"):
        n = text.partition(":")[2] or str(os.cpu_count() or 1)
        if not n.isdigit() or not 1 <= int(n) <= 256:
            raise ComputeError(f"scheduler {text!r}: expected local or local:N with N in 1..256")
        return "local", int(n)
    if "://" not in text and ":" not in text:
        raise ComputeError(f"scheduler {text!r}: expected threads, local[:N] or an address "
                           "such as tcp://host:8786")
    return "address", text


def _check_workers(client: Any, where: str) -> int:
    """Number of workers; ComputeError if none comes or they differ from this process."""
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except Exception:  # noqa: BLE001 - TimeoutError from distributed
        raise ComputeError(f"scheduler {where}: no worker joined within "
                           f"{CONNECT_TIMEOUT:g} s") from None
    try:
        seen = client.run(worker_versions)
    except Exception as exc:  # noqa: BLE001 - e.g. ModuleNotFoundError on a worker
        raise ComputeError(f"scheduler {where}: workers cannot run mpd_pin "
                           f"({type(exc).__name__}: {exc}); install it on every worker") from None
    mine = worker_versions()
    for addr, theirs in seen.items():
        if theirs != mine:
            raise ComputeError(f"scheduler {where}: worker {addr} has {theirs}, this process "
                               f"{mine}; identical energies need identical versions")
    return len(seen)


def open_compute(scheduler: Any = None) -> Compute:
    """Connect where edge energies run (see the module docstring); ComputeError (one line)
    if a scheduler cannot be reached or has no usable worker, before any work."""
    if isinstance(scheduler, Compute):
        return scheduler
    if _is_client(scheduler):
        return Compute(scheduler, str(scheduler.scheduler.address),
                       len(scheduler.scheduler_info()["workers"]))
    if isinstance(scheduler, cf.Executor):
        workers = getattr(scheduler, "_max_workers", 1)
        return Compute(scheduler, type(scheduler).__name__, workers)
    kind, arg = parse_scheduler(scheduler)
    if kind == "threads":
        return Compute(None, "threads", 1)
    import logging

    from distributed import Client, LocalCluster

    if kind == "local":
        cluster = LocalCluster(n_workers=int(arg), threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=":0",
                               silence_logs=logging.ERROR)
        client = Client(cluster)
        compute = Compute(client, f"local:{arg}", int(arg), owned=[cluster, client])
    else:
        try:
            client = Client(str(arg), timeout=f"{CONNECT_TIMEOUT}s")
        except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, ValueError
            msg = " ".join(str(exc).split())[:200]
            raise ComputeError(f"cannot reach the Dask scheduler at {arg!r} "
                               f"({type(exc).__name__}: {msg})") from None
        compute = Compute(client, str(arg), 0, owned=[client])
    try:
        compute.workers = _check_workers(compute.executor, repr(compute.scheduler))
    except BaseException:
        compute.close()
        raise
    return compute


def run_chunks(
    compute: Compute | None,
    drive: Drive,
    Q0: np.ndarray,
    Q1: np.ndarray,
    durations: np.ndarray,
    dt: float,
    chunks: Sequence[np.ndarray],
    *,
    inner_chunk: int = 1024,
) -> Iterator[tuple[np.ndarray, EdgeOutcomes]]:
    """Yield ``(rows, outcomes)`` per chunk as chunks finish (any order). In this process
    chunks run one after another with all cores; elsewhere they are submitted at once and
    a worker's lost chunks are recomputed by the executor. Pending work is cancelled
    when the consumer stops early (an exception, Ctrl-C)."""
    executor = None if compute is None else compute.executor
    if executor is None:
        for rows in chunks:
            yield rows, edge_outcomes(drive, Q0[rows], Q1[rows], durations[rows], dt,
                                      chunk=inner_chunk)
        return
    spec = DriveSpec.of(drive)
    submit: Callable[..., Any]
    if _is_client(executor):
        from distributed import as_completed

        def submit(*args: Any) -> Any:
            return executor.submit(outcomes_task, *args, pure=False)
    else:
        as_completed = cf.as_completed

        def submit(*args: Any) -> Any:
            return executor.submit(outcomes_task, *args)
    futures = {}
    try:
        for rows in chunks:
            fut = submit(spec, Q0[rows], Q1[rows], durations[rows], dt, 1, inner_chunk)
            futures[fut] = rows
        for fut in as_completed(list(futures)):
            yield futures.pop(fut), fut.result()
    finally:
        for fut in futures:
            fut.cancel()
