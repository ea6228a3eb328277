"""Timed trajectories priced as given (docs/design.md §9a, "timed";
``trajectory_energy(drive, W, execution="timed", times=t)``).

Independent references: through two points at [0, T] the timed spline is the rest-to-rest
edge quintic, so its energy is :func:`simulate_edge`'s (the per-edge reference code, not
the batched spline tables) — also at a duration that is not a whole number of steps, at
the step the pricing says it uses; the peak speed of that quintic is 1.875·|Δq|/T; the
non-stop execution's own motion re-timed at its own node times gives its energy back;
dense sampling of the curve for the collision certificate.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.kinds import load_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.motion import EXECUTIONS, PRICINGS, MotionOptions, trajectory_energy
from mpd_pin.motion.series import motion_series
from mpd_pin.motion.timed import check_times, timed_spline, timed_step


@pytest.fixture(scope="module")
def qs():
    """quickstart: scenario, drive, checker and a free 3-waypoint path W whose straight
    segments are certified free."""
    scn = load_scenario("quickstart")
    checker = CollisionChecker(scn.arm, scn.world)
    rng = np.random.default_rng(1)
    r = scn.options.resolution
    W = None
    for _ in range(50):
        mid = scn.start + rng.uniform(-0.6, 0.6, 3)
        end = mid + rng.uniform(-0.6, 0.6, 3)
        if checker.is_free(mid) and checker.is_free(end) and checker.edges_free(
                np.array([scn.start, mid]), np.array([mid, end]), r).all():
            W = np.array([scn.start, mid, end])
            break
    assert W is not None
    return scn, scn.drive(), checker, W


def _vlim(scn):
    v = np.asarray(scn.arm.model.velocityLimit, float)
    return np.where(np.isfinite(v) & (v > 0), v, np.inf)


# ----------------------------------------------------------------------------- references
@pytest.mark.parametrize("T", [1.5, 1.2345])
def test_two_points_are_the_edge_quintic(qs, T):
    """[q0, q1] at [0, T] costs what simulate_edge charges the edge of duration T; at a T
    off the dt grid, simulate_edge at the step T/⌈T/dt⌉."""
    scn, drive, checker, _ = qs
    dt = scn.options.dt
    q0, q1 = scn.start, scn.start + np.array([0.4, -0.3, 0.5])
    me = trajectory_energy(drive, [q0, q1], "timed", times=[0.0, T], options=scn.options,
                           checker=checker)
    h = dt if T == 1.5 else T / math.ceil(T / dt)
    assert timed_step(T, dt) == pytest.approx(h, rel=1e-15)
    ref = mp.simulate_edge(drive, q0, q1, duration=T, dt=h)
    np.testing.assert_allclose(me.energy_per_joint, ref.energy, rtol=1e-9)
    assert me.total_energy == pytest.approx(float(ref.energy.sum()), rel=1e-9)
    assert me.end_error == pytest.approx(float(np.max(np.abs(ref.q[-1] - q1))), rel=1e-6,
                                         abs=1e-12)
    assert me.execution == "timed" and me.feasible and me.reason == ""
    assert me.duration == me.fastest == T and me.stops == 0 and me.pieces == [(0, 1)]
    np.testing.assert_array_equal(me.piece_durations, [T])
    assert me.energy_by_execution == {"timed": me.total_energy}
    # the peak speed of the quintic: 1.875 |Δq| / T at mid-edge
    vel = float(np.max(1.875 * np.abs(q1 - q0) / T / _vlim(scn)))
    assert me.velocity_ratio == pytest.approx(vel, rel=1e-5)
    assert me.to_dict()["execution"] == "timed"


def test_the_nonstop_motion_at_its_own_node_times(qs):
    """The non-stop motion of W, re-priced at the node times it passes its waypoints,
    costs what the non-stop execution charged (same spline, built on other knots)."""
    scn, drive, checker, W = qs
    non = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
    assert non.feasible and non.stops == 0
    t = motion_series(drive, non, scn.options.dt)["node_times"]
    assert t.shape == (3,) and t[-1] == pytest.approx(non.duration)
    me = trajectory_energy(drive, W, "timed", times=t, options=scn.options, checker=checker)
    assert me.feasible
    np.testing.assert_allclose(me.energy_per_joint, non.energy_per_joint, rtol=1e-9)
    np.testing.assert_allclose(me.bus_energy, non.bus_energy, rtol=1e-9)
    assert me.velocity_ratio == pytest.approx(non.velocity_ratio, rel=1e-6)
    assert me.effort_ratio == pytest.approx(non.effort_ratio, rel=1e-9)
    # another timing of the same waypoints costs something else
    other = trajectory_energy(drive, W, "timed", times=[0.0, t[1] * 0.6, t[2] * 0.6],
                              options=scn.options)
    assert other.total_energy > non.total_energy * 1.05


def test_series_of_a_timed_motion(qs):
    """motion_series re-simulates a timed motion from its piece_durations (the segment
    durations): the same energy, passing the via points at the given times."""
    scn, drive, checker, W = qs
    t = np.array([0.0, 1.1, 2.7183])  # 2.7183 s: not on the 5 ms grid
    me = trajectory_energy(drive, W, "timed", times=t, options=scn.options, checker=checker)
    np.testing.assert_allclose(me.piece_durations, np.diff(t), rtol=0, atol=0)
    s = motion_series(drive, me, scn.options.dt)
    np.testing.assert_allclose(s["energy_t"][-1], me.energy_per_joint, rtol=1e-12)
    np.testing.assert_allclose(s["node_times"], t, rtol=1e-14)
    assert s["t"][-1] == pytest.approx(t[-1], rel=1e-12)
    np.testing.assert_allclose(np.diff(s["t"]), timed_step(t[-1], scn.options.dt), rtol=1e-9)
    np.testing.assert_allclose(s["q"][-1], W[-1], atol=scn.options.arrival_tolerance)
    # the reference passes the waypoints at the given times
    Q, *_ = timed_spline(W, t).derivatives(t, t[-1])
    np.testing.assert_allclose(Q, W, atol=1e-12)


# ----------------------------------------------------------------------------- feasibility
def test_infeasible_timed_motions_say_why(qs):
    scn, drive, checker, W = qs
    t = np.array([0.0, 1.0, 2.0])
    capped = trajectory_energy(drive, W, "timed", times=t, options=scn.options,
                               max_duration=1.5)
    assert not capped.feasible and "takes 2.000 s > max_duration 1.5 s" in capped.reason
    assert capped.energy_by_execution == {"timed": None} and capped.duration == 2.0
    fast = trajectory_energy(drive, W, "timed", times=t * 0.05, options=scn.options)
    assert not fast.feasible and "velocity limit exceeded" in fast.reason
    assert fast.velocity_ratio > 1.0


def test_a_colliding_curve_is_refused_with_its_time(qs):
    """start → goal in a straight line collides (test_motion.test_stop_refuses...): the
    timed curve fails its certificate, at a time the dense samples confirm; it is not
    split into pieces."""
    scn, drive, checker, _ = qs
    W = np.array([scn.start, scn.goal])
    t = np.array([0.0, 4.0])
    me = trajectory_energy(drive, W, "timed", times=t, options=scn.options, checker=checker)
    assert not me.feasible and me.pieces == [(0, 1)] and me.stops == 0
    m = re.search(r"not collision-free at t = ([0-9.]+) s \(between waypoints 1 and 2, "
                  r"counting from 1\)", me.reason)
    assert m, me.reason
    fail = float(m.group(1))
    ts = np.linspace(0.0, 4.0, 4001)
    Q, *_ = timed_spline(W, t).derivatives(ts, 4.0)
    free = checker.is_free_batch(Q)
    first_hit = ts[np.flatnonzero(~free)[0]]
    assert free[ts < fail - 0.01].all() and fail <= first_hit + 1e-3
    # without the checker the same motion is feasible: the certificate is what refused it
    assert trajectory_energy(drive, W, "timed", times=t, options=scn.options).feasible


def test_repeated_waypoints_are_a_dwell(qs):
    """A repeated waypoint with its own time is kept (the untimed executions drop it)."""
    scn, drive, _, W = qs
    D = np.array([W[0], W[1], W[1], W[2]])
    me = trajectory_energy(drive, D, "timed", times=[0.0, 1.0, 1.5, 2.5], options=scn.options)
    assert me.waypoints.shape == (4, 3) and len(me.piece_durations) == 3
    assert me.feasible


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("times, words", [
    ([0.0, 1.0, 1.0], "time row 3 (counting from 1), 1 s, is not after row 2"),
    ([0.0, 2.0, 1.0], "time row 3 (counting from 1)"),
    ([0.5, 1.0, 2.0], "time row 1 (counting from 1) is 0.5 s"),
    ([0.0, math.nan, 2.0], "time row 2 (counting from 1) is NaN"),
    ([0.0, 1.0, math.inf], "time row 3 (counting from 1) is NaN or infinity"),
    ([0.0, 1.0], "times has 2 values for 3 waypoints: time row 3 (counting from 1) is "
                 "missing"),
    ([0.0, 1.0, 2.0, 3.0], "time row 4 (counting from 1) has no waypoint"),
    ([[0.0, 1.0, 2.0]], "3 values, got shape (1, 3)"),
    (["a", "b", "c"], "times must be numbers"),
])
def test_bad_times(qs, times, words):
    scn, drive, _, W = qs
    with pytest.raises(ValueError) as exc:
        trajectory_energy(drive, W, "timed", times=times, options=scn.options)
    assert words in str(exc.value)
    assert str(exc.value).count("row") <= 2


def test_bad_waypoints_and_arguments(qs):
    scn, drive, _, W = qs
    bad = W.copy()
    bad[1, 2] = math.nan
    with pytest.raises(ValueError, match=r"waypoint row 2 \(counting from 1\)"):
        trajectory_energy(drive, bad, "timed", times=[0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="at least two waypoints"):
        trajectory_energy(drive, W[:1], "timed", times=[0.0])
    with pytest.raises(ValueError, match="'timed' needs times"):
        trajectory_energy(drive, W, "timed")
    with pytest.raises(ValueError, match="times are for execution 'timed', not 'nonstop'"):
        trajectory_energy(drive, W, "nonstop", times=[0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="timed"):  # the message lists it
        trajectory_energy(drive, W, "fast")
    np.testing.assert_array_equal(check_times((0, 1, 3), 3), [0.0, 1.0, 3.0])


def test_timed_is_a_pricing_not_a_planning_execution():
    assert PRICINGS == (*EXECUTIONS, "timed") and "timed" not in EXECUTIONS
    with pytest.raises(ValueError, match="execution"):
        MotionOptions(execution="timed")
