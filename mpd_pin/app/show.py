"""``mpd-pin show NAME --all``: a built-in energy scenario's TOML with every section and
its defaults (docs/design.md §7e).

:func:`with_defaults` keeps the file as shipped — its comments and order — and adds each
key the file leaves to its default, marked ``# default``: at the end of its section when
the file has the section, else in a new section at the end. Keys without a default value
(``[sensor] range``, ``[motion] max_duration``) are written as comments, since TOML has no
null. The text loads back to the same scenario (``tests/test_show_all.py`` checks it on
the built-in scenarios and checks :data:`DEFAULTS` against the parser's dataclasses).

Like ``mpd-pin show``, this reads TOML only: no Pinocchio, Coal or matplotlib, so the
defaults of the dataclasses (``RoadmapOptions``, ``MotionOptions``, ``Supply``) are
spelled out here.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from typing import Any

from ..search.registry import DEFAULT_PLANNER, PLANNERS
from .config import ConfigError

__all__ = ["DEFAULTS", "with_defaults"]

#: Section → (key, default — None: none, the key is optional —, comment), in the order they
#: are written. ``[motor]`` is added only when the file has neither it nor ``[[motors]]``.
DEFAULTS: dict[str, list[tuple[str, Any, str]]] = {
    "motor": [
        ("preset", "paper", 'or "servo", "sized" (§3g); R, L, Kt, Ke, B, J, gear_ratio, '
                            "v_max override it"),
    ],
    "controller": [
        ("kp", 40.0, "V/rad, one value or one per joint"),
        ("kd", 4.0, "V·s/rad"),
        ("feedforward", True, ""),
    ],
    "roadmap": [
        ("evaluation", "lazy", 'or "eager": simulate every edge before the search (§4g)'),
        ("collision", "lazy", 'or "eager": collision-check every edge before the search'),
        ("num_nodes", 200, "random samples (the start and the goal come on top)"),
        ("k", 10, "neighbours per node"),
        ("seed", 0, "of the samples"),
        ("max_attempts", 200, "draws per requested sample"),
        ("resolution", 0.05, "rad, step of the edge collision check"),
        ("duration_rule", "fixed", 'or "distance": by the largest joint move (§4e)'),
        ("duration", 1.0, "s per edge (fixed rule)"),
        ("joint_speed", 1.0, "rad/s, mean joint speed (distance rule)"),
        ("duration_quantum", 0.25, "s, durations rounded up to it (distance rule)"),
        ("min_duration", 0.5, "s, shortest edge (distance rule)"),
        ("max_edge_duration", 4.0, "s, longest edge (distance rule; not [motion] "
                                   "max_duration)"),
        ("dt", 0.005, "s, RK4 step"),
        ("velocity_limits", True, "edges timed within the URDF velocity limits"),
        ("effort_limits", True, "edges over a URDF effort limit refused"),
        ("arrival_tolerance", 0.01, "rad, edges ending farther from their node refused"),
    ],
    "planner": [
        ("algorithm", DEFAULT_PLANNER, "one of " + ", ".join(PLANNERS) + " (§5)"),
        ("hazard_penalty", math.inf, ">= 1: cost factor of edges too close to a hazard; inf "
                                     "removes them"),
    ],
    "sensor": [
        ("range", None, "m, required when an obstacle is hidden"),
    ],
    "compute": [
        ("scheduler", "threads", 'or "local[:N]" or a Dask scheduler address (§4h)'),
    ],
    "motion": [
        ("execution", "auto", 'or "stop" (rest at every waypoint) or "nonstop" (§9f)'),
        ("refine", True, "shortcut the roadmap paths where the energy drops"),
        ("optimize", True, "then optimise the motion as a whole (§9g)"),
        ("max_duration", None, "s, the longest the whole motion may take (none: no "
                                "limit)"),
    ],
    "supply": [
        ("bus", "per_joint", 'or "shared": one DC bus feeding every drive (§3i)'),
        ("regeneration", 0.0, "share of braking energy returned, in [0, 1] (shared bus only)"),
    ],
}

#: Keys that stand for another one of :data:`DEFAULTS` (an old name, still read).
ALIASES = {("roadmap", "max_duration"): "max_edge_duration"}

_HEADER = re.compile(r"^\s*\[\[?\s*([A-Za-z_][\w.\-]*)\s*\]\]?\s*(#.*)?$")


def _value(v: Any) -> str:
    """``v`` as a TOML value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    return json.dumps(v, ensure_ascii=False)  # a basic string


def _line(key: str, value: Any, comment: str) -> str:
    if value is None:  # no default value: a comment
        return f"{'# ' + key + ' =':<26} # no default; {comment}"
    text = f"{key} = {_value(value)}"
    return f"{text:<26} # default" + (f"; {comment}" if comment else "")


def _missing(data: dict[str, Any]) -> dict[str, list[tuple[str, Any, str]]]:
    """Section → the default entries ``data`` leaves out (only sections with some)."""
    out = {}
    for section, entries in DEFAULTS.items():
        if section == "motor" and ("motor" in data or "motors" in data):
            continue
        have = set(data.get(section) or {})
        have |= {new for (sec, old), new in ALIASES.items() if sec == section and old in have}
        rows = [e for e in entries if e[0] not in have]
        if rows:
            out[section] = rows
    return out


def _expected(data: dict[str, Any], missing: dict[str, list]) -> dict[str, Any]:
    """``data`` with the missing defaults that have a value filled in."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    for section, rows in missing.items():
        table = out.setdefault(section, {})
        table.update({k: v for k, v, _ in rows if v is not None})
    return out


def _block_end(lines: list[str], start: int) -> int:
    """Index after the last key line of the table whose header is ``lines[start]``: before
    the next header, trailing blank and comment lines left below the insertion."""
    end = next((i for i in range(start + 1, len(lines)) if _HEADER.match(lines[i])),
               len(lines))
    while end > start + 1 and (not lines[end - 1].strip()
                               or lines[end - 1].lstrip().startswith("#")):
        end -= 1
    return end


def with_defaults(text: str, name: str = "scenario") -> str:
    """The TOML ``text`` of an energy scenario with every section of :data:`DEFAULTS` and
    each key it leaves to its default (module docstring). ConfigError for another kind."""
    data = tomllib.loads(text)
    kind = data.get("kind", "energy")
    if kind != "energy":
        raise ConfigError(f"show --all: {name!r} is a {kind} scenario; --all lists the "
                          "defaults of energy scenarios (mpd-pin show NAME prints it as "
                          "shipped)")
    missing = _missing(data)
    lines = text.splitlines()
    headers = {m.group(1): i for i, ln in enumerate(lines) if (m := _HEADER.match(ln))
               and not ln.lstrip().startswith("[[")}
    inserts: list[tuple[int, list[str]]] = []
    appended: list[str] = []
    for section, rows in missing.items():
        body = [_line(k, v, c) for k, v, c in rows]
        if section in headers:
            inserts.append((_block_end(lines, headers[section]), body))
        elif section in data:  # a table given without a header of its own (inline, dotted)
            raise ConfigError(f"show --all: [{section}] of {name!r} has no header line")
        else:
            appended += ["", f"[{section}]", *body]
    for at, body in sorted(inserts, reverse=True):
        lines[at:at] = body
    head = (f"# mpd-pin show {name} --all: the file as shipped, with every section and each "
            "key left to its default (# default)")
    out = "\n".join([head, *lines, *appended]) + "\n"
    if tomllib.loads(out) != _expected(data, missing):  # the additions landed where meant
        raise ConfigError(f"show --all: could not add the defaults to {name!r}")
    return out
