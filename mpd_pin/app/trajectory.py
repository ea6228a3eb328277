"""The executed motion as files a robot can run (docs/design.md §7c).

* ``trajectory.csv`` (:func:`write_trajectory_csv`) — the simulated motion at the RK4
  step: ``t`` (s), then for each joint ``q_<joint>`` (rad), ``v_<joint>`` (rad/s),
  ``i_<joint>`` (A), ``V_<joint>`` (V), ``tau_<joint>`` (motor torque at the joint
  n·Kt·i, N·m), then ``P_bus`` (W), the bus power Σ_k V_k·i_k (docs/design.md §3i).
  One time base: t = 0 at the start node, no duplicate sample at the
  joins of edges (:func:`~mpd_pin.app.verify.simulate_path`). A continuous joint's
  angle is continuous in time (unwrapped, docs/design.md §1d): it may leave [−π, π]
  but never jumps by 2π.
* ``trajectory.json`` (:func:`joint_trajectory`) — the same motion shaped like ROS
  ``trajectory_msgs/JointTrajectory``: ``joint_names`` and ``points``, each with
  ``positions`` (rad), ``velocities`` (rad/s), ``accelerations`` (rad/s²), ``effort``
  (N·m, n·Kt·i), ``time_from_start`` (s, a float) and ``time_from_start_ros``, the
  same time as ROS's ``builtin_interfaces/Duration`` ``{"sec": int, "nanosec": int}``
  (:func:`ros_duration`; the float keeps its name for existing readers), sampled every
  1/rate s from 0 (default 100 Hz) plus the final sample when the duration is not on
  that grid. Positions,
  velocities and effort are linear interpolations of the simulation samples;
  accelerations are central finite differences of the simulated velocities on the
  simulation step (``numpy.gradient``), then interpolated likewise.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.supply import bus_power
from .results import readable_mode, write_json

__all__ = [
    "DEFAULT_TRAJECTORY_RATE",
    "trajectory_columns",
    "trajectory_table",
    "write_trajectory_csv",
    "joint_trajectory",
    "ros_duration",
    "write_trajectory_json",
]

#: Default sampling rate of trajectory.json (Hz).
DEFAULT_TRAJECTORY_RATE = 100.0

_FIELDS = ("q", "v", "i", "V", "tau")


def trajectory_columns(joint_names: Sequence[str]) -> list[str]:
    """The CSV header: ``t``, then ``q_, v_, i_, V_, tau_`` for each joint, joint by joint,
    then ``P_bus``."""
    return ["t"] + [f"{f}_{name}" for name in joint_names for f in _FIELDS] + ["P_bus"]


def trajectory_table(series: dict[str, np.ndarray], torque_per_amp: np.ndarray) -> np.ndarray:
    """(samples, 2 + 5·nq) array in the column order of :func:`trajectory_columns`;
    ``series`` from :func:`~mpd_pin.app.verify.simulate_path`, ``torque_per_amp`` n·Kt
    (N·m/A) per joint."""
    tau = series["i"] * np.asarray(torque_per_amp, float)
    per = np.stack([series["q"], series["v"], series["i"], series["V"], tau], axis=2)
    p_bus = bus_power(series["V"], series["i"])
    return np.column_stack([series["t"], per.reshape(len(series["t"]), -1), p_bus])


def write_trajectory_csv(
    path: Path, joint_names: Sequence[str], series: dict[str, np.ndarray], torque_per_amp
) -> Path:
    """Write ``trajectory.csv`` (module docstring) atomically: temporary file, then rename."""
    path = Path(path)
    table = trajectory_table(series, torque_per_amp)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(",".join(trajectory_columns(joint_names)) + "\n")
            np.savetxt(f, table, delimiter=",", fmt="%.10g")
        os.chmod(tmp, readable_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _sample_times(duration: float, rate: float) -> np.ndarray:
    """0, 1/rate, 2/rate, … ≤ duration, and ``duration`` itself when off that grid (s)."""
    n = int(np.floor(duration * rate + 1e-9))
    t = np.arange(n + 1) / rate
    if duration - t[-1] > 1e-9:
        t = np.append(t, duration)
    return t


def ros_duration(seconds: float) -> dict[str, int]:
    """``seconds`` (≥ 0) as ROS's ``builtin_interfaces/Duration``: ``{"sec": int,
    "nanosec": int}`` with 0 ≤ nanosec < 10⁹, rounded to the nanosecond."""
    if not (np.isfinite(seconds) and seconds >= 0):
        raise ValueError(f"a time from start must be a number ≥ 0 (s), got {seconds!r}")
    sec, nanosec = divmod(round(float(seconds) * 1e9), 10**9)
    return {"sec": int(sec), "nanosec": int(nanosec)}


def joint_trajectory(
    joint_names: Sequence[str],
    series: dict[str, np.ndarray],
    torque_per_amp,
    rate: float = DEFAULT_TRAJECTORY_RATE,
) -> dict[str, Any]:
    """The motion of ``series`` as a JointTrajectory-like dict sampled at ``rate`` Hz
    (module docstring; times in s)."""
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"trajectory rate must be a number > 0 (Hz), got {rate!r}")
    t = np.asarray(series["t"], float)
    ts = _sample_times(float(t[-1]), float(rate))
    acc = np.gradient(series["v"], t, axis=0) if len(t) > 1 else np.zeros_like(series["v"])
    tau = series["i"] * np.asarray(torque_per_amp, float)

    def interp(x: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(ts, t, x[:, k]) for k in range(x.shape[1])])

    cols = [interp(series["q"]), interp(series["v"]), interp(acc), interp(tau)]
    points = [
        {
            "positions": cols[0][k],
            "velocities": cols[1][k],
            "accelerations": cols[2][k],
            "effort": cols[3][k],
            "time_from_start": float(ts[k]),
            "time_from_start_ros": ros_duration(float(ts[k])),
        }
        for k in range(len(ts))
    ]
    return {
        "joint_names": list(joint_names),
        "rate_hz": float(rate),
        "accelerations": "central finite differences of the simulated velocities",
        "effort": "motor torque at the joint n*Kt*i (N*m)",
        "points": points,
    }


def write_trajectory_json(path: Path, trajectory: dict[str, Any]) -> Path:
    """Write ``trajectory.json`` atomically (:func:`~mpd_pin.app.results.write_json`)."""
    return write_json(path, trajectory)
