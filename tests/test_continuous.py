"""Continuous joints take the shorter way round (docs/design.md §1d).

References: the wrapped difference computed by hand (2π − 6 rad), brute-force periodic
distances for the kNN, simulate_edge to the unwrapped target for the roadmap's energies,
and the URDF limits for every re-simulated edge of a planned Kinova path.
"""

from __future__ import annotations

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.plan import path_length, plan_path, prepare
from mpd_pin.app.scenario import load_scenario_data, parse_energy_scenario, resolve_scenario
from mpd_pin.app.verify import simulate_path
from mpd_pin.arm.continuous import edge_target, nearest_neighbours, wrap_angle
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost
from mpd_pin.dynamics.sizing import sized_motors
from mpd_pin.planning.roadmap import Roadmap, _neighbour_pairs
from mpd_pin.world import Sphere, World

DT = 5e-3


@pytest.fixture(scope="module")
def kinova():
    return mp.Arm.from_example_robot_data("kinova")


@pytest.fixture(scope="module")
def drive(kinova):
    return mp.Drive(kinova, sized_motors(kinova), kp=20.0, kd=1.0, feedforward=True)


def _q(j1: float) -> np.ndarray:
    return np.array([j1, 2.9, 1.3, 2.5, 2.0, 0.0])


def test_wrap_and_edge_target_by_hand():
    x = np.array([-7.0, -np.pi, 0.0, np.pi, 3.5, 6.0])
    w = wrap_angle(x)
    assert np.all((w >= -np.pi) & (w < np.pi))
    assert np.allclose(np.sin(w), np.sin(x), atol=1e-15) and np.allclose(np.cos(w), np.cos(x))
    mask = np.array([True, False])
    Q0, Q1 = np.array([[3.0, 3.0], [-3.0, 0.1]]), np.array([[-3.0, -3.0], [3.0, 0.2]])
    T = edge_target(Q0, Q1, mask)
    assert T[0, 0] == pytest.approx(3.0 + (2 * np.pi - 6.0), abs=1e-14)
    assert T[1, 0] == pytest.approx(-3.0 - (2 * np.pi - 6.0), abs=1e-14)
    assert T[0, 1] == -3.0 and T[1, 1] == 0.2  # not periodic: unchanged
    assert np.array_equal(edge_target(Q0, T, mask), T)  # idempotent
    assert edge_target(Q0, Q1, np.zeros(2, bool)) is Q1  # no periodic joint: Q1 itself


def test_kinova_edge_across_pi_is_short(kinova, drive):
    q0, q1 = _q(3.0), _q(-3.0)
    assert kinova.continuous_joints[0] == kinova.joint_names[0]
    target = kinova.edge_target(q0, q1)
    assert target[0] == pytest.approx(2 * np.pi - 3.0, abs=1e-14)
    assert np.array_equal(target[1:], q1[1:])
    # one hand-built edge, re-simulated as the verify step does
    cost = EnergyCost(drive, DT)
    out = cost.outcomes(q0[None], q1[None], np.array([1.0]))
    ref = mp.simulate_edge(drive, q0, target, 1.0, DT)
    np.testing.assert_allclose(out.energy[0], ref.energy, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(out.end_error)) < 0.01  # arrives at the (unwrapped) node
    rm = Roadmap(nodes=np.vstack([q0, q1]), start=0, goal=1, src=np.array([0]),
                 dst=np.array([1]), durations=np.array([1.0]), energy=out.energy, key="x")
    s = simulate_path(drive, rm, [0, 1], DT)
    j1 = s["q"][:, 0]
    assert np.all(np.diff(j1) >= -1e-9)  # monotone: it turns one way only
    travelled = j1.max() - j1.min()
    assert travelled == pytest.approx(2 * np.pi - 6.0, abs=0.01)  # 0.28 rad, not 6 rad
    np.testing.assert_allclose(s["edge_energy"][0], ref.energy, rtol=1e-12)
    # the collision check follows the short way: a ball where the long way passes
    # (joint 1 at 0 rad) does not block the edge
    frame = kinova.model.frames[-1].name
    ball = Sphere(0.06, position=kinova.frame_position(_q(0.0), frame), name="ball")
    checker = CollisionChecker(kinova, World((ball,)))
    assert not checker.is_free(_q(0.0)) and checker.is_free(q0) and checker.is_free(q1)
    assert checker.edges_free(q0[None], q1[None], 0.05)[0]
    assert checker.edge_free(q1, q0, 0.05)
    assert not checker.edge_free(_q(1.5), _q(-1.5), 0.05)  # through 0: blocked


