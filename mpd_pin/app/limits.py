"""Physical ranges of every number a scenario file may hold (docs/design.md §7b).

A scenario value outside its range is refused when it is read (:class:`~mpd_pin.app.config.Table`
calls :meth:`Bound.check`; :class:`Bound` is defined in :mod:`mpd_pin.app.config`, beside
the table that applies it, and named here too), with one line naming the key and the
bound, so that no numerical routine ever sees an absurd or non-finite number. Two kinds
of bound:

* fixed ones, :data:`BOUNDS` — far beyond any real motor, gain or step size, tight enough
  that a typo (``1e308``, degrees for radians) fails clearly;
* lengths relative to the arm: :func:`workspace_bound` is ``WORKSPACE_FACTOR`` (10) times the
  arm's reach (:func:`arm_reach`, an upper bound of the distance of any frame from the base);
  positions (obstacle centres, vertices, trajectories, end-effector targets, grid corners)
  must lie within ± that bound per coordinate, sizes (widths, radii, sides, clearances,
  margins) within (0, 2 × bound].
"""

from __future__ import annotations

import math

import numpy as np

from .config import Bound, ConfigError, Table, did_you_mean

__all__ = [
    "BOUNDS",
    "Bound",
    "WORKSPACE_FACTOR",
    "arm_reach",
    "workspace_bound",
    "position_bound",
    "size_bound",
    "joint_bounds",
    "apply_joint_limits",
    "check_joint_limits",
]

#: Positions within ± this many times the arm's reach (m).
WORKSPACE_FACTOR = 10.0


def _b(lo: float, hi: float, unit: str, what: str, **kw) -> Bound:
    return Bound(lo, hi, unit, what, **kw)


#: Fixed ranges of the scenario numbers that do not scale with the arm (SI units).
BOUNDS: dict[str, Bound] = {
    # motors (docs/design.md §3a); the presets are R 1–2 Ω, L 1e-3–0.5 H, Kt 0.01–0.03
    "R": _b(1e-6, 1e4, "Ω", "the motor resistance range"),
    "L": _b(1e-9, 100.0, "H", "the motor inductance range"),
    "Kt": _b(1e-6, 100.0, "N·m/A", "the torque constant range"),
    "Ke": _b(0.0, 100.0, "V·s/rad", "the back-EMF constant range"),
    "B": _b(0.0, 100.0, "N·m·s/rad", "the motor friction range"),
    "J": _b(0.0, 100.0, "kg·m²", "the rotor inertia range"),
    "gear_ratio": _b(1e-3, 1e5, "", "the gear ratio range"),
    "v_max": _b(1e-3, 1e4, "V", "the supply voltage range"),
    # controller (§3c)
    "kp": _b(0.0, 1e6, "V/rad", "the gain range"),
    "kd": _b(0.0, 1e6, "V·s/rad", "the gain range"),
    # roadmap (§4e)
    "dt": _b(1e-9, 1.0, "s", "the step size range"),  # and ≤ 100000 steps per edge
    "duration": _b(1e-3, 60.0, "s", "the edge duration range"),
    "joint_speed": _b(1e-3, 1e3, "rad/s", "the joint speed range"),
    "resolution": _b(1e-3, 2 * math.pi, "rad", "the resolution range"),
    "arrival_tolerance": _b(0.0, math.pi, "rad", "the tolerance range", lo_open=True),
    "angle": _b(-2 * math.pi, 2 * math.pi, "rad", "the angle bound"),
    # [limits] table: joint velocity and effort limits (§7b); prismatic: m/s and N
    "velocity": _b(0.0, 1e3, "rad/s", "the joint velocity limit range", lo_open=True),
    "effort": _b(0.0, 1e5, "N·m", "the joint effort limit range", lo_open=True),
    "max_duration": _b(0.0, 3600.0, "s", "the motion duration range", lo_open=True),
    "hazard_penalty": _b(1.0, 1e12, "", "the penalty range", allow_inf=True,
                         note="or inf: edges through a hazard removed"),
    # dynamic2link (§6)
    "sample_time": _b(1e-4, 1.0, "s", "the sample time range"),
    "max_joint_step": _b(0.0, math.pi, "rad", "the joint step range", lo_open=True),
    "speed": _b(0.0, 1e3, "m/s", "the obstacle speed range", lo_open=True),
    "delay": _b(0.0, 1e5, "s", "the delay range"),
    "phase": _b(0.0, 1.0, "", "the phase range"),
    "pso_coefficient": _b(0.0, 10.0, "", "the PSO coefficient range"),
}

#: Integer ranges of dynamic2link counts (the energy roadmap's are in scenario.LIMITS).
INT_LIMITS = {
    "substeps": 100,
    "max_samples": 100_000,
    "lookahead": 10_000,
    "particles": 10_000,
    "iterations": 100_000,
    "via_points": 1_000,
    "seed": 2**63 - 1,
    "polyline_points": 10_000,
}


