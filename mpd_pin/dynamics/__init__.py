"""Stage 2 — dynamics: DC motors, the PD + feed-forward drive, edge simulation and edge costs.

The motor-augmented ODE and its energy integrals are docs/design.md §3.
:func:`simulate_edge` integrates one edge with RK4; :func:`edge_energies` integrates
thousands at once (``pin.abaInParallel``) with identical results row by row.
"""

from .cost import EnergyCost
from .motor import PAPER_MOTOR, SERVO_MOTOR, DCMotor, Drive
from .simulate import (
    EdgeOutcomes,
    EdgeSimulation,
    edge_energies,
    edge_outcomes,
    ideal_edge_energies,
    ideal_edge_energy,
    quintic,
    simulate_edge,
    step_count,
)
from .sizing import sized_motor, sized_motors
from .supply import Supply

__all__ = [
    "DCMotor",
    "Drive",
    "edge_energies",
    "edge_outcomes",
    "EdgeOutcomes",
    "EdgeSimulation",
    "EnergyCost",
    "ideal_edge_energies",
    "ideal_edge_energy",
    "PAPER_MOTOR",
    "quintic",
    "SERVO_MOTOR",
    "simulate_edge",
    "sized_motor",
    "sized_motors",
    "step_count",
    "Supply",
]