def test_periodic_knn_matches_brute_force():
    rng = np.random.default_rng(3)
    mask = np.array([True, False, True, False])
    nodes = rng.uniform([-np.pi, -2, -np.pi, 0], [np.pi, 2, np.pi, 5], size=(300, 4))
    nodes[:3, 0] = [np.pi, -np.pi, 3.1]  # on and near the seam
    k = 6
    nbr = nearest_neighbours(nodes, k, mask)
    diff = nodes[:, None, :] - nodes[None, :, :]
    diff[..., mask] = wrap_angle(diff[..., mask])
    dist = np.linalg.norm(diff, axis=2)
    brute = np.sort(dist, axis=1)[:, : k + 1]
    got = np.sort(np.take_along_axis(dist, nbr, axis=1), axis=1)
    np.testing.assert_allclose(got, brute, atol=1e-12)
    # the roadmap's pairs: every node joined to its k periodic nearest neighbours
    pairs = {tuple(p) for p in _neighbour_pairs(nodes, k, mask).tolist()}
    for i in range(len(nodes)):
        for j in np.argsort(dist[i])[1 : k + 1]:
            if dist[i, j] < brute[i, k] - 1e-12:  # not a tie at the k-th distance
                assert (min(i, j), max(i, j)) in pairs
    # two nodes across the seam are neighbours (Euclidean would put them 6 rad apart)
    seam = np.array([[3.1, 0, 0, 0], [-3.1, 0, 0, 0], [0.0, 0, 0, 0]])
    assert (0, 1) in {tuple(p) for p in _neighbour_pairs(seam, 1, mask).tolist()}
    assert (0, 1) not in {tuple(p) for p in _neighbour_pairs(seam, 1, None).tolist()}


@pytest.fixture(scope="module")
def kinova_plan():
    path = resolve_scenario("kinova")
    data = load_scenario_data(path)
    data["roadmap"]["num_nodes"] = 15
    data["task"]["start"] = [2.8, 2.9, 1.3, 2.5, 2.0, 3.0]
    data["task"]["goal"] = [-2.6, 2.9, 1.3, 2.5, 2.0, -3.0]  # across ±π on joints 1 and 6
    scn = parse_energy_scenario(data, source=str(path), base_dir=path.parent)
    setup = prepare(scn, show_progress=False)
    return scn, setup, plan_path(scn, setup)


