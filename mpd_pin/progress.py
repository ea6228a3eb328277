"""Progress bars and status lines: the one place that makes them (issues 23 and 34).

Every phase of a run that can take longer than about a second shows either a tqdm bar
(:func:`bar`, or the class of :func:`tqdm_class`: sampling, edge checks, edge energies,
lazy rounds, refinement, optimisation) or a status line (:func:`status`: phases without a
natural count, such as verification, plots and replay). Both write to stderr, and nothing
at all when ``enabled`` is False (the CLI's ``--quiet``, ``show_progress=False``).

How a bar looks depends on where stderr goes, decided when the bar is made:

* a terminal: tqdm frames (``\\r``-redrawn). A terminal that reports a size of 0 × 0 (a
  pty opened without a window size: ``pty.openpty()``, some CI runners and container
  sessions) is drawn :data:`FALLBACK_SIZE` wide; tqdm itself takes it as -1 × -1 and
  draws no frame at all;
* anything else (a file, a pipe, a captured stream): no frames, one line when the bar
  closes, ``edge checks: 4178 edges in 12.1 s`` (its postfix in parentheses;
  ``stopped at 3000/4178 edges after …`` when the block raised). Unlike status lines
  they have no ``mpd-pin:`` prefix, so a roadmap build that fails or is interrupted
  still shows one ``mpd-pin:`` line: the error (or ``mpd-pin: interrupted``);
* a Jupyter notebook (``tqdm.auto`` picks its widget): the widget, unchanged.
"""

from __future__ import annotations

import functools
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["PREFIX", "FALLBACK_SIZE", "is_terminal", "tqdm_class", "bar", "status"]

#: What every status line starts with.
PREFIX = "mpd-pin"

#: (columns, lines) assumed for a terminal that reports a size of 0.
FALLBACK_SIZE = (80, 24)


def is_terminal(stream: Any) -> bool:
    """Whether ``stream`` (a text stream such as ``sys.stderr``) is a terminal."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or closed
        return False


def _terminal_size(stream: Any) -> tuple[int, int]:
    """(columns, lines) of the terminal behind ``stream``; 0 where it reports none."""
    try:
        size = os.get_terminal_size(stream.fileno())
    except (AttributeError, ValueError, OSError):  # io.UnsupportedOperation is an OSError
        return 0, 0
    return size.columns, size.lines


class _Discard:
    """A text stream that drops what is written (where a log-mode bar draws its frames)."""

    encoding = "utf-8"

    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False


def _count(x: float) -> str:
    """A bar count for a line: ``12``, or ``2.5`` when not whole."""
    x = float(x)
    return str(int(x)) if x.is_integer() else f"{x:g}"


def _units(unit: str, n: float) -> str:
    """``unit`` (tqdm's, e.g. ``"edge"`` or ``" rounds"``) in the number of ``n``."""
    u = unit.strip() or "it"
    if u == "it":
        return u
    if float(n) == 1:
        return u[:-1] if u.endswith("s") and len(u) > 1 else u
    return u if u.endswith("s") else f"{u}s"


@functools.cache
def _bar_class() -> type:
    """The terminal-or-log bar class (module docstring), made on first use so that
    importing this module does not import tqdm."""
    from tqdm.std import tqdm

    class Bar(tqdm):
        """tqdm that draws frames on a terminal (of any reported size) and, elsewhere,
        writes one line when it closes. ``disable=None`` means enabled (a non-terminal
        gets its line)."""

        def __init__(self, *args: Any, file: Any = None, disable: bool | None = False,
                     **kw: Any) -> None:
            stream = sys.stderr if file is None else file
            self._log, self._stopped = None, False
            if not disable:
                if is_terminal(stream):
                    columns, lines = _terminal_size(stream)
                    if columns <= 0 or lines <= 0:
                        kw.setdefault("ncols", FALLBACK_SIZE[0] - 1)  # tqdm's: one spare
                        kw.setdefault("nrows", FALLBACK_SIZE[1])
                else:
                    self._log, stream = stream, _Discard()
            super().__init__(*args, file=stream, disable=bool(disable), **kw)

        def __exit__(self, exc_type: Any, *exc: Any) -> None:
            self._stopped = exc_type is not None
            return super().__exit__(exc_type, *exc)

        def close(self) -> None:
            log = getattr(self, "_log", None)
            if log is None or self.disable:  # a terminal, disabled, or closed already
                return super().close()
            seconds = self._time() - self.start_t
            super().close()
            print(self.summary(seconds), file=log, flush=True)

        def summary(self, seconds: float) -> str:
            """The line a log gets: ``DESC: N UNITS in S s (POSTFIX)``."""
            n, total = self.n, self.total
            units = _units(self.unit, n)
            if self._stopped:
                done = f"{_count(n)}/{_count(total)}" if total is not None else _count(n)
                text = f"stopped at {done} {units} after {seconds:.1f} s"
            else:
                done = _count(n) if total is None or n == total else (
                    f"{_count(n)}/{_count(total)}")
                text = f"{done} {units} in {seconds:.1f} s"
            desc = (self.desc or "progress").rstrip(": ")
            postfix = f" ({self.postfix})" if self.postfix else ""
            return f"{desc}: {text}{postfix}"

    return Bar


def tqdm_class(enabled: bool) -> type:
    """The progress-bar class: the terminal-or-log bar (module docstring) when shown,
    ``tqdm.auto``'s widget in a notebook, plain ``tqdm`` when not shown (``tqdm.auto``
    warns in Jupyter without ipywidgets even when disabled). Pass ``disable=not
    enabled`` to it as well."""
    if not enabled:
        from tqdm import tqdm

        return tqdm
    from tqdm.asyncio import tqdm as plain
    from tqdm.auto import tqdm as auto

    return auto if auto is not plain else _bar_class()  # tqdm.auto: plain outside notebooks


def bar(total: int | None, desc: str, unit: str = "it", enabled: bool = True, **kw: Any):
    """A bar on stderr (``total=None``: a counter without a bar) that disappears when
    closed on a terminal (``leave=False``) and leaves one line elsewhere; a disabled one,
    which writes nothing, unless ``enabled``. Use it as a context manager; other keywords
    go to tqdm."""
    kw.setdefault("leave", False)
    return tqdm_class(enabled)(total=total, desc=desc, unit=unit, disable=not enabled, **kw)


@contextmanager
def status(desc: str, enabled: bool = True) -> Iterator[None]:
    """Say on stderr that ``desc`` runs (``mpd-pin: desc ...``) and, once the block is
    left, how long it took (``mpd-pin: desc done in 1.2 s``, or ``stopped after`` when it
    raised); nothing unless ``enabled``. Plain lines, on a terminal and in a log alike."""
    if not enabled:
        yield
        return
    print(f"{PREFIX}: {desc} ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    try:
        yield
    except BaseException:
        print(f"{PREFIX}: {desc} stopped after {time.perf_counter() - t0:.1f} s",
              file=sys.stderr, flush=True)
        raise
    print(f"{PREFIX}: {desc} done in {time.perf_counter() - t0:.1f} s", file=sys.stderr,
          flush=True)
