"""The time-optimal duration along a fixed geometric path (TOPP-RA), a lower bound for the
uniform stretch the package runs (docs/design.md §9c).

:func:`time_optimal_duration` parameterises the curve of a
:class:`~mpd_pin.motion.spline.ViaSpline` time-optimally under the joint velocity and effort
limits with `toppra` (Pham & Pham, IEEE T-RO 2018), from rest to rest. Its time law is not
a uniform stretch: it runs at the velocity or torque limit almost everywhere, which is why
its duration is shorter than :meth:`~mpd_pin.motion.MotionEnergy.fastest_duration`. The
package does not use it to plan (the energy-optimal motions run at 1–3× the fastest
duration, where a stretched smooth spline serves, §9b); the benchmarks and tests use it as
a bound. `toppra` is an optional dependency (the ``test`` and ``bench`` extras), imported
only here: it imports matplotlib's pyplot and takes about a second to load.

The torque is the perfect-tracking feed-forward of §3c: RNEA of the drive's model (armature
n²J included) plus the viscous n²B q̇. TOPP-RA's constraints are linear in ṡ² and s̈, and
the viscous term is linear in ṡ, so it is bounded instead: |n²B q̇| ≤ n²B v_lim, and the
torque limits are widened by that much (a relaxation, so the result stays a lower bound;
in the built-in scenarios n²B v_lim is 0.03–3.5 % of the limit).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from ..dynamics.motor import Drive
from .screen import joint_limits
from .spline import ViaSpline

__all__ = ["time_optimal_duration"]

#: Grid points of the TOPP-RA discretisation, at least (and 20 per polynomial piece).
GRIDPOINTS = 400


def time_optimal_duration(drive: Drive, vs: ViaSpline, options: Any = None,
                          gridpoints: int = GRIDPOINTS) -> float | None:
    """The least duration (s) of any time law along the curve of ``vs`` from rest to rest
    within the velocity limits (when ``options.velocity_limits``) and the effort limits
    (when ``options.effort_limits``; widened by the viscous term, module docstring), by
    TOPP-RA on ``gridpoints`` points (the ``Interpolation`` scheme). None when TOPP-RA finds
    no parameterisation (holding the arm exceeds a limit) or no limit applies."""
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint as tc
    except ImportError:
        raise ImportError("time_optimal_duration needs toppra>=0.6 (pip install "
                          "'mpd-pin[test]' or 'mpd-pin[bench]')") from None
    from pinocchio import rnea

    logging.getLogger("toppra").setLevel(logging.ERROR)
    from ..planning.roadmap import RoadmapOptions

    options = options or RoadmapOptions()
    vlim, elim = joint_limits(drive)
    big = 1e9
    constraints = []
    if options.velocity_limits and np.isfinite(vlim).any():
        v = np.where(np.isfinite(vlim), vlim, big)
        constraints.append(tc.JointVelocityConstraint(np.vstack([-v, v]).T))
    if options.effort_limits and np.isfinite(elim).any():
        viscous = np.where(np.isfinite(vlim), drive.damping * vlim, big)
        lim = np.where(np.isfinite(elim), elim + viscous, big)
        model = drive.model
        data = model.createData()

        def inverse_dynamics(q, qd, qdd):
            return rnea(model, data, np.asarray(q, float), np.asarray(qd, float),
                        np.asarray(qdd, float))

        constraints.append(tc.JointTorqueConstraint(
            inverse_dynamics, np.vstack([-lim, lim]).T, np.zeros(drive.nq),
            discretization_scheme=tc.DiscretizationType.Interpolation))
    if not constraints:
        return None

    class _Path(toppra.interpolator.AbstractGeometricPath):
        def __call__(self, s, order=0):
            return vs.spline(np.asarray(s, dtype=float), order)

        @property
        def dof(self):
            return drive.nq

        @property
        def path_interval(self):
            return np.array([0.0, vs.unit_duration])

    n = max(int(gridpoints), 20 * (len(np.unique(vs.spline.t)) - 1))
    grid = np.linspace(0.0, vs.unit_duration, n + 1)
    algo = toppra.algorithm.TOPPRA(constraints, _Path(), gridpoints=grid)
    _, sd, _, _ = algo.compute_parameterization(0.0, 0.0, return_data=True)
    if sd is None or not np.all(np.isfinite(sd)):
        return None
    sd = np.maximum(np.asarray(sd, dtype=float), 0.0)
    ds = np.diff(grid)
    # constant path acceleration between grid points: Δt = 2 Δs / (ṡ_i + ṡ_{i+1})
    return float(np.sum(2.0 * ds / np.maximum(sd[:-1] + sd[1:], 1e-300)))
