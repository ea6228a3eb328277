"""The motion a run returns (docs/design.md §9f): result.json, trajectory files, settings,
the paper scenarios unchanged, hazards and hidden obstacles, bad input.

References: the roadmap path's own energies (result.json ``roadmap_path``), the checker at
every sample of trajectory.csv (brute force), the trapezoid integral of the CSV's V·i.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import read_result, run_once

from mpd_pin.app.cli import main
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.runner import run_energy_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.motion.refine import OPTIMIZED, SEED_FACTOR


def _csv(out: Path) -> tuple[list[str], np.ndarray]:
    with open(out / "trajectory.csv", encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """quickstart run with the default [motion] (auto, refine): ``mpd-pin run quickstart
    --quiet``, shared with tests/test_cli.py (conftest.run_once)."""
    res, out = run_once(tmp_path_factory, "quickstart", "--quiet")
    assert res.returncode == 0, res.stderr
    return load_scenario("quickstart"), out, read_result(out)


def test_quickstart_returns_a_refined_motion_cheaper_than_the_roadmap_path(quick_run):
    scn, out, r = quick_run
    m, rp = r["motion"], r["roadmap_path"]
    assert r["total_energy"] == m["total_energy"]
    assert r["energy_per_joint"] == m["energy_per_joint"]
    assert m["feasible"] and m["execution"] in ("stop", "nonstop")
    # the roadmap path is the MPD* Lite optimum, and the motion beats it
    assert rp["nodes"] == r["path"]["nodes"]
    assert m["total_energy"] < 0.9 * rp["total_energy"]
    cands = {c["name"]: c for c in m["refinement"]["candidates"]}
    assert {"energy optimum", "shortest path"} <= set(cands)
    assert set(cands) - {"energy optimum", "shortest path"} <= {"alternative 1"}
    priced = {n: c for n, c in cands.items() if "total_energy" in c}
    assert {"energy optimum", "shortest path"} <= set(priced)  # never pruned
    for n in set(cands) - set(priced):
        assert cands[n]["reason"].startswith("pruned")
    for c in priced.values():  # each step kept only what lowered the stop-and-go energy
        assert c["stop_energy_out"] <= c["stop_energy_relaxed"] + 1e-12
        assert c["stop_energy_relaxed"] <= c["stop_energy_shortcut"] + 1e-12
        assert c["stop_energy_shortcut"] <= c["stop_energy_in"] + 1e-12
        # auto: both executions priced, the cheaper kept
        by = c["energy_by_execution"]
        assert set(by) == {"stop", "nonstop"}
        assert c["total_energy"] == pytest.approx(min(v for v in by.values() if v is not None))
    # the motion returned is the optimum of the cheapest candidates (docs/design.md §9g),
    # at its seed's duration and cheaper, simulated, than every priced candidate
    assert m["refinement"]["candidate"] == OPTIMIZED
    opt = m["optimization"]
    assert opt["kept_seed"] is False and opt["certified"] is True
    seed = priced[opt["seed"]]
    assert opt["energy_before"] == pytest.approx(seed["total_energy"], rel=1e-12)
    assert opt["energy_after"] == m["total_energy"]
    assert m["total_energy"] < min(c["total_energy"] for c in priced.values())
    assert m["execution"] == "nonstop" and m["energy_by_execution"] == {
        "nonstop": m["total_energy"]}
    assert m["duration"] == pytest.approx(seed["duration"], abs=1e-12)
    assert [r["seed"] for r in opt["runs"]] == sorted(
        (n for n, c in priced.items() if c["total_energy"] <= SEED_FACTOR * min(
            c["total_energy"] for c in priced.values())),
        key=lambda n: priced[n]["total_energy"])[: scn.motion.seeds]
    # the comparison's shortest path, refined the same way
    rs = r["comparison"]["refined_shortest_path"]
    assert rs["total_energy"] == pytest.approx(cands["shortest path"]["total_energy"])
    assert r["comparison"]["motion_energy_saved_percent"] == pytest.approx(
        100 * (1 - m["total_energy"] / rs["total_energy"]))
    assert (out / "energy_duration.png").stat().st_size > 10_000
    assert "refinement" in r["cpu_seconds_per_phase"]


def test_quickstart_motion_files_are_the_motion(quick_run):
    """trajectory.csv is the returned motion: it starts at the start, ends at the goal
    within the arrival tolerance, is collision-free at every sample, lasts the motion's
    duration and integrates (max(V·i, 0) per joint) to the reported energy within 2 %."""
    scn, out, r = quick_run
    header, T = _csv(out)
    names = scn.arm.joint_names
    q = T[:, [header.index(f"q_{n}") for n in names]]
    V = T[:, [header.index(f"V_{n}") for n in names]]
    i = T[:, [header.index(f"i_{n}") for n in names]]
    t = T[:, 0]
    np.testing.assert_allclose(q[0], scn.start, atol=1e-9)
    assert np.max(np.abs(q[-1] - scn.goal)) <= scn.options.arrival_tolerance
    assert t[-1] == pytest.approx(r["motion"]["duration"], abs=1e-6)
    checker = CollisionChecker(scn.arm, scn.world)
    assert checker.is_free_batch(q).all()
    E = np.trapezoid(np.maximum(V * i, 0.0), t, axis=0)
    assert E.sum() == pytest.approx(r["total_energy"], rel=0.02)
    np.testing.assert_allclose(r["motion"]["trajectory_energy_per_joint"], E, rtol=1e-6)
    for name in ("result.json", "trajectory.csv", "trajectory.json"):  # readable like the PNGs
        assert (out / name).stat().st_mode & 0o777 == (out / "path.png").stat().st_mode & 0o777
    traj = json.loads((out / "trajectory.json").read_text(encoding="utf-8"))
    assert traj["points"][-1]["time_from_start"] == pytest.approx(t[-1])


def test_paper_scenario_keeps_the_roadmap_path_bit_for_bit(tmp_path_factory):
    """case1 ([motion] stop, no refine): the motion is the roadmap path and its energy the
    roadmap's, pinned to the value before motions existed (86,160.8 J, README). The run is
    ``mpd-pin run case1 --quiet``, shared with tests/test_cli.py (conftest.run_once)."""
    scn = load_scenario("case1")
    assert scn.motion.execution == "stop" and not scn.motion.refine
    res, out = run_once(tmp_path_factory, "case1", "--quiet")
    assert res.returncode == 0, res.stderr
    r = read_result(out)
    assert r["total_energy"] == r["roadmap_path"]["total_energy"]
    assert r["total_energy"] == pytest.approx(86160.8, abs=0.05)
    assert r["motion"]["execution"] == "stop" and "refinement" not in r["motion"]
    assert r["motion"]["stops"] == len(r["path"]["nodes"]) - 2
    assert not (out / "energy_duration.png").exists()


def test_no_refine_stop_prices_the_roadmap_path_exactly(tmp_path, capsys):
    code = main(["run", "quickstart", "--out", str(tmp_path), "--quiet", "--no-replay",
                 "--no-refine", "--execution", "stop"])
    assert code == 0
    r = json.loads((tmp_path / "result.json").read_text(encoding="utf-8"))
    assert r["total_energy"] == r["roadmap_path"]["total_energy"]
    assert r["motion"]["waypoints"] == r["path"]["configurations"]
    assert "40.6021 J" in capsys.readouterr().out


@pytest.mark.parametrize("flags, execution, refine", [
    ([], "auto", True),
    (["--execution", "nonstop"], "nonstop", True),
    (["--no-refine"], "auto", False),
    (["--execution", "stop", "--no-refine"], "stop", False),
])
def test_motion_flags_reach_the_run(tmp_path, monkeypatch, flags, execution, refine):
    """A spy on the runner: the scenario it is given carries the flags' [motion]."""
    import mpd_pin.app.kinds as kinds

    seen = {}

    def spy(scn, out_dir, **kw):
        seen["motion"] = scn.motion
        raise SystemExit(0)

    monkeypatch.setattr(kinds, "run_scenario", spy)
    with pytest.raises(SystemExit):
        main(["run", "quickstart", "--out", str(tmp_path), "--quiet", *flags])
    assert seen["motion"].execution == execution and seen["motion"].refine is refine


