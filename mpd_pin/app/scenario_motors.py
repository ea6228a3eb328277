"""The motors and gains of an energy scenario: ``[motor]`` (constants shared, or one value
per joint), ``[[motors]]`` (one table per joint), presets (``paper``, ``servo``, ``sized``
from the URDF limits, docs/design.md §3g) and ``[controller]`` gains, each number checked
against its physical range (app/limits.py) with errors that name the key and the joint.
:mod:`mpd_pin.app.scenario` reads the rest of the file.
"""

from __future__ import annotations

import re
from dataclasses import replace

from ..arm.model import Arm
from ..dynamics.motor import PAPER_MOTOR, SERVO_MOTOR, DCMotor
from ..dynamics.sizing import sized_motors
from .config import ConfigError, Table
from .limits import BOUNDS

__all__ = ["MOTOR_CONSTANTS", "MOTOR_PRESETS", "gain", "motor_tables", "motors_from_tables"]

MOTOR_PRESETS = {"paper": PAPER_MOTOR, "servo": SERVO_MOTOR, "sized": None}  # sized: per arm

MOTOR_CONSTANTS = ("R", "L", "Kt", "Ke", "B", "J", "gear_ratio", "v_max")


def _sized(t: Table, arm: Arm) -> list[DCMotor]:
    """``preset = "sized"``: motors sized from the arm's URDF limits at the supply voltage
    ``v_max`` (default 24 V; docs/design.md §3g)."""
    supply = t.number("v_max", 24.0, bound=BOUNDS["v_max"]) if t.has("v_max") else 24.0
    try:
        return sized_motors(arm, supply_voltage=supply)
    except ValueError as exc:
        raise ConfigError(f"{t.path}.preset: {exc}") from None


def _motor_one(
    t: Table, arm: Arm, index: int | None = None, *, joint: int | None = None
) -> DCMotor:
    """One motor from a table of scalars; with ``index``, array values give joint ``index``.

    ``joint`` is the joint the motor drives (``preset = "sized"`` needs it)."""
    preset = t.string("preset", "paper", choices=MOTOR_PRESETS)
    if preset == "sized":
        j = index if index is not None else joint
        if j is None:
            raise ConfigError(f"{t.path}.preset: 'sized' gives one motor per joint")
        base = _sized(t, arm)[j]
    else:
        base = MOTOR_PRESETS[preset]
    t.seen.update(MOTOR_CONSTANTS)  # every constant is a known key (for unknown-key errors)
    fields = {}
    for name in MOTOR_CONSTANTS:
        if not t.has(name):
            continue
        if index is None:
            fields[name] = t.number(name, positive=name == "v_max")
        else:
            val = t.numbers(name)
            fields[name] = val if isinstance(val, float) else val[index]
    j = index if index is not None else joint
    label = "" if j is None else f" (joint {arm.joint_names[j]!r})"
    if fields.get("v_max", 1.0) <= 0:
        raise ConfigError(f"{t.path}.v_max: must be > 0, got {fields['v_max']}{label}")
    for name, val in fields.items():  # the physical ranges first (app/limits.py)
        per_joint = index is not None and isinstance(t.data[name], list)
        try:
            BOUNDS[name].check(f"{t.path}.{name}" + (f"[{index}]" if per_joint else ""), val)
        except ConfigError as exc:  # name the joint when the value is one joint's
            raise ConfigError(f"{exc}{label if per_joint or joint is not None else ''}") from None
    try:
        motor = replace(base, **fields)
    except ValueError as exc:  # DCMotor's own checks (R > 0, B ≥ 0, ...)
        raise ConfigError(f"{t.path}{label}: {exc}") from None
    return motor


def motors_from_tables(top: Table, arm: Arm) -> DCMotor | list[DCMotor]:
    """``[motor]`` (constants scalar or one per joint) or ``[[motors]]`` (one table per joint).

    Returns one DCMotor when every constant is a scalar, else a list of ``nq``.
    """
    nq = arm.nq
    if top.has("motor") and top.has("motors"):
        raise ConfigError("give [motor] (shared or per-joint arrays) or [[motors]], not both")
    if top.has("motors"):
        tables = top.tables("motors")
        if len(tables) != nq:
            raise ConfigError(
                f"motors: expected one [[motors]] table per joint ({nq}), got {len(tables)}"
            )
        motors = []
        for j, t in enumerate(tables):
            motors.append(_motor_one(t, arm, joint=j))
            t.done()
        return motors
    t = top.table("motor")
    per_joint = []
    for name in MOTOR_CONSTANTS:
        if t.has(name) and isinstance(t.data[name], list):
            val = _per_joint_numbers(t, name, arm)
            if len(val) != nq:
                raise ConfigError(
                    f"motor.{name}: expected one value or {nq} values (one per joint), "
                    f"got {len(val)}"
                )
            per_joint.append(name)
    if not per_joint and t.raw("preset", "paper") != "sized":
        motor = _motor_one(t, arm)
        t.done()
        return motor
    motors = [_motor_one(t, arm, j) for j in range(nq)]
    t.done()
    return motors


def _per_joint_numbers(t: Table, name: str, arm: Arm) -> list[float] | float:
    """``t.numbers(name)``; an error about element ``[i]`` also names joint i."""
    try:
        return t.numbers(name)
    except ConfigError as exc:
        m = re.match(rf"{re.escape(t.path)}\.{name}\[(\d+)\]", str(exc))
        if m is None or int(m.group(1)) >= arm.nq:
            raise
        raise ConfigError(f"{exc} (joint {arm.joint_names[int(m.group(1))]!r})") from None


def motor_tables(top: Table) -> list[dict]:
    """The raw ``[motor]`` / ``[[motors]]`` tables (for a first look at their presets)."""
    raw = [top.data.get("motor", {})] + list(top.data.get("motors", []) or [])
    return [m for m in raw if isinstance(m, dict)]


def gain(t: Table, key: str, default: float, nq: int) -> float | list[float]:
    if t.has(key) and isinstance(t.data[key], (int, float)) and t.data[key] < 0:
        raise ConfigError(f"{t.path}.{key}: gains must be ≥ 0, got {t.data[key]}")
    val = t.numbers(key, default, bound=BOUNDS[key])
    if isinstance(val, list) and len(val) != nq:
        raise ConfigError(f"{t.path}.{key}: expected one value or {nq} values, got {len(val)}")
    vals = [val] if isinstance(val, float) else val
    if any(v < 0 for v in vals):
        raise ConfigError(f"{t.path}.{key}: gains must be ≥ 0, got {val}")
    return val
