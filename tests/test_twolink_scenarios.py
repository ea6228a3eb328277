"""End-to-end runs of the paper-002 scenarios env1 and env2, checked independently.

Every executed motion sample is re-checked here with plain numpy: the links are
segments base -> elbow -> end effector (forward kinematics written out below)
with radius 0.03 m (capsules), the obstacles discs; a sample is free when every
disc centre is farther than radius + 0.03 m from both segments.
"""

import copy
import json
import math
import tomllib
from importlib import resources

import numpy as np
import pytest

from mpd_pin.cli import main as cli_main
from mpd_pin.config import ConfigError
from mpd_pin.twolink.run import run_dynamic_scenario
from mpd_pin.twolink.scenario import parse_dynamic_scenario

LINK_RADIUS = 0.03


def _data(name):
    path = resources.files("mpd_pin") / "scenarios" / f"{name}.toml"
    return tomllib.loads(path.read_text())


def _segment_distance(c, a, b):
    ab = b - a
    t = np.clip(np.dot(c - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(c - (a + t * ab)))


def _fk(q, l1, l2):
    elbow = np.array([l1 * math.cos(q[0]), l1 * math.sin(q[0])])
    ee = elbow + np.array([l2 * math.cos(q[0] + q[1]), l2 * math.sin(q[0] + q[1])])
    return elbow, ee


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    d1 = tmp_path_factory.mktemp("env1")
    # env1 through the CLI (dispatch on kind = "dynamic2link"), env2 directly.
    assert cli_main(["run", "env1", "--out", str(d1), "--quiet"]) == 0
    out["env1"] = (json.loads((d1 / "result.json").read_text()), d1)
    d2 = tmp_path_factory.mktemp("env2")
    res = run_dynamic_scenario(_data("env2"), d2, show_progress=False)
    out["env2"] = (res, d2)
    assert json.loads((d2 / "result.json").read_text()) == res
    return out


@pytest.mark.parametrize("name", ["env1", "env2"])
def test_every_sample_is_collision_free(runs, name):
    res, _ = runs[name]
    l1, l2 = res["link_lengths"]
    assert (l1, l2) == (0.5, 0.5)
    worst = math.inf
    for s in res["samples"]:
        elbow, ee = _fk(s["q"], l1, l2)
        for ob in s["obstacles"]:
            c = np.array(ob["center"])
            d = min(_segment_distance(c, np.zeros(2), elbow), _segment_distance(c, elbow, ee))
            worst = min(worst, d - ob["radius"] - LINK_RADIUS)
    assert worst > 0.0, worst
    assert res["capsule_clearance"]["pso_samples"] == pytest.approx(worst, abs=1e-12)
    # Coal's clearance of the cylinder links keeps the scenario's margin.
    assert res["min_clearance"] > res["margin"]


@pytest.mark.parametrize("name", ["env1", "env2"])
def test_motion_reaches_the_goal_and_is_shorter(runs, name):
    res, out = runs[name]
    data = _data(name)
    samples = res["samples"]
    l1, l2 = res["link_lengths"]
    ts = data["motion"]["sample_time"]
    assert [s["t"] for s in samples] == pytest.approx([k * ts for k in range(len(samples))])
    ee = np.array([_fk(s["q"], l1, l2)[1] for s in samples])
    np.testing.assert_allclose(ee, [s["ee"] for s in samples], atol=1e-12)
    step = 0.05
    np.testing.assert_allclose(ee[0], data["task"]["start"], atol=step / 2)
    np.testing.assert_allclose(ee[-1], data["task"]["goal"], atol=step / 2)
    np.testing.assert_allclose(ee[-1], res["goal"], atol=1e-12)
    # The D* motion starts and ends at the same places.
    d = np.array([s["ee"] for s in res["dstar_samples"]])
    np.testing.assert_allclose(d[[0, -1]], ee[[0, -1]], atol=1e-12)
    # Path lengths, recomputed from the samples.
    L_pso = float(np.sum(np.linalg.norm(np.diff(ee, axis=0), axis=1)))
    L_d = float(np.sum(np.linalg.norm(np.diff(d, axis=0), axis=1)))
    assert res["path_length_pso"] == pytest.approx(L_pso, rel=1e-12)
    assert res["path_length_dstar"] == pytest.approx(L_d, rel=1e-12)
    assert res["path_length_pso"] <= res["path_length_dstar"]
    assert res["pso_improved"] and res["path_length_pso"] < 0.95 * res["path_length_dstar"]
    # Joint motion is continuous: no jump beyond max_joint_step between samples.
    q = np.array([s["q"] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() <= data["motion"]["max_joint_step"] + 1e-12
    # PSO cost curve: one value per iteration plus the initial swarm, never increasing.
    curve = [c for c in res["pso_cost_curve"] if c is not None]
    assert len(res["pso_cost_curve"]) == data["pso"]["iterations"] + 1
    assert np.all(np.diff(curve) <= 0) and curve[-1] == pytest.approx(res["path_length_pso"])
    for png in ("fcs.png", "paths.png", "dstar_motion.png", "pso_motion.png",
                "joint_angles.png", "joint_changes.png", "obstacles.png"):
        assert (out / png).stat().st_size > 10_000, png


def test_events(runs):
    ev1 = runs["env1"][0]["events"]
    kinds1 = [e["type"] for e in ev1]
    assert "stop" in kinds1 and "backward" in kinds1
    ev2 = runs["env2"][0]["events"]
    assert sum(e["type"] == "backward" for e in ev2) >= 2
    for res, _ in runs.values():
        n = len(res["dstar_samples"])
        for e in res["events"]:
            assert 1 <= e["sample"] < n
        state = [(tuple(s["ee"]), s["branch"]) for s in res["dstar_samples"]]
        for e in res["events"]:
            k = e["sample"]
            if e["type"] == "stop":
                assert state[k] == state[k - 1]
            elif e["type"] == "backward":
                assert state[k] != state[k - 1]


def test_env1_obstacle_follows_its_trajectory(runs):
    # Back and forth between x = -0.7 and 0.7 at z = 0.6, 3 m/s, starting at x = -0.7.
    res, _ = runs["env1"]
    for s in res["samples"]:
        t = s["t"]
        u = (3.0 * t) % 2.8
        x = -0.7 + (u if u <= 1.4 else 2.8 - u)
        (ob,) = s["obstacles"]
        assert ob["radius"] == 0.12
        np.testing.assert_allclose(ob["center"], [x, 0.6], atol=1e-12)


def test_env2_has_four_obstacles_two_on_squares():
    data = _data("env2")
    motions = [o["motion"] for o in data["obstacles"]]
    assert len(motions) == 4 and motions.count("square") == 2


def _bad(mutate):
    data = copy.deepcopy(_data("env1"))
    mutate(data)
    return data


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.update(colour="red"), "unknown key.*colour"),
        (lambda d: d["pso"].update(inertia=0.5), r"pso: unknown key.*inertia"),
        (lambda d: d["obstacles"][0].update(spin=1.0), r"obstacles\[0\]: unknown key.*spin"),
        (lambda d: d["obstacles"][0].update(motion="orbit"), "motion"),
        (lambda d: d["obstacles"][0].update(phase=1.5), "phase"),
        (lambda d: d["pso"].update(k=2.0), "pso.k"),
        (lambda d: d["task"].update(start_branch="left"), "start_branch"),
        (lambda d: d["grid"].update(step=-0.1), "grid.step"),
        (lambda d: d.update(kind="energy"), "kind"),
        (lambda d: d["arm"].update(builtin="planar_3link"), "two-link"),
        (lambda d: d["task"].pop("goal"), "task.goal: required"),
    ],
)
def test_bad_scenarios_raise_config_errors(mutate, match):
    with pytest.raises(ConfigError, match=match):
        parse_dynamic_scenario(_bad(mutate))


