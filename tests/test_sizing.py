"""Motors sized from the URDF limits (the ``sized`` preset, docs/design.md §3g)."""

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.dynamics.sizing import MOTOR_FRAMES, sized_motor, sized_motors


@pytest.mark.parametrize("name", ["panda", "ur5", "so100", "kinova"])
def test_sized_motors_cover_the_urdf_limits_and_follow_an_edge(name):
    arm = mp.Arm.from_example_robot_data(name)
    motors = sized_motors(arm)
    effort, velocity = arm.model.effortLimit, arm.model.velocityLimit
    frames = {round(f.km, 6): f for f in MOTOR_FRAMES}
    for k, m in enumerate(motors):
        frame = frames[round(m.Kt / np.sqrt(m.R), 6)]  # the winding keeps the frame's Km
        assert m.gear_ratio * frame.torque >= effort[k] * (1 - 1e-12)
        assert m.v_max / m.Ke >= 1.25 * m.gear_ratio * velocity[k] * (1 - 1e-12)
        assert m.Kt == m.Ke and m.L / m.R == pytest.approx(frame.tau_e)
    drive = mp.Drive(arm, motors, kp=20.0, kd=1.0, feedforward=True)
    q0 = arm.q_reference
    q1 = np.clip(q0 + 0.4, arm.lower_limits, arm.upper_limits)
    T = float(np.ceil(np.max(1.875 * np.abs(q1 - q0) / velocity) / 0.25) * 0.25)
    sim = mp.simulate_edge(drive, q0, q1, max(T, 0.5), 5e-3)
    assert np.abs(sim.q[-1] - q1).max() < 1e-3  # the motion arrives at its node
    assert np.all(sim.energy >= 0) and sim.energy.sum() > 0


def test_sized_motor_refuses_missing_limits_and_impossible_efforts():
    with pytest.raises(ValueError, match="effort limit is 0"):
        sized_motor(0.0, 2.0, what="joint 'j'")
    with pytest.raises(ValueError, match="velocity limit is inf"):
        sized_motor(10.0, float("inf"))
    with pytest.raises(ValueError, match="needs more than 400:1"):
        sized_motor(1e4, 1.0)
    with pytest.raises(ValueError, match="'sized' motor preset needs"):
        sized_motors(mp.Arm.from_example_robot_data("double_pendulum"))


def _scenario(motor_toml: str):
    import tomllib

    from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario

    data = load_scenario_data(builtin_scenarios()["panda"])
    data["motor"] = tomllib.loads(motor_toml)
    return parse_energy_scenario(data, source="test", base_dir=None)


def test_scenario_preset_sized_gives_the_sized_motors_with_overrides():
    scn = _scenario('preset = "sized"')
    assert scn.motor == sized_motors(scn.arm)
    scn = _scenario('preset = "sized"\nv_max = 48.0\nB = [0, 0, 0, 0, 1e-5, 1e-5, 1e-5]')
    ref = sized_motors(scn.arm, supply_voltage=48.0)
    assert [m.gear_ratio for m in scn.motor] == [m.gear_ratio for m in ref]
    assert [m.Kt for m in scn.motor] == [m.Kt for m in ref]
    assert [m.B for m in scn.motor] == [0.0] * 4 + [1e-5] * 3


def test_scenario_preset_sized_errors_name_the_key():
    from mpd_pin.app.config import ConfigError

    with pytest.raises(ConfigError, match=r"motor\.v_max"):
        _scenario('preset = "sized"\nv_max = -1.0')
    with pytest.raises(ConfigError, match="preset"):
        _scenario('preset = "sizzled"')
