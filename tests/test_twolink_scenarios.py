"""End-to-end runs of the paper-002 scenarios env1 and env2, checked independently.

Every executed motion sample is re-checked here with plain numpy: the links are
segments base -> elbow -> end effector (forward kinematics written out below)
with radius 0.03 m (capsules), the obstacles discs whose centres are recomputed
from the scenario TOML's trajectory definitions by the code below (not read
from result.json); a sample is free when every disc centre is farther than
radius + 0.03 m from both segments. Between samples the joints are
interpolated linearly and the discs put where their trajectories have them at
that instant. Joint velocity limits are read from the URDF here.
"""

import copy
import json
import math
import tomllib
import xml.etree.ElementTree as ET
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from conftest import run_once

from mpd_pin.app.cli import main as cli_main
from mpd_pin.app.config import ConfigError
from mpd_pin.twolink.run import run_dynamic_scenario
from mpd_pin.twolink.scenario import parse_dynamic_scenario

LINK_RADIUS = 0.03
URDF = Path(__file__).resolve().parents[1] / "robots" / "planar_2link.urdf"
BETWEEN = 20  # instants per sample interval for the between-samples checks


def _data(name):
    path = resources.files("mpd_pin") / "scenarios" / f"{name}.toml"
    return tomllib.loads(path.read_text())