def test_kinova_path_resimulated_within_limits(kinova_plan):
    scn, setup, plan = kinova_plan
    rm, drive, arm = setup.roadmap, setup.drive, scn.arm
    assert len(plan.path) >= 2 and plan.path[0] == rm.start and plan.path[-1] == rm.goal
    vlim = arm.model.velocityLimit
    elim = arm.model.effortLimit
    npkt = np.array([m.gear_ratio * m.Kt for m in drive.motors])
    for e in rm.edge_ids(plan.path):
        q0 = rm.nodes[rm.src[e]]
        q1 = arm.edge_target(q0, rm.nodes[rm.dst[e]])
        assert np.all(np.abs(q1 - q0)[arm.continuous_mask] <= np.pi + 1e-12)
        T = float(rm.durations[e])
        sim = mp.simulate_edge(drive, q0, q1, T, scn.options.dt)
        assert np.max(np.abs(sim.q[-1] - q1)) <= scn.options.arrival_tolerance
        assert np.all(1.875 * np.abs(q1 - q0) / T <= vlim * (1 + 1e-12))  # quintic peak
        assert np.all(np.abs(sim.v).max(axis=0) <= vlim)
        assert np.all(np.abs(sim.i * npkt).max(axis=0) <= elim)
        np.testing.assert_allclose(sim.energy, rm.energy[e], rtol=1e-9, atol=1e-12)
    # the written motion is continuous in time (unwrapped), nodes stay in [−π, π]
    s = simulate_path(drive, rm, plan.path, scn.options.dt)
    steps = np.abs(np.diff(s["q"], axis=0)).max()
    assert steps < 0.05
    assert np.all(np.abs(rm.nodes[:, arm.continuous_mask]) <= np.pi)
    assert abs(s["q"][-1, 0] - (-2.6 + 2 * np.pi)) < 0.01 or abs(s["q"][-1, 0] + 2.6) < 0.01
    # the short way round: joint 1 turns 0.88 rad across the seam, not 5.4 rad
    assert abs(s["q"][-1, 0] - s["q"][0, 0]) < np.pi
    assert path_length(rm, plan.path, arm) < path_length(rm, plan.path)


def test_refinement_takes_a_path_across_the_seam_the_short_way(kinova, drive):
    """A roadmap path holds its nodes wrapped to [−π, π); the refinement (shortcut DP,
    via-point relaxation, pricing) unwraps them first, so it refines the path the roadmap
    priced. Reference: the same path unwrapped by hand (+2π after the seam) gives the same
    motion, bit for bit, and joint 1 turns 0.88 rad, not 5.4 rad. Without the unwrapping
    the shortcut priced the 6.1 rad jump between nodes 2 and 3 (a Bravo 7 path across the
    seam was refused whole)."""
    from mpd_pin.motion.refine import MotionOptions, refine_candidates

    wrapped = np.array([_q(2.7), _q(3.05), _q(-3.05), _q(-2.7)])
    wrapped[:, 1] = [2.9, 2.7, 2.6, 2.9]  # a real detour: the shortcut has a choice
    by_hand = wrapped.copy()
    by_hand[2:, 0] += 2 * np.pi
    checker = CollisionChecker(kinova, World(()))
    options = mp.RoadmapOptions(duration=1.0, dt=DT)
    motion = MotionOptions(optimize=False)
    out = refine_candidates(drive, checker, options, {"path": wrapped}, motion)
    ref = refine_candidates(drive, checker, options, {"path": by_hand}, motion)
    assert out.motion.feasible and ref.motion.feasible
    assert out.motion.total_energy == ref.motion.total_energy
    np.testing.assert_array_equal(out.motion.waypoints, ref.motion.waypoints)
    j1 = out.motion.waypoints[:, 0]
    assert j1[-1] - j1[0] == pytest.approx(2 * np.pi - 5.4, abs=1e-12)
    assert out.candidates[0]["stop_energy_in"] == ref.candidates[0]["stop_energy_in"]


def test_a_continuous_joint_has_no_range_to_leave(kinova):
    """``range_reason``: past ±π on a continuous joint is no limit passed (§1d); the same
    excess on a joint with a range is, named with the amount (reference: the URDF limits
    read by hand from the model)."""
    from mpd_pin.motion.outcome import range_reason

    cont = np.flatnonzero(kinova.continuous_mask)
    ranged = np.flatnonzero(~kinova.continuous_mask)
    assert cont.size and ranged.size
    q = np.tile(0.5 * (kinova.lower_limits + kinova.upper_limits), (3, 1))
    q[1, cont[0]] = np.pi + 0.4
    assert range_reason(kinova, q) == ""
    j = int(ranged[0])
    q[2, j] = float(kinova.model.lowerPositionLimit[j]) - 0.02
    assert range_reason(kinova, q) == (f"joint {kinova.joint_names[j]!r} passes its lower "
                                       "limit by 0.02 rad (simulated)")
