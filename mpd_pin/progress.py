"""Progress bars and status lines: the one place that makes them (issue 23).

Every phase of a run that can take longer than about a second shows either a tqdm bar
(:func:`bar`: node and edge checks, edge energies, lazy rounds, refinement) or a status
line (:func:`status`: phases without a natural count, such as plots and replay). Both
write to stderr and are silent when ``enabled`` is False (the CLI's ``--quiet``,
``show_progress=False``), so nothing reaches stderr then.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["PREFIX", "tqdm_class", "bar", "status"]

#: What every status line starts with.
PREFIX = "mpd-pin"


def tqdm_class(enabled: bool):
    """The progress-bar class: ``tqdm.auto`` when shown, plain ``tqdm`` when not
    (``tqdm.auto`` warns in Jupyter without ipywidgets even when disabled)."""
    if enabled:
        from tqdm.auto import tqdm
    else:
        from tqdm import tqdm
    return tqdm


def bar(total: int | None, desc: str, unit: str = "it", enabled: bool = True, **kw):
    """A tqdm bar on stderr (``total=None``: a counter without a bar) that disappears
    when closed (``leave=False``); a disabled one, which writes nothing, unless
    ``enabled``. Use it as a context manager; other keywords go to tqdm."""
    kw.setdefault("leave", False)
    return tqdm_class(enabled)(total=total, desc=desc, unit=unit, disable=not enabled, **kw)


@contextmanager
def status(desc: str, enabled: bool = True) -> Iterator[None]:
    """Say on stderr that ``desc`` runs (``mpd-pin: desc ...``) and, once the block is
    left, how long it took (``mpd-pin: desc done in 1.2 s``, or ``stopped after`` when it
    raised); nothing unless ``enabled``."""
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
