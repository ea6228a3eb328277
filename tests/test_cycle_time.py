"""The cycle time is the input (issue 32; docs/design.md §8a, §8b, §9f): ``max_duration``
on the command line and per query, no motion within it as a planning outcome (exit 3,
result.json with ``feasible`` false and the fastest motion found), bad values refused
before any work, and the drive's supply kept by ``EnergyPlanner`` (issue 35).

The references are :func:`mpd_pin.trajectory_energy` pricing the returned waypoints again
(with and without a cap, at and just below the duration reported as the fastest), and for
the supply the same scenario given as a TOML file with ``[supply]``.
"""

import re
from dataclasses import fields, replace

import numpy as np
import pytest
from conftest import read_result

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.planner import configure
from mpd_pin.app.scenario import builtin_scenarios
from mpd_pin.errors import MpdPinError

NODES = 40  # quickstart with a small roadmap: a few seconds per query


@pytest.fixture(scope="module")
def quick():
    """quickstart with a 40-node roadmap, and one planner for its queries (the roadmap is
    built by the first and reused by the others)."""
    scn = mp.load_scenario("quickstart")
    scn = replace(scn, options=replace(scn.options, num_nodes=NODES), motion=_plain(scn.motion))
    return scn, mp.EnergyPlanner.from_scenario(scn, show_progress=False)


def _plain(motion):
    """``motion`` without the whole-motion optimisation (``optimize``), so that a
    motion is its waypoints and :func:`mpd_pin.trajectory_energy` prices it again."""
    names = {f.name for f in fields(motion)}
    return replace(motion, optimize=False) if "optimize" in names else motion


@pytest.fixture(scope="module")
def free_plan(quick):
    scn, planner = quick
    return planner.plan(scn.start, scn.goal)


def _price(scn, W, execution, max_duration=None):
    return mp.trajectory_energy(scn.drive(), W, execution, options=scn.options,
                                checker=mp.CollisionChecker(scn.arm, scn.world),
                                max_duration=max_duration)


def test_max_duration_per_query_caps_the_motion(quick, free_plan):
    """``planner.plan(a, b, max_duration=D)``: a motion within D, priced as
    trajectory_energy prices its waypoints under the same cap, dearer than the same
    waypoints without it (a shorter motion costs more here), and the cap is for that query
    only."""
    scn, planner = quick
    free = free_plan
    D = 3.0
    assert free.motion.duration > D  # the cap binds: the free motion takes longer
    capped = planner.plan(scn.start, scn.goal, max_duration=D)
    m = capped.motion
    assert capped.feasible and capped.to_dict()["feasible"] is True
    assert "reason" not in capped.to_dict()
    assert m.feasible and m.duration <= D + 1e-9 and m.duration <= free.motion.duration
    again = _price(scn, capped.path, m.execution, max_duration=D)
    assert again.feasible and again.duration <= D + 1e-9
    assert again.total_energy == pytest.approx(capped.total_energy, rel=1e-9)
    uncapped = _price(scn, capped.path, m.execution)
    assert uncapped.duration > D and uncapped.total_energy < capped.total_energy
    # the per-query cap does not stay on the planner
    assert planner.scenario.motion.max_duration is None
    # motion.fastest_duration: a lower bound of what this geometry allows, within the cap
    fastest = capped.to_dict()["motion"]["fastest_duration"]
    assert fastest == capped.fastest_duration
    assert 0 < fastest <= m.duration + 1e-9
    assert fastest <= again.fastest + 1e-12  # the returned geometry is one of the candidates


def test_plan_takes_max_duration(quick, free_plan):
    """``mp.plan(scn, max_duration=D)`` (through :func:`configure`) caps the motion too."""
    scn, _ = quick
    D = 4.0
    plan = mp.plan(scn, max_duration=D, show_progress=False)
    assert plan.motion.duration <= D + 1e-9 < free_plan.motion.duration
    assert plan.total_energy > free_plan.total_energy  # a shorter motion costs more here
    assert configure(scn, max_duration=D).motion.max_duration == D


def test_no_motion_within_the_cap_raises_with_the_fastest_plan(quick):
    """Below the fastest motion: ``mp.NoMotionWithinDuration`` (an MpdPinError, not a
    ValueError) with ``.fastest`` and ``.plan``, the plan's result infeasible and its motion
    the fastest one found: feasible at that duration, not a little below it."""
    scn, planner = quick
    D = 1.2
    with pytest.raises(mp.NoMotionWithinDuration) as info:
        planner.plan(scn.start, scn.goal, max_duration=D)
    exc = info.value
    assert isinstance(exc, MpdPinError) and not isinstance(exc, ValueError)
    assert exc.max_duration == D and exc.fastest > D
    doc = exc.plan.to_dict()
    assert doc["feasible"] is False and not exc.plan.feasible
    assert doc["reason"] == str(exc)
    assert str(exc) == (f"no motion within max_duration {D:g} s: the fastest motion found "
                        f"takes {exc.fastest:.3f} s")
    motion = doc["motion"]
    assert motion["duration"] == exc.fastest and motion["feasible"] is False
    assert motion["fastest_duration"] == exc.fastest
    W = np.asarray(motion["waypoints"])
    at = _price(scn, W, motion["execution"], max_duration=exc.fastest)
    assert at.feasible and at.duration == pytest.approx(exc.fastest, abs=1e-9)
    assert at.total_energy == pytest.approx(motion["total_energy"], rel=1e-9)
    # nothing faster on these waypoints, stop-and-go or non-stop (the bisection's tolerance
    # is 0.01 s here)
    below = _price(scn, W, "auto", max_duration=exc.fastest - 0.05)
    assert not below.feasible and not below.alternative.feasible
    assert not _price(scn, W, motion["execution"], max_duration=D).feasible


