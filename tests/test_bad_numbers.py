"""Absurd and non-finite scenario numbers are refused where they are read (docs/design.md §7b).

Every bad value below goes through the command (``mpd-pin run FILE --out DIR``, in-process
with stdout/stderr captured at the file descriptors and warnings shown as a fresh interpreter
shows them: tests/conftest.py ``run_cli``): exit status 2, exactly one line on stderr naming
the key (no numpy RuntimeWarning before it), and nothing written. Valid extreme-but-physical
values, the bounds themselves and every built-in scenario still parse.
"""

import copy
import math
import re

import numpy as np
import pytest
from conftest import run_cli

from mpd_pin.app import cli
from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.limits import BOUNDS, arm_reach, workspace_bound
from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data
from mpd_pin.arm.builtin import builtin_arm

NAN, INF = math.nan, math.inf


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


def to_toml(data, prefix=""):
    """A minimal TOML writer for scenario dicts (scalars, arrays, tables, arrays of tables)."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v, False))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v, True))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    for k, v, many in tables:
        name = f"{prefix}{k}"
        for sub in (v if many else [v]):
            lines.append(f"\n[[{name}]]" if many else f"\n[{name}]")
            lines.append(to_toml(sub, prefix=f"{name}."))
    return "\n".join(lines)


def builtin(name):
    return copy.deepcopy(load_scenario_data(builtin_scenarios()[name]))


def _set(path, value):
    """A mutation setting the dotted ``path`` (list indices as integers) to ``value``."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]

    def apply(data):
        node = data
        for k in keys[:-1]:
            node = node.setdefault(k, {}) if isinstance(k, str) else node[k]
        node[keys[-1]] = value
        return data
    return apply


def _swap(section, key_out, key_in, value):
    def apply(data):
        data[section].pop(key_out, None)
        data[section][key_in] = value
        return data
    return apply


def _with(*mutations):
    def apply(data):
        for m in mutations:
            data = m(data)
        return data
    return apply


def _motors_tables(data):
    data.pop("motor")
    data["motors"] = [{"preset": "paper", "J": 1e308}, {"preset": "paper"}, {"preset": "paper"}]
    return data


def _motors_tables_kt(kt):
    def apply(data):
        data.pop("motor")
        data["motors"] = [{"preset": "paper", "gear_ratio": 9.0} for _ in range(3)]
        data["motors"][1]["Kt"] = kt
        return data
    return apply


def _static_disc(data):
    data["obstacles"] = [{"name": "c", "radius": 0.1, "motion": "static", "center": [NAN, 0.5]}]
    return data


def _polyline(point):
    def apply(data):
        data["obstacles"] = [{"radius": 0.1, "motion": "polyline", "speed": 1.0,
                              "points": [[0.0, 0.5], point]}]
        return data
    return apply


