"""Scenario files: the built-in TOML files, reading any TOML file and its ``kind``
(docs/design.md §7b).

Light on purpose — only the standard library and :mod:`mpd_pin.app.config` — so that
``mpd-pin scenarios`` and ``mpd-pin show`` answer without importing Pinocchio, Coal or
yourdfpy (docs/design.md §8a). The kind names are here (:data:`KIND_NAMES`); how each kind
is parsed and run is :data:`mpd_pin.app.kinds.KINDS`, which imports this module.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from .config import ConfigError

__all__ = ["DEFAULT_KIND", "KIND_NAMES", "builtin_scenarios", "resolve_scenario",
           "load_scenario_data", "scenario_kind"]

#: The values of a scenario file's ``kind``, the default first (each is a key of
#: :data:`mpd_pin.app.kinds.KINDS`).
KIND_NAMES = ("energy", "dynamic2link")

#: The kind of a scenario file that gives none.
DEFAULT_KIND = KIND_NAMES[0]


def scenario_kind(data: Mapping[str, Any]) -> str:
    """The ``kind`` of parsed scenario TOML (``"energy"`` when it gives none)."""
    return str(data.get("kind", DEFAULT_KIND))


def builtin_scenarios() -> dict[str, Path]:
    """Built-in scenario names → TOML files shipped inside the package."""
    root = resources.files("mpd_pin") / "scenarios"
    out = {}
    for entry in root.iterdir():
        if entry.name.endswith(".toml"):
            out[entry.name[: -len(".toml")]] = Path(str(entry))
    return dict(sorted(out.items()))


def resolve_scenario(name_or_path: str) -> Path:
    """A built-in scenario name or a path to a ``.toml`` file → the file path."""
    builtins = builtin_scenarios()
    if name_or_path in builtins:
        return builtins[name_or_path]
    path = Path(name_or_path)
    if path.is_file():
        return path
    raise ConfigError(
        f"unknown scenario {name_or_path!r}: not a built-in ({', '.join(builtins)}) and not a file"
    )


def load_scenario_data(path: Path) -> dict[str, Any]:
    """Parse a TOML file; malformed TOML raises ConfigError with the line."""
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"malformed TOML in {str(path)!r}: {exc}") from None
    except OSError as exc:
        raise ConfigError(f"cannot read scenario {str(path)!r}: {exc.strerror}") from None
    kind = scenario_kind(data)
    if kind not in KIND_NAMES:
        raise ConfigError(f"kind: {kind!r} is not one of {list(KIND_NAMES)}")
    return data
