"""What a priced motion is (docs/design.md §9a): :class:`MotionEnergy`, the executions, and
the checks of waypoints and limits shared by every way of pricing a path
(:mod:`mpd_pin.motion.energy`, :mod:`mpd_pin.motion.timed`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from ..dynamics.supply import PER_JOINT, Supply, energy_by_supply
from .spline import ViaSpline

__all__ = ["EXECUTIONS", "PRICINGS", "MotionEnergy", "waypoint_array", "check_waypoints",
           "limit_reasons", "joint_range", "range_reason", "RANGE_TOLERANCE"]

#: Values of ``execution``; the first is the default.
EXECUTIONS = ("auto", "stop", "nonstop")

#: What :func:`trajectory_energy` prices: the executions, and "timed" (a trajectory with its
#: own times, :mod:`mpd_pin.motion.timed`; not a planning option, so not in EXECUTIONS).
PRICINGS = EXECUTIONS + ("timed",)

@dataclass
class MotionEnergy:
    """What a path costs when the arm runs it (all energies E⁺, J; times s; angles rad).

    execution: "stop" or "nonstop" (the one these numbers are for); waypoints (m+1, nq):
    the via points as executed (continuous joints unwrapped); stops: via points where the
    arm comes to rest between start and goal; pieces: (first, last) waypoint index of each
    piece run in one go; piece_durations (s); energy_per_joint, total_energy (J);
    duration (s); end_error: largest |q(T) − q_end| over pieces and joints (rad);
    velocity_ratio: peak |q̇_ref| / velocity limit; effort_ratio: peak |n·Kt·i| / effort
    limit; feasible: within both limits, arriving within the tolerance, and certified
    collision-free when a checker was given (``reason`` says why not);
    energy_by_execution: total E⁺ of each mode evaluated (None: infeasible);
    duration_curve: (duration, E⁺) pairs the non-stop search simulated and found feasible
    within its duration range (all it simulated when none was); ideal_curve: the
    perfect-tracking (duration, E⁺) screen over that range; fastest: the shortest duration
    of a feasible motion of this execution and geometry (s: stop-and-go, the roadmap
    timing; non-stop, the fastest uniform stretch of each piece's spline that is simulated
    within the effort, velocity and arrival limits, docs/design.md §9c; timed, its own);
    velocity_fastest: the velocity limits' bound alone (s); longest: the end of the
    duration range searched (s); duration_rule: how the duration was chosen.
    """

    execution: str
    waypoints: np.ndarray
    energy_per_joint: np.ndarray
    total_energy: float
    duration: float
    end_error: float
    velocity_ratio: float
    effort_ratio: float
    feasible: bool
    stops: int
    pieces: list[tuple[int, int]]
    piece_durations: np.ndarray
    reason: str = ""
    energy_by_execution: dict[str, float | None] = field(default_factory=dict)
    duration_curve: list[tuple[float, float]] = field(default_factory=list)
    ideal_curve: list[tuple[float, float]] = field(default_factory=list)
    alternative: MotionEnergy | None = None
    #: the shortest duration of a feasible motion of this execution and geometry (s)
    fastest: float = 0.0
    #: the shortest duration the velocity limits alone allow (s; ≤ ``fastest``)
    velocity_fastest: float = 0.0
    #: the longest duration the search allowed (s; the end of the energy–time front)
    longest: float = 0.0
    #: how the duration was chosen (result.json ``motion.duration_rule``)
    duration_rule: str = ""
    #: a straight segment between the waypoints failed the certified check
    colliding: bool = False
    #: [B⁺, B⁻] of the shared bus over the motion (J, docs/design.md §3i)
    bus_energy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    #: the supply ``total_energy`` is priced with (the drive's)
    supply: Supply = PER_JOINT
    #: an optimised motion's own curve (docs/design.md §9g): one non-stop piece that
    #: follows this spline (at unit stretch its duration) instead of the spline through
    #: ``waypoints``; None for every other motion
    curve: ViaSpline | None = None
    #: ``motion.optimization`` of the optimisation that made or kept this motion (§9g)
    optimization: dict[str, Any] | None = None
    #: the recorded series (:class:`~mpd_pin.dynamics.tracking.TrackedSeries`) of the
    #: simulation that priced an optimised motion at ``duration``: its time series is that
    #: simulation's, not simulated again (docs/design.md §9d); None for every other motion
    recorded: Any = field(default=None, repr=False, compare=False)

    @property
    def fastest_duration(self) -> float:
        """``fastest`` (s): the shortest duration of a feasible motion of this execution
        and geometry — for non-stop pieces the fastest uniform stretch within the velocity,
        effort and arrival limits, simulated (docs/design.md §9c)."""
        return float(self.fastest)

    def energy_by_supply(self) -> dict[str, float]:
        """This motion's energy (J) per joint, on a shared bus, and on a shared bus with
        this supply's regeneration (docs/design.md §3i)."""
        return energy_by_supply(self.energy_per_joint, self.bus_energy,
                                self.supply.regeneration)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data (docs/design.md §9d)."""
        return {
            "execution": self.execution,
            "feasible": bool(self.feasible),
            "reason": self.reason,
            "total_energy": float(self.total_energy),
            "energy_per_joint": [float(x) for x in self.energy_per_joint],
            "bus_energy": [float(x) for x in self.bus_energy],
            "duration": float(self.duration),
            "stops": int(self.stops),
            "pieces": [[int(a), int(b)] for a, b in self.pieces],
            "piece_durations": [float(x) for x in self.piece_durations],
            "end_error": float(self.end_error),
            "velocity_ratio": float(self.velocity_ratio),
            "effort_ratio": float(self.effort_ratio),
            "energy_by_execution": {k: (None if v is None else float(v))
                                    for k, v in self.energy_by_execution.items()},
            "waypoints": np.asarray(self.waypoints, float).tolist(),
        }


# ----------------------------------------------------------------------------- input
def waypoint_array(drive: Drive, waypoints: Any) -> np.ndarray:
    """``waypoints`` as an (m+1, nq) float array, continuous joints unwrapped (each point
    the shorter way round from the one before, docs/design.md §1d), repeated points kept;
    ValueError naming the row (from 1) for a wrong shape or NaN."""
    W = np.asarray(waypoints, dtype=float)
    nq = drive.nq
    if W.ndim != 2 or W.shape[1] != nq:
        raise ValueError(f"waypoints must have shape (m, {nq}) (one configuration per row), "
                         f"got {W.shape}")
    bad = np.flatnonzero(~np.isfinite(W).all(axis=1))
    if bad.size:
        raise ValueError(f"waypoint row {int(bad[0]) + 1} (counting from 1) contains NaN or "
                         "infinity")
    arm = drive.arm
    if arm.continuous_joints:
        W = W.copy()
        for r in range(1, W.shape[0]):
            W[r] = arm.edge_target(W[r - 1], W[r])
    return W


def check_waypoints(drive: Drive, waypoints: Any) -> np.ndarray:
    """:func:`waypoint_array` with repeated points dropped; ValueError naming the row for a
    wrong shape, NaN or fewer than 2 distinct points."""
    W = waypoint_array(drive, waypoints)
    keep = np.concatenate([[True], np.any(np.abs(np.diff(W, axis=0)) > 1e-12, axis=1)])
    W = W[keep]
    if W.shape[0] < 2:
        raise ValueError("waypoints must hold at least two distinct configurations")
    return W


#: How far (rad) a simulated motion may pass a joint limit before :func:`range_reason`
#: names it: round-off of the tracking simulation (a Panda optimum along its limit was
#: simulated 7e-9 rad past it), far below any encoder's resolution.
RANGE_TOLERANCE = 1e-6


def joint_range(arm: Any) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's range (lower, upper), (nq,) rad or m: the URDF limits, ±inf for a
    continuous joint, which has none (docs/design.md §1d)."""
    cont = np.asarray(arm.continuous_mask, dtype=bool)
    lo = np.where(cont, -np.inf, np.asarray(arm.lower_limits, float))
    hi = np.where(cont, np.inf, np.asarray(arm.upper_limits, float))
    return lo, hi