def _toml(tmp_path: Path, base: str, motion: str) -> Path:
    from mpd_pin.app.scenario import builtin_scenarios

    text = builtin_scenarios()[base].read_text(encoding="utf-8")
    text = text.replace("\n[motion]", "\n[unused_motion]") if "\n[motion]" in text else text
    start = text.find("\n[unused_motion]")
    if start >= 0:  # drop the scenario's own [motion] table
        end = text.find("\n[", start + 1)
        text = text[:start] + text[end:]
    path = tmp_path / f"{base}_motion.toml"
    path.write_text(text.replace("\n[task]", f"\n[motion]\n{motion}\n\n[task]", 1),
                    encoding="utf-8")
    return path


@pytest.mark.parametrize("motion, words", [
    ('execution = "fast"', "motion.execution"),
    ("refine = 1", "motion.refine"),
    ("max_duration = -2.0", "motion.max_duration"),
    ("max_duraton = 5.0", "max_duraton"),
])
def test_bad_motion_settings_are_one_line_and_exit_2(tmp_path, capsys, motion, words):
    path = _toml(tmp_path, "case1", motion)
    out = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out), "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("mpd-pin: error:") and words in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()  # no empty folder left behind


def test_max_duration_no_motion_fits_is_exit_3_with_the_fastest_motion(tmp_path, capsys):
    """``[motion] max_duration`` below what the velocity limits allow is a planning outcome
    (docs/design.md §8a): status 3, one line naming the fastest motion found, whose
    duration (above the limit asked for) is result.json's motion, feasible false; its
    waypoints priced again fit that duration, and nothing a little shorter."""
    import mpd_pin as mp

    D = 0.2
    path = _toml(tmp_path, "case1", f'max_duration = {D}\nrefine = true\nexecution = "auto"')
    out = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out), "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert code == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    hit = re.match(rf"mpd-pin: no motion within max_duration {D:g} s: the fastest motion "
                   r"found takes ([0-9.]+) s", lines[0])
    assert hit, lines[0]
    fastest = float(hit.group(1))
    assert fastest > D
    r = read_result(out)
    m = r["motion"]
    assert r["feasible"] is False and r["reason"].startswith(f"no motion within max_duration "
                                                             f"{D:g} s")
    assert m["feasible"] is False and m["duration"] == pytest.approx(fastest, abs=5e-4)
    scn = load_scenario(path)
    W = np.asarray(m["waypoints"])
    checker = CollisionChecker(scn.arm, scn.world)
    at = mp.trajectory_energy(scn.drive(), W, m["execution"], options=scn.options,
                              checker=checker, max_duration=m["duration"])
    assert at.feasible and at.total_energy == pytest.approx(m["total_energy"], rel=1e-9)
    below = mp.trajectory_energy(scn.drive(), W, "auto", options=scn.options,
                                 checker=checker, max_duration=m["duration"] - 0.05)
    assert not below.feasible and not below.alternative.feasible


