"""DC motors, gearing and the joint voltage controller (docs/design.md §3; paper 000 Table 7).

Per joint k the motor obeys

    L di/dt = V − R i − n Ke q̇             (armature circuit, Kirchhoff)
    τ_joint = n Kt i − n² B q̇              (torque through an ideal gear of ratio n)

and adds the reflected rotor inertia n² J to the arm's inertia matrix.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from ..arm.model import Arm
from .payload import Payload, carried_payload, payload_arm
from .supply import PER_JOINT, Supply

__all__ = ["DCMotor", "PAPER_MOTOR", "SERVO_MOTOR", "Drive"]


@dataclass(frozen=True)
class DCMotor:
    """A brushed DC motor with gearbox.

    Attributes
    ----------
    R: armature resistance (Ω), > 0.
    L: armature inductance (H), > 0.
    Kt: torque constant (N·m/A), > 0.
    Ke: back-EMF constant (V·s/rad), ≥ 0.
    B: viscous friction on the motor side (N·m·s/rad), ≥ 0.
    J: rotor inertia (kg·m²), ≥ 0.
    gear_ratio: n, motor turns per joint turn, > 0.
    v_max: supply voltage limit (V) for saturation, or None for none.
    """

    R: float = 1.0
    L: float = 0.5
    Kt: float = 0.01
    Ke: float = 0.02
    B: float = 0.1
    J: float = 0.01
    gear_ratio: float = 1.0
    v_max: float | None = None

    def __post_init__(self) -> None:
        for name in ("R", "L", "Kt", "Ke", "B", "J", "gear_ratio", "v_max"):
            val = getattr(self, name)
            if val is None and name == "v_max":
                continue
            try:
                num = float(val)
            except (TypeError, ValueError):
                raise ValueError(f"DCMotor.{name} must be a number, got {val!r}") from None
            strict = name in ("R", "L", "Kt", "gear_ratio", "v_max")
            if not math.isfinite(num) or num < 0 or (strict and num == 0):
                bound = "> 0" if strict else "≥ 0"
                raise ValueError(f"DCMotor.{name} must be a finite number {bound}, got {val!r}")
            object.__setattr__(self, name, num)

    def with_gear_ratio(self, n: float) -> DCMotor:
        """The same motor behind a gearbox of ratio ``n``."""
        return replace(self, gear_ratio=float(n))


#: Table 7 of paper 000 (R 1 Ω, L 0.5 H, Kt 0.01 N·m/A, Ke 0.02 V·s/rad, b 0.1 N·m·s).
#: The paper gives no rotor inertia: J = 0.01 kg·m² is our assumption. Its constants
#: are not energy-consistent (Ke ≠ Kt) and weak: the paper scenarios use a gear ratio
#: of a few units and feed-forward to track (see the scenario files for the values).
PAPER_MOTOR = DCMotor(R=1.0, L=0.5, Kt=0.01, Ke=0.02, B=0.1, J=0.01, gear_ratio=1.0)

#: A realistic small servo (Kt = Ke in SI units) behind a 100:1 gearbox, 24 V supply.
#: Its electrical time constant L/R = 0.5 ms is stiff at a 5 ms step (docs/design.md §3e).
SERVO_MOTOR = DCMotor(R=2.0, L=1e-3, Kt=0.03, Ke=0.03, B=1e-6, J=5e-6, gear_ratio=100.0, v_max=24.0)


def _per_joint(value, nq: int, what: str, *, positive: bool = False) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(nq, float(arr))
    if arr.shape != (nq,):
        raise ValueError(f"{what} must be a scalar or {nq} values, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be finite, got {arr.tolist()}")
    if np.any(arr < 0) or (positive and np.any(arr <= 0)):
        raise ValueError(f"{what} must be {'> 0' if positive else '≥ 0'}, got {arr.tolist()}")
    return arr


@dataclass(eq=False)
class Drive:
    """An arm with one DC motor per joint and a PD + feed-forward voltage controller.

    ``V = sat(V_ff + Kp (q_ref − q) + Kd (q̇_ref − q̇), ±V_max)`` (docs/design.md §3).

    Parameters
    ----------
    arm: the :class:`~mpd_pin.Arm`.
    motors: one :class:`DCMotor` for every joint, or one per joint.
    kp: proportional gain (V/rad), scalar or per joint, ≥ 0.
    kd: derivative gain (V·s/rad), scalar or per joint, ≥ 0.
    feedforward: add the model-based voltage V_ff (else V_ff = 0).
    supply: how the drives are fed (:class:`~mpd_pin.Supply`; default: one supply per
        joint, no regeneration, paper 000). It prices the motion, it does not change it.

    Per-joint motor constants are exposed as arrays ``R, L, Kt, Ke, B, J, n,
    v_max`` (``inf`` where unsaturated). ``model`` is a copy of the arm's model
    with ``armature = n² J`` (used by ABA and RNEA, which add armature themselves).
    """

    arm: Arm
    motors: DCMotor | Sequence[DCMotor]
    kp: float | Sequence[float]
    kd: float | Sequence[float]
    feedforward: bool = True
    supply: Supply = PER_JOINT
    model: pin.Model = field(init=False, repr=False)

    def __post_init__(self) -> None:
        nq = self.arm.nq
        motors = [self.motors] * nq if isinstance(self.motors, DCMotor) else list(self.motors)
        if len(motors) != nq or not all(isinstance(m, DCMotor) for m in motors):
            raise ValueError(
                f"motors must be one DCMotor or a list of {nq} DCMotor, got {self.motors!r}"
            )
        self.motor_list: list[DCMotor] = motors
        self.R = np.array([m.R for m in motors])
        self.L = np.array([m.L for m in motors])
        self.Kt = np.array([m.Kt for m in motors])
        self.Ke = np.array([m.Ke for m in motors])
        self.B = np.array([m.B for m in motors])
        self.J = np.array([m.J for m in motors])
        self.n = np.array([m.gear_ratio for m in motors])
        self.v_max = np.array([math.inf if m.v_max is None else m.v_max for m in motors])
        self.kp_vec = _per_joint(self.kp, nq, "kp")
        self.kd_vec = _per_joint(self.kd, nq, "kd")
        self.feedforward = bool(self.feedforward)
        if not isinstance(self.supply, Supply):
            raise ValueError(f"supply must be a mpd_pin.Supply, got {self.supply!r}")
        # Joint-side quantities.
        self.armature = self.n**2 * self.J  # reflected rotor inertia (kg·m²)
        self.damping = self.n**2 * self.B  # reflected viscous friction (N·m·s/rad)
        self.torque_per_amp = self.n * self.Kt  # N·m/A at the joint
        self.emf_per_rad_s = self.n * self.Ke  # V·s/rad at the joint
        self.model = self.arm.model.copy()
        self.model.armature = self.armature.copy()

    @property
    def nq(self) -> int:
        return self.arm.nq

    @property
    def payload(self) -> Payload | None:
        """The :class:`~mpd_pin.Payload` the arm carries (:meth:`with_payload`), or None."""
        return carried_payload(self.arm)

    def with_payload(self, part: Payload | None) -> Drive:
        """A new drive (same motors, gains, feed-forward and supply) whose arm carries
        ``part`` (kg, m; :func:`mpd_pin.dynamics.payload.payload_arm`): its inertia is added
        to the joint carrying the part's frame, on a deep copy of the model, and its box (if
        it has a ``size``) to the arm's collision geometry. This drive is left untouched.
        A payload replaces the one this drive may carry; ``None`` gives the drive without
        payload. ValueError naming ``Payload.frame`` if the arm has no such moving frame.
        """
        return replace(self, arm=payload_arm(self.arm, part))

    @property
    def saturated(self) -> bool:
        """True if any joint has a finite voltage limit."""
        return bool(np.any(np.isfinite(self.v_max)))

    def holding_current(self, q) -> np.ndarray:
        """Current (A) that holds the arm still at ``q``: ``G(q) / (n Kt)``."""
        return self.arm.gravity(q) / self.torque_per_amp

    def describe(self) -> dict:
        """Plain-data description (for hashing, result files)."""
        return {
            "arm": self.arm.name,
            "motors": [m.__dict__ for m in self.motor_list],
            "kp": self.kp_vec.tolist(),
            "kd": self.kd_vec.tolist(),
            "feedforward": self.feedforward,
        } | ({} if self.supply.is_default else {"supply": self.supply.describe()})
