"""Strict validation of plain-data tables (TOML scenario files) with clear errors.

Every check names the offending key by its dotted path, e.g.
``scenario 'x.toml': roadmap.k: expected an integer, got 'ten'``. A number's physical
range is a :class:`Bound` (the ranges of every scenario number: :mod:`mpd_pin.app.limits`).
This module imports nothing of the package.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["Bound", "ConfigError", "Table", "check_array", "did_you_mean"]


class ConfigError(ValueError):
    """A scenario or configuration value is missing, unknown, mistyped or impossible."""


@dataclass(frozen=True)
class Bound:
    """A closed range ``[lo, hi]`` of one physical quantity (``lo_open``: ``lo`` excluded).

    ``tol``: how far beyond ``[lo, hi]`` a value is still accepted (not shown in the
    message); ``far_hint``: appended to the message of a value more than ``far`` outside
    the range, e.g. "did you give degrees?" for joint angles
    (:func:`~mpd_pin.app.limits.joint_bounds`). The ranges themselves are
    :mod:`mpd_pin.app.limits`.
    """

    lo: float
    hi: float
    unit: str = ""
    what: str = ""  # e.g. "the workspace bound" (symmetric ranges), else "the range"
    lo_open: bool = False
    allow_inf: bool = False  # +inf accepted as a value with a meaning (e.g. "no edge")
    note: str = ""  # appended to the description, e.g. "or inf: no edge"
    tol: float = 0.0
    interval: bool = False  # describe as [lo, hi] even when symmetric
    far: float = math.inf
    far_hint: str = ""

    def describe(self) -> str:
        """The range as error messages give it: "the gain range [0, 1e+06] V/rad"."""
        u = f" {self.unit}" if self.unit else ""
        note = f", {self.note}" if self.note else ""
        if self.lo == -self.hi and not self.lo_open and not self.interval:
            return f"{self.what or 'the bound'} of ±{self.hi:g}{u}{note}"
        left = "(" if self.lo_open else "["
        return f"{self.what or 'the range'} {left}{self.lo:g}, {self.hi:g}]{u}{note}"

    def check(self, name: str, value: float) -> float:
        """``value`` if within range, else ConfigError naming ``name`` and the bound."""
        u = f" {self.unit}" if self.unit else ""
        if math.isinf(value) and value > 0 and self.allow_inf:
            return value
        if not math.isfinite(value):
            raise ConfigError(f"{name} = {value} is not a finite number "
                              f"(expected within {self.describe()})")
        lo, hi = self.lo - self.tol, self.hi + self.tol
        below = value <= lo if self.lo_open else value < lo
        if below or value > hi:
            hint = ""
            if self.far_hint and (value < self.lo - self.far or value > self.hi + self.far):
                hint = f"; {self.far_hint}"
            raise ConfigError(f"{name} = {value:g}{u} is outside {self.describe()}{hint}")
        return value


class Table:
    """A read-once view of a mapping: typed getters, and :meth:`done` rejects unknown keys."""

    def __init__(self, data: Any, path: str) -> None:
        if not isinstance(data, Mapping):
            raise ConfigError(f"{path or 'top level'}: expected a table, got {type(data).__name__}")
        self.data = dict(data)
        self.path = path
        self.seen: set[str] = set()

    def key_path(self, key: str) -> str:
        """``key``'s dotted path from the top of the file, as error messages name it
        (``roadmap.k``; ``key`` itself in the top-level table)."""
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = ...) -> Any:
        self.seen.add(key)
        if key not in self.data:
            if default is ...:
                raise ConfigError(f"{self.key_path(key)}: required key is missing")
            return default
        return self.data[key]

    def table(self, key: str, required: bool = False) -> Table:
        val = self.raw(key, ... if required else {})
        return Table(val, self.key_path(key))

    def tables(self, key: str) -> list[Table]:
        val = self.raw(key, [])
        if not isinstance(val, list):
            raise ConfigError(f"{self.key_path(key)}: expected an array of tables ([[{key}]])")
        return [Table(v, f"{self.key_path(key)}[{i}]") for i, v in enumerate(val)]

    def string(self, key: str, default: Any = ..., choices: Iterable[str] | None = None) -> str:
        val = self.raw(key, default)
        if val is None and default is None:
            return None  # type: ignore[return-value]
        if not isinstance(val, str):
            raise ConfigError(f"{self.key_path(key)}: expected a string, got {val!r}")
        if choices is not None and val not in set(choices):
            raise ConfigError(f"{self.key_path(key)}: {val!r} is not one of {sorted(choices)}")
        return val

    def boolean(self, key: str, default: Any = ...) -> bool:
        val = self.raw(key, default)
        if not isinstance(val, bool):
            raise ConfigError(f"{self.key_path(key)}: expected true or false, got {val!r}")
        return val

    def integer(
        self,
        key: str,
        default: Any = ...,
        minimum: int | None = None,
        maximum: int | None = None,
    ) -> int:
        val = self.raw(key, default)
        if isinstance(val, bool) or not isinstance(val, int):
            raise ConfigError(f"{self.key_path(key)}: expected an integer, got {val!r}")
        if minimum is not None and val < minimum:
            raise ConfigError(f"{self.key_path(key)}: must be ≥ {minimum}, got {val}")
        if maximum is not None and val > maximum:
            raise ConfigError(f"{self.key_path(key)}: must be ≤ {maximum}, got {val}")
        return val

    def number(
        self,
        key: str,
        default: Any = ...,
        *,
        positive: bool = False,
        nonnegative: bool = False,
        minimum: float | None = None,
        maximum: float | None = None,
        bound: Bound | None = None,
    ) -> float:
        """A number; ``bound`` (:class:`Bound`, e.g. of :data:`mpd_pin.app.limits.BOUNDS`)
        its physical range."""
        if key not in self.data and default is not ...:
            self.seen.add(key)
            return default  # defaults are trusted (may be None or inf)
        val = self.raw(key)
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            raise ConfigError(f"{self.key_path(key)}: expected a number, got {val!r}")
        val = float(val)
        if bound is not None and not math.isfinite(val):
            return bound.check(self.key_path(key), val)  # raises, unless inf has a meaning
        if not math.isfinite(val):
            raise ConfigError(f"{self.key_path(key)}: must be finite, got {val}")
        if positive and val <= 0:
            raise ConfigError(f"{self.key_path(key)}: must be > 0, got {val}")
        if nonnegative and val < 0:
            raise ConfigError(f"{self.key_path(key)}: must be ≥ 0, got {val}")
        if minimum is not None and val < minimum:
            raise ConfigError(f"{self.key_path(key)}: must be ≥ {minimum:g}, got {val:g}")
        if maximum is not None and val > maximum:
            raise ConfigError(f"{self.key_path(key)}: must be ≤ {maximum:g}, got {val:g}")
        return val if bound is None else bound.check(self.key_path(key), val)

    def numbers(
        self,
        key: str,
        default: Any = ...,
        length: int | None = None,
        *,
        bound: Bound | Sequence[Bound] | None = None,
        labels: Sequence[str] | None = None,
    ) -> list[float] | float:
        """A number or an array of numbers (optionally of a given length).

        Every value is finite and, with ``bound`` (one, or one per element), in its range;
        elements are named ``key[i]`` or, with ``labels``, ``key x`` / ``key z``.
        """
        val = self.raw(key, default)
        if val is None and default is None:
            return None  # type: ignore[return-value]
        if key not in self.data:
            return val  # defaults are trusted
        if isinstance(val, (int, float)) and not isinstance(val, bool):
            return self._checked(self.key_path(key), float(val), bound)
        if not isinstance(val, list) or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in val
        ):
            raise ConfigError(
                f"{self.key_path(key)}: expected a number or an array of numbers, got {val!r}"
            )
        if length is not None and len(val) != length:
            raise ConfigError(f"{self.key_path(key)}: expected {length} numbers, got {len(val)}")
        return check_array(self.key_path(key), val, bound, labels)

    @staticmethod
    def _checked(name: str, val: float, bound: Bound | None) -> float:
        if bound is not None:
            return bound.check(name, val)
        if not math.isfinite(val):
            raise ConfigError(f"{name} = {val} is not a finite number")
        return val

    def vector(
        self,
        key: str,
        default: Any = ...,
        length: int | None = None,
        *,
        bound: Bound | Sequence[Bound] | None = None,
        labels: Sequence[str] | None = None,
    ) -> list[float]:
        """An array of numbers (see :meth:`numbers`)."""
        val = self.numbers(key, default, length, bound=bound, labels=labels)
        if val is None:
            return None  # type: ignore[return-value]
        if isinstance(val, float):
            raise ConfigError(f"{self.key_path(key)}: expected an array of numbers, got {val!r}")
        return val

    def done(self) -> None:
        """Raise ConfigError for any key that was never read (unknown keys), suggesting the
        nearest known key of this table for each (:func:`did_you_mean`)."""
        unknown = sorted(set(self.data) - self.seen)
        if unknown:
            known = ", ".join(sorted(self.seen)) or "none"
            raise ConfigError(
                f"{self.path or 'top level'}: unknown key(s) {', '.join(map(repr, unknown))} "
                f"(known here: {known}){did_you_mean(unknown, self.seen)}"
            )


def did_you_mean(unknown: Sequence[str], known: Iterable[str]) -> str:
    """``"; did you mean 'num_nodes'?"`` — the closest of ``known`` to each name of
    ``unknown`` (``difflib.get_close_matches``, its default cutoff 0.6), ``" for 'x'"``
    added when there are several unknown names; "" when none is close."""
    known = sorted(str(k) for k in known)
    hints = []
    for name in unknown:
        close = difflib.get_close_matches(str(name), known, n=1)
        if close:
            hints.append(f"{close[0]!r}" + (f" for {name!r}" if len(unknown) > 1 else ""))
    return f"; did you mean {', '.join(hints)}?" if hints else ""


def check_array(
    name: str,
    values: Sequence[Any],
    bound: Bound | Sequence[Bound] | None = None,
    labels: Sequence[str] | None = None,
) -> list[float]:
    """``values`` as floats, each a finite number within its ``bound`` (one for all, or one
    per element), else ConfigError naming the element (``name[i]`` or ``name label``)."""
    out = []
    for i, x in enumerate(values):
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise ConfigError(f"{name}: expected numbers, got {x!r}")
        label = f"{name} {labels[i]}" if labels is not None and i < len(labels) else f"{name}[{i}]"
        b = bound[i] if isinstance(bound, Sequence) else bound
        out.append(Table._checked(label, float(x), b))
    return out
