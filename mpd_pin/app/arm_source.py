"""The ``[arm]`` table of a scenario → an :class:`~mpd_pin.arm.model.Arm` (docs/design.md §1, §7).

Shared by every scenario kind. The table gives exactly one of::

    builtin = "planar_3link"          # robots/*.urdf shipped with the package
    urdf = "arm.urdf"                 # relative to the scenario file (absolute paths too)
    example_robot_data = "panda"      # a fixed-base robot of example-robot-data

A URDF that urdfdom (C++) rejects prints its reasons on file descriptor 2; they are
captured and folded into the one-line :class:`~mpd_pin.app.config.ConfigError`.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

from ..arm.builtin import BUILTIN_ARMS, builtin_arm
from ..arm.model import Arm
from .config import ConfigError, Table

__all__ = ["ARM_SOURCES", "arm_from_table", "load_urdf"]

#: The keys of ``[arm]``, one of which a scenario gives.
ARM_SOURCES = ("builtin", "urdf", "example_robot_data")


@contextlib.contextmanager
def _native_stderr(captured: list[str]) -> Iterator[None]:
    """Send file descriptor 2 (what C++ libraries such as urdfdom print) to a temporary file
    for the duration; its text is appended to ``captured``."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            captured.append(tmp.read().decode("utf-8", errors="replace"))


def load_urdf(path: Path) -> Arm:
    """:meth:`Arm.from_urdf` with urdfdom's own messages folded into the one-line ConfigError
    (and passed on to stderr when loading succeeds)."""
    captured: list[str] = []
    try:
        with _native_stderr(captured):
            arm = Arm.from_urdf(path)
    except ValueError as exc:
        errors = [
            " ".join(line.split()[1:])
            for line in "".join(captured).splitlines()
            if line.strip().startswith("Error:")
        ]
        detail = f" (urdfdom: {'; '.join(errors)})" if errors else ""
        raise ConfigError(f"{exc}{detail}") from None
    if "".join(captured).strip():
        sys.stderr.write("".join(captured))
    return arm


def arm_from_table(t: Table, base_dir: Path | None, *, default_builtin: str | None = None) -> Arm:
    """The arm an ``[arm]`` table names (ConfigError if it names none or several).

    ``base_dir``: the scenario file's folder, against which a relative ``urdf`` path is
    resolved (``None``: the working directory). ``default_builtin``: the built-in arm of
    an empty table (``None``: one of :data:`ARM_SOURCES` is required).
    """
    choices = [k for k in ARM_SOURCES if t.has(k)]
    if not choices and default_builtin is not None:
        t.done()
        return builtin_arm(default_builtin)
    if len(choices) != 1:
        raise ConfigError(f"{t.path}: give exactly one of {', '.join(ARM_SOURCES)}")
    source = choices[0]
    if source == "builtin":
        arm = builtin_arm(t.string("builtin", choices=BUILTIN_ARMS))
    elif source == "urdf":
        rel = Path(t.string("urdf"))
        arm = load_urdf(rel if rel.is_absolute() or base_dir is None else base_dir / rel)
    else:
        arm = Arm.from_example_robot_data(t.string("example_robot_data"))
    t.done()
    return arm