def test_cli_no_motion_within_the_cap_exits_3_with_result_json(tmp_path, capsys):
    """``mpd-pin run --max-duration`` below the fastest motion: status 3, one line naming
    the fastest duration, which is result.json's motion duration (feasible false)."""
    out = tmp_path / "out"
    D = 1.2
    code = main(["run", "quickstart", "--out", str(out), "--nodes", str(NODES),
                 "--max-duration", str(D), "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert code == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    hit = re.match(rf"mpd-pin: no motion within max_duration {D:g} s: the fastest motion "
                   r"found takes ([0-9.]+) s", lines[0])
    assert hit, lines[0]
    fastest = float(hit.group(1))
    assert fastest > D
    result = read_result(out)
    assert result["feasible"] is False and result["reason"].startswith("no motion within")
    assert result["motion"]["feasible"] is False
    assert result["motion"]["duration"] == pytest.approx(fastest, abs=5e-4)
    assert result["total_energy"] == result["motion"]["total_energy"]
    assert "trajectory.csv" in result["outputs"]
    t = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, usecols=0)
    assert t[-1] == pytest.approx(result["motion"]["duration"], abs=1e-9)


@pytest.mark.parametrize("value", ["0", "nan", "-1", "abc", "inf", "-inf", "1e9"])
def test_cli_bad_max_duration_is_one_line_and_exit_2(tmp_path, capsys, value):
    out = tmp_path / "out"
    code = main(["run", "quickstart", "--out", str(out), f"--max-duration={value}",
                 "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("mpd-pin: error: --max-duration: ") and repr(value) in err
    assert not out.exists()


def test_cli_max_duration_is_for_energy_scenarios(tmp_path, capsys):
    code = main(["run", "env1", "--out", str(tmp_path / "o"), "--max-duration", "3",
                 "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "--max-duration does not apply to 'env1'" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value", [0, 0.0, -1.0, float("nan"), float("inf"), 1e9, "3", True,
                                   [2.0]])
def test_python_bad_max_duration_is_a_config_error_before_any_work(quick, value):
    scn, _ = quick
    planner = mp.EnergyPlanner.from_scenario(scn, show_progress=False)
    with pytest.raises(ConfigError, match=r"^max_duration: expected a number of seconds"):
        planner.plan(scn.start, scn.goal, max_duration=value)
    assert planner.roadmap is None  # nothing was built
    with pytest.raises(ConfigError, match=r"^max_duration: "):
        configure(scn, max_duration=value)


def _shared_toml(tmp_path):
    text = builtin_scenarios()["quickstart"].read_text(encoding="utf-8")
    assert "[supply]" not in text
    text = text.replace("[task]", '[supply]\nbus = "shared"\nregeneration = 0.6\n\n[task]', 1)
    path = tmp_path / "shared.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_energy_planner_keeps_the_drives_supply(tmp_path):
    """Issue 35: ``EnergyPlanner(Drive(..., supply=Supply("shared", 0.6)), world)`` plans
    for that bus, as the same scenario given as TOML with ``[supply]`` does (the roadmap
    path as it is: its costs are the bus's, docs/design.md §3i)."""
    scn = mp.load_scenario(_shared_toml(tmp_path))
    scn = replace(scn, options=replace(scn.options, num_nodes=NODES),
                  motion=replace(scn.motion, refine=False, execution="stop"))
    assert scn.supply == mp.Supply("shared", 0.6)
    ref = mp.plan(scn, show_progress=False)
    drive = scn.drive()
    assert drive.supply == mp.Supply("shared", 0.6)
    planner = mp.EnergyPlanner(drive, scn.world, roadmap=scn.options, motion=scn.motion,
                               evaluation=scn.evaluation, collision=scn.collision,
                               planner=scn.planner, show_progress=False)
    plan = planner.plan(scn.start, scn.goal)
    doc, ref_doc = plan.to_dict(), ref.to_dict()
    assert doc["supply"] == ref_doc["supply"] == {"bus": "shared", "regeneration": 0.6}
    assert plan.total_energy == pytest.approx(ref.total_energy, rel=1e-9)
    np.testing.assert_allclose(plan.path, ref.path, rtol=0, atol=1e-12)
    # priced on the bus: B⁺ − η B⁻, below the per-joint sum of E⁺
    assert doc["energy_by_supply"]["shared_regeneration"] == pytest.approx(plan.total_energy)
    assert plan.total_energy < doc["energy_by_supply"]["per_joint"]
