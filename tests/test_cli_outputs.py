"""What a new user reads: the paper-motor warning and the cached-roadmap note (console line
and result.json), ``mpd-pin show``, choosing the IK solution of start_ee/goal_ee by a seed
posture or an elbow side, and the out-of-reach distance (issue 17, points 1, 5 and 8)."""

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import read_result, run_cli
from scenario_texts import SMALL_2LINK

from mpd_pin.app.config import ConfigError
from mpd_pin.app.outputs import PAPER_MOTOR_SECTION
from mpd_pin.app.scenario import builtin_scenarios, parse_energy_scenario

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
LINKS_3 = np.array([0.5, 0.4, 0.3])  # planar_3link (mpd_pin/arm/builtin.py)

SMALL = SMALL_2LINK


def _headings(text):
    return {m.group(1).strip() for m in re.finditer(r"^#+ (.+)$", text, re.M)}


# ------------------------------------------------------------------ warnings and cache
@pytest.fixture(scope="module")
def cached_runs(tmp_path_factory):
    """SMALL (default motor: the paper's) run twice with one --cache file, then with
    ``preset = "sized"``: (process, result) each."""
    folder = tmp_path_factory.mktemp("cached")
    scn = folder / "s.toml"
    scn.write_text(SMALL)
    runs = []
    for k in range(2):
        res = run_cli("run", str(scn), "--out", str(folder / f"o{k}"), "--quiet", "--no-replay",
                      "--cache", str(folder / "roadmap"))
        assert res.returncode == 0, res.stderr
        runs.append((res, read_result(folder / f"o{k}")))
    sized = folder / "sized.toml"
    # (sized motors are stiff: a 5 ms step, docs/design.md §3e)
    sized.write_text(SMALL.replace("dt = 0.01", "dt = 0.005") + '\n[motor]\npreset = "sized"\n')
    res = run_cli("run", str(sized), "--out", str(folder / "o_sized"), "--quiet", "--no-replay")
    assert res.returncode == 0, res.stderr
    runs.append((res, read_result(folder / "o_sized")))
    return runs, folder


def test_paper_motor_warning_in_console_and_result(cached_runs):
    runs, _ = cached_runs
    (res, result), _, (res_sized, sized) = runs
    assert result["motor"]["Kt"] == 0.01 and result["motor"]["R"] == 1.0  # Table 7
    [warning] = result["warnings"]
    assert "Table 7" in warning and "10⁴–10⁵ J" in warning
    assert f'README.md section "{PAPER_MOTOR_SECTION}"' in warning
    assert PAPER_MOTOR_SECTION in _headings(README)  # the pointer leads somewhere
    lines = res.stdout.strip().splitlines()
    assert len(lines) == 1 and f"warning: {warning}" in lines[0]
    # realistic motors: no warning, and no warning on the console
    assert sized["warnings"] == [] and "warning" not in res_sized.stdout
    assert isinstance(sized["motor"], list) and sized["motor"][0]["Kt"] != 0.01


def test_reused_roadmap_reported(cached_runs):
    runs, folder = cached_runs
    (res0, first), (res1, second) = runs[0], runs[1]
    npz = str(folder / "roadmap.npz")
    assert first["roadmap"]["cache"] == {"path": npz, "reused": False}
    assert second["roadmap"]["cache"] == {"path": npz, "reused": True}
    assert f"(saved to {npz})" in res0.stdout and f"(reused from {npz})" in res1.stdout
    assert first["roadmap"]["key"] == second["roadmap"]["key"]
    assert second["total_energy"] == first["total_energy"]
    # without --cache: no file, not reused
    assert runs[2][1]["roadmap"]["cache"] == {"path": None, "reused": False}


# ------------------------------------------------------------------ mpd-pin show
def test_show_prints_the_builtin_toml():
    res = run_cli("show", "quickstart")
    assert res.returncode == 0, res.stderr
    path = builtin_scenarios()["quickstart"]
    assert res.stdout == path.read_text(encoding="utf-8")
    assert tomllib.loads(res.stdout)["motor"]["preset"] == "sized"


def test_show_unknown_name_lists_the_names():
    res = run_cli("show", "case99")
    assert res.returncode == 2 and res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "unknown built-in scenario 'case99'" in lines[0]
    assert all(name in lines[0] for name in builtin_scenarios())


