"""Batched edge energies (abaInParallel) against the one-edge reference integrator."""

import numpy as np
import pytest

import mpd_pin as mp

PANDA_MOTOR = mp.DCMotor(R=1.0, L=0.01, Kt=0.1, Ke=0.1, B=1e-4, J=1e-4, gear_ratio=50.0)


def _random_edges(arm, rng, k, scale):
    lo, hi = arm.lower_limits, arm.upper_limits
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    Q0 = mid + half * rng.uniform(-0.8, 0.8, (k, arm.nq))
    Q1 = np.clip(Q0 + rng.normal(0.0, scale, (k, arm.nq)), lo, hi)
    return Q0, Q1


CASES = {
    "3link-ff": ("planar_3link", mp.PAPER_MOTOR.with_gear_ratio(5.0), 40.0, 4.0, True, 1.0, 5e-3),
    "3link-pd-saturated": (
        "planar_3link",
        mp.DCMotor(R=1.0, L=0.5, Kt=0.01, Ke=0.02, B=0.1, J=0.01, gear_ratio=5.0, v_max=30.0),
        40.0, 4.0, False, 1.0, 5e-3,
    ),
    "3link-servo-stiff-saturated": (  # L/R = 0.5 ms at dt = 5 ms: exponential current step
        "planar_3link", mp.DCMotor(**{**mp.SERVO_MOTOR.__dict__, "v_max": 6.0}), 200.0, 10.0, True,
        1.0, 5e-3,
    ),
    "panda-ff-saturated": (
        "panda", mp.DCMotor(**{**PANDA_MOTOR.__dict__, "v_max": 12.0}), 20.0, 1.0, True, 1.0, 5e-3
    ),
}


@pytest.fixture(scope="module")
def arms():
    return {"planar_3link": mp.builtin_arm("planar_3link"),
            "panda": mp.Arm.from_example_robot_data("panda")}


@pytest.mark.parametrize("case", sorted(CASES))
def test_batch_equals_single_edge(arms, case):
    arm_name, motor, kp, kd, ff, T, dt = CASES[case]
    arm = arms[arm_name]
    drive = mp.Drive(arm, motor, kp=kp, kd=kd, feedforward=ff)
    rng = np.random.default_rng(len(case))
    K = 50  # >= 50 random edges per arm and case (issue: foundation)
    Q0, Q1 = _random_edges(arm, rng, K, 0.5)
    Ep, En = mp.edge_energies(drive, Q0, Q1, T, dt, net=True, chunk=7)
    saturated = False
    for k in range(K):
        sim = mp.simulate_edge(drive, Q0[k], Q1[k], T, dt)
        np.testing.assert_allclose(Ep[k], sim.energy, rtol=1e-8, atol=1e-12 * sim.energy.max())
        np.testing.assert_allclose(En[k], sim.net_energy, rtol=1e-8,
                                   atol=1e-10 * np.abs(sim.net_energy).max())
        saturated |= bool(np.any(np.abs(sim.V) >= motor.v_max - 1e-12)) if motor.v_max else False
    if motor.v_max is not None:
        assert saturated, "the saturated case must actually saturate"
    assert np.all(Ep >= 0)


def test_per_edge_durations_grouped(arms):
    arm = arms["planar_3link"]
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    rng = np.random.default_rng(3)
    Q0, Q1 = _random_edges(arm, rng, 6, 0.4)
    T = np.array([0.5, 1.0, 0.5, 0.75, 1.0, 0.5])
    E = mp.edge_energies(drive, Q0, Q1, T, 5e-3)
    for k in range(6):
        np.testing.assert_allclose(E[k], mp.simulate_edge(drive, Q0[k], Q1[k], T[k], 5e-3).energy,
                                   rtol=1e-8)


def test_ideal_batch_equals_single(arms):
    arm = arms["planar_3link"]
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    Q0, Q1 = _random_edges(arm, np.random.default_rng(5), 8, 0.5)
    E = mp.ideal_edge_energies(drive, Q0, Q1, 1.0, 5e-3)
    for k in range(8):
        np.testing.assert_allclose(E[k], mp.ideal_edge_energy(drive, Q0[k], Q1[k], 1.0, 5e-3),
                                   rtol=1e-10)


def test_zero_length_edge_costs_holding_energy(arms):
    """A move from q to q keeps the holding current: E⁺ = R i² T per joint exactly (to RK4)."""
    arm = arms["planar_3link"]
    motor = mp.PAPER_MOTOR.with_gear_ratio(5.0)
    drive = mp.Drive(arm, motor, kp=40.0, kd=4.0)
    q = np.array([0.3, -0.2, 0.5])
    i_hold = arm.gravity(q) / (motor.gear_ratio * motor.Kt)
    E = mp.edge_energies(drive, q[None], q[None], 1.0, 5e-3)[0]
    np.testing.assert_allclose(E, motor.R * i_hold**2 * 1.0, rtol=1e-10)


def test_batch_bad_input(arms):
    drive = mp.Drive(arms["planar_3link"], mp.PAPER_MOTOR, kp=1.0, kd=0.1)
    with pytest.raises(ValueError, match="shape"):
        mp.edge_energies(drive, np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        mp.edge_energies(drive, np.full((1, 3), np.nan), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="whole number"):
        mp.edge_energies(drive, np.zeros((1, 3)), np.ones((1, 3)), 1.0, 0.003)
    with pytest.raises(ValueError, match="one value per edge"):
        mp.edge_energies(drive, np.zeros((2, 3)), np.ones((2, 3)), [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="motors"):
        mp.Drive(arms["planar_3link"], [mp.PAPER_MOTOR] * 2, kp=1.0, kd=0.1)
    with pytest.raises(ValueError, match="kp"):
        mp.Drive(arms["planar_3link"], mp.PAPER_MOTOR, kp=[1.0, 2.0], kd=0.1)


@pytest.mark.parametrize("case", ["3link-pd-saturated", "3link-servo-stiff-saturated"])
def test_edge_outcomes_equal_the_single_edge_series(arms, case):
    """End error, end velocity and peak joint torque of the batch equal those read off
    simulate_edge's time series (q(T) − q¹, q̇(T), max |n Kt i| over the samples)."""
    arm_name, motor, kp, kd, ff, T, dt = CASES[case]
    drive = mp.Drive(arms[arm_name], motor, kp=kp, kd=kd, feedforward=ff)
    Q0, Q1 = _random_edges(arms[arm_name], np.random.default_rng(5), 6, 0.6)
    out = mp.dynamics.edge_outcomes(drive, Q0, Q1, T, dt, chunk=4)
    np.testing.assert_array_equal(out.energy, mp.edge_energies(drive, Q0, Q1, T, dt))
    for k in range(len(Q0)):
        sim = mp.simulate_edge(drive, Q0[k], Q1[k], T, dt)
        np.testing.assert_allclose(out.end_error[k], sim.q[-1] - Q1[k], rtol=1e-7, atol=1e-10)
        np.testing.assert_allclose(out.end_velocity[k], sim.v[-1], rtol=1e-7, atol=1e-9)
        peak = np.abs(sim.i).max(axis=0) * drive.torque_per_amp
        np.testing.assert_allclose(out.peak_torque[k], peak, rtol=1e-8)
    if "pd-saturated" in case:  # PD alone behind a saturated supply lags: it does not arrive
        assert np.abs(out.end_error).max() > 0.01
