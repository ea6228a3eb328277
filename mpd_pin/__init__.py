"""mpd_pin — energy-optimal, collision-free motion planning for robot arms.

Pinocchio dynamics with DC-motor models give the electrical energy of every
roadmap edge; Coal checks collisions; MPD* Lite (a D* Lite that stores each
node's best successor, paper 000) finds and repairs minimum-energy paths.
"""

from .arm import Arm
from .energy import (
    EdgeSimulation,
    edge_energies,
    ideal_edge_energies,
    ideal_edge_energy,
    quintic,
    simulate_edge,
)
from .errors import MpdPinError, NoPathError
from .motor import PAPER_MOTOR, SERVO_MOTOR, DCMotor, Drive
from .robots import BUILTIN_ARMS, builtin_arm, builtin_arm_urdf
from .urdf import planar_arm_urdf

__version__ = "0.1.0"

__all__ = [
    "Arm",
    "BUILTIN_ARMS",
    "DCMotor",
    "Drive",
    "EdgeSimulation",
    "MpdPinError",
    "NoPathError",
    "PAPER_MOTOR",
    "SERVO_MOTOR",
    "builtin_arm",
    "builtin_arm_urdf",
    "edge_energies",
    "ideal_edge_energies",
    "ideal_edge_energy",
    "planar_arm_urdf",
    "quintic",
    "simulate_edge",
]