def range_reason(arm: Any, q: np.ndarray, what: str = "simulated") -> str:
    """Why the joint positions ``q`` (n, nq) rad leave the arm's range (:func:`joint_range`)
    by more than :data:`RANGE_TOLERANCE`, "" when they do not: the joint that passes a
    limit furthest, which limit and by how much (rad), and ``what`` ``q`` is."""
    lo, hi = joint_range(arm)
    q = np.asarray(q, float)
    below = np.max(lo - q, axis=0, initial=-np.inf)
    above = np.max(q - hi, axis=0, initial=-np.inf)
    excess = np.maximum(below, above)
    if not (excess > RANGE_TOLERANCE).any():
        return ""
    k = int(np.argmax(excess))
    side = "lower" if below[k] >= above[k] else "upper"
    return (f"joint {arm.joint_names[k]!r} passes its {side} limit by {excess[k]:.3g} rad "
            f"({what})")


def limit_reasons(options, effort: float, end_error: float, velocity: float, end: str,
                  *, effort_on: bool | None = None) -> list[str]:
    """Why a simulated motion is infeasible under ``options`` (a RoadmapOptions): peak
    ``effort`` and ``velocity`` as multiples of their limits (each enforced when the
    options ask), ``end_error`` (rad) from ``end`` (e.g. "a waypoint") beyond the arrival
    tolerance. ``effort_on`` overrides ``options.effort_limits``."""
    effort_on = bool(options.effort_limits) if effort_on is None else effort_on
    reasons = []
    if effort_on and effort > 1.0 + 1e-12:
        reasons.append(f"effort limit exceeded ({effort:.3g}× the limit)")
    if end_error > options.arrival_tolerance:
        reasons.append(f"ends {end_error:.3g} rad from {end} (tolerance "
                       f"{options.arrival_tolerance:g})")
    if options.velocity_limits and velocity > 1.0 + 1e-9:
        reasons.append(f"velocity limit exceeded ({velocity:.3g}×)")
    return reasons
