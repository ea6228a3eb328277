"""Obstacles moving on known trajectories, and collision checking at motion samples (paper 002).

Paper 002 §5 moves its obstacles by a known displacement per motion sample,
``v = Δx / (MS × Ts)`` with the sample time ``Ts = 0.01 s``. Here an obstacle is
a disc (radius m) in the arm's x–z plane whose centre follows a
:class:`PolylineTrajectory`: a polyline of way-points (m) run at constant
``speed`` (m/s), either once (a straight move that stops at the last point),
back and forth, or round a closed loop (a square, for example). Positions are
functions of time t (s), vectorised over t; the displacement per motion sample
is ``speed · Ts``.

Collision checking uses the package's world and Coal: the obstacles at time t
become a :class:`~mpd_pin.world.World` of :meth:`Cylinder.planar
<mpd_pin.world.Cylinder.planar>` discs, checked by a
:class:`~mpd_pin.collision.CollisionChecker`. :class:`SampledCollisionChecker`
keeps one checker per motion sample k (t = k·Ts), built on first use and
cached; :meth:`SampledCollisionChecker.at_time` does the same for the
intermediate times (k + j/n)·Ts of the sub-step checks between samples
(:meth:`SampledCollisionChecker.is_free_between`: the joints interpolated
linearly from sample k to k+1, the obstacles where they are at that time).
Measured with ``bench/twolink.py`` on the shared 2-core machine (best
of three): building a checker for the two-link arm and four discs takes
~1–3 ms; one FCS map of env2 (0.025 m grid, ~10,000 configurations) costs
~32 ms per sample with a rebuilt checker's ``is_free_batch`` and ~38 ms with
the alternative of one ``pin.GeometryModel`` whose obstacle placements are
moved in place (a Python loop of ``pin.computeCollisions``; the two agree but
for configurations within 1e-9 m of the margin). Rebuilding is as fast and reuses the package's
checker unchanged; one thread (two were slower under load).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from ..arm.model import Arm
from ..collision import CollisionChecker
from ..world import Cylinder, World

__all__ = [
    "MODES",
    "PolylineTrajectory",
    "MovingObstacle",
    "MovingScene",
    "SampledCollisionChecker",
    "straight",
    "back_and_forth",
    "square",
    "static",
]

#: Trajectory modes: run the polyline once and stay at its end, go back and forth
#: along it, or go round it as a closed loop (last point joined to the first).
MODES = ("once", "back_and_forth", "loop")


def _xy(value: Any, what: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be (x, z) in m, got {value!r}") from None
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be one finite (x, z) pair in m, got {value!r}")
    return a


@dataclass(frozen=True)
class PolylineTrajectory:
    """Centre (x, z) (m) moving along way-points at constant ``speed`` (m/s).

    ``mode``: ``"once"`` (stop at the last point), ``"back_and_forth"`` or
    ``"loop"`` (closed: the last point joins the first). ``delay`` (s): the
    obstacle rests at its starting point until then. ``phase`` ∈ [0, 1): the
    starting point as a fraction of one cycle (0 = first way-point; a cycle is
    the polyline once, there and back, or once round the loop). A single
    way-point, or ``speed = 0``, is a static obstacle.
    """

    points: tuple[tuple[float, float], ...]
    speed: float = 0.0
    mode: str = "once"
    delay: float = 0.0
    phase: float = 0.0
    _cum: np.ndarray = field(init=False, repr=False, compare=False)
    _pts: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            pts = np.asarray(self.points, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"trajectory points must be (x, z) pairs, got {self.points!r}"
            ) from None
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 1:
            raise ValueError(f"trajectory points must be N ≥ 1 (x, z) pairs, got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError("trajectory points must be finite")
        if self.mode not in MODES:
            raise ValueError(f"trajectory mode must be one of {MODES}, got {self.mode!r}")
        speed = float(self.speed)
        if not math.isfinite(speed) or speed < 0:
            raise ValueError(f"speed must be finite and ≥ 0 (m/s), got {self.speed!r}")
        delay = float(self.delay)
        if not math.isfinite(delay) or delay < 0:
            raise ValueError(f"delay must be finite and ≥ 0 (s), got {self.delay!r}")
        phase = float(self.phase)
        if not (0.0 <= phase < 1.0):
            raise ValueError(f"phase must be in [0, 1), got {self.phase!r}")
        object.__setattr__(self, "points", tuple((float(x), float(z)) for x, z in pts))
        object.__setattr__(self, "speed", speed)
        object.__setattr__(self, "delay", delay)
        object.__setattr__(self, "phase", phase)
        path = np.vstack([pts, pts[:1]]) if (self.mode == "loop" and len(pts) > 1) else pts
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        if np.any(seg == 0.0):
            raise ValueError("trajectory has repeated consecutive way-points")
        object.__setattr__(self, "_pts", path)
        object.__setattr__(self, "_cum", np.concatenate([[0.0], np.cumsum(seg)]))

    @property
    def length(self) -> float:
        """Length (m) of the polyline (closed for loops)."""
        return float(self._cum[-1])

    @property
    def cycle_length(self) -> float:
        """Distance (m) travelled in one cycle (twice the length back and forth)."""
        return 2.0 * self.length if self.mode == "back_and_forth" else self.length

    @property
    def is_static(self) -> bool:
        return self.length == 0.0 or self.speed == 0.0

    def arc(self, t: Any) -> np.ndarray:
        """Distance (m) along the polyline at time(s) ``t`` (s), folded by the mode."""
        t = np.asarray(t, dtype=float)
        L = self.length
        if L == 0.0:
            return np.zeros_like(t)
        s = self.speed * np.maximum(t - self.delay, 0.0) + self.phase * self.cycle_length
        if self.mode == "once":
            return np.minimum(s, L)
        if self.mode == "loop":
            return np.mod(s, L)
        s = np.mod(s, 2.0 * L)
        return np.where(s <= L, s, 2.0 * L - s)

    def position(self, t: Any) -> np.ndarray:
        """Centre (x, z) (m) at time(s) ``t`` (s): shape ``t.shape + (2,)``."""
        t = np.asarray(t, dtype=float)
        if self.length == 0.0:
            return np.broadcast_to(self._pts[0], t.shape + (2,)).copy()
        s = self.arc(t)
        cum = self._cum
        i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(cum) - 2)
        u = (s - cum[i]) / (cum[i + 1] - cum[i])
        p0 = self._pts[i]
        p1 = self._pts[i + 1]
        return p0 + u[..., None] * (p1 - p0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "points": [list(p) for p in self.points],
            "speed": self.speed,
            "mode": self.mode,
            "delay": self.delay,
            "phase": self.phase,
        }


def static(center: Sequence[float]) -> PolylineTrajectory:
    """A disc that does not move, at ``center`` (x, z) (m)."""
    c = _xy(center, "center")
    return PolylineTrajectory(((c[0], c[1]),))


def straight(
    start: Sequence[float], end: Sequence[float], speed: float, *, delay: float = 0.0
) -> PolylineTrajectory:
    """Straight move from ``start`` to ``end`` (m) at ``speed`` (m/s); stays at ``end``."""
    a, b = _xy(start, "start"), _xy(end, "end")
    return PolylineTrajectory((tuple(a), tuple(b)), speed, "once", delay)


def back_and_forth(
    a: Sequence[float], b: Sequence[float], speed: float, *, delay: float = 0.0, phase: float = 0.0
) -> PolylineTrajectory:
    """Back and forth between ``a`` and ``b`` (m) at ``speed`` (m/s), starting at ``a``."""
    a_, b_ = _xy(a, "a"), _xy(b, "b")
    return PolylineTrajectory((tuple(a_), tuple(b_)), speed, "back_and_forth", delay, phase)


def square(
    center: Sequence[float],
    side: float,
    speed: float,
    *,
    clockwise: bool = False,
    delay: float = 0.0,
    phase: float = 0.0,
) -> PolylineTrajectory:
    """Round a square of ``side`` (m) centred at ``center`` (m), at ``speed`` (m/s).

    Starts at the bottom-left corner (x − side/2, z − side/2) unless ``phase``
    moves the start along the loop; counter-clockwise unless ``clockwise``.
    """
    c = _xy(center, "center")
    h = float(side) / 2.0
    if not math.isfinite(h) or h <= 0:
        raise ValueError(f"square side must be finite and > 0 (m), got {side!r}")
    corners = [(-h, -h), (h, -h), (h, h), (-h, h)]
    if clockwise:
        corners = [corners[0], *corners[:0:-1]]
    pts = tuple((c[0] + dx, c[1] + dz) for dx, dz in corners)
    return PolylineTrajectory(pts, speed, "loop", delay, phase)


@dataclass(frozen=True)
class MovingObstacle:
    """A disc of ``radius`` (m) in the x–z plane whose centre follows ``trajectory``."""

    name: str
    radius: float
    trajectory: PolylineTrajectory
    motion: str = "polyline"  # how it was described (for plots and result files)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"obstacle name must be a non-empty string, got {self.name!r}")
        r = float(self.radius)
        if not math.isfinite(r) or r <= 0:
            raise ValueError(f"obstacle {self.name!r}: radius must be finite and > 0 (m)")
        object.__setattr__(self, "radius", r)
        if not isinstance(self.trajectory, PolylineTrajectory):
            raise ValueError(f"obstacle {self.name!r}: trajectory must be a PolylineTrajectory")

    def center(self, t: Any) -> np.ndarray:
        """Centre (x, z) (m) at time(s) t (s)."""
        return self.trajectory.position(t)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "radius": self.radius,
            "motion": self.motion,
            "trajectory": self.trajectory.to_dict(),
        }


class MovingScene:
    """The moving obstacles of a scenario, with the motion sample time ``ts`` (s).

    Sample k is at time t = k·ts; ``world_at_sample(k)`` is the package
    :class:`~mpd_pin.world.World` of the discs at that time (cylinders across
    the plane, ``depth`` m long).
    """

    def __init__(
        self, obstacles: Sequence[MovingObstacle], ts: float = 0.01, *, depth: float = 1.0
    ) -> None:
        obstacles = tuple(obstacles)
        for ob in obstacles:
            if not isinstance(ob, MovingObstacle):
                raise ValueError(f"not a MovingObstacle: {ob!r}")
        names = [ob.name for ob in obstacles]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate obstacle names in {names}")
        ts = float(ts)
        if not math.isfinite(ts) or ts <= 0:
            raise ValueError(f"sample time must be finite and > 0 (s), got {ts!r}")
        self.obstacles = obstacles
        self.ts = ts
        self.depth = float(depth)
        self.radii = np.array([ob.radius for ob in obstacles], dtype=float)

    def __len__(self) -> int:
        return len(self.obstacles)

    def centers(self, t: Any) -> np.ndarray:
        """Centres (m) at time(s) ``t`` (s): shape ``t.shape + (n_obstacles, 2)``."""
        t = np.asarray(t, dtype=float)
        if not self.obstacles:
            return np.zeros(t.shape + (0, 2))
        return np.stack([ob.center(t) for ob in self.obstacles], axis=-2)

    def centers_at_samples(self, k: Any) -> np.ndarray:
        """Centres (m) at sample index(es) ``k`` (t = k·ts)."""
        return self.centers(np.asarray(k, dtype=float) * self.ts)

    def world_at(self, t: float) -> World:
        """The obstacles at time ``t`` (s) as a World of planar cylinders."""
        c = self.centers(float(t))
        return World(
            tuple(
                Cylinder.planar(c[i], ob.radius, depth=self.depth, name=ob.name)
                for i, ob in enumerate(self.obstacles)
            )
        )

    def world_at_sample(self, k: int) -> World:
        return self.world_at(int(k) * self.ts)

    def snapshot(self, t: float) -> list[dict[str, Any]]:
        """``[{"name", "center": [x, z], "radius"}]`` at time ``t`` (s), for result files."""
        c = self.centers(float(t))
        return [
            {"name": ob.name, "center": [float(c[i, 0]), float(c[i, 1])], "radius": ob.radius}
            for i, ob in enumerate(self.obstacles)
        ]

    def to_dict(self) -> dict[str, Any]:
        return {"sample_time": self.ts, "obstacles": [ob.to_dict() for ob in self.obstacles]}


class SampledCollisionChecker:
    """One :class:`~mpd_pin.collision.CollisionChecker` per motion sample, built lazily.

    ``margin`` (m) is the security margin of every arm–obstacle pair: a
    configuration is free only if every link keeps more than ``margin`` from
    every disc. The link geometry is the URDF's cylinders (radius 0.03 m for the
    built-in arm); a margin ≥ the link radius also clears the *capsules* of the
    same radius (the rounded ends stick out of the cylinder by at most one radius).
    """

    def __init__(
        self,
        arm: Arm,
        scene: MovingScene,
        *,
        margin: float = 0.0,
        num_threads: int = 1,
        cache_size: int = 4096,
    ) -> None:
        margin = float(margin)
        if not math.isfinite(margin) or margin < 0:
            raise ValueError(f"margin must be finite and ≥ 0 (m), got {margin!r}")
        self.arm = arm
        self.scene = scene
        self.margin = margin
        self.num_threads = int(num_threads)
        self.cache_size = int(cache_size)
        self._checkers: dict[Fraction, CollisionChecker] = {}
        self.builds = 0

    def at_sample(self, k: int) -> CollisionChecker:
        """The checker of sample ``k`` (obstacles at t = k·ts)."""
        return self.at_time(k)

    def at_time(self, k: int, j: int = 0, n: int = 1) -> CollisionChecker:
        """The checker of the obstacles at t = (k + j/n)·ts (0 ≤ j < n), built once and cached.

        ``j = 0`` is sample k itself; (k, 1, 2) and (k, 2, 4) share one checker.
        """
        k, j, n = int(k), int(j), int(n)
        if k < 0:
            raise ValueError(f"sample index must be ≥ 0, got {k}")
        if n < 1 or not 0 <= j < n:
            raise ValueError(f"sub-step j/n must satisfy 0 ≤ j < n, got {j}/{n}")
        key = Fraction(k * n + j, n)
        chk = self._checkers.get(key)
        if chk is None:
            if len(self._checkers) >= self.cache_size:
                self._checkers.pop(next(iter(self._checkers)))
            chk = CollisionChecker(
                self.arm,
                self.scene.world_at(float(key) * self.scene.ts),
                margin=self.margin,
                num_threads=self.num_threads,
            )
            self._checkers[key] = chk
            self.builds += 1
        return chk

    def is_free_between(self, q0: Any, q1: Any, k: int, substeps: int) -> bool:
        """True if the move q0 (sample k) → q1 (sample k+1) is free at its inner sub-steps.

        The joints are interpolated linearly, q0 + (j/n)(q1 − q0), and checked
        against the obstacles at t = (k + j/n)·ts for j = 1 … n−1 (n =
        ``substeps``; n = 1 checks nothing). The two ends are the samples
        themselves, which the caller checks.
        """
        Q0 = np.asarray(q0, dtype=float)[None, :]
        Q1 = np.asarray(q1, dtype=float)[None, :]
        return bool(self.is_free_between_batch(Q0, Q1, k, substeps)[0])

    def is_free_between_batch(self, Q0: Any, Q1: Any, k: int, substeps: int) -> np.ndarray:
        """:meth:`is_free_between` for the rows of ``Q0``, ``Q1`` (M, 2) (rad); (M,) bool."""
        Q0 = np.asarray(Q0, dtype=float)
        Q1 = np.asarray(Q1, dtype=float)
        n = int(substeps)
        if n < 1:
            raise ValueError(f"substeps must be ≥ 1, got {substeps!r}")
        ok = np.ones(Q0.shape[0], dtype=bool)
        for j in range(1, n):
            idx = np.flatnonzero(ok)
            if idx.size == 0:
                break
            Qj = Q0[idx] + (j / n) * (Q1[idx] - Q0[idx])
            ok[idx[~self.at_time(k, j, n).is_free_batch(Qj)]] = False
        return ok

    def is_free(self, q: Any, k: int) -> bool:
        """True if ``q`` (rad) is free at sample ``k``."""
        return self.at_sample(k).is_free(q)

    def is_free_batch(self, Q: Any, k: int) -> np.ndarray:
        """Validity (K,) of the rows of ``Q`` (K, 2) (rad) at sample ``k``."""
        Q = np.asarray(Q, dtype=float)
        if Q.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        return self.at_sample(k).is_free_batch(Q)

    def clearance(self, q: Any, k: int) -> float:
        """Signed distance (m) from the link geometry to the nearest disc at sample ``k``."""
        return self.at_sample(k).clearance(q)
