"""The arm's surroundings: obstacles, hazard zones and hidden obstacles (docs/design.md §4).

:class:`World` holds named obstacles (:mod:`mpd_pin.world.shapes`) and hazards. An
obstacle with ``hidden=True`` is not known at first: :class:`World` reports it only
after :meth:`World.reveal`. :class:`Hazard` wraps a shape with a ``clearance`` (m):
the zone may never be entered and may only be approached to beyond that distance
when clearance is enforced.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import pinocchio as pin

from .shapes import SHAPES, Obstacle, geometry_object

__all__ = ["Hazard", "World", "shape_from_dict"]


@dataclass(frozen=True)
class Hazard:
    """A "No Enter" zone: ``shape`` may not be entered nor approached closer than ``clearance`` (m).

    Its name and hidden flag are the shape's.
    """

    shape: Obstacle
    clearance: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.shape, tuple(SHAPES.values())):
            raise ValueError(f"hazard shape must be a Box, Cylinder, Sphere or Polygon, got "
                             f"{type(self.shape).__name__}")
        try:
            c = float(self.clearance)
        except (TypeError, ValueError):
            raise ValueError(f"hazard clearance must be a number, got {self.clearance!r}") from None
        if not math.isfinite(c) or c < 0.0:
            raise ValueError(
                f"hazard clearance must be finite and >= 0 (m), got {self.clearance!r}"
            )
        object.__setattr__(self, "clearance", c)

    @property
    def name(self) -> str:
        return self.shape.name

    @property
    def hidden(self) -> bool:
        return self.shape.hidden

    def to_dict(self) -> dict[str, Any]:
        return {"type": "hazard", "clearance": self.clearance, "shape": self.shape.to_dict()}


def shape_from_dict(data: Mapping[str, Any]) -> Obstacle | Hazard:
    """Build an obstacle or hazard from :meth:`to_dict` plain data (ValueError if malformed)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"obstacle description must be a mapping, got {type(data).__name__}")
    d = dict(data)
    kind = d.pop("type", None)
    if kind == "hazard":
        if "shape" not in d:
            raise ValueError("hazard description needs a 'shape'")
        shape = shape_from_dict(d["shape"])
        if isinstance(shape, Hazard):
            raise ValueError("a hazard's shape cannot itself be a hazard")
        return Hazard(shape, d.get("clearance", 0.0))
    if kind not in SHAPES:
        raise ValueError(f"unknown obstacle type {kind!r}; known: {', '.join(SHAPES)}, hazard")
    cls = SHAPES[kind]
    allowed = {f for f in cls.__dataclass_fields__ if f != "rotation"}
    unknown = set(d) - allowed
    if unknown:
        raise ValueError(f"unknown {kind} fields {sorted(unknown)}; allowed: {sorted(allowed)}")
    try:
        return cls(**d)
    except TypeError as exc:
        raise ValueError(f"invalid {kind} description: {exc}") from None


