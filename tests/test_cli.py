"""The mpd-pin command: built-in scenarios end to end, result consistency, bad input."""

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker
from mpd_pin.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario
from mpd_pin.world import World

ENERGY_SCENARIOS = [n for n, p in builtin_scenarios().items()
                    if load_scenario_data(p).get("kind", "energy") == "energy"]


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "mpd_pin", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=900)


def test_scenarios_lists_all_builtins():
    res = run_cli("scenarios")
    assert res.returncode == 0, res.stderr
    names = [line.split()[0] for line in res.stdout.strip().splitlines()]
    assert names == list(builtin_scenarios())
    for expected in ("case1", "case2", "case3", "case4", "replan", "hazard", "panda"):
        assert expected in names


@pytest.mark.parametrize("name", ENERGY_SCENARIOS)
def test_builtin_energy_scenario_end_to_end(name, tmp_path):
    out = tmp_path / "out"
    res = run_cli("run", name, "--out", str(out), "--quiet")
    assert res.returncode == 0, res.stderr
    result = json.loads((out / "result.json").read_text())
    for fname in ("path.png", "joint_angles.png", "energy.png", "replay.html"):
        assert (out / fname).stat().st_size > 1000, fname
    scn = parse_energy_scenario(load_scenario_data(builtin_scenarios()[name]))
    drive = scn.drive()
    Q = np.array(result["path"]["configurations"])
    np.testing.assert_allclose(Q[0], scn.start, atol=1e-12)
    np.testing.assert_allclose(Q[-1], scn.goal, atol=1e-12)
    # Energies = sum over the path's edges, recomputed here with simulate_edge.
    opts = scn.options
    durations = opts.durations(Q[:-1], Q[1:])
    E = np.zeros(drive.nq)
    for k in range(len(Q) - 1):
        E += mp.simulate_edge(drive, Q[k], Q[k + 1], durations[k], opts.dt).energy
    np.testing.assert_allclose(result["energy_per_joint"], E, rtol=1e-8)
    assert result["total_energy"] == pytest.approx(E.sum(), rel=1e-8)
    assert result["path"]["length_nodes"] == len(Q)
    assert result["roadmap"]["num_nodes"] == opts.num_nodes + 2
    for phase in ("roadmap_edge_energies", "search", "verification", "total"):
        assert result["seconds_per_phase"][phase] >= 0
    # The path is collision-free against the full world (hidden obstacles included).
    world = World.from_dict({k: v for k, v in result["world"].items()})
    truth = CollisionChecker(scn.arm, world, include_hidden=True)
    for k in range(len(Q) - 1):
        assert truth.edge_free(Q[k], Q[k + 1], opts.resolution / 10), k
    if world.hidden_names() or result["world"]["revealed"]:
        assert result["execution"]["replans"], "a hidden obstacle must trigger a replan"
    if any(h["clearance"] > 0 for h in result["world"]["hazards"]):
        assert result["hazard_replanning"]["final_margin"] >= 0


def _write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(textwrap.dedent(text))
    return path


GOOD = """
    [arm]
    builtin = "planar_2link"
    [roadmap]
    num_nodes = 30
    k = 6
    duration = 0.5
    dt = 0.01
    [task]
    start = [0.3, 0.2]
    goal = [1.2, -0.4]
"""


def _assert_one_line_error(res, pattern):
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    assert pattern in lines[0], lines[0]


def test_small_custom_scenario_runs(tmp_path):
    res = run_cli("run", str(_write(tmp_path, GOOD)), "--out", str(tmp_path / "o"), "--quiet",
                  "--no-replay", "--seed", "4")
    assert res.returncode == 0, res.stderr
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert result["roadmap"]["options"]["seed"] == 4


@pytest.mark.parametrize(
    "text, pattern",
    [
        (GOOD.replace("[roadmap]", "[roadmap]\n    nodes = 3"), "roadmap: unknown key(s) 'nodes'"),
        (GOOD + "\n    colour = 'red'\n", "task: unknown key(s) 'colour'"),
        (GOOD.replace("num_nodes = 30", "num_nodes = 'many'"), "roadmap.num_nodes"),
        (GOOD + "\n    [[obstacles]]\n    type = 'box'\n    center = [0.6, 0.1]\n"
                "    width = 0.2\n    height = 0.2\n    wobble = 2\n",
         "obstacles[0]: unknown key(s) 'wobble'"),
        (GOOD + "\n    [[obstacles]]\n    type = 'box'\n    center = [0.6, 0.1]\n"
                "    width = -0.2\n    height = 0.2\n", "obstacles[0].width: must be > 0"),
        ("[arm\nbuiltin = 'x'", "malformed TOML"),
        (GOOD.replace("planar_2link", "planar_9link"), "arm.builtin"),
        (GOOD.replace("start = [0.3, 0.2]", "start = [0.3]"), "task.start: expected 2 numbers"),
        (GOOD.replace("dt = 0.01", "dt = 0.003"), "whole number"),
    ],
)
def test_bad_scenario_files(tmp_path, text, pattern):
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, pattern)


def test_unknown_scenario(tmp_path):
    _assert_one_line_error(run_cli("run", "case99", "--out", str(tmp_path)), "unknown scenario")


def test_start_in_collision(tmp_path):
    text = GOOD + """
    [[obstacles]]
    type = "cylinder"
    center = [0.45, 0.14]
    radius = 0.1
    """
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, "start [0.3, 0.2] is in collision")


def test_unreachable_goal(tmp_path):
    # The 2-link arm starts inside a tight horizontal tunnel it cannot turn out of.
    text = GOOD.replace("start = [0.3, 0.2]", "start = [0.0, 0.0]").replace(
        "goal = [1.2, -0.4]", "goal = [3.0, 0.0]") + """
    [[obstacles]]
    type = "box"
    center = [0.6, 0.1]
    width = 0.9
    height = 0.1
    [[obstacles]]
    type = "box"
    center = [0.6, -0.1]
    width = 0.9
    height = 0.1
    """
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    assert res.returncode == 3
    _assert_one_line_error(res, "no path")


def test_bad_urdf_path(tmp_path):
    text = GOOD.replace('builtin = "planar_2link"', 'urdf = "missing.urdf"')
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, "URDF file not found")


@pytest.mark.parametrize(
    "motor, line",
    [
        ('preset = "turbo"', "mpd-pin: error: motor.preset: 'turbo' is not one of "
                             "['paper', 'servo']"),
        ("R = 'one'", "mpd-pin: error: motor.R: expected a number, got 'one'"),
        ("R = 0.0", "mpd-pin: error: motor: DCMotor.R must be a finite number > 0, got 0.0"),
    ],
)
def test_motor_errors_have_one_prefix(tmp_path, motor, line):
    text = GOOD + f"\n    [motor]\n    {motor}\n"
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, line)
    assert res.stderr.strip() == line