def _segment_distance(c, a, b):
    """Distance from points c (..., 2) to segments a-b (..., 2), broadcast."""
    ab = b - a
    t = np.clip(np.sum((c - a) * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
    return np.linalg.norm(c - (a + t[..., None] * ab), axis=-1)


def _fk(q, l1, l2):
    q = np.asarray(q, dtype=float)
    elbow = np.stack([l1 * np.cos(q[..., 0]), l1 * np.sin(q[..., 0])], axis=-1)
    a = q[..., 0] + q[..., 1]
    ee = elbow + np.stack([l2 * np.cos(a), l2 * np.sin(a)], axis=-1)
    return elbow, ee


def _along(points, s):
    """Point at arc length s along the polyline ``points`` (s clipped to its length)."""
    for p0, p1 in zip(points[:-1], points[1:], strict=True):
        seg = math.dist(p0, p1)
        if s <= seg:
            return np.asarray(p0) + (s / seg) * (np.asarray(p1) - np.asarray(p0))
        s -= seg
    return np.asarray(points[-1], dtype=float)


def _reference_center(ob, t):
    """Disc centre at time t (s) from one [[obstacles]] table of a scenario TOML."""
    motion = ob["motion"]
    if motion == "static":
        return np.asarray(ob["center"], dtype=float)
    v = ob["speed"]
    run = v * max(t - ob.get("delay", 0.0), 0.0)
    if motion == "straight":
        a, b = ob["start"], ob["end"]
        return _along([a, b], min(run, math.dist(a, b)))
    if motion == "back_and_forth":
        a, b = ob["a"], ob["b"]
        L = math.dist(a, b)
        u = (run + ob.get("phase", 0.0) * 2 * L) % (2 * L)
        return _along([a, b], u if u <= L else 2 * L - u)
    assert motion == "square", motion
    (cx, cz), h = ob["center"], ob["side"] / 2
    bl, br, tr, tl = (cx - h, cz - h), (cx + h, cz - h), (cx + h, cz + h), (cx - h, cz + h)
    loop = [bl, tl, tr, br, bl] if ob.get("clockwise", False) else [bl, br, tr, tl, bl]
    u = (run + ob.get("phase", 0.0) * 4 * ob["side"]) % (4 * ob["side"])
    return _along(loop, u)


def _reference_scene(data, times):
    """Centres (T, n_obs, 2) and radii (n_obs,) at ``times`` from the TOML definitions."""
    obs = data["obstacles"]
    c = np.array([[_reference_center(ob, float(t)) for ob in obs] for t in times])
    return c.reshape(len(times), len(obs), 2), np.array([ob["radius"] for ob in obs])


def _capsule_clearance(q, centers, radii, l1, l2):
    """(T, n_obs) clearance of the capsule links at joint angles q (T, 2) to the discs."""
    elbow, ee = _fk(q, l1, l2)
    e, p = elbow[:, None, :], ee[:, None, :]
    d = np.minimum(_segment_distance(centers, np.zeros_like(e), e),
                   _segment_distance(centers, e, p))
    return d - radii[None, :] - LINK_RADIUS


def _between(q, ts, n):
    """Joint angles and times at the n-1 instants inside each sample interval."""
    q = np.asarray(q, dtype=float)
    f = np.arange(1, n) / n
    qq = q[:-1, None, :] + f[None, :, None] * (q[1:] - q[:-1])[:, None, :]
    t = (np.arange(len(q) - 1)[:, None] + f[None, :]) * ts
    return qq.reshape(-1, 2), t.ravel()


def _urdf_velocity_limits():
    root = ET.parse(URDF).getroot()
    return [float(j.find("limit").get("velocity")) for j in root.iter("joint")
            if j.get("type") == "revolute"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    # env1 through the CLI (dispatch on kind = "dynamic2link"; the run is shared with
    # tests/test_schema.py: conftest.run_once), env2 directly.
    res1, d1 = run_once(tmp_path_factory, "env1", "--quiet")
    assert res1.returncode == 0, res1.stderr
    out["env1"] = (json.loads((d1 / "result.json").read_text()), d1)
    d2 = tmp_path_factory.mktemp("env2")
    res = run_dynamic_scenario(_data("env2"), d2, show_progress=False)
    out["env2"] = (res, d2)
    assert json.loads((d2 / "result.json").read_text()) == res
    return out


@pytest.mark.parametrize("name", ["env1", "env2"])
def test_every_sample_is_collision_free(runs, name):
    res, _ = runs[name]
    data = _data(name)
    l1, l2 = res["link_lengths"]
    assert (l1, l2) == (0.5, 0.5)
    ts = data["motion"]["sample_time"]
    samples = res["samples"]
    # The obstacles, recomputed from the TOML (env2: two squares, a shuttle, a crossing).
    centers, radii = _reference_scene(data, [k * ts for k in range(len(samples))])
    for k, s in enumerate(samples):  # what result.json reports is where they really are
        np.testing.assert_allclose([o["center"] for o in s["obstacles"]], centers[k], atol=1e-12)
        assert [o["radius"] for o in s["obstacles"]] == radii.tolist()
    q = np.array([s["q"] for s in samples])
    worst = _capsule_clearance(q, centers, radii, l1, l2).min()
    assert worst > 0.0, worst
    assert res["capsule_clearance"]["pso_samples"] == pytest.approx(worst, abs=1e-12)
    # The D* motion too (its samples carry no obstacles: recomputed above for its length).
    qd = np.array([s["q"] for s in res["dstar_samples"]])
    cd, _ = _reference_scene(data, [k * ts for k in range(len(qd))])
    worst_d = _capsule_clearance(qd, cd, radii, l1, l2).min()
    assert worst_d > 0.0, worst_d
    assert res["capsule_clearance"]["dstar_samples"] == pytest.approx(worst_d, abs=1e-12)
    # Coal's clearance of the cylinder links keeps the scenario's margin.
    assert res["min_clearance"] > res["margin"]


@pytest.mark.parametrize("name", ["env1", "env2"])
@pytest.mark.parametrize("motion", ["pso", "dstar"])
def test_clearance_between_samples(runs, name, motion):
    res, _ = runs[name]
    data = _data(name)
    l1, l2 = res["link_lengths"]
    ts = data["motion"]["sample_time"]
    q = np.array([s["q"] for s in res["samples" if motion == "pso" else "dstar_samples"]])
    qq, t = _between(q, ts, BETWEEN)
    centers, radii = _reference_scene(data, t)
    clear = _capsule_clearance(qq, centers, radii, l1, l2)
    assert clear.min() >= 0.0, clear.min()
    cap = res["capsule_clearance"]
    assert cap["substeps"] == BETWEEN
    assert cap[f"{motion}_between_samples"] == pytest.approx(clear.min(), abs=1e-12)
    # A bound for every instant, not only these: over 1/BETWEEN of a sample a link point
    # moves at most (l1 + l2)|dq1| + l2|dq2| and a disc at most speed * dt; the clearance
    # is 1-Lipschitz in both, so it cannot dip below (c_a + c_b - L) / 2 in between.
    qa, ta = _between(q, ts, BETWEEN)
    qall = np.concatenate([q[:-1, None, :], qa.reshape(len(q) - 1, BETWEEN - 1, 2)], axis=1)
    qall = np.vstack([qall.reshape(-1, 2), q[-1:]])
    tall = np.arange(len(qall)) * ts / BETWEEN
    c_all = _capsule_clearance(qall, _reference_scene(data, tall)[0], radii, l1, l2)
    dq = np.abs(np.diff(qall, axis=0))
    speeds = np.array([ob["speed"] if ob["motion"] != "static" else 0.0
                       for ob in data["obstacles"]])
    L = ((l1 + l2) * dq[:, 0] + l2 * dq[:, 1])[:, None] + speeds * ts / BETWEEN
    ca, cb = c_all[:-1], c_all[1:]
    bound = np.where(np.abs(ca - cb) <= L, (ca + cb - L) / 2, np.minimum(ca, cb)).min()
    assert bound >= 0.0, bound
    assert cap[f"{motion}_certified_between"] == pytest.approx(bound, abs=1e-12)


@pytest.mark.parametrize("name", ["env1", "env2"])
def test_joint_speeds_within_the_urdf_limits(runs, name):
    res, _ = runs[name]
    ts = _data(name)["motion"]["sample_time"]
    vmax = _urdf_velocity_limits()
    assert vmax == [10.0, 10.0] and res["velocity_limits"] == vmax
    # No max_joint_step in the scenario: the step limit is velocity limit x Ts.
    assert "max_joint_step" not in _data(name)["motion"]
    assert res["max_joint_step"] == pytest.approx(min(vmax) * ts, rel=1e-15)
    assert res["max_joint_step_source"].startswith("arm velocity limits")
    for key, motion in (("samples", "pso"), ("dstar_samples", "dstar")):
        q = np.array([s["q"] for s in res[key]])
        speed = np.abs(np.diff(q, axis=0)).max(axis=0) / ts
        np.testing.assert_allclose(res["peak_joint_speed"][motion], speed, rtol=1e-12)
        assert np.all(speed <= np.array(vmax) * (1 + 1e-12)), (motion, speed)


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
    step = data["grid"]["step"]
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
    # Joint motion is continuous: no jump beyond max_joint_step between samples, and on one
    # elbow branch throughout (module docstring of grid_dstar: no switch fits 0.1 rad).
    q = np.array([s["q"] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() <= res["max_joint_step"] + 1e-12
    assert {s["branch"] for s in samples} == {data["task"]["start_branch"]}
    assert {s["branch"] for s in res["dstar_samples"]} == {data["task"]["start_branch"]}
    # PSO cost curve: one value per iteration plus the initial swarm, never increasing.
    curve = [c for c in res["pso_cost_curve"] if c is not None]
    assert len(res["pso_cost_curve"]) == data["pso"]["iterations"] + 1
    assert np.all(np.diff(curve) <= 0) and curve[-1] == pytest.approx(res["path_length_pso"])
    for png in ("fcs.png", "paths.png", "dstar_motion.png", "pso_motion.png",
                "joint_angles.png", "joint_changes.png", "obstacles.png"):
        assert (out / png).stat().st_size > 10_000, png


@pytest.mark.parametrize("name", ["env1", "env2"])
def test_events(runs, name):
    res, _ = runs[name]
    kinds = [e["type"] for e in res["events"]]
    # Both scenarios exercise both of the paper's extra cases, and never switch the elbow.
    assert "stop" in kinds and "backward" in kinds and "switch" not in kinds
    assert res["event_counts"] == {k: kinds.count(k) for k in ("stop", "backward", "switch")}
    n = len(res["dstar_samples"])
    state = [(tuple(s["ee"]), s["branch"]) for s in res["dstar_samples"]]
    goal = np.array(res["goal"])
    for e in res["events"]:
        k = e["sample"]
        assert 1 <= k < n
        if e["type"] == "stop":
            assert state[k] == state[k - 1]
        elif e["type"] == "backward":
            assert state[k] != state[k - 1]
            np.testing.assert_allclose(e["from"], state[k - 1][0], atol=1e-12)
            np.testing.assert_allclose(e["cell"], state[k][0], atol=1e-12)
            # A retreat: the arm ends no closer to the goal than it was (in these scenarios a
            # free cell not closer to the goal always exists; test_twolink_dstar checks the
            # rule where it may not).
            d0, d1 = (float(np.linalg.norm(np.array(p) - goal)) for p in (e["from"], e["cell"]))
            assert e["retreat"] is True and d1 >= d0 - 1e-9, e
            assert e["goal_distance"] == pytest.approx([d0, d1], abs=1e-12)


def test_env1_obstacle_follows_its_trajectory(runs):
    # Back and forth between x = -0.7 and 0.7 at z = 0.6, 3 m/s, starting at x = -0.7
    # (written out by hand, a check of _reference_center too).
    res, _ = runs["env1"]
    for s in res["samples"]:
        t = s["t"]
        u = (3.0 * t) % 2.8
        x = -0.7 + (u if u <= 1.4 else 2.8 - u)
        (ob,) = s["obstacles"]
        assert ob["radius"] == 0.12
        np.testing.assert_allclose(ob["center"], [x, 0.6], atol=1e-12)
        np.testing.assert_allclose(_reference_center(_data("env1")["obstacles"][0], t), [x, 0.6],
                                   atol=1e-12)


def test_env2_has_four_obstacles_two_on_squares(runs):
    data = _data("env2")
    motions = [o["motion"] for o in data["obstacles"]]
    assert len(motions) == 4 and motions.count("square") == 2
    # Close to the links: every disc comes within 5 cm of the (capsule) arm during the motion.
    res, _ = runs["env2"]
    l1, l2 = res["link_lengths"]
    ts = data["motion"]["sample_time"]
    q = np.array([s["q"] for s in res["dstar_samples"]])
    centers, radii = _reference_scene(data, [k * ts for k in range(len(q))])
    assert np.all(_capsule_clearance(q, centers, radii, l1, l2).min(axis=0) < 0.05)


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
        (lambda d: d["motion"].update(substeps=0), "motion.substeps"),
        (lambda d: d["motion"].update(max_joint_step=-0.1), "motion.max_joint_step"),
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
    res = run_dynamic_scenario(_bad(lambda d: d["task"].update(goal=[0.775, 0.1])), tmp_path,
                               show_progress=False, plots=False)
    assert res["num_samples"] == 2 and res["pso_cost_curve"] == []
    assert res["path_length_pso"] == res["path_length_dstar"] == pytest.approx(0.025)
    assert res["capsule_clearance"]["pso_certified_between"] > 0
    # No obstacles: clearances are reported as null, not as a non-JSON infinity.
    res = run_dynamic_scenario(_bad(lambda d: d.update(obstacles=[])), tmp_path,
                               show_progress=False, plots=False)
    assert res["min_clearance"] is None and res["events"] == []
    assert json.loads((tmp_path / "result.json").read_text())["num_samples"] == res["num_samples"]


def test_joint_step_limit_from_velocity_limits_or_override():
    prob = parse_dynamic_scenario(_data("env1")).problem
    assert prob.max_joint_step is None and prob.substeps == 4
    assert prob.joint_step_limit == pytest.approx(min(_urdf_velocity_limits()) * 0.01)
    prob = parse_dynamic_scenario(_bad(lambda d: d["motion"].update(max_joint_step=0.3))).problem
    assert prob.joint_step_limit == 0.3
    # An arm without usable velocity limits needs an explicit max_joint_step.
    from mpd_pin import builtin_arm
    from mpd_pin.twolink.planner import DynamicProblem

    arm = builtin_arm("planar_2link")
    arm.model.velocityLimit = np.zeros(2)
    kw = dict(scene=prob.scene, grid=prob.grid, start=prob.start, goal=prob.goal)
    with pytest.raises(ValueError, match="velocity limits"):
        DynamicProblem(arm, **kw)
    assert DynamicProblem(arm, max_joint_step=0.2, **kw).joint_step_limit == 0.2
