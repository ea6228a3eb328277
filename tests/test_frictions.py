"""The frictions a new user met (issue 35): energy.png compares like with like; path.png
and energy_duration.png draw what they name; ``[roadmap] max_edge_duration`` (the old
``max_duration`` read with one warning); ``mpd-pin show NAME --all``; the README's
commands; result.json's ``path.what`` and ``search.edge_cost_reads``.

The figures are checked on the matplotlib objects make_figures returns (lines, their
labels, gids, dash patterns, marker sizes and z-orders), their numbers against the plan's
own records (result.json's ``comparison``, the verifications), one quickstart plan for the
module.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
import tomllib
import warnings
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from conftest import run_cli  # noqa: E402
from scenario_texts import SMALL_2LINK  # noqa: E402

import mpd_pin as mp  # noqa: E402
from mpd_pin.app.config import ConfigError  # noqa: E402
from mpd_pin.app.outputs import make_figures, path_what  # noqa: E402
from mpd_pin.app.results import validate_result  # noqa: E402
from mpd_pin.app.scenario import parse_energy_scenario  # noqa: E402
from mpd_pin.app.scenario_files import builtin_scenarios, scenario_kind  # noqa: E402
from mpd_pin.app.show import DEFAULTS, with_defaults  # noqa: E402
from mpd_pin.viz import scene  # noqa: E402
from mpd_pin.world import Box, World  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def quick():
    """quickstart planned once (its motion refined, non-stop; its shortest path's nodes
    differ from the energy optimum's), with its figures."""
    plan = mp.plan("quickstart", show_progress=False)
    figs = plan.figures()
    yield plan, plan._parts, figs
    for fig in figs.values():
        plt.close(fig)


def _figures(p, shortest, motion):
    return make_figures(p.scenario, p.setup, p.result, p.moved if motion is not None
                        else p.check, shortest, motion=motion)


def _by_gid(ax, prefix):
    return [ln for ln in ax.get_lines() if str(ln.get_gid()).startswith(prefix)]


def _closed(figs):
    for fig in figs.values():
        plt.close(fig)


# ------------------------------------------------------------------ energy.png
def test_energy_png_compares_the_motion_with_the_shortest_path_refined_the_same_way(quick):
    plan, p, figs = quick
    ax = figs["energy.png"].axes[0]
    (total,) = _by_gid(ax, "total")
    (other,) = _by_gid(ax, "compare:")
    rec = plan.to_dict()["comparison"]
    refined, unrefined = (rec["refined_shortest_path"]["total_energy"],
                          rec["shortest_path"]["total_energy"])
    assert refined < 0.6 * unrefined  # quickstart: 19.7 J against 48.3 J (roadmap)
    # the compared total is the shortest path refined as the motion was, not the roadmap's
    assert other.get_ydata()[-1] == pytest.approx(refined, rel=2e-3)
    assert other.get_xdata()[-1] == pytest.approx(rec["refined_shortest_path"]["duration"])
    assert total.get_ydata()[-1] == pytest.approx(plan.total_energy, rel=2e-3)
    assert total.get_xdata()[-1] == pytest.approx(plan.motion.duration)
    assert total.get_label().startswith("total (returned motion, nonstop):")
    assert other.get_label().startswith(
        "total, shortest joint-space path refined the same way, nonstop:")


def test_energy_png_of_the_roadmap_path_compares_it_with_the_shortest_roadmap_path(quick):
    """No refinement (motion None: the roadmap path as it is): roadmap path against roadmap
    path; when their nodes are the same, one total saying so (and path.png's poses too)."""
    _, p, _ = quick
    figs = _figures(p, (p.shortest, p.shortest_check), None)
    ax = figs["energy.png"].axes[0]
    (total,) = _by_gid(ax, "total")
    (other,) = _by_gid(ax, "compare:")
    assert total.get_ydata()[-1] == pytest.approx(p.check.total_energy, rel=1e-9)
    assert other.get_ydata()[-1] == pytest.approx(p.shortest_check.total_energy, rel=1e-9)
    assert "energy-optimal roadmap path, stop-and-go" in total.get_label()
    assert "shortest joint-space path on the roadmap, stop-and-go" in other.get_label()
    _closed(figs)
    figs = _figures(p, (p.result, p.check), None)  # the shortest path's nodes = the path's
    ax = figs["energy.png"].axes[0]
    assert _by_gid(ax, "compare:") == []
    (total,) = _by_gid(ax, "total")
    assert "it is also the shortest joint-space path" in total.get_label()
    pax = figs["path.png"].axes[0]
    assert _by_gid(pax, "other:") == []  # drawn once: as the path itself
    labels = [ln.get_label() for ln in pax.get_lines()]
    assert "arm at each path node (the path is also the shortest joint-space path)" in labels
    _closed(figs)


def test_energy_png_without_a_refined_shortest_path_compares_the_two_roadmap_paths(quick):
    _, p, _ = quick
    figs = _figures(p, (p.shortest, p.shortest_check),
                    dataclasses.replace(p.motion, shortest=None))
    ax = figs["energy.png"].axes[0]
    (total,) = _by_gid(ax, "total")
    first, second = _by_gid(ax, "compare:")
    assert total.get_ydata()[-1] == pytest.approx(p.motion.energy.total_energy, rel=2e-3)
    # both compared totals are the roadmap paths, simulated stop-and-go
    assert first.get_ydata()[-1] == pytest.approx(p.check.total_energy, rel=1e-6)
    assert second.get_ydata()[-1] == pytest.approx(p.shortest_check.total_energy, rel=1e-9)
    assert "energy-optimal roadmap path, unrefined" in first.get_label()
    assert "shortest joint-space path on the roadmap, unrefined" in second.get_label()
    assert "no shortest joint-space path refined the same way" in total.get_label()
    _closed(figs)


def test_energy_png_draws_a_shortest_motion_that_is_the_motion_once(quick):
    _, p, _ = quick
    motion = dataclasses.replace(p.motion, shortest=p.motion.energy)
    figs = _figures(p, (p.shortest, p.shortest_check), motion)
    ax = figs["energy.png"].axes[0]
    assert _by_gid(ax, "compare:") == []
    (total,) = _by_gid(ax, "total")
    assert "the shortest joint-space path refined the same way is this motion" in (
        total.get_label())
    # path.png: roadmap path and shortest path have different nodes: both drawn, and their
    # dashes interleave (on one dash, off one, the second offset by one dash)
    pax = figs["path.png"].axes[0]
    lines = _by_gid(pax, "other:")
    assert len(lines) == 2
    patterns = [ln._unscaled_dash_pattern for ln in lines]  # (offset, (on, off)), points
    (o0, (on0, off0)), (o1, (on1, off1)) = patterns
    assert (on0, off0) == (on1, off1) and on0 == off0 > 0
    assert abs(o1 - o0) == pytest.approx(on0)
    _closed(figs)


# ------------------------------------------------------------------ path.png
def test_path_png_draws_the_roadmap_path_once_when_it_is_the_shortest_path(quick):
    _, p, _ = quick
    figs = _figures(p, (p.result, p.check), p.motion)  # shortest nodes = roadmap path's
    ax = figs["path.png"].axes[0]
    (line,) = _by_gid(ax, "other:")
    assert line.get_label().endswith("= the shortest joint-space path: end effector")
    assert not [ln for ln in ax.get_lines()
                if ln.get_label().startswith("shortest joint-space path")]
    _closed(figs)


def test_obstacle_labels_sit_on_their_own_solid_away_from_the_others():
    """panda's scene: the table's name was written at its centre, on the foot of the wall
    that stands there."""
    data = tomllib.loads(builtin_scenarios()["panda"].read_text(encoding="utf-8"))
    boxes = {o["name"]: Box(size=o["size"], position=o["position"], name=o["name"])
             for o in data["obstacles"]}
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    scene.draw_world_3d(ax, World(tuple(boxes.values())))
    labels = {t.get_text(): np.array(t.get_position_3d(), float) for t in ax.texts
              if str(t.get_gid()).startswith("label:")}
    plt.close(fig)
    assert set(labels) == set(boxes) == {"table", "wall", "bin"}
    extent = {n: (np.array(b.position) - np.array(b.size) / 2,
                  np.array(b.position) + np.array(b.size) / 2) for n, b in boxes.items()}
    for name, xyz in labels.items():
        lo, hi = extent[name]
        assert np.all(xyz[:2] >= lo[:2]) and np.all(xyz[:2] <= hi[:2]), name  # over it
        assert xyz[2] == pytest.approx(hi[2]), name  # on its top
        for other, (olo, ohi) in extent.items():
            if other != name:  # 0.12 m: a tenth of the scene (the table is 1.2 m long)
                gap = np.linalg.norm(np.maximum(np.maximum(olo - xyz, xyz - ohi), 0.0))
                assert gap >= 0.12 - 1e-9, (name, other, gap)


# ------------------------------------------------------------------ energy_duration.png
def test_energy_duration_simulated_dots_visible_and_the_screen_explained(quick):
    _, _, figs = quick
    ax = figs["energy_duration.png"].axes[0]
    dots = _by_gid(ax, "simulated:")
    (star,) = _by_gid(ax, "returned")
    lines = _by_gid(ax, "screen:") + _by_gid(ax, "stop:")
    assert dots and lines
    for dot in dots:
        assert dot.get_markersize() >= 7
        assert dot.get_zorder() > star.get_zorder()  # not hidden by the star
        assert dot.get_zorder() > max(ln.get_zorder() for ln in lines)
    legend = ax.get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    (screen,) = [t for t in texts if "screen" in t]
    assert "perfect-tracking" in screen and "estimate" in screen and "not simulated" in screen
    (handle,) = [h for h, t in zip(legend.legend_handles, texts, strict=True)
                 if t.startswith("non-stop, simulated")]
    assert handle.get_marker() == "o"
    assert handle.get_markersize() == dots[0].get_markersize()


# ------------------------------------------------------------------ result.json
def test_result_says_path_is_the_roadmap_path_and_names_the_edge_counters(quick):
    plan, p, _ = quick
    doc = plan.to_dict()
    validate_result({**doc, "outputs": []})  # before save: no files listed yet
    what = doc["path"]["what"]
    assert what.startswith("the roadmap path: the search's node sequence, stop-and-go")
    assert "the returned motion, which the arm runs, is motion" in what
    assert doc["path"]["nodes"] == doc["roadmap_path"]["nodes"]
    # the roadmap path's node times: its stop-and-go run (the motion has its own)
    assert doc["path"]["node_times"][-1] == pytest.approx(p.check.duration)
    assert len(doc["path"]["node_times"]) == len(doc["path"]["nodes"]) != len(
        doc["motion"]["node_times"])
    search = doc["search"]
    assert search["edge_cost_reads"] == search["edge_evaluations"] > doc["roadmap"][
        "edges_evaluated"]
    assert "edge_cost_reads" not in p.result.search  # the plan's own record is unchanged


def test_path_what_for_an_unrefined_and_a_travelled_path(quick):
    _, p, _ = quick
    unrefined = dataclasses.replace(p.motion, refined=None)
    assert path_what(p.result, unrefined).endswith(
        "; the returned motion (motion) is this path as it is")
    travelled = dataclasses.replace(p.result, execution=object())
    assert path_what(travelled, None).startswith(
        "the travelled roadmap path (executed with sensing and repair)")


# ------------------------------------------------------------------ [roadmap] rename
def _case1(**roadmap):
    path = builtin_scenarios()["case1"]
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["roadmap"].update(duration_rule="distance", **roadmap)
    return parse_energy_scenario(data, source=str(path), base_dir=path.parent)


def test_roadmap_max_edge_duration_and_its_old_name():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new key: no warning
        new = _case1(max_edge_duration=2.5)
    assert new.options.max_duration == 2.5
    with pytest.warns(FutureWarning) as seen:
        old = _case1(max_duration=2.5)
    (w,) = seen
    assert str(w.message).startswith(
        "roadmap.max_duration is renamed roadmap.max_edge_duration (the longest roadmap "
        "edge, s; [motion] max_duration is the whole motion's)")
    assert "\n" not in str(w.message)
    # the same options, hence the same roadmap key and energies (field name unchanged)
    assert old.options == new.options and asdict(old.options) == asdict(new.options)
    with pytest.raises(ConfigError, match=r"^roadmap.max_duration: the old name of "
                                          r"roadmap.max_edge_duration; give only"):
        _case1(max_duration=2.5, max_edge_duration=2.5)
    with pytest.raises(ConfigError, match=r"roadmap: min_duration must not exceed "
                                          r"max_edge_duration"):
        _case1(max_edge_duration=0.25)


# ------------------------------------------------------------------ mpd-pin show --all
def _same_scenario(a, b) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "source":
            continue
        if f.name == "arm":
            assert x.fingerprint() == y.fingerprint()
        elif f.name == "world":
            assert (x.obstacles, x.hazards) == (y.obstacles, y.hazards)
        elif isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y, f.name


@pytest.mark.parametrize("name", ["quickstart", "replan"])
def test_show_all_loads_back_to_the_same_scenario(name, tmp_path):
    res = run_cli("show", name, "--all")
    assert res.returncode == 0 and res.stderr == "", res.stderr
    text = res.stdout
    data = tomllib.loads(text)
    for section in DEFAULTS:
        if section != "motor":
            assert section in data, section
    assert data["roadmap"]["max_edge_duration"] == 4.0  # a default, written out
    assert "# max_duration =" in text  # [motion]: no default value, as a comment
    shipped = builtin_scenarios()[name].read_text(encoding="utf-8")
    assert all(line in text.splitlines() for line in shipped.splitlines())  # comments kept
    (tmp_path / f"{name}.toml").write_text(text, encoding="utf-8")
    _same_scenario(mp.load_scenario(name), mp.load_scenario(str(tmp_path / f"{name}.toml")))


def test_show_all_of_a_scenario_with_no_sections_gives_the_parser_defaults(tmp_path):
    """Every default of DEFAULTS written out loads to what the parser gives without it (a
    default that drifted from the parser's fails here)."""
    small = 'name = "small"\n' + SMALL_2LINK
    text = with_defaults(small, "small")
    data = tomllib.loads(text)
    assert {"motor", "controller", "planner", "compute", "motion", "supply"} <= set(data)
    assert data["controller"] == {"kp": 40.0, "kd": 4.0, "feedforward": True}
    assert data["planner"]["hazard_penalty"] == float("inf")
    (tmp_path / "a.toml").write_text(small, encoding="utf-8")
    (tmp_path / "b.toml").write_text(text, encoding="utf-8")
    _same_scenario(mp.load_scenario(str(tmp_path / "a.toml")),
                   mp.load_scenario(str(tmp_path / "b.toml")))
    # the dataclasses' defaults, which show.py spells out (it imports no Pinocchio)
    table = {s: {k: v for k, v, _ in rows if v is not None} for s, rows in DEFAULTS.items()}
    opts = asdict(mp.RoadmapOptions())
    opts["max_edge_duration"] = opts.pop("max_duration")
    assert table["roadmap"] == {**opts, "evaluation": "lazy", "collision": "lazy"}
    motion = mp.MotionOptions()
    assert table["motion"] == {"execution": motion.execution, "refine": motion.refine,
                               "optimize": motion.optimize}
    assert motion.max_duration is None
    assert table["supply"] == {"bus": mp.Supply().bus,
                               "regeneration": mp.Supply().regeneration}


def test_show_all_every_builtin_and_without_all_as_shipped():
    for name, path in builtin_scenarios().items():
        shipped = path.read_text(encoding="utf-8")
        assert run_cli("show", name).stdout == shipped
        res = run_cli("show", name, "--all")
        if scenario_kind(tomllib.loads(shipped)) != "energy":
            assert res.returncode == 2 and "--all lists the defaults of energy scenarios" in (
                res.stderr)
            continue
        assert res.returncode == 0, res.stderr
        data = tomllib.loads(res.stdout)
        assert {"motion", "supply", "controller", "roadmap", "planner", "sensor",
                "compute"} <= set(data), name


def test_show_all_imports_nothing_heavy():
    code = ("import contextlib, io, sys\nfrom mpd_pin.app.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    assert main(['show', 'quickstart', '--all']) == 0\n"
            "print(','.join(m for m in ('pinocchio', 'coal', 'matplotlib', 'scipy') "
            "if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == ""


# ------------------------------------------------------------------ README
def test_readme_gives_each_command_its_block_the_quick_tests_first():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = [b.strip() for b in re.findall(r"^```bash\n(.*?)^```$", text, re.M | re.S)]
    assert blocks[0] == "pip install . && mpd-pin run quickstart --out out/"
    full = blocks.index('pip install -e ".[test]" && pytest')
    quick = [k for k, b in enumerate(blocks) if b.startswith('pip install -e ".[test]" && '
                                                               "pytest tests/")]
    assert quick and quick[0] < full
