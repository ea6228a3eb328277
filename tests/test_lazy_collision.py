"""Lazy collision checking (docs/design.md §4g): edges enter unchecked and the search
certifies those it needs.

References: the same plans with every edge checked first (eager), and a dense
brute-force sampling of each edge the lazy search certified free.
"""

import json

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.plan import prepare
from mpd_pin.app.planner import configure
from mpd_pin.planning.roadmap import Roadmap, build_roadmap


def _plan(name, collision, **settings):
    scn = configure(mp.load_scenario(name), collision=collision, refine=False,
                    execution="stop", **settings)
    return mp.plan(scn, show_progress=False)


@pytest.mark.parametrize("name,nodes", [("quickstart", 60), ("case2", 80), ("replan", 150),
                                        ("hazard", 150)])
def test_lazy_checks_give_the_eager_optimum(name, nodes):
    """Plain search, hidden obstacles sensed on the way (replan) and hazard re-planning
    (hazard): the same path and energies as with every edge checked first, with fewer
    edges checked."""
    lazy, eager = (_plan(name, c, num_nodes=nodes) for c in ("lazy", "eager"))
    a, b = lazy.to_dict(), eager.to_dict()
    assert a["path"]["nodes"] == b["path"]["nodes"]
    assert a["total_energy"] == b["total_energy"]
    assert a["comparison"]["shortest_path"]["nodes"] == b["comparison"]["shortest_path"]["nodes"]
    assert a["roadmap"]["collision"] == "lazy" and b["roadmap"]["collision"] == "eager"
    assert 0 < a["roadmap"]["edges_checked"] < b["roadmap"]["edges_checked"]
    if name == "replan":  # the same repairs (the lazy roadmap blocks more candidate edges)
        keys = ("step", "node", "revealed", "path_before", "path_after")
        assert [{k: ev[k] for k in keys} for ev in a["execution"]["replans"]] == [
            {k: ev[k] for k in keys} for ev in b["execution"]["replans"]]


def test_certified_edges_are_free_by_dense_sampling():
    """Every edge the lazy search certified free is free at 200 samples per edge (an
    independent check by configurations), and the blocked ones are refused."""
    scn = configure(mp.load_scenario("case2"), collision="lazy", num_nodes=80)
    setup = prepare(scn, show_progress=False)
    from mpd_pin.app.plan import plan_path

    plan_path(scn, setup)
    lazy, rm = setup.lazy, setup.roadmap
    certified = np.flatnonzero(rm.checked_mask & ~lazy.refused)
    assert certified.size and not rm.checked_mask.all()
    s = np.linspace(0.0, 1.0, 200)[:, None]
    for e in certified[:: max(1, certified.size // 60)]:
        q0, q1 = rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]]
        assert setup.checker.is_free_batch(q0 + s * (q1 - q0)).all(), e
    blocked = np.flatnonzero(rm.checked_mask & lazy.refused)
    assert blocked.size == lazy.count.collided + lazy.count.refused


def test_roadmap_file_records_checked_edges_and_eager_load_completes_them(tmp_path):
    """A lazily checked roadmap saved by the search keeps its checked flags; built again
    eagerly from that file, its unchecked edges are certified and the blocked ones dropped:
    the same edges as an eager build."""
    scn = configure(mp.load_scenario("quickstart"), collision="lazy", num_nodes=40)
    cache = tmp_path / "rm.npz"
    setup = prepare(scn, cache=cache, show_progress=False)
    from mpd_pin.app.plan import plan_path

    plan_path(scn, setup)  # writes what it evaluated and checked back to the file
    loaded = Roadmap.load(cache)
    assert loaded.checked is not None and 0 < loaded.checked.sum() < loaded.num_edges
    cost, checker = setup.cost, setup.checker
    done = build_roadmap(cost, checker, scn.start, scn.goal, scn.options, cache=cache,
                         show_progress=False, evaluate=False, check_edges=True)
    fresh = build_roadmap(cost, checker, scn.start, scn.goal, scn.options,
                          show_progress=False, evaluate=False, check_edges=True)
    assert done.checked is None
    assert set(zip(done.src.tolist(), done.dst.tolist(), strict=True)) == set(
        zip(fresh.src.tolist(), fresh.dst.tolist(), strict=True))
    assert Roadmap.load(cache).checked is None  # saved again, complete


def test_later_query_edges_enter_unchecked():
    """A second query on a lazily checked roadmap adds its edges unchecked and still
    finds the eager planner's optimum on the same nodes."""
    scn = mp.load_scenario("quickstart")
    C = np.array([-0.4, 1.2, -1.0])
    legs = {}
    for c in ("lazy", "eager"):
        p = mp.EnergyPlanner.from_scenario(
            configure(scn, collision=c, num_nodes=40, refine=False, execution="stop"),
            show_progress=False)
        legs[c] = p.plan_legs([scn.start, scn.goal, C])
        if c == "lazy":
            assert not p.roadmap.checked_mask.all()
    assert legs["lazy"][1].roadmap_path.nodes == legs["eager"][1].roadmap_path.nodes
    assert legs["lazy"][1].total_energy == legs["eager"][1].total_energy


def test_bad_collision_value_is_one_line_naming_the_key(tmp_path, capsys):
    text = (mp_show("quickstart")).replace("[roadmap]\n", '[roadmap]\ncollision = "maybe"\n', 1)
    f = tmp_path / "s.toml"
    f.write_text(text)
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mpd-pin: error: roadmap.collision: 'maybe' is not one of")
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_cli_collision_flag_reaches_the_run(tmp_path):
    """--collision reaches the run: eager checks every candidate pair (both directions),
    which are exactly the edges a lazy roadmap holds unchecked."""
    docs = {}
    for c in ("eager", "lazy"):
        assert main(["run", "quickstart", "--nodes", "40", "--collision", c, "--no-refine",
                     "--execution", "stop", "--no-replay", "--quiet", "--out",
                     str(tmp_path / c)]) == 0
        docs[c] = json.loads((tmp_path / c / "result.json").read_text())["roadmap"]
    eager, lazy = docs["eager"], docs["lazy"]
    assert (eager["collision"], lazy["collision"]) == ("eager", "lazy")
    assert eager["edges_checked"] == lazy["num_edges"] > eager["num_edges"]
    assert lazy["edges_checked"] < eager["edges_checked"]


def mp_show(name: str) -> str:
    from mpd_pin.app.scenario_files import builtin_scenarios

    return builtin_scenarios()[name].read_text(encoding="utf-8")
