"""Collisions in words: what a checker's colliding pairs are called and how they are
reported in one phrase (the errors of bad start/goal input, docs/design.md §4b).

Plain functions over the Pinocchio models; :class:`~mpd_pin.collision.CollisionChecker`
finds the colliding pairs, this module names them.
"""

from __future__ import annotations

import pinocchio as pin

from ..dynamics.payload import GEOMETRY_PREFIX


def geometry_label(model: pin.Model, gm: pin.GeometryModel, arm_ids: list[int], i: int) -> str:
    """``"link 'name'"`` for an arm geometry (its parent frame's name, else the
    geometry's name without Pinocchio's ``_<index>`` suffix), ``"payload 'name'"`` for a
    carried part, ``"obstacle 'name'"`` or ``"hazard 'name'"`` for the world's."""
    go = gm.geometryObjects[i]
    if i in arm_ids:
        if go.name.startswith(GEOMETRY_PREFIX):
            return f"payload {go.name.removeprefix(GEOMETRY_PREFIX)!r}"
        frame = int(go.parentFrame)
        if 0 <= frame < model.nframes:
            return f"link {model.frames[frame].name!r}"
        base, _, tail = go.name.rpartition("_")
        name = base if base and tail.isdigit() else go.name
        return f"link {name!r}"
    kind, _, name = go.name.partition(":")
    return f"{kind} {name!r}" if name else repr(go.name)


def collision_phrase(named: list[tuple[str, str, float]], limit: int = 3) -> str:
    """(link, other, margin m) pairs as one phrase, the links grouped by what they touch,
    e.g. "link 'link3' touches obstacle 'divider'", "links 'link2' and 'link3' touch
    obstacle 'box0'" ("come(s) within 0.05 m of" where a margin applies); at most
    ``limit`` groups, then "and N more"; "" for no pair."""
    groups: dict[tuple[str, float], list[str]] = {}
    for a, b, m in named:
        groups.setdefault((b, m), []).append(a)
    parts = []
    for (b, m), labels in list(groups.items())[:limit]:
        one = len(labels) == 1
        links = [a.removeprefix("link ") for a in labels if a.startswith("link ")]
        names = ([f"link {links[0]}" if len(links) == 1 else "links " + _and(links)]
                 if links else []) + [a for a in labels if not a.startswith("link ")]
        who = _and(names)
        verb = ("touches" if one else "touch") if m <= 0.0 else (
            f"{'comes' if one else 'come'} within {m:g} m of")
        parts.append(f"{who} {verb} {b}")
    if len(groups) > limit:
        parts.append(f"and {len(groups) - limit} more")
    return "; ".join(parts)


def _and(items: list[str]) -> str:
    """``"a"``, ``"a and b"``, ``"a, b and c"``."""
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} and {items[-1]}"
