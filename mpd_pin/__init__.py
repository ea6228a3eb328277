"""mpd_pin — energy-optimal, collision-free motion planning for robot arms.

Pinocchio dynamics with DC-motor models give the electrical energy of every
roadmap edge; Coal checks collisions; MPD* Lite (a D* Lite that stores each
node's best successor, paper 000) finds and repairs minimum-energy paths.

The top-level names (``mp.Arm``, ``mp.Drive``, ``mp.simulate_edge``, …) are
loaded lazily (PEP 562): ``import mpd_pin`` and ``import mpd_pin.search`` do not
import Pinocchio or Coal; the first access to a name that needs them does.
"""

import os as _os

# Pinocchio's parallel algorithms use OpenMP; with the default (active) wait policy
# its idle threads spin, and on a busy machine a batched roadmap build was measured
# 7x slower (6.8 s vs 0.9 s for 600 edges). Must be set before pinocchio loads.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import importlib as _importlib  # noqa: E402

__version__ = "0.1.0"

#: public name -> submodule (relative to this package) that defines it
_LAZY = {
    "Arm": "arm",
    "BUILTIN_ARMS": "arm",
    "builtin_arm": "arm",
    "builtin_arm_urdf": "arm",
    "planar_arm_urdf": "arm",
    "DCMotor": "dynamics",
    "Drive": "dynamics",
    "PAPER_MOTOR": "dynamics",
    "SERVO_MOTOR": "dynamics",
    "EdgeSimulation": "dynamics",
    "edge_energies": "dynamics",
    "ideal_edge_energies": "dynamics",
    "ideal_edge_energy": "dynamics",
    "quintic": "dynamics",
    "simulate_edge": "dynamics",
    "sized_motors": "dynamics",
    "Supply": "dynamics",
    "Payload": "dynamics.payload",
    "MotionEnergy": "motion",
    "MotionOptions": "motion",
    "trajectory_energy": "motion",
    "optimize_motion": "motion.optimize",
    "motion_series": "motion.series",
    "World": "world",
    "Box": "world",
    "Cylinder": "world",
    "Sphere": "world",
    "Polygon": "world",
    "Hazard": "world",
    "CollisionChecker": "collision",
    "RoadmapOptions": "planning.roadmap",
    "load_scenario": "app.kinds",
    "Scenario": "app.scenario",
    "plan": "app.api",
    "EnergyPlanner": "app.planner",
    "PlannerOptions": "app.planner_options",
    "Plan": "app.planned",
    "Leg": "app.legs",
    "Cycle": "app.cycle",
    "MpdPinError": "errors",
    "NoPathError": "errors",
    "NoMotionWithinDuration": "errors",
    "CycleTimeTooShort": "errors",
}

#: public names defined under another name in their module
_ALIAS = {"Scenario": "EnergyScenario"}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    """Import the submodule defining ``name`` on first access and cache the value."""
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(_importlib.import_module(f".{module}", __name__), _ALIAS.get(name, name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
