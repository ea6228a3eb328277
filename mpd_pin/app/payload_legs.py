"""Legs that carry a payload, on the roadmap of every leg (docs/design.md §4i, issue 33).

:meth:`mpd_pin.EnergyPlanner.plan` with ``payload=part`` plans one leg with the part in
the dynamics (``drive.with_payload(part)``) and in the collision checks
(``CollisionChecker(arm, world, payload=part)``). The planner keeps one roadmap for every
leg: the roadmap of the bare arm (the *base*, built by the first query and grown by each
later one, whatever it carries) holds the nodes, and each payload has its own
:class:`~mpd_pin.app.plan.Setup` on those nodes, its edges and energies derived from the
base on every query that carries it (:func:`mpd_pin.planning.payloads.payload_roadmap`:
nodes where the part collides have no edge; an edge certified with the part is certified
without it, not the other way round; energies per payload, in memory and in a roadmap
file of their own beside the base's cache).

:class:`PayloadLegs` is that state: per payload (by :func:`payload_digest`) the arm
carrying it, its checker and edge cost, what it knows of its edges
(:class:`~mpd_pin.planning.payloads.EdgeMemo`) and its file.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..arm.model import Arm
from ..collision import CollisionChecker
from ..dynamics import EnergyCost
from ..dynamics.payload import Payload, payload_arm
from ..planning.lazy import LazyEdges
from ..planning.payloads import (
    EdgeMemo,
    payload_cache_path,
    payload_digest,
    payload_key,
    payload_roadmap,
    share_certificates,
)
from ..planning.roadmap import check_endpoint
from .plan import Setup
from .scenario import EnergyScenario

__all__ = ["PayloadLegs"]


@dataclass
class _Carried:
    """One payload's state: the part, the arm carrying it, its checker, its edge cost (made
    at its first query), its memo of edges, its file and the setup of its last query."""

    part: Payload
    arm: Arm
    checker: CollisionChecker
    memo: EdgeMemo = field(default_factory=EdgeMemo)
    cost: EnergyCost | None = None
    key: str = ""
    path: Path | None = None
    file_read: bool = False
    file_reused: bool = False
    setup: Setup | None = None


class PayloadLegs:
    """The payloads one :class:`~mpd_pin.EnergyPlanner` has carried (module docstring)."""

    def __init__(self) -> None:
        self._carried: dict[str, _Carried] = {}
        self._last: _Carried | None = None

    def scenario(self, scn: EnergyScenario, part: Payload | None) -> EnergyScenario:
        """``scn`` with its arm carrying ``part`` (None: ``scn``). ValueError (one line) for
        a part that is not a :class:`~mpd_pin.Payload`, on no moving frame of the arm, or
        in collision at ``scn.start`` or ``scn.goal`` (naming what touches what)."""
        if part is None:
            return scn
        if not isinstance(part, Payload):
            raise ValueError(f"payload must be an mpd_pin.Payload or None, got {part!r}")
        digest = payload_digest(part)
        state = self._carried.get(digest)
        if state is None:
            arm = payload_arm(scn.arm, part)
            state = _Carried(part, arm, CollisionChecker(arm, scn.world))
            self._carried[digest] = state
        for what, q in (("start", scn.start), ("goal", scn.goal)):
            check_endpoint(state.arm, state.checker, q, f"{what} (carrying payload "
                           f"{part.name!r})")
        return replace(scn, arm=state.arm)

    def settle(self, base: Setup | None) -> None:
        """What the last payload leg found out, kept: its simulated energies, checks and
        refusals in its memo, and its collision certificates passed to the base's unchecked
        edges (``base``: the planner's base setup)."""
        last, self._last = self._last, None
        if last is None or last.setup is None:
            return
        setup = last.setup
        if setup.lazy is not None:
            last.memo.absorb(setup.lazy.roadmap, setup.lazy.refused)
            if base is not None and base.lazy is not None:
                share_certificates(setup.lazy.roadmap, setup.lazy.refused, base.lazy.roadmap)
        else:
            last.memo.absorb(setup.roadmap)

    def setup(self, scn: EnergyScenario, base: Setup, *, cache: Path | None, compute: Any,
              show_progress: bool) -> tuple[Setup, Path | None, bool]:
        """The setup of a leg carrying the payload of ``scn`` (from :meth:`scenario`) on the
        nodes of ``base`` (the base setup, already joined to this query's start and goal):
        (setup, the payload's roadmap file or None, whether that file was read)."""
        state = next(s for s in self._carried.values() if s.arm is scn.arm)
        if state.cost is None:
            state.cost = EnergyCost(scn.drive(), scn.options.dt, executor=compute)
            state.key = payload_key(state.part, state.cost, state.checker.fingerprint(),
                                    scn.options)
        if cache is not None and not state.file_read:
            state.path = payload_cache_path(cache, state.part)
            state.file_reused = state.memo.absorb_file(state.path, state.key, scn.arm.nq)
            state.file_read = True
        lazy = base.lazy
        nodes = base.roadmap if lazy is None else lazy.roadmap.without_edges(lazy.refused)
        base.world.reset()
        roadmap = payload_roadmap(nodes, state.cost, state.checker, scn.options,
                                  key=state.key, memo=state.memo,
                                  evaluate=base.evaluation == "eager",
                                  check_edges=base.collision == "eager",
                                  show_progress=show_progress)
        if state.path is not None and base.evaluation == "eager":
            roadmap.save(state.path)
        setup = Setup(
            state.cost.drive, base.world, state.checker, roadmap, base.world.to_dict(),
            state.cost.compute_record(), evaluation=base.evaluation,
            lazy=None if base.evaluation == "eager" else LazyEdges(
                roadmap, state.cost, scn.options, progress=show_progress,
                checker=state.checker),
            cache=state.path, notes=list(base.notes), cost=state.cost,
            collision=base.collision,
        )
        state.setup = setup
        self._last = state
        return setup, state.path, state.file_reused
