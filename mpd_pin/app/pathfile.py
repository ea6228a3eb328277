"""Waypoint files: paths planned elsewhere (OMPL, MoveIt, a spreadsheet) read for pricing by
``mpd-pin energy`` (:func:`mpd_pin.motion.trajectory_energy`).

Accepted formats
----------------
The format is chosen by the file name's extension (upper or lower case); positions are in
rad (revolute and continuous joints) or m (prismatic joints), one waypoint per row/point:

* ``.csv`` — comma-separated values, UTF-8 (a byte-order mark is ignored), blank lines
  skipped. Either

  - a **header row** naming the columns: each of the arm's joints must have a column,
    named after the joint (``joint1``) or ``q_<joint>`` as in mpd_pin's own
    ``trajectory.csv``; the columns may come in any order; a column ``t`` holds the time
    of each row (s, as in ``trajectory.csv``); other columns (``time``, velocities, …) are
    ignored; every row has as many fields as the header;
  - or **no header** (the first row is all numbers): exactly one column per joint, in the
    arm's joint order (``Arm.joint_names``, the ``joint_names`` of mpd_pin's result.json).

* ``.json`` — an object shaped like ROS ``trajectory_msgs/JointTrajectory``:
  ``{"joint_names": [...], "points": [{"positions": [...]}, ...]}``; positions are
  reordered by ``joint_names``, joints the arm does not have (a gripper) are ignored,
  other point fields (``velocities``, ``effort``, …) too. ``time_from_start`` (s), on every
  point or on none, is the point's time: a number (mpd_pin's own files) or a ROS
  ``Duration`` object, ``{"sec": int, "nanosec": int}`` (ROS 2) or ``{"secs": int,
  "nsecs": int}`` (ROS 1). mpd_pin's own
  ``trajectory.json`` has this shape; so does ``joint_trajectory`` of a
  ``moveit_msgs/RobotTrajectory``, which is accepted as well (an object whose
  ``joint_trajectory`` holds the above).

Positions are read, and the times when the file has them (:attr:`PathFile.times`, None
otherwise): ``mpd-pin energy`` then prices the trajectory with its own timing
(``trajectory_energy(..., execution="timed", times=...)``); the other executions time the
motion themselves (roadmap timing stop and go, or the least-energy duration non-stop).
Velocities and efforts in the file are ignored.

Rows are counted from 1 over the data rows (the header and blank lines not counted);
for CSV the error messages add the line number, for JSON the index into ``points``.

Checks
------
:func:`read_path_file` rejects, with a :class:`~mpd_pin.app.config.ConfigError` naming
the file and the row: an unreadable file, malformed JSON or an unknown extension (the
message lists the accepted formats), a missing joint column, a row with the wrong number
of values, an empty, non-numeric or non-finite value (a time too), a JSON file with
``time_from_start`` on some points only, and fewer than two waypoints. :func:`check_times`
rejects times that do not start at 0 or do not increase strictly (for timed pricing only).
:func:`check_path` then rejects a waypoint outside the joint position limits (1e-9
tolerance; continuous joints have none) or in collision (naming the colliding pair).
Files are only parsed (``csv``, ``json``), never executed or unpickled.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .config import ConfigError

__all__ = ["FORMATS", "LIMIT_TOLERANCE", "PathFile", "check_path", "check_times",
           "read_path_file", "read_waypoints"]

#: Extension → what it holds (for the message on an unknown extension).
FORMATS = {
    ".csv": "waypoints, one per row, with a header row naming the joints (and t, s) or "
            "exactly one column per joint in joint order",
    ".json": "trajectory_msgs/JointTrajectory: joint_names and points[].positions (and "
             "points[].time_from_start)",
}

#: How far a waypoint may lie outside a joint's position limits (rad or m).
LIMIT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class PathFile:
    """A waypoint file as read: ``waypoints`` (m, nq) in the arm's joint order (rad or m),
    ``rows[k]`` how messages name waypoint k ("row 3 (line 4)"), ``times`` (m,) s when the
    file gives them (a CSV ``t`` column, JSON ``time_from_start``), else None."""

    path: Path
    format: str
    waypoints: np.ndarray
    rows: list[str]
    times: np.ndarray | None = None


def read_waypoints(path: str | Path, joint_names: Sequence[str]) -> np.ndarray:
    """The waypoints of the file ``path`` as an (m, nq) float array (rad or m), columns in
    the order of ``joint_names`` (module docstring: formats); ConfigError for bad input."""
    return read_path_file(path, joint_names).waypoints


def read_path_file(path: str | Path, joint_names: Sequence[str]) -> PathFile:
    """:func:`read_waypoints` with the row labels the messages use (:class:`PathFile`)."""
    path = Path(path)
    joint_names = list(joint_names)
    fmt = path.suffix.lower()
    if fmt not in FORMATS:
        kinds = "; ".join(f"{ext} ({what})" for ext, what in FORMATS.items())
        got = repr(path.suffix) if path.suffix else "none"
        raise ConfigError(f"{path}: unknown path file type (extension {got}); accepted: "
                          f"{kinds}")
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            if fmt == ".csv":
                W, rows, times = _read_csv(f, path, joint_names)
            else:
                W, rows, times = _read_json(f, path, joint_names)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    if W.shape[0] < 2:
        raise ConfigError(f"{path}: {W.shape[0]} waypoint(s); a path needs at least 2")
    return PathFile(path, fmt[1:], W, rows, times)


def _number(text: str) -> float | None:
    """``text`` as a float, None if it is not a number (NaN and inf are numbers here)."""
    try:
        return float(text)
    except ValueError:
        return None


def _value(x: Any, where: str, joint: str) -> float:
    """One position: a finite number (the CSV text or the JSON value ``x``)."""
    if isinstance(x, str):
        if not x.strip():
            raise ConfigError(f"{where}: empty value for {joint}")
        v = _number(x)
        if v is None:
            raise ConfigError(f"{where}: {joint} = {x.strip()!r} is not a number")
    elif isinstance(x, (int, float)) and not isinstance(x, bool):
        v = float(x)
    else:
        raise ConfigError(f"{where}: {joint} = {json.dumps(x)} is not a number")
    if not math.isfinite(v):
        raise ConfigError(f"{where}: {joint} = {v} is not a finite number")
    return v


def _read_csv(f, path: Path, joint_names: list[str]
              ) -> tuple[np.ndarray, list[str], np.ndarray | None]:
    reader = csv.reader(f)
    lines: list[tuple[int, list[str]]] = []
    try:
        for cells in reader:
            if any(c.strip() for c in cells):
                lines.append((reader.line_num, cells))
    except csv.Error as exc:
        raise ConfigError(f"{path}: line {reader.line_num}: malformed CSV ({exc})") from None
    if not lines:
        raise ConfigError(f"{path}: no waypoints (the file is empty)")
    nq = len(joint_names)
    first = lines[0][1]
    time_column = None
    if all(_number(c) is not None for c in first):  # no header: joint order
        columns = list(range(nq))
        width = nq
        expect = (f"expected {nq} (one per joint: {', '.join(joint_names)}; or give a header "
                  f"row naming the columns)")
    else:
        header = [c.strip() for c in first]
        columns = []
        for name in joint_names:
            for key in (name, f"q_{name}"):
                hits = [k for k, h in enumerate(header) if h == key]
                if len(hits) > 1:
                    raise ConfigError(f"{path}: the header names column {key!r} "
                                      f"{len(hits)} times")
                if hits:
                    columns.append(hits[0])
                    break
            else:
                hint = ""
                if any(";" in c or "\t" in c for c in first):
                    hint = "; fields must be separated by commas"
                elif any(_number(c) is not None for c in first):
                    hint = "; the first row was read as a header as it is not all numbers"
                raise ConfigError(f"{path}: no column for joint {name!r} in the header "
                                  f"({', '.join(header)}); one per joint is needed: "
                                  f"{', '.join(joint_names)}{hint}")
        hits = [k for k, h in enumerate(header) if h == "t"]
        if len(hits) > 1:
            raise ConfigError(f"{path}: the header names column 't' {len(hits)} times")
        time_column = hits[0] if hits else None
        width = len(header)
        expect = f"the header has {width} columns"
        lines = lines[1:]
    W = np.empty((len(lines), nq))
    times = None if time_column is None else np.empty(len(lines))
    rows = []
    for r, (line, cells) in enumerate(lines):
        where = f"{path}: row {r + 1} (line {line})"
        if len(cells) != width:
            raise ConfigError(f"{where} has {len(cells)} values, {expect}")
        W[r] = [_value(cells[c], where, name) for c, name in zip(columns, joint_names,
                                                                  strict=True)]
        if times is not None:
            times[r] = _value(cells[time_column], where, "t")
        rows.append(f"row {r + 1} (line {line})")
    return W, rows, times


def _time_from_start(x: Any, where: str) -> float:
    """A point's ``time_from_start`` (s): a number, or a ROS Duration object."""
    for sec, nsec in (("sec", "nanosec"), ("secs", "nsecs")):
        if isinstance(x, dict) and set(x) == {sec, nsec}:
            parts = [x[sec], x[nsec]]
            if all(isinstance(v, int) and not isinstance(v, bool) for v in parts):
                return float(parts[0]) + float(parts[1]) * 1e-9
    if isinstance(x, dict):
        raise ConfigError(f'{where}: time_from_start = {json.dumps(x)} is not a time (a '
                          'number of s, or {"sec": int, "nanosec": int})')
    return _value(x, where, "time_from_start")