# ----------------------------------------------------------------------- world
@dataclass(eq=False)
class World:
    """Obstacles and hazard zones; hidden ones become known through :meth:`reveal`.

    Names are unique (empty names become ``"<type><index>"``). ``version`` grows
    by one with every change of what is known, so checkers can resynchronise.
    """

    obstacles: tuple[Obstacle, ...] = ()
    hazards: tuple[Hazard, ...] = ()
    revealed: frozenset[str] = frozenset()
    version: int = field(default=0, compare=False)

    def __post_init__(self) -> None:
        obstacles: list[Obstacle] = []
        hazards: list[Hazard] = []
        for item in self.obstacles:
            if isinstance(item, Hazard):
                hazards.append(item)
            elif isinstance(item, tuple(SHAPES.values())):
                obstacles.append(item)
            else:
                raise ValueError(f"not an obstacle: {item!r}")
        for item in self.hazards:
            if not isinstance(item, Hazard):
                raise ValueError(f"hazards must be Hazard objects, got {type(item).__name__}")
            hazards.append(item)
        seen: set[str] = set()
        named_obs = []
        for i, ob in enumerate(obstacles):
            ob = ob if ob.name else replace(ob, name=f"{ob.kind}{i}")
            named_obs.append(ob)
        named_haz = []
        for i, hz in enumerate(hazards):
            if not hz.name:
                hz = Hazard(replace(hz.shape, name=f"hazard{i}"), hz.clearance)
            named_haz.append(hz)
        for item in [*named_obs, *named_haz]:
            if item.name in seen:
                raise ValueError(f"duplicate obstacle name {item.name!r}")
            seen.add(item.name)
        self.obstacles = tuple(named_obs)
        self.hazards = tuple(named_haz)
        revealed = frozenset(self.revealed)
        unknown = revealed - seen
        if unknown:
            raise ValueError(f"cannot reveal unknown obstacles {sorted(unknown)}")
        self.revealed = frozenset(n for n in revealed if self[n].hidden)

    # access --------------------------------------------------------------
    def __iter__(self) -> Iterator[Obstacle | Hazard]:
        yield from self.obstacles
        yield from self.hazards

    def __len__(self) -> int:
        return len(self.obstacles) + len(self.hazards)

    def __getitem__(self, name: str) -> Obstacle | Hazard:
        for item in self:
            if item.name == name:
                return item
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return any(item.name == name for item in self)

    @property
    def names(self) -> list[str]:
        """Names of all obstacles then all hazards."""
        return [item.name for item in self]

    def is_known(self, name: str) -> bool:
        """True if the obstacle/hazard is visible: not hidden, or revealed."""
        item = self._get(name)
        return (not item.hidden) or name in self.revealed

    def hidden_names(self) -> list[str]:
        """Names of the obstacles and hazards still unknown."""
        return [item.name for item in self if not self.is_known(item.name)]

    def _get(self, name: str) -> Obstacle | Hazard:
        try:
            return self[name]
        except KeyError:
            raise ValueError(f"no obstacle named {name!r}; known names: {self.names}") from None

    # changes ---------------------------------------------------------------
    def reveal(self, *names: str) -> list[str]:
        """Make hidden obstacles known; returns the names that were newly revealed."""
        new = []
        for name in names:
            item = self._get(name)
            if item.hidden and name not in self.revealed:
                new.append(name)
        if new:
            self.revealed = self.revealed | frozenset(new)
            self.version += 1
        return new

    def reset(self) -> None:
        """Hide every revealed obstacle again (back to the initial map)."""
        if self.revealed:
            self.revealed = frozenset()
            self.version += 1

    def known(self, include_hidden: bool = False) -> World:
        """A new world with only the known obstacles and hazards (all marked not hidden).

        With ``include_hidden``: every obstacle and hazard, all marked not hidden.
        """
        def seen(name: str) -> bool:
            return include_hidden or self.is_known(name)

        obs = [replace(o, hidden=False) for o in self.obstacles if seen(o.name)]
        haz = [
            Hazard(replace(h.shape, hidden=False), h.clearance)
            for h in self.hazards
            if seen(h.name)
        ]
        return World(tuple(obs), tuple(haz))

    def visible(self, include_hidden: bool = False) -> list[Obstacle | Hazard]:
        """The obstacles and hazards a planner sees (all of them with ``include_hidden``)."""
        return [item for item in self if include_hidden or self.is_known(item.name)]

    # geometry ----------------------------------------------------------------
    def geometry_model(self, include_hidden: bool = False, *, hazards: bool = True):
        """A ``pin.GeometryModel`` of the obstacles (and hazards), fixed to the universe joint.

        Geometry names are ``"obstacle:<name>"`` and ``"hazard:<name>"``; no collision pairs.
        """
        gm = pin.GeometryModel()
        for item in self.visible(include_hidden):
            if isinstance(item, Hazard):
                if not hazards:
                    continue
                gm.addGeometryObject(geometry_object(item.shape, f"hazard:{item.name}"))
            else:
                gm.addGeometryObject(geometry_object(item, f"obstacle:{item.name}"))
        return gm

    # plain data ----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain data: ``{"obstacles": [...], "hazards": [...], "revealed": [...]}``."""
        return {
            "obstacles": [o.to_dict() for o in self.obstacles],
            "hazards": [h.to_dict() for h in self.hazards],
            "revealed": sorted(self.revealed),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> World:
        """Inverse of :meth:`to_dict` (ValueError on malformed data)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"world description must be a mapping, got {type(data).__name__}")
        unknown = set(data) - {"obstacles", "hazards", "revealed"}
        if unknown:
            raise ValueError(f"unknown world fields {sorted(unknown)}")
        obstacles = [shape_from_dict(d) for d in data.get("obstacles", [])]
        hazards = [shape_from_dict(d) for d in data.get("hazards", [])]
        for h in hazards:
            if not isinstance(h, Hazard):
                raise ValueError("entries of 'hazards' must have type 'hazard'")
        revealed = data.get("revealed", [])
        if isinstance(revealed, str) or not isinstance(revealed, Iterable):
            raise ValueError("'revealed' must be a list of names")
        return cls(tuple(obstacles), tuple(hazards), frozenset(revealed))

    def fingerprint(self) -> str:
        """Stable SHA-256 hex digest of :meth:`to_dict` (for cache keys)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