# ------------------------------------------------------------------ IK choice
def _task(**task):
    data = tomllib.loads(SMALL.replace("planar_2link", "planar_3link"))
    data["task"] = task
    return parse_energy_scenario(data)


def _fk(q):
    """Planar forward kinematics by hand: joint origins and the end effector (x, z), m."""
    c = np.cumsum(q)
    pts = np.cumsum(np.stack([LINKS_3 * np.cos(c), LINKS_3 * np.sin(c)], axis=1), axis=0)
    return np.vstack([[0.0, 0.0], pts])


def _side(q, target):
    """'up' if the elbow (end of link 1) is above the line through the shoulder (the
    origin) and the target: higher z than the line at the elbow's x."""
    elbow = _fk(q)[1]
    return "up" if elbow[1] > target[1] / target[0] * elbow[0] else "down"


@pytest.mark.parametrize("elbow", ["up", "down"])
def test_elbow_chooses_the_ik_branch(elbow):
    start, goal = np.array([0.6, 0.3]), np.array([-0.5, 0.5])
    scn = _task(start_ee=start.tolist(), goal_ee=goal.tolist(), elbow=elbow)
    for q, target in ((scn.start, start), (scn.goal, goal)):
        np.testing.assert_allclose(_fk(q)[-1], target, atol=1e-6)
        assert _side(q, target) == elbow


def test_seed_posture_returns_the_nearest_solution():
    target = [0.6, 0.3]
    seed = np.array([1.5, -2.0, 0.0])
    plain = _task(start_ee=target, goal=[0.0, 0.0, 0.0]).start
    seeded = _task(start_ee=target, start_seed=seed.tolist(), goal=[0.0, 0.0, 0.0]).start
    np.testing.assert_allclose(_fk(seeded)[-1], target, atol=1e-6)
    assert np.linalg.norm(seeded - seed) < np.linalg.norm(plain - seed)
    # a solution in the seed's neighbourhood: the redundant arm's self-motion through it
    assert np.linalg.norm(seeded - seed) < 0.5


@pytest.mark.parametrize("task, line", [
    ({"start": [0.1, 0.2, 0.3], "start_seed": [0.0, 0.0, 0.0], "goal": [0.0, 0.0, 0.0]},
     "task.start_seed: a seed posture is for start_ee"),
    ({"start": [0.1, 0.2, 0.3], "goal": [0.0, 0.0, 0.0], "elbow": "up"},
     "task.elbow: chooses the IK solution of start_ee/goal_ee"),
    ({"start_ee": [0.6, 0.3], "goal": [0.0, 0.0, 0.0], "elbow": "sideways"},
     "task.elbow: 'sideways' is not one of"),
    ({"start_ee": [0.6, 0.3], "start_seed": [0.0, 9.0, 0.0], "goal": [0.0, 0.0, 0.0]},
     "task.start_seed"),
    ({"start_ee": [0.6, 0.3], "goal": [0.0, 0.0, 0.0], "elbow_joint": "joint2"},
     "task.elbow_joint: give elbow"),
])
def test_bad_ik_choice_keys(task, line):
    with pytest.raises(ConfigError, match=re.escape(line)):
        _task(**task)


@pytest.mark.parametrize("goal", [[3.0, 0.0], [-3.0, 0.0], [0.0, 3.0], [2.1213, 2.1213]])
def test_out_of_reach_reports_the_distance_to_the_workspace(tmp_path, goal):
    """3 m from the shoulder with a 1.2 m reach: 1.8 m beyond reach, in every direction."""
    text = SMALL.replace("planar_2link", "planar_3link").replace(
        "start = [0.3, 0.2]", "start = [0.3, 0.2, 0.1]").replace(
        "goal = [1.2, -0.4]", f"goal_ee = {goal}")
    (tmp_path / "s.toml").write_text(text)
    res = run_cli("run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o"), "--quiet")
    assert res.returncode == 2
    [line] = res.stderr.strip().splitlines()
    expected = np.hypot(*goal) - LINKS_3.sum()  # the workspace is the 1.2 m disc
    m = re.search(r"out of reach of frame 'ee': ([0-9.]+) m beyond reach", line)
    assert m, line
    assert float(m.group(1)) == pytest.approx(expected, abs=0.01)