def test_start_in_collision_and_unreachable_goal(tmp_path):
    data = _bad(lambda d: d["task"].update(start=[-0.55, 0.55]))  # inside the disc at t = 0
    with pytest.raises(ValueError, match="start .* in collision at t = 0"):
        run_dynamic_scenario(data, tmp_path, show_progress=False, plots=False)
    data = _bad(lambda d: d["task"].update(goal=[0.95, 0.95]))
    with pytest.raises(ValueError, match="goal cell .* unreachable"):
        run_dynamic_scenario(data, tmp_path, show_progress=False, plots=False)
    assert not (tmp_path / "result.json").exists()


def test_cli_reports_bad_scenario_in_one_line(tmp_path, capsys):
    text = (resources.files("mpd_pin") / "scenarios" / "env1.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[task]", "[task]\nwobble = 1"))
    assert cli_main(["run", str(bad), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "wobble" in err


def test_degenerate_runs_write_valid_json(tmp_path):
    # Goal one cell away: two samples, nothing to smooth.
    res = run_dynamic_scenario(_bad(lambda d: d["task"].update(goal=[0.8, 0.1])), tmp_path,
                               show_progress=False, plots=False)
    assert res["num_samples"] == 2 and res["pso_cost_curve"] == []
    assert res["path_length_pso"] == res["path_length_dstar"] == pytest.approx(0.05)
    # No obstacles: clearances are reported as null, not as a non-JSON infinity.
    res = run_dynamic_scenario(_bad(lambda d: d.update(obstacles=[])), tmp_path,
                               show_progress=False, plots=False)
    assert res["min_clearance"] is None and res["events"] == []
    assert json.loads((tmp_path / "result.json").read_text())["num_samples"] == res["num_samples"]
