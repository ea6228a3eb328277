"""Motors sized from the URDF limits: the ``sized`` preset (docs/design.md §3g).

Per joint, a DC motor and a gear ratio are chosen so that

* the motor's continuous torque behind the gearbox covers the URDF effort limit,
  ``n · τ_cont ≥ τ_lim``, and
* its no-load speed at the supply voltage covers the URDF velocity limit with a
  margin, ``V_s / Ke ≥ (1 + margin) · n · ω_lim``.

The motors follow one datasheet class: graphite-brushed DC motors with an ironless
rotor, wound for a 24 V supply. A *frame* fixes what the winding does not change —
continuous torque τ_cont, motor constant Km = Kt/√R, rotor inertia J, electrical
time constant L/R and viscous friction B — and the winding then sets Kt = Ke (SI
units): R = (Kt/Km)², L = R·(L/R). The frame constants below are rounded values
representative of public catalogue data for 25, 40 and 65 mm motors of this class,
not any one product. The smallest frame whose gear ratio stays within
``max_gear_ratio`` is taken (smaller rotors reflect less inertia n²J).

A motor sized this way covers the limits the URDF states; whether it can follow a
particular edge is decided by simulating it (a motor that cannot follow makes the
edge miss its node, and such an edge is refused, never costed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..arm.model import Arm
from .motor import DCMotor, Drive

__all__ = ["MotorFrame", "MOTOR_FRAMES", "sized_motor", "sized_motors", "check_holding"]


@dataclass(frozen=True)
class MotorFrame:
    """What a motor frame fixes, whatever its winding.

    torque: continuous (thermal) torque (N·m); km: motor constant Kt/√R (N·m/√W);
    J: rotor inertia (kg·m²); tau_e: electrical time constant L/R (s);
    B: viscous friction at the motor shaft (N·m·s).
    """

    name: str
    torque: float
    km: float
    J: float
    tau_e: float
    B: float


#: Graphite-brushed, ironless-rotor DC motors (24 V class), smallest first.
MOTOR_FRAMES: tuple[MotorFrame, ...] = (
    MotorFrame("25 mm, 20 W", torque=0.028, km=0.016, J=1.1e-6, tau_e=1.1e-4, B=1.1e-6),
    MotorFrame("40 mm, 150 W", torque=0.18, km=0.055, J=1.4e-5, tau_e=2.7e-4, B=3.8e-6),
    MotorFrame("65 mm, 250 W", torque=0.85, km=0.16, J=1.3e-4, tau_e=4.0e-4, B=2.5e-5),
)


def sized_motor(
    effort: float,
    velocity: float,
    *,
    supply_voltage: float = 24.0,
    speed_margin: float = 0.25,
    max_gear_ratio: float = 400.0,
    what: str = "joint",
) -> tuple[DCMotor, MotorFrame]:
    """The motor (with gear ratio and ``v_max = supply_voltage``) for one joint.

    ``effort`` (N·m) and ``velocity`` (rad/s) are the joint's URDF limits. Raises
    ValueError if a limit is missing (0, negative, non-finite) or no frame reaches the
    effort within ``max_gear_ratio``.
    """
    for name, val in (("effort", effort), ("velocity", velocity)):
        if not (math.isfinite(val) and val > 0.0):
            raise ValueError(
                f"{what}: the URDF {name} limit is {val!r}; the 'sized' motor preset needs "
                "positive effort and velocity limits"
            )
    for frame in MOTOR_FRAMES:
        n = max(1.0, effort / frame.torque)
        if n <= max_gear_ratio:
            break
    else:
        biggest = MOTOR_FRAMES[-1]
        raise ValueError(
            f"{what}: effort limit {effort:g} N·m needs more than {max_gear_ratio:g}:1 even on "
            f"the largest motor frame ({biggest.name}, {biggest.torque:g} N·m continuous)"
        )
    k = supply_voltage / ((1.0 + speed_margin) * n * velocity)  # Kt = Ke (SI)
    R = (k / frame.km) ** 2
    motor = DCMotor(
        R=R, L=R * frame.tau_e, Kt=k, Ke=k, B=frame.B, J=frame.J, gear_ratio=n,
        v_max=supply_voltage,
    )
    return motor, frame


def sized_motors(
    arm: Arm,
    *,
    supply_voltage: float = 24.0,
    speed_margin: float = 0.25,
    max_gear_ratio: float = 400.0,
) -> list[DCMotor]:
    """One :func:`sized_motor` per joint of ``arm`` from its URDF effort and velocity limits."""
    effort = np.asarray(arm.model.effortLimit, dtype=float)
    velocity = np.asarray(arm.model.velocityLimit, dtype=float)
    return [
        sized_motor(
            float(effort[k]), float(velocity[k]), supply_voltage=supply_voltage,
            speed_margin=speed_margin, max_gear_ratio=max_gear_ratio,
            what=f"joint {name!r} of {arm.name!r}",
        )[0]
        for k, name in enumerate(arm.joint_names)
    ]


def check_holding(drive: Drive, q, what: str = "q", *, effort_limits: bool = True) -> None:
    """ValueError naming the first joint whose motor cannot hold the arm still at ``q``
    (rad) against gravity (docs/design.md §3g).

    The test is the **stall torque** at the supply voltage: holding needs the current
    i = G(q)/(n·Kt), hence the voltage R·i, so a joint with ``|G_k(q)| > n·Kt·V_max/R``
    cannot be held at all (a motor without ``v_max`` never fails it). The continuous
    torque is not a property of a general :class:`DCMotor` (only sized motors have one,
    and theirs covers the effort limit); with ``effort_limits`` a holding torque above
    the URDF effort limit (where it is positive) is refused too, since every edge from
    or to ``q`` would then be refused by the effort rule (§4e).
    """
    arm = drive.arm
    G = np.abs(arm.gravity(q))
    stall = drive.torque_per_amp * drive.v_max / drive.R  # inf without a voltage limit
    effort = np.asarray(arm.model.effortLimit, dtype=float)
    for k, name in enumerate(arm.joint_names):
        if G[k] > stall[k]:
            raise ValueError(
                f"{what}: the motor of joint {name!r} is too weak to hold the arm there: "
                f"gravity needs {G[k]:.4g} N·m, its stall torque n·Kt·V_max/R is "
                f"{stall[k]:.4g} N·m; use a stronger motor or gear ratio (e.g. [motor] "
                'preset = "sized")'
            )
        if effort_limits and math.isfinite(effort[k]) and 0 < effort[k] < G[k]:
            raise ValueError(
                f"{what}: holding the arm there needs {G[k]:.4g} N·m at joint {name!r}, "
                f"above its effort limit of {effort[k]:.4g} N·m (every edge from or to it "
                "would be refused)"
            )