def _read_json(f, path: Path, joint_names: list[str]
               ) -> tuple[np.ndarray, list[str], np.ndarray | None]:
    try:
        doc = json.load(f)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: not valid JSON (line {exc.lineno} column {exc.colno}: "
                          f"{exc.msg})") from None
    shape = ('expected an object shaped like trajectory_msgs/JointTrajectory: '
             '{"joint_names": [...], "points": [{"positions": [...]}, ...]}')
    if isinstance(doc, dict) and "points" not in doc and isinstance(
            doc.get("joint_trajectory"), dict):
        doc = doc["joint_trajectory"]  # moveit_msgs/RobotTrajectory
    if not isinstance(doc, dict) or "joint_names" not in doc or "points" not in doc:
        raise ConfigError(f"{path}: {shape}")
    names, points = doc["joint_names"], doc["points"]
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise ConfigError(f"{path}: joint_names must be a list of strings; {shape}")
    if not isinstance(points, list):
        raise ConfigError(f"{path}: points must be a list; {shape}")
    for name in set(names):
        if names.count(name) > 1:
            raise ConfigError(f"{path}: joint_names lists {name!r} {names.count(name)} times")
    missing = [n for n in joint_names if n not in names]
    if missing:
        raise ConfigError(f"{path}: joint_names ({', '.join(names)}) lacks joint "
                          f"{missing[0]!r}; the arm's joints are {', '.join(joint_names)}")
    columns = [names.index(n) for n in joint_names]
    W = np.empty((len(points), len(joint_names)))
    timed = [isinstance(p, dict) and "time_from_start" in p for p in points]
    times = np.empty(len(points)) if any(timed) else None
    rows = []
    for r, point in enumerate(points):
        label = f"row {r + 1} (points[{r}])"
        where = f"{path}: {label}"
        pos = point.get("positions") if isinstance(point, dict) else None
        if not isinstance(pos, list):
            raise ConfigError(f"{where} has no positions list")
        if len(pos) != len(names):
            raise ConfigError(f"{where} has {len(pos)} positions, joint_names has "
                              f"{len(names)}")
        W[r] = [_value(pos[c], where, name) for c, name in zip(columns, joint_names,
                                                               strict=True)]
        if times is not None:
            if not timed[r]:
                first = timed.index(True)
                raise ConfigError(f"{where} has no time_from_start (row {first + 1} has one: "
                                  "give it on every point or on none)")
            times[r] = _time_from_start(point["time_from_start"], where)
        rows.append(label)
    return W, rows, times


