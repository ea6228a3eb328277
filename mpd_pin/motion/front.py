"""The energy–time front of the returned motion and of every candidate (docs/design.md §9c,
§9d): result.json ``energy_duration``, :attr:`mpd_pin.Plan.energy_duration` and
``energy_duration.png``.

A candidate's geometry fixes its energy as a function of its duration T. For a non-stop
piece the package runs one spline stretched uniformly, so E(T) runs from the fastest
feasible stretch (:meth:`~mpd_pin.motion.MotionEnergy.fastest_duration`) to the longest
duration its search allowed; the front holds the perfect-tracking screen over that range
(no simulation, ``ideal_curve``) and the durations simulated with the RK4 of §3
(``duration_curve``). A stop-and-go motion has one timing (the roadmap's rule), so its
front is one point.
"""

from __future__ import annotations

from typing import Any

from .outcome import MotionEnergy

__all__ = ["front_record", "energy_duration_record"]


def _pairs(curve) -> list[list[float]]:
    return [[float(T), float(E)] for T, E in curve]


def front_record(m: MotionEnergy) -> dict[str, Any]:
    """One execution's front: its duration and energy, the fastest feasible and the
    velocity-limit durations, the longest allowed, the duration rule, the screen and the
    simulated points ([T (s), E (J)] pairs; a stop-and-go motion: its one point), and its
    pieces (first and last waypoint of each piece run in one go)."""
    nonstop = m.execution == "nonstop"
    simulated = _pairs(m.duration_curve) if nonstop else (
        [[float(m.duration), float(m.total_energy)]] if m.feasible else [])
    return {
        "execution": m.execution,
        "feasible": bool(m.feasible),
        "duration": float(m.duration),
        "total_energy": float(m.total_energy),
        "fastest_duration": float(m.fastest or m.duration),
        "velocity_bound": float(m.velocity_fastest or m.fastest or m.duration),
        "longest_duration": float(m.longest or m.duration),
        "duration_rule": m.duration_rule,
        "screen": _pairs(m.ideal_curve) if nonstop else [],
        "simulated": simulated,
        "pieces": [[int(a), int(b)] for a, b in m.pieces],
    }


def _variants(m: MotionEnergy) -> dict[str, MotionEnergy]:
    """The executions priced for one candidate's geometry, by execution (an optimised
    curve is its own geometry: its ``alternative`` is its seed, another geometry)."""
    out = {m.execution: m}
    alt = m.alternative
    if m.curve is None and alt is not None and alt.curve is None and (
            alt.execution not in out):
        out[alt.execution] = alt
    return out


def energy_duration_record(returned_name: str | None, returned: MotionEnergy,
                           candidates: dict[str, MotionEnergy],
                           max_duration: float | None) -> dict[str, Any]:
    """result.json ``energy_duration``: the front of the motion returned (``returned``,
    from the candidate ``returned_name``) and, per candidate priced (name → its motion,
    the other execution in ``.alternative``), the front of each execution."""
    rows = []
    for name, m in candidates.items():
        fronts = _variants(m)
        rows.append({
            "name": name,
            "returned": name == returned_name,
            "execution": m.execution,
            "feasible": bool(m.feasible),
            "duration": float(m.duration),
            "total_energy": float(m.total_energy),
            "waypoints": [[float(x) for x in row] for row in m.waypoints],
            "nonstop": front_record(fronts["nonstop"]) if "nonstop" in fronts else None,
            "stop": front_record(fronts["stop"]) if "stop" in fronts else None,
        })
    return {
        "max_duration": None if max_duration is None else float(max_duration),
        "returned": {"candidate": returned_name, **front_record(returned)},
        "candidates": rows,
    }
