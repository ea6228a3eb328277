"""Scenario files: the built-in TOML files and reading any TOML file (docs/design.md §7b).

Light on purpose — only the standard library and :mod:`mpd_pin.app.kinds` — so that
``mpd-pin scenarios`` and ``mpd-pin show`` answer without importing Pinocchio, Coal or
yourdfpy (docs/design.md §8a).
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from .config import ConfigError
from .kinds import KINDS, scenario_kind

__all__ = ["builtin_scenarios", "resolve_scenario", "load_scenario_data"]


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
    if kind not in KINDS:
        raise ConfigError(f"kind: {kind!r} is not one of {list(KINDS)}")
    return data