def arm_reach(arm) -> float:
    """An upper bound (m) of the distance of any frame of ``arm`` from the world origin.

    The sum of the joints' placement offsets, the largest prismatic travel of each
    joint and the largest frame offset from its joint (triangle inequality).
    """
    model = arm.model
    lo, hi = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
    reach = 0.0
    for j in range(1, model.njoints):
        reach += float(np.linalg.norm(model.jointPlacements[j].translation))
        short = model.joints[j].shortname()
        if short.startswith("JointModelP") and not short.startswith("JointModelPlanar"):
            # a prismatic joint adds its travel
            i = model.joints[j].idx_q
            travel = np.abs(np.concatenate([lo[i:i + 1], hi[i:i + 1]]))
            reach += float(np.max(travel[np.isfinite(travel)], initial=0.0))
    reach += max((float(np.linalg.norm(f.placement.translation)) for f in model.frames),
                 default=0.0)
    return max(reach, 0.1)


def workspace_bound(arm) -> float:
    """± this (m) per coordinate bounds every position in a scenario of ``arm``."""
    return float(f"{WORKSPACE_FACTOR * arm_reach(arm):.2g}")


def position_bound(arm) -> Bound:
    """The range of one coordinate of a position (m)."""
    w = workspace_bound(arm)
    return Bound(-w, w, "m", "the workspace bound",
                 note=f"{WORKSPACE_FACTOR:g} × the arm's reach of {arm_reach(arm):.3g} m")


def size_bound(arm, *, zero: bool = False) -> Bound:
    """The range of a size, radius, clearance or margin (m): (0, 2 × workspace bound]
    (``zero``: 0 allowed)."""
    return Bound(0.0, 2 * workspace_bound(arm), "m", "the size range", lo_open=not zero)


# ------------------------------------------------------------ joint limits ([limits])
def _is_prismatic(model, k: int) -> bool:
    short = model.joints[k + 1].shortname()
    return short.startswith("JointModelP") and not short.startswith("JointModelPlanar")


#: How far (rad) outside its limits a joint angle must be to earn the degrees hint.
DEGREES_HINT_BEYOND = 2 * math.pi
DEGREES_HINT = "the angles are in radians (did you give degrees?)"


def joint_bounds(arm, tol: float = 1e-9) -> list[Bound]:
    """The position range of each movable joint of ``arm`` (rad, or m if prismatic), with
    ``tol`` of slack; an angle more than :data:`DEGREES_HINT_BEYOND` outside the limits of
    a revolute or continuous joint gets :data:`DEGREES_HINT` in its message."""
    model = arm.model
    out = []
    for k, (name, lo, hi) in enumerate(zip(arm.joint_names, arm.lower_limits,
                                           arm.upper_limits, strict=True)):
        revolute = not _is_prismatic(model, k)
        out.append(Bound(float(lo), float(hi), "", f"the limits of joint {name!r}", tol=tol,
                         interval=True, far=DEGREES_HINT_BEYOND if revolute else math.inf,
                         far_hint=DEGREES_HINT if revolute else ""))
    return out


def _units(model, k: int) -> dict[str, str]:
    return {"velocity": "m/s", "effort": "N"} if _is_prismatic(model, k) else {
        "velocity": "rad/s", "effort": "N·m"}


def apply_joint_limits(t: Table, arm) -> dict[str, dict[str, float]]:
    """``[limits]``: ``joint = { velocity = …, effort = … }`` (rad/s and N·m; m/s and N
    for prismatic joints) fills or overrides the URDF limits of the named joints of
    ``arm`` in place (its Pinocchio model, so the fingerprint follows). ConfigError
    naming the key for an unknown joint, key or a value outside (0, bound]
    (docs/design.md §7b). Returns the values applied, joint by joint."""
    names = arm.joint_names
    applied: dict[str, dict[str, float]] = {}
    for joint in list(t.data):
        if joint not in names:
            locked = " (it is locked)" if joint in arm.locked_joints else ""
            hint = "" if locked else did_you_mean([joint], names)
            raise ConfigError(f"{t.path}.{joint}: the arm has no movable joint {joint!r}"
                              f"{locked}; joints: {names}{hint}")
        jt = t.table(joint)
        k = names.index(joint)
        units = _units(arm.model, k)
        entry = {}
        for kind in ("velocity", "effort"):
            if jt.has(kind):
                b = BOUNDS[kind]
                entry[kind] = jt.number(kind, bound=Bound(b.lo, b.hi, units[kind], b.what,
                                                          lo_open=True))
        jt.done()
        if not entry:
            raise ConfigError(f"{t.path}.{joint}: give velocity and/or effort")
        if "velocity" in entry:
            arm.model.velocityLimit[k] = entry["velocity"]
        if "effort" in entry:
            arm.model.effortLimit[k] = entry["effort"]
        applied[joint] = entry
    t.done()
    return applied


def check_joint_limits(arm, *, velocity: bool = True, effort: bool = True) -> None:
    """ConfigError naming the first joint whose URDF velocity (if ``velocity``) or
    effort (if ``effort``) limit is zero, negative or not finite — common in
    hand-written URDFs — with the ``[limits]`` entry that would supply it (§7b)."""
    model = arm.model
    for k, name in enumerate(arm.joint_names):
        units = _units(model, k)
        for kind, on, arr in (("velocity", velocity, model.velocityLimit),
                              ("effort", effort, model.effortLimit)):
            val = float(arr[k])
            if on and not (math.isfinite(val) and val > 0):
                raise ConfigError(
                    f"arm: joint {name!r} has no {kind} limit in its URDF ({val:g} "
                    f"{units[kind]}); add it to the scenario: [limits] {name} = "
                    f"{{ {kind} = ... }} ({units[kind]})"
                )
