"""Exceptions raised by mpd_pin."""

from __future__ import annotations

from typing import Any


class MpdPinError(Exception):
    """Base class of every error raised on purpose by mpd_pin."""


class NoPathError(MpdPinError):
    """The goal cannot be reached from the start in the current graph."""


class NoMotionWithinDuration(MpdPinError):
    """No candidate motion runs within the ``max_duration`` asked for (a planning outcome,
    not bad input; docs/design.md §9f); with no cap (``max_duration`` None), no candidate
    gives a feasible motion at any duration. ``max_duration`` (s) is the cap; ``fastest`` (s)
    the duration of the fastest motion found; ``plan`` the
    :class:`~mpd_pin.app.planned.Plan` of that motion, priced without the cap (at its
    fastest duration), whose ``to_dict()["feasible"]`` is False and ``to_dict()["reason"]``
    says why. ``mpd-pin run`` writes that plan's files and exits with status 3."""

    def __init__(self, message: str, fastest: float, plan: Any = None,
                 max_duration: float | None = None) -> None:
        super().__init__(message)
        self.fastest = float(fastest)
        self.plan = plan
        self.max_duration = max_duration
        #: result.json as written by ``mpd-pin run`` (None until saved)
        self.result: dict[str, Any] | None = None


class CycleTimeTooShort(NoMotionWithinDuration):
    """A cycle time below the fastest cycle: the sum of the legs' fastest motions and the
    dwells (a planning outcome, like :class:`NoMotionWithinDuration`; ``mpd-pin run``
    exits with status 3). ``minimum`` (s, also ``fastest``) is that sum, ``max_duration``
    (s) the cycle time asked for, ``legs`` the fastest duration of each leg (s) and
    ``dwell`` the dwells' sum (s)."""

    def __init__(self, message: str, minimum: float, cycle_time: float,
                 legs: list[float], dwell: float) -> None:
        super().__init__(message, minimum, None, max_duration=cycle_time)
        self.minimum = float(minimum)
        self.legs = [float(x) for x in legs]
        self.dwell = float(dwell)