# (base scenario, mutation, the key that stderr must name and what it must say)
BAD = {
    # ---- energy scenarios: the three cases of the issue first
    "goal_ee 1e308": ("case1", _set("task.goal_ee", [1e308, 0.55]),
                      "task.goal_ee x = 1e+308 m is outside the workspace bound of ±12 m"),
    "hazard vertex nan": ("hazard", _set("hazards.0.vertices", [[0.4, -0.55], [NAN, -0.55],
                                                                [0.55, -0.3]]),
                          "hazards[0].vertices[1] x = nan is not a finite number"),
    "start_ee inf": ("case1", _set("task.start_ee", [0.42, -INF]), "task.start_ee z = -inf"),
    "goal_ee 3-D huge": ("panda", _with(_swap("task", "goal", "goal_ee", [0.5, 1e200, 0.5])),
                         "task.goal_ee y = 1e+200 m is outside the workspace bound"),
    "start angle nan": ("case1", _swap("task", "start_ee", "start", [0.6, NAN, 0.2]),
                        "task.start[1] = nan is not a finite number"),
    "goal angle 1e308": ("case1", _swap("task", "goal_ee", "goal", [1e308, 0.0, 0.0]),
                         "task.goal[0] = 1e+308 is outside the limits of joint"),
    "box center nan": ("case1", _set("obstacles.0.center", [NAN, 0.75]),
                       "obstacles[0].center x = nan"),
    "box center 1e308": ("case1", _set("obstacles.0.center", [0.0, 1e308]),
                         "obstacles[0].center z = 1e+308 m is outside the workspace bound"),
    "box width 1e308": ("case1", _set("obstacles.0.width", 1e308),
                        "obstacles[0].width = 1e+308 m is outside the size range (0, 24] m"),
    "box height inf": ("case1", _set("obstacles.0.height", INF), "obstacles[0].height = inf"),
    "box angle 1e308": ("case1", _set("obstacles.0.angle", 1e308),
                        "obstacles[0].angle = 1e+308 rad is outside the angle bound"),
    "box depth nan": ("case1", _set("obstacles.0.depth", NAN), "obstacles[0].depth = nan"),
    "3-D size nan": ("panda", _set("obstacles.0.size", [0.8, NAN, 0.04]),
                     "obstacles[0].size y = nan"),
    "3-D position 1e308": ("panda", _set("obstacles.1.position", [1e308, 0.0, 0.25]),
                           "obstacles[1].position x = 1e+308 m"),
    "3-D rpy inf": ("panda", _set("obstacles.2.rpy", [INF, 0.0, 0.0]),
                    "obstacles[2].rpy roll = inf"),
    "cylinder radius 1e308": ("case1", _set("obstacles.0", {"type": "cylinder",
                                                            "center": [0.0, 0.75],
                                                            "radius": 1e308}),
                              "obstacles[0].radius = 1e+308 m"),
    "sphere position nan": ("case1", _set("obstacles.0", {"type": "sphere", "radius": 0.1,
                                                          "position": [0.0, 0.0, NAN]}),
                            "obstacles[0].position z = nan"),
    "clearance 1e308": ("hazard", _set("hazards.0.clearance", 1e308),
                        "hazards[0].clearance = 1e+308 m is outside the size range"),
    "sensor range nan": ("replan", _set("sensor.range", NAN), "sensor.range"),
    "motor R per joint 1e308": ("case1", _set("motor.R", [1.0, 1e308, 1.0]),
                                "motor.R[1] = 1e+308 Ω is outside the motor resistance range"),
    "motor Kt nan": ("case1", _set("motor.Kt", NAN), "motor.Kt"),
    "motor Ke per joint inf": ("case1", _set("motor.Ke", [0.02, 0.02, INF]), "motor.Ke[2] = inf"),
    "motor gear 1e308": ("case1", _set("motor.gear_ratio", 1e308),
                         "motor.gear_ratio = 1e+308 is outside the gear ratio range"),
    "motor L 1e308": ("panda", _set("motor.L", 1e308), "motor.L = 1e+308 H"),
    "motor v_max inf": ("panda", _set("motor.v_max", INF), "motor.v_max"),
    "motors table J": ("case1", _motors_tables, "motors[0].J = 1e+308 kg·m²"),
    # negative or NaN motor constants of one joint name that joint (issue 12)
    "motor R negative per joint": ("case1", _set("motor.R", [1.0, -1.0, 1.0]),
                                   "motor.R[1] = -1 Ω is outside the motor resistance range"
                                   " [1e-06, 10000] Ω (joint 'joint2')"),
    "motor B nan per joint": ("case1", _set("motor.B", [0.1, 0.1, NAN]),
                              "motor.B[2] = nan is not a finite number"),
    "motor B nan names joint": ("case1", _set("motor.B", [0.1, 0.1, NAN]), "(joint 'joint3')"),
    "motor Kt negative": ("case1", _set("motor.Kt", -0.01),
                          "motor.Kt = -0.01 N·m/A is outside the torque constant range"),
    "motors table Kt negative": ("case1", _motors_tables_kt(-0.01),
                                 "motors[1].Kt = -0.01 N·m/A is outside the torque constant "
                                 "range [1e-06, 100] N·m/A (joint 'joint2')"),
    # a motor too weak to hold the arm at the start (stall torque n·Kt·V_max/R)
    "weak motor at start": ("case1", _set("motor.v_max", 1.0),
                            "task.start: the motor of joint 'joint1' is too weak to hold the arm"
                            " there: gravity needs "),
    "holding above effort limit": ("ur5", _set("limits", {"shoulder_lift_joint": {"effort": 10.0}}),
                                   "task.start: holding the arm there needs 23.25 N·m at joint "
                                   "'shoulder_lift_joint', above its effort limit of 10 N·m"),
    "limits unknown joint": ("ur5", _set("limits", {"elbow": {"effort": 10.0}}),
                             "limits.elbow: the arm has no movable joint 'elbow'"),
    "limits velocity nan": ("ur5", _set("limits", {"elbow_joint": {"velocity": NAN}}),
                            "limits.elbow_joint.velocity = nan is not a finite number"),
    "limits effort negative": ("ur5", _set("limits", {"elbow_joint": {"effort": -5.0}}),
                               "limits.elbow_joint.effort = -5 N·m is outside the joint effort "
                               "limit range (0, 100000] N·m"),
    "limits unknown key": ("ur5", _set("limits", {"elbow_joint": {"speed": 1.0}}),
                           "limits.elbow_joint"),
    "kp per joint nan": ("case1", _set("controller.kp", [40.0, NAN, 40.0]),
                         "controller.kp[1] = nan"),
    "kd 1e308": ("case1", _set("controller.kd", 1e308),
                 "controller.kd = 1e+308 V·s/rad is outside the gain range"),
    "dt 1e-300": ("case1", _set("roadmap.dt", 1e-300), "roadmap.dt = 1e-300 s is outside"),
    "duration nan": ("case1", _set("roadmap.duration", NAN), "roadmap.duration"),
    "joint_speed 1e308": ("case1", _set("roadmap.joint_speed", 1e308), "roadmap.joint_speed"),
    "hazard_penalty nan": ("hazard", _set("planner.hazard_penalty", NAN),
                           "planner.hazard_penalty = nan"),
    "hazard_penalty -inf": ("hazard", _set("planner.hazard_penalty", -INF),
                            "planner.hazard_penalty = -inf"),
    "hazard_penalty 1e308": ("hazard", _set("planner.hazard_penalty", 1e308),
                             "planner.hazard_penalty = 1e+308 is outside the penalty range"),
    # ---- dynamic2link scenarios (paper 002)
    "disc centre nan": ("env1", _static_disc, "obstacles[0].center x = nan"),
    "sweep end 1e308": ("env1", _set("obstacles.0.b", [1e308, 0.6]),
                        "obstacles[0].b x = 1e+308 m is outside the workspace bound of ±10 m"),
    "speed 1e308": ("env1", _set("obstacles.0.speed", 1e308),
                    "obstacles[0].speed = 1e+308 m/s is outside the obstacle speed range"),
    "radius inf": ("env1", _set("obstacles.0.radius", INF), "obstacles[0].radius = inf"),
    "delay 1e308": ("env1", _set("obstacles.0.delay", 1e308), "obstacles[0].delay = 1e+308 s"),
    "square side 1e308": ("env2", _set("obstacles.0.side", 1e308),
                          "obstacles[0].side = 1e+308 m"),
    "square centre inf": ("env2", _set("obstacles.1.center", [0.0, INF]),
                          "obstacles[1].center z = inf"),
    "straight start nan": ("env2", _set("obstacles.3.start", [NAN, -0.2]),
                           "obstacles[3].start x = nan"),
    "polyline point 1e308": ("env1", _polyline([1e308, 0.5]), "obstacles[0].points[1] x = 1e+308"),
    "polyline point nan": ("env1", _polyline([0.5, NAN]), "obstacles[0].points[1] z = nan"),
    "task start nan": ("env1", _set("task.start", [NAN, 0.1]), "task.start x = nan"),
    "task goal 1e308": ("env1", _set("task.goal", [0.0, 1e308]), "task.goal z = 1e+308 m"),
    "grid x 1e308": ("env1", _set("grid.x", [-1e308, 1.0]), "grid.x min = -1e+308 m"),
    "grid step nan": ("env1", _set("grid.step", NAN), "grid.step = nan"),
    "grid step 1e308": ("env1", _set("grid.step", 1e308), "grid.step = 1e+308 m"),
    "sample_time 1e-300": ("env1", _set("motion.sample_time", 1e-300), "motion.sample_time"),
    "margin nan": ("env1", _set("motion.margin", NAN), "motion.margin = nan"),
    "max_joint_step 1e308": ("env1", _set("motion.max_joint_step", 1e308),
                             "motion.max_joint_step = 1e+308 rad"),
    "switch_penalty inf": ("env1", _set("motion.switch_penalty", INF), "motion.switch_penalty"),
    "max_samples huge": ("env1", _set("motion.max_samples", 10**15), "motion.max_samples"),
    "pso c1 1e308": ("env1", _set("pso.c1", 1e308), "pso.c1 = 1e+308 is outside"),
    "pso w nan": ("env1", _set("pso.w", NAN), "pso.w = nan"),
    "pso k inf": ("env1", _set("pso.k", INF), "pso.k"),
    "pso particles huge": ("env1", _set("pso.particles", 10**12), "pso.particles"),
    "pso via_points huge": ("env1", _set("pso.via_points", 10**9), "pso.via_points"),
    "plots sample huge": ("env1", _set("plots.fcs_samples", [0, 10**15]), "plots.fcs_samples"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_number_is_one_line_exit_2(case, tmp_path):
    base, mutate, expected = BAD[case]
    path = tmp_path / "bad.toml"
    path.write_text(to_toml(mutate(builtin(base))))
    out = tmp_path / "out"
    res = run_cli("run", path, "--out", out, "--quiet")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("mpd-pin: error: "), lines[0]
    assert expected in lines[0], lines[0]
    assert "closest inf" not in lines[0]
    assert not out.exists() or not any(out.iterdir())


def test_writer_round_trips_builtins(tmp_path):
    """The test's TOML writer reproduces every built-in scenario (so the cases above differ
    from a built-in only by their mutation)."""
    import tomllib

    for name in builtin_scenarios():
        assert tomllib.loads(to_toml(builtin(name))) == builtin(name)


@pytest.mark.parametrize("name", list(builtin_scenarios()))
def test_builtin_scenarios_parse(name):
    scn = load_scenario(name)
    assert scn.name == name


def test_workspace_bound_from_the_arm():
    """Reach = the sum of the joint offsets + the largest frame offset: 2 × 0.5 m for the
    planar two-link arm; its frames never get farther than that (brute force)."""
    arm = builtin_arm("planar_2link")
    assert arm_reach(arm) == pytest.approx(1.0)
    assert workspace_bound(arm) == 10.0
    rng = np.random.default_rng(0)
    for arm_name in ("planar_2link", "planar_3link", "planar_7link"):
        arm = builtin_arm(arm_name)
        far = max(np.linalg.norm(arm.frame_position(q, f.name))
                  for q in rng.uniform(arm.lower_limits, arm.upper_limits, (50, arm.nq))
                  for f in arm.model.frames)
        assert far <= arm_reach(arm) + 1e-12


def _parse(data, tmp_path):
    path = tmp_path / "ok.toml"
    path.write_text(to_toml(data))
    return load_scenario(str(path))


def test_extreme_but_physical_values_pass(tmp_path):
    data = builtin("case1")
    data["obstacles"].append({"type": "box", "name": "far", "center": [11.9, -11.9],
                              "width": 24.0, "height": 0.1, "angle": -2 * math.pi})
    data["motor"].update(R=[1e-6, 1e4, 1.0], gear_ratio=1e5, Kt=100.0, B=0.0, J=0.0)
    data["controller"] = {"kp": [0.0, 1e6, 40.0], "kd": 1e6}
    data["roadmap"]["dt"] = 1e-4
    scn = _parse(data, tmp_path)
    assert [m.R for m in scn.motor] == [1e-6, 1e4, 1.0]
    assert scn.world.obstacles[-1].name == "far"
    assert scn.kp == [0.0, 1e6, 40.0]
    hz = builtin("hazard")
    hz["planner"] = {"hazard_penalty": INF}
    assert _parse(hz, tmp_path).hazard_penalty == INF
    hz["planner"] = {"hazard_penalty": 1e12}
    assert _parse(hz, tmp_path).hazard_penalty == 1e12
    env = builtin("env1")
    env["obstacles"][0].update(speed=1e3, b=[10.0, -10.0], delay=1e5)
    env["pso"].update(c1=10.0, w=0.0)
    scn = _parse(env, tmp_path)
    assert scn.problem.pso.c1 == 10.0


def test_value_just_past_the_bound_is_refused(tmp_path):
    data = builtin("case1")
    data["motor"]["R"] = BOUNDS["R"].hi * (1 + 1e-12)
    with pytest.raises(ConfigError, match=r"^motor\.R = 10000 Ω is outside"):
        _parse(data, tmp_path)
    data = builtin("case1")
    data["obstacles"][0]["center"] = [12.0 + 1e-9, 0.0]
    with pytest.raises(ConfigError, match=r"obstacles\[0\]\.center x"):
        _parse(data, tmp_path)


def test_cli_turns_floating_point_warnings_into_the_internal_error_line(monkeypatch, capsys):
    """A numerical problem that slipped through validation ends as one internal-error line
    (exit 1), not a RuntimeWarning followed by a misleading message."""

    def overflowing(_args):
        return int(np.float64(1e308) * np.float64(10.0))

    monkeypatch.setattr(cli, "cmd_scenarios", overflowing)
    status = cli.main(["scenarios"])
    err = capsys.readouterr().err.splitlines()
    assert status == 1
    assert err == ["mpd-pin: internal error: FloatingPointError: overflow encountered in "
                   "scalar multiply"]


def test_local_divergence_detection_still_works_under_the_cli_errstate():
    """simulate_edge's own np.errstate lets a diverging simulation report itself as a
    ValueError (the CLI's one-line error), not a FloatingPointError."""
    import mpd_pin as mp
    from mpd_pin.dynamics.simulate import simulate_edge

    drive = mp.Drive(builtin_arm("planar_2link"), mp.PAPER_MOTOR, 1e6, 0.0)
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        with pytest.raises(ValueError, match="integration diverged"):
            simulate_edge(drive, np.zeros(2), np.array([1.0, -1.0]), 1.0, 0.05)


# ---------------------------------------------------------------- [limits] and weak motors
HAND_URDF = """<robot name="hand">
<link name="base"/>
<link name="l1"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
<inertia ixx="0.001" iyy="0.021" izz="0.021" ixy="0" ixz="0" iyz="0"/></inertial>
<collision><origin xyz="0.25 0 0" rpy="0 1.5708 0"/>
<geometry><cylinder radius="0.03" length="0.4"/></geometry></collision></link>
<link name="l2"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
<inertia ixx="0.001" iyy="0.021" izz="0.021" ixy="0" ixz="0" iyz="0"/></inertial>
<collision><origin xyz="0.25 0 0" rpy="0 1.5708 0"/>
<geometry><cylinder radius="0.03" length="0.4"/></geometry></collision></link>
<joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/>
<axis xyz="0 -1 0"/><limit lower="-3.1" upper="3.1"/></joint>
<joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
<axis xyz="0 -1 0"/><limit lower="-3.1" upper="3.1" effort="0" velocity="0"/></joint>
</robot>
"""


def _hand_scenario(tmp_path, limits=None, roadmap=None, v_max=24.0, goal=(0.0, 0.0)):
    (tmp_path / "hand.urdf").write_text(HAND_URDF)
    data = {
        "name": "hand",
        "arm": {"urdf": "hand.urdf"},
        "motor": {"preset": "servo", "v_max": v_max},
        "controller": {"kp": 40.0, "kd": 1.0},
        "roadmap": {"num_nodes": 12, "k": 4, "seed": 0, "duration": 0.5, **(roadmap or {})},
        "task": {"start": [-1.5707963267948966, 0.0], "goal": list(goal)},
    }
    if limits is not None:
        data["limits"] = limits
    path = tmp_path / "hand.toml"
    path.write_text(to_toml(data))
    return path


def _run_cli(path, tmp_path):
    res = run_cli("run", path, "--out", tmp_path / "out", "--quiet")
    return res.returncode, res.stderr.splitlines()


def test_missing_urdf_limits_are_refused_unless_the_scenario_gives_them(tmp_path):
    """A hand-written URDF without effort/velocity (shoulder) or with zeros (elbow): one
    line naming the joint and the [limits] entry to add; the table fills them."""
    code, lines = _run_cli(_hand_scenario(tmp_path), tmp_path)
    assert code == 2 and len(lines) == 1, lines
    assert lines[0] == ("mpd-pin: error: arm: joint 'shoulder' has no velocity limit in its "
                        "URDF (0 rad/s); add it to the scenario: [limits] shoulder = "
                        "{ velocity = ... } (rad/s)")
    code, lines = _run_cli(_hand_scenario(tmp_path, {"shoulder": {"velocity": 2.0,
                                                                  "effort": 30.0}}), tmp_path)
    assert code == 2 and len(lines) == 1 and "joint 'elbow' has no velocity limit" in lines[0]
    code, lines = _run_cli(_hand_scenario(tmp_path, {"shoulder": {"velocity": 2.0},
                                                     "elbow": {"velocity": 3.0, "effort": 20.0}}),
                           tmp_path)
    assert code == 2 and len(lines) == 1 and "joint 'shoulder' has no effort limit" in lines[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    # without the rules that need them, zero limits are not refused
    scn = load_scenario(str(_hand_scenario(tmp_path, roadmap={"velocity_limits": False,
                                                              "effort_limits": False})))
    assert scn.arm.model.velocityLimit.tolist() == [0.0, 0.0]


def test_limits_table_fills_and_overrides_urdf_limits(tmp_path):
    from mpd_pin.app.plan import prepare

    limits = {"shoulder": {"velocity": 1.5, "effort": 30.0}, "elbow": {"velocity": 2.5,
                                                                        "effort": 20.0}}
    scn = load_scenario(str(_hand_scenario(tmp_path, limits)))
    np.testing.assert_array_equal(scn.arm.model.velocityLimit, [1.5, 2.5])
    np.testing.assert_array_equal(scn.arm.model.effortLimit, [30.0, 20.0])
    setup = prepare(scn, show_progress=False)
    rm = setup.roadmap
    assert rm.num_edges > 0
    dq = np.abs(rm.nodes[rm.dst] - rm.nodes[rm.src])
    need = np.max(1.875 * dq / np.array([1.5, 2.5]), axis=1)  # quintic peak ≤ the limit
    assert np.all(rm.durations >= need - 1e-12)
    assert rm.edge_counts["lengthened_for_velocity"] > 0
    # an override of a URDF's own limit (the planar arms state 10 rad/s, 100 N·m)
    data = builtin("case1")
    data["limits"] = {"joint2": {"velocity": 0.5}}
    scn = _parse(data, tmp_path)
    np.testing.assert_array_equal(scn.arm.model.velocityLimit, [10.0, 0.5, 10.0])
    np.testing.assert_array_equal(scn.arm.model.effortLimit, [100.0, 100.0, 100.0])
    assert scn.arm.fingerprint() != builtin_arm("planar_3link").fingerprint()


def test_weak_motor_refused_against_hand_gravity(tmp_path):
    """Gravity of the horizontal 2-link arm by hand: G₁ = g·(m₁·l₁/2 + m₂·(l₁ + l₂/2)) =
    9.81 N·m; the servo's stall torque n·Kt·V/R = 100·0.03·V/2 = 1.5·V N·m."""
    g1 = 9.81 * (1.0 * 0.25 + 1.0 * 0.75)
    limits = {"shoulder": {"velocity": 1.5, "effort": 30.0}, "elbow": {"velocity": 2.5,
                                                                        "effort": 20.0}}
    v_weak = 0.99 * g1 / 1.5
    code, lines = _run_cli(_hand_scenario(tmp_path, limits, v_max=v_weak), tmp_path)
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(
        f"mpd-pin: error: task.goal: the motor of joint 'shoulder' is too weak to hold the arm "
        f"there: gravity needs {g1:.4g} N·m, its stall torque n·Kt·V_max/R is "
        f"{1.5 * v_weak:.4g} N·m"), lines[0]
    # a little stronger: it parses (the start, hanging down, needs no torque at all)
    scn = load_scenario(str(_hand_scenario(tmp_path, limits, v_max=1.01 * g1 / 1.5)))
    assert np.abs(scn.arm.gravity(scn.goal))[0] == pytest.approx(g1, rel=1e-12)


@pytest.mark.parametrize("evaluation", ["eager", "lazy"])
def test_no_path_message_counts_refused_edges(tmp_path, evaluation):
    """Edges too fast for the motors are refused (they do not arrive, or need more torque
    than the effort limit); when no path is left the message counts them by reason. Eager:
    the counts of the whole roadmap; lazy: of the edges it simulated, out of the same
    collision-free edges."""
    from mpd_pin.app.plan import prepare

    limits = {"shoulder": {"velocity": 1.5, "effort": 30.0}, "elbow": {"velocity": 2.5,
                                                                        "effort": 20.0}}
    fast = {"velocity_limits": False, "duration": 0.1, "dt": 0.001, "evaluation": "eager"}
    path = _hand_scenario(tmp_path, limits, roadmap=fast, goal=(1.0, 0.5))
    rm = prepare(load_scenario(str(path)), show_progress=False).roadmap  # the whole build
    counts = rm.edge_counts
    refused = counts["refused_effort"] + counts["refused_arrival"]
    assert refused > 0
    total = rm.num_edges + refused  # the collision-free directed edges
    if evaluation == "lazy":
        fast["evaluation"] = "lazy"
        path = _hand_scenario(tmp_path, limits, roadmap=fast, goal=(1.0, 0.5))
    code, lines = _run_cli(path, tmp_path)
    assert code == 3 and len(lines) == 1, lines
    assert lines[0].startswith("mpd-pin: no path: ")
    if evaluation == "lazy":
        m = re.search(r"the roadmap refused (\d+) of its (\d+) collision-free directed edges "
                      r"\(lazy evaluation simulated (\d+) of them\): ", lines[0])
        assert m, lines[0]
        k, n, simulated = map(int, m.groups())
        assert n == total and 0 < k <= min(refused, simulated) and simulated <= total
        assert "because the motor torque" in lines[0] or "ended more than" in lines[0]
    else:
        assert (f"the roadmap refused {refused} of its {total} collision-free "
                "directed edges: ") in lines[0]
        if counts["refused_effort"]:
            assert f"{counts['refused_effort']} because the motor torque" in lines[0]
        if counts["refused_arrival"]:
            assert (f"{counts['refused_arrival']} because the simulated motion ended more "
                    "than 0.01 rad from its end node") in lines[0]
    assert 'preset = "sized"' in lines[0] and "longer edges" in lines[0]
