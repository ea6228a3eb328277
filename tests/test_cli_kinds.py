"""Scenario kinds through the CLI: one [arm] loader for both kinds, the kind registry,
``mpd-pin run --planner``."""

import json
import shutil
from importlib import resources
from pathlib import Path

import pytest
from conftest import run_cli
from scenario_texts import SMALL_2LINK

from mpd_pin.app.cli import main as cli_main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import KINDS, load_scenario
from mpd_pin.app.scenario import EnergyScenario, builtin_scenarios
from mpd_pin.search import PLANNERS
from mpd_pin.twolink.scenario import DynamicScenario

ROBOTS = Path(__file__).resolve().parents[1] / "robots"

ENERGY = SMALL_2LINK
DYNAMIC = (resources.files("mpd_pin") / "scenarios" / "env1.toml").read_text()
ARM_LINE = 'builtin = "planar_2link"'


def _scenario(folder: Path, text: str, arm: str, name: str = "s") -> Path:
    assert ARM_LINE in text
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text.replace(ARM_LINE, arm, 1))
    return path


def _one_line_error(res) -> str:
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    return lines[0]


BAD_URDFS = {
    "missing": None,
    "truncated": '<robot name="x"><link name="a">\n',
    "not_xml": "not xml at all",
    # Well-formed XML that urdfdom rejects, with its reasons on the C++ stderr.
    "no_limits": '<robot name="x"><link name="a"/><link name="b"/><joint name="j" '
                 'type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>'
                 "</joint></robot>",
}


@pytest.mark.parametrize("case", list(BAD_URDFS))
def test_bad_urdf_same_one_line_error_for_both_kinds(tmp_path, case):
    """A missing or malformed URDF: exit 2, one stderr line, the same line for both kinds."""
    if BAD_URDFS[case] is not None:
        (tmp_path / "arm.urdf").write_text(BAD_URDFS[case])
    lines = {}
    for kind, text in (("energy", ENERGY), ("dynamic2link", DYNAMIC)):
        scn = _scenario(tmp_path / "scenarios", text, 'urdf = "../arm.urdf"', kind)
        res = run_cli("run", str(scn), "--out", str(tmp_path / f"out_{kind}"), "--quiet")
        lines[kind] = _one_line_error(res)
    assert lines["energy"] == lines["dynamic2link"]
    path = tmp_path / "scenarios" / ".." / "arm.urdf"
    expected = {
        "missing": "URDF file not found",
        "truncated": f"malformed URDF XML in {path}: Premature end of data in tag link",
        "not_xml": f"malformed URDF XML in {path}: Start tag expected, '<' not found",
        "no_limits": "(urdfdom: Joint [j] is of type REVOLUTE but it does not specify limits; "
                     "joint xml is not initialized correctly)",
    }[case]
    assert lines["energy"].startswith("mpd-pin: error: ")
    assert expected in lines["energy"], lines["energy"]


def test_dynamic_urdf_relative_to_the_scenario_file(tmp_path, monkeypatch):
    shutil.copy(ROBOTS / "planar_2link.urdf", tmp_path / "arm.urdf")
    path = _scenario(tmp_path / "scn", DYNAMIC, 'urdf = "../arm.urdf"')
    monkeypatch.chdir(ROBOTS.parent)  # not where the scenario is
    scn = load_scenario(str(path))
    assert isinstance(scn, DynamicScenario)
    assert scn.problem.arm.nq == 2


def test_dynamic_arm_sources_are_exclusive(tmp_path):
    path = _scenario(tmp_path, DYNAMIC, ARM_LINE + '\nurdf = "arm.urdf"')
    with pytest.raises(ConfigError, match="arm: give exactly one of builtin, urdf, "
                                          "example_robot_data"):
        load_scenario(str(path))


def test_load_scenario_returns_the_kind_of_every_builtin():
    assert set(KINDS) == {"energy", "dynamic2link"}
    types = {"energy": EnergyScenario, "dynamic2link": DynamicScenario}
    for name in ("case1", "env1", "env2"):
        scn = load_scenario(name)
        assert isinstance(scn, types[scn.kind]) and scn.name == name
    assert load_scenario("env1", seed=7).seed == 7
    assert load_scenario("case1", seed=7).options.seed == 7
    assert load_scenario("case1", planner="astar").planner == "astar"
    assert set(builtin_scenarios()) >= {"case1", "env1", "env2"}


def test_planner_override_same_energy_as_mpdstar(tmp_path, case1_cached):
    """Dijkstra and MPD* Lite both find the minimum-energy path on the same roadmap: MPD*
    Lite is the default planner of the session's shared case1 run (conftest.case1_cached),
    ``--planner dijkstra`` runs on a copy of its roadmap file."""
    _, mpdstar_out, shared_cache = case1_cached
    cache = tmp_path / "roadmap.npz"
    shutil.copyfile(shared_cache, cache)
    results = {"mpdstar": json.loads((mpdstar_out / "result.json").read_text())}
    out = tmp_path / "dijkstra"
    status = cli_main(["run", "case1", "--out", str(out), "--quiet", "--no-replay",
                       "--cache", str(cache), "--planner", "dijkstra"])
    assert status == 0
    results["dijkstra"] = json.loads((out / "result.json").read_text())
    assert results["dijkstra"]["roadmap"]["cache"] == {"path": str(cache), "reused": True}
    assert results["dijkstra"]["planner"] == "dijkstra"
    assert results["mpdstar"]["planner"] == "mpdstar"
    assert results["dijkstra"]["total_energy"] == results["mpdstar"]["total_energy"]


def test_planner_refused_for_dynamic_scenarios(tmp_path, capsys):
    assert cli_main(["run", "env1", "--out", str(tmp_path / "o"), "--planner", "dijkstra",
                     "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("mpd-pin: error: planner: 'dijkstra' does not apply to 'env1', "
                          "a dynamic2link scenario")
    assert not (tmp_path / "o").exists()


def test_unknown_planner_and_help_lists_planners(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli_main(["run", "case1", "--out", str(tmp_path), "--planner", "bogus"])
    assert exc.value.code == 2
    assert "invalid choice: 'bogus'" in capsys.readouterr().err
    with pytest.raises(ConfigError, match="planner: 'bogus' is not one of"):
        load_scenario("case1", planner="bogus")
    with pytest.raises(SystemExit):
        cli_main(["run", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    for name, cls in PLANNERS.items():
        assert f"{name} ({cls.__name__})" in out


def test_dynamic_out_is_an_existing_file(tmp_path, monkeypatch):
    """``mpd-pin run env1 --out FILE`` (a two-link scenario) with FILE an existing regular
    file: exit 2 and one line naming --out and the path before any work — the kind's
    runner is never called, nothing is written — and the file is left as it was."""
    import time

    import mpd_pin.app.kinds as kinds

    called = []
    real = kinds.run_scenario

    def spy(*args, **kwargs):
        called.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(kinds, "run_scenario", spy)
    blocker = tmp_path / "o"
    blocker.write_text("keep me")
    start = time.perf_counter()
    res = run_cli("run", "env1", "--out", str(blocker), "--quiet")
    elapsed = time.perf_counter() - start
    line = _one_line_error(res)
    assert line == (f"mpd-pin: error: --out {str(blocker)!r} exists and is not a "
                    "directory"), line
    assert called == []  # no planning: the kind's runner never ran
    assert elapsed < 10.0, elapsed
    assert blocker.read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]