def check_times(pf: PathFile) -> np.ndarray:
    """The times (s) of the path file ``pf`` for timed pricing: ConfigError naming the file
    (and the row) when it has none, when the first is not 0 or when they do not increase
    strictly."""
    if pf.times is None:
        what = "no t column" if pf.format == "csv" else "no time_from_start on its points"
        raise ConfigError(f"{pf.path}: the file has no times ({what}); timed pricing needs "
                          "them (or choose --execution auto, stop or nonstop)")
    t = pf.times
    if t[0] != 0.0:
        raise ConfigError(f"{pf.path}: {pf.rows[0]}: the first time is {t[0]:.9g} s; a timed "
                          "trajectory starts at 0 s")
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if back.size:
        k = int(back[0]) + 1
        raise ConfigError(f"{pf.path}: {pf.rows[k]}: time {t[k]:.9g} s is not after the "
                          f"time of {pf.rows[k - 1]}, {t[k - 1]:.9g} s: times must increase "
                          "strictly")
    return t


def check_path(W: np.ndarray, arm: Any, checker: Any = None, *, rows: Sequence[str] | None
               = None, source: str = "") -> None:
    """ConfigError naming the first waypoint (row of ``W``, (m, nq) rad or m) outside the
    position limits of ``arm`` (:data:`LIMIT_TOLERANCE`; continuous joints have none) or,
    with a ``checker`` (:class:`~mpd_pin.collision.CollisionChecker`), in collision.
    ``rows``: the waypoints' labels (default "row k", from 1); ``source``: the file."""
    W = np.asarray(W, dtype=float)
    rows = list(rows) if rows is not None else [f"row {k + 1}" for k in range(W.shape[0])]
    prefix = f"{source}: " if source else ""
    lo = np.asarray(arm.model.lowerPositionLimit, dtype=float)
    hi = np.asarray(arm.model.upperPositionLimit, dtype=float)
    limited = ~np.asarray(arm.continuous_mask, dtype=bool)
    out = ((W < lo - LIMIT_TOLERANCE) | (W > hi + LIMIT_TOLERANCE)) & limited
    if out.any():
        r, j = map(int, np.argwhere(out)[0])
        raise ConfigError(f"{prefix}{rows[r]}: {arm.joint_names[j]} = {W[r, j]:.6g} is "
                          f"outside its limits [{lo[j]:.6g}, {hi[j]:.6g}]")
    if checker is None:
        return
    free = np.asarray(checker.is_free_batch(W), dtype=bool)
    if not free.all():
        r = int(np.flatnonzero(~free)[0])
        what = checker.describe_collision(W[r])
        raise ConfigError(f"{prefix}{rows[r]} is in collision{': ' + what if what else ''}")
