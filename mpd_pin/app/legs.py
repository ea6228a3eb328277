"""The legs of a cycle as data: :class:`Leg` and a scenario's ``[cycle]``
(:class:`CycleSpec`) (docs/design.md §7b, §8b, issue 33). Planning them is
:mod:`mpd_pin.app.cycle`; this module imports no planning code, so scenario files can
name the types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamics.payload import Payload

__all__ = ["Leg", "CycleSpec", "leg_configuration"]


def leg_configuration(q: Any, nq: int, what: str) -> np.ndarray:
    """``q`` as (nq,) finite floats (rad; m for prismatic joints), else ValueError naming
    ``what`` (a leg's goal, a query's start or goal)."""
    try:
        arr = np.asarray(q, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected {nq} joint values (rad), got {q!r}") from None
    if arr.shape != (nq,):
        raise ValueError(f"{what}: expected {nq} joint values (rad), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: joint values must be finite, got {arr.tolist()}")
    return arr


@dataclass(frozen=True)
class Leg:
    """One leg of a cycle: move to ``goal`` (rad, one value per joint) carrying
    ``payload`` (a :class:`~mpd_pin.Payload`; None: nothing), then wait ``dwell`` s at the
    goal holding that payload (the grasp or release happens at the end of the dwell,
    :mod:`mpd_pin.app.cycle`). ``name`` labels the leg (default "leg k").
    ValueError naming the field for a payload that is not a Payload or a dwell that is not
    a finite number >= 0."""

    goal: Any
    payload: Payload | None = None
    dwell: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        if self.payload is not None and not isinstance(self.payload, Payload):
            raise ValueError(f"Leg.payload must be an mpd_pin.Payload or None, got "
                             f"{self.payload!r}")
        if isinstance(self.dwell, (bool, np.bool_)) or not isinstance(
                self.dwell, (int, float, np.integer, np.floating)):
            raise ValueError(f"Leg.dwell must be a number of seconds >= 0, got {self.dwell!r}")
        dwell = float(self.dwell)
        if not (math.isfinite(dwell) and dwell >= 0.0):
            raise ValueError(f"Leg.dwell must be a number of seconds >= 0, got {self.dwell!r}")
        object.__setattr__(self, "dwell", dwell)
        if not isinstance(self.name, str):
            raise ValueError(f"Leg.name must be a string, got {self.name!r}")


@dataclass(frozen=True)
class CycleSpec:
    """A scenario's ``[cycle]``: ``legs`` (:class:`Leg`, from ``[task] start``) and
    ``cycle_time`` (s; None: each leg follows its own duration rule)."""

    legs: tuple[Leg, ...]
    cycle_time: float | None = None