def test_alternatives_share_no_interior_node(quick_run):
    """The detour candidates (docs/design.md §9f) against networkx: the shortest path by
    joint-space length once the interior nodes of the optimum and the shortest path are
    removed."""
    import networkx as nx

    from mpd_pin.app.motion_step import alternative_paths
    from mpd_pin.app.plan import edge_lengths, prepare

    scn, _, r = quick_run
    setup = prepare(replace(scn, evaluation="lazy"), show_progress=False)
    rm = setup.roadmap
    taken = [r["path"]["nodes"], r["comparison"]["shortest_path"]["nodes"]]
    alt = alternative_paths(rm, taken, 2, scn.arm)
    assert alt, "quickstart's roadmap has a node-disjoint detour"
    banned = {v for p in taken for v in p[1:-1]}
    G = nx.DiGraph()
    for s, d, w in zip(rm.src, rm.dst, edge_lengths(rm, scn.arm), strict=True):
        if s not in banned and d not in banned:
            G.add_edge(int(s), int(d), weight=float(w))
    ref = nx.shortest_path_length(G, rm.start, rm.goal, weight="weight")
    got = sum(np.linalg.norm(rm.nodes[b] - rm.nodes[a])
              for a, b in zip(alt[0][:-1], alt[0][1:], strict=True))
    assert got == pytest.approx(ref, rel=1e-9)
    assert not banned & set(alt[0][1:-1])
    if len(alt) > 1:
        assert not set(alt[0][1:-1]) & set(alt[1][1:-1])


