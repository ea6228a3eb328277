"""The ``[arm]`` table of a scenario → an :class:`~mpd_pin.arm.model.Arm` (docs/design.md §1, §7).

Shared by every scenario kind. The table gives exactly one of::

    builtin = "planar_3link"          # robots/*.urdf shipped with the package
    urdf = "arm.urdf"                 # relative to the scenario file (absolute paths too)
    example_robot_data = "panda"      # a fixed-base robot of example-robot-data

With ``urdf`` (a ``.urdf`` or a ``.xacro`` file, docs/design.md §1c) also::

    package_dirs = ["../src"]         # folders holding package folders (package://NAME/...)
    srdf = "my_arm.srdf"              # disable_collisions pairs
    xacro_args = { length = 0.4 }     # <xacro:arg> values of a .xacro file

and with ``urdf`` or ``example_robot_data``::

    lock = { gripper_joint = 0.02 }   # joints fixed at these values (rad or m)

Relative paths are relative to the scenario file.
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
from typing import Any

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


def load_urdf(path: Path, **options: Any) -> Arm:
    """:meth:`Arm.from_urdf` (``options``: its keyword arguments) with urdfdom's own
    messages folded into the one-line ConfigError (and passed on to stderr when loading
    succeeds)."""
    captured: list[str] = []
    try:
        with _native_stderr(captured):
            arm = Arm.from_urdf(path, **options)
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
    for key in ("package_dirs", "srdf", "xacro_args"):
        if t.has(key) and source != "urdf":
            raise ConfigError(f"{t.key_path(key)}: only with {t.key_path('urdf')}")
    if t.has("lock") and source == "builtin":
        raise ConfigError(f"{t.key_path('lock')}: only with urdf or example_robot_data")
    lock = _lock_table(t)
    if source == "builtin":
        arm = builtin_arm(t.string("builtin", choices=BUILTIN_ARMS))
    elif source == "urdf":
        options = _urdf_options(t, base_dir)
        arm = load_urdf(_path(t.string("urdf"), base_dir), lock=lock, **options)
    else:
        try:
            arm = Arm.from_example_robot_data(t.string("example_robot_data"), lock=lock)
        except ValueError as exc:
            raise ConfigError(f"{t.path}: {exc}") from None
    t.done()
    return arm


def _path(text: str, base_dir: Path | None) -> Path:
    """``text`` as a path, relative to ``base_dir`` (the scenario's folder) unless absolute."""
    rel = Path(text).expanduser()
    return rel if rel.is_absolute() or base_dir is None else base_dir / rel


def _lock_table(t: Table) -> dict[str, float] | None:
    """``[arm] lock``: joint name -> number (rad or m); limits are checked on loading."""
    if not t.has("lock"):
        return None
    lock = t.table("lock")
    out = {name: lock.number(name) for name in list(lock.data)}
    lock.done()
    return out


def _urdf_options(t: Table, base_dir: Path | None) -> dict[str, Any]:
    """``package_dirs``, ``srdf`` and ``xacro_args`` of an ``[arm]`` table with ``urdf``."""
    dirs = t.raw("package_dirs", [])
    if not isinstance(dirs, list) or not all(isinstance(d, str) for d in dirs):
        raise ConfigError(f"{t.key_path('package_dirs')}: expected an array of folder names")
    dirs = [_path(d, base_dir) for d in dirs]
    for d in dirs:
        if not d.is_dir():
            raise ConfigError(f"{t.key_path('package_dirs')}: {str(d)!r} is not a folder")
    srdf = t.string("srdf", None)
    args = t.table("xacro_args")
    xacro_args = {}
    for key, value in args.data.items():
        args.seen.add(key)
        if isinstance(value, bool) or isinstance(value, (int, float, str)):
            xacro_args[key] = value
        else:
            raise ConfigError(
                f"{args.key_path(key)}: expected a string, number or boolean, got {value!r}"
            )
    return {
        "package_dirs": [str(d) for d in dirs],
        "srdf_path": None if srdf is None else _path(srdf, base_dir),
        "xacro_args": xacro_args or None,
    }