def test_refined_motion_keeps_the_hazard_clearance(tmp_path):
    """The hazard scenario with [motion] refined: every sample of the returned motion keeps
    each hazard's clearance (brute force with the checker's hazard margin)."""
    path = _toml(tmp_path, "hazard", 'execution = "auto"\nrefine = true')
    scn = load_scenario(str(path))
    out = tmp_path / "out"
    r = run_energy_scenario(scn, out, show_progress=False, replay=False)
    assert "refinement" in r["motion"]
    header, T = _csv(out)
    q = T[:, [header.index(f"q_{n}") for n in scn.arm.joint_names]]
    checker = CollisionChecker(scn.arm, scn.world)
    margins = np.array([checker.hazard_margin(x) for x in q[::2]])
    assert margins.min() >= -1e-6
    assert checker.is_free_batch(q).all()
    assert r["total_energy"] <= r["roadmap_path"]["total_energy"]


def test_hidden_obstacles_keep_the_travelled_path_and_say_why(tmp_path):
    path = _toml(tmp_path, "replan", 'execution = "auto"\nrefine = true')
    scn = load_scenario(str(path))
    scn = replace(scn, options=replace(scn.options))
    r = run_energy_scenario(scn, tmp_path / "out", show_progress=False, replay=False)
    assert r["motion"]["execution"] == "stop"
    assert "sensed on the way" in r["motion"]["note"]
    assert r["total_energy"] == r["roadmap_path"]["total_energy"]


def test_the_shortest_path_is_refined_once_as_a_candidate(monkeypatch):
    """Issue 34, one refinement: the comparison's "shortest path refined the same way" is
    the refinement's own shortest-path candidate, never a second refinement of it — also
    when that candidate's refinement fails (here made to), when there is then nothing to
    compare with."""
    import mpd_pin as mp
    from mpd_pin.app import motion_step
    from mpd_pin.motion import refine

    calls: list[list[str]] = []
    original, one = motion_step.refine_candidates, refine._refine_one

    def counted(*args, **kwargs):
        calls.append(sorted(args[3]))
        return original(*args, **kwargs)

    def failing(drive, W, checker, options, motion, memo, rec, *args, **kwargs):
        if rec["name"] == "shortest path":
            raise ValueError("made to fail by the test")
        return one(drive, W, checker, options, motion, memo, rec, *args, **kwargs)

    monkeypatch.setattr(motion_step, "refine_candidates", counted)
    plan = mp.plan("case2", num_nodes=60, refine=True, execution="auto", show_progress=False)
    cmp = plan.comparison
    assert cmp["shortest_path"]["nodes"] != plan.roadmap_path.nodes  # two paths, two candidates
    assert calls == [["alternative 1", "energy optimum", "shortest path"]]
    cand = {c["name"]: c for c in plan.to_dict()["motion"]["refinement"]["candidates"]}
    assert cmp["refined_shortest_path"]["total_energy"] == cand["shortest path"]["total_energy"]

    calls.clear()
    monkeypatch.setattr(refine, "_refine_one", failing)
    plan = mp.plan("case2", num_nodes=60, refine=True, execution="auto", show_progress=False)
    assert len(calls) == 1
    cand = {c["name"]: c for c in plan.to_dict()["motion"]["refinement"]["candidates"]}
    assert cand["shortest path"]["reason"] == "made to fail by the test"
    assert "refined_shortest_path" not in plan.comparison
