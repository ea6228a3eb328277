"""The public Python API (docs/design.md §8b): load_scenario, plan, EnergyPlanner, Plan.

References: the `mpd-pin run` command for the same scenario (one computation, two doors),
networkx Dijkstra on the saved roadmap for later queries, brute-force nearest neighbours
for the nodes a query joins, and an independent stop-and-go re-pricing of the roadmap path.
"""

import subprocess
import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError

ROOT = Path(__file__).resolve().parents[1]

#: The names DESIGN §1 / docs/design.md §8b promise at the top level.
PUBLIC = ("load_scenario", "plan", "EnergyPlanner", "Plan", "Scenario", "World", "Box",
          "Cylinder", "Sphere", "Polygon", "Hazard", "RoadmapOptions", "MotionOptions",
          "trajectory_energy", "MotionEnergy", "Drive", "Arm", "sized_motors", "simulate_edge")


def test_public_names_are_documented_with_units():
    for name in PUBLIC:
        assert name in mp.__all__ and name in dir(mp), name
        obj = getattr(mp, name)
        assert obj.__doc__ and len(obj.__doc__.strip()) > 20, name
    for fn in (mp.plan, mp.EnergyPlanner, mp.EnergyPlanner.plan, mp.Plan, mp.trajectory_energy):
        assert any(u in fn.__doc__ for u in ("(J)", "J)", "rad", "energies J")), fn


def test_example_script_runs_in_an_empty_folder(tmp_path):
    """The issue's acceptance script: quickstart to the CLI's energy and result.json, two
    legs on one planner (the second reuses the roadmap and is faster), trajectory_energy
    stop-and-go equal to the roadmap energy. Its asserts are the checks."""
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "python_api.py")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("ok")
    assert (tmp_path / "python_out" / "result.json").is_file()
    assert (tmp_path / "cli_out" / "result.json").is_file()


def _small_quickstart(**settings):
    scn = mp.load_scenario("quickstart")
    from mpd_pin.app.planner import configure

    return configure(scn, num_nodes=40, refine=False, execution="stop", **settings)


def _nx_optimum(roadmap, start, goal) -> float:
    g = nx.DiGraph()
    cost = np.asarray(roadmap.energy, float).sum(axis=1)
    for u, v, c in zip(roadmap.src.tolist(), roadmap.dst.tolist(), cost.tolist(), strict=True):
        g.add_edge(u, v, weight=c)
    return nx.dijkstra_path_length(g, start, goal)


@pytest.fixture(scope="module")
def two_queries():
    """An eager and a lazy planner on the same small quickstart roadmap, each asked
    start → goal, then goal → a new configuration C."""
    scn = _small_quickstart(evaluation="eager")
    eager = mp.EnergyPlanner.from_scenario(scn, show_progress=False)
    first = eager.plan(scn.start, scn.goal)
    before = eager.roadmap
    C = np.array([-0.4, 1.2, -1.0])
    second = eager.plan(scn.goal, C)
    lazy = mp.EnergyPlanner.from_scenario(_small_quickstart(evaluation="lazy"),
                                          show_progress=False)
    lazy_legs = lazy.plan_legs([scn.start, scn.goal, C])
    return scn, eager, before, first, second, lazy_legs, C


def test_first_query_is_the_scenario_run(two_queries):
    scn, _, _, first, _, lazy_legs, _ = two_queries
    ref = mp.plan(_small_quickstart(evaluation="eager"), show_progress=False)
    assert first.total_energy == ref.total_energy
    assert first.roadmap_path.nodes == ref.roadmap_path.nodes
    # lazy evaluation finds the same optimum (docs/design.md §4g)
    assert lazy_legs[0].roadmap_path.total_energy == pytest.approx(
        first.roadmap_path.total_energy, rel=1e-9)


def test_later_query_reuses_the_roadmap_and_is_optimal(two_queries):
    scn, eager, before, _, second, lazy_legs, C = two_queries
    after = eager.roadmap
    n = before.num_nodes
    # C is appended; the goal (node 1) is reused as the new start
    assert after.num_nodes == n + 1 and after.start == 1 and after.goal == n
    np.testing.assert_array_equal(after.nodes[:n], before.nodes)
    np.testing.assert_array_equal(after.nodes[n], C)
    # every old edge is kept with its energy, bit for bit
    E = before.num_edges
    np.testing.assert_array_equal(after.src[:E], before.src)
    np.testing.assert_array_equal(after.energy[:E], before.energy)
    # the new edges join C to its k nearest nodes or nodes that have C among theirs
    k = scn.options.k
    d = np.linalg.norm(after.nodes[:, None, :] - after.nodes[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    knn = np.argsort(d, axis=1)[:, :k]
    candidates = {int(v) for v in knn[n]} | {int(u) for u in range(n) if n in knn[u]}
    new = {int(v) for u, v in zip(after.src[E:], after.dst[E:], strict=True) if u == n}
    assert new and new <= candidates
    pairs = set(zip(after.src.tolist(), after.dst.tolist(), strict=True))
    assert len(pairs) == after.num_edges  # no edge twice
    # the optimum on the extended roadmap: networkx Dijkstra
    opt = _nx_optimum(after, after.start, after.goal)
    assert second.roadmap_path.total_energy == pytest.approx(opt, rel=1e-12)
    assert lazy_legs[1].roadmap_path.total_energy == pytest.approx(opt, rel=1e-9)
    lazy_rec = lazy_legs[1].to_dict()["roadmap"]["lazy"]
    assert lazy_rec["reused"] >= lazy_legs[0].to_dict()["roadmap"]["lazy"]["simulated"] > 0


def test_plan_fields_agree_with_result_json(two_queries):
    _, _, _, _, second, _, _ = two_queries
    doc = second.to_dict()
    assert doc["total_energy"] == second.total_energy
    np.testing.assert_allclose(doc["energy_per_joint"], second.energy_per_joint, rtol=0)
    np.testing.assert_allclose(second.path, np.asarray(doc["motion"]["waypoints"]), rtol=0)
    assert doc["roadmap_path"]["nodes"] == second.roadmap_path.nodes
    assert doc["roadmap_path"]["total_energy"] == second.roadmap_path.total_energy
    from mpd_pin.app.results import to_jsonable

    assert to_jsonable(second.comparison) == doc["comparison"]
    fig = second.plot("energy.png")
    assert fig.axes and "Table 7" not in fig.axes[0].get_title()  # sized motors: no warning
    with pytest.raises(ValueError, match="not one of"):
        second.plot("nope.png")


def test_save_writes_the_cli_files(two_queries, tmp_path):
    _, _, _, first, _, _, _ = two_queries
    doc = first.save(tmp_path / "o", replay=False)
    files = {p.name for p in (tmp_path / "o").iterdir()}
    assert {"result.json", "trajectory.csv", "trajectory.json", "path.png",
            "joint_angles.png", "energy.png"} <= files
    assert doc == first.to_dict()
    assert doc["outputs"] == sorted(files - {"result.json"})


def test_bad_input_is_one_clear_error(two_queries, tmp_path):
    scn, eager, *_ = two_queries
    with pytest.raises(ValueError, match="expected 3 joint values"):
        eager.plan([0.1, 0.2], scn.goal)
    with pytest.raises(ValueError, match="finite"):
        eager.plan([np.nan, 0.0, 0.0], scn.goal)
    with pytest.raises(ValueError, match="at least 2"):
        eager.plan_legs([scn.start])
    with pytest.raises(TypeError, match="World"):
        mp.EnergyPlanner(scn.drive(), world="table")
    with pytest.raises(ConfigError, match="dynamic2link"):
        mp.plan("env1")
    with pytest.raises(ConfigError, match="nodes"):
        mp.plan(scn, num_nodes=-3)
    blocked = tmp_path / "file"
    blocked.write_text("x")
    with pytest.raises(ConfigError, match="not a directory"):
        two_queries[3].save(blocked)


def test_cli_version_and_nodes(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"mpd-pin {mp.__version__}"
    assert main(["run", "quickstart", "--nodes", "40", "--no-refine", "--execution", "stop",
                 "--no-replay", "--quiet", "--out", str(tmp_path / "n")]) == 0
    import json

    doc = json.loads((tmp_path / "n" / "result.json").read_text())
    assert doc["roadmap"]["num_nodes"] == 42 and doc["roadmap"]["options"]["num_nodes"] == 40
    capsys.readouterr()
    assert main(["run", "env1", "--nodes", "30", "--out", str(tmp_path / "e")]) == 2
    assert "--nodes does not apply to 'env1'" in capsys.readouterr().err


def test_replan_figures_mark_the_replan_and_warn_of_the_paper_motor():
    """replan (paper motor, a hidden obstacle): energy.png has a dashed line at the time the
    obstacle was sensed — the node time of the replanning event — and every figure's title
    carries the paper motor's warning; quickstart's (sized motors) does not."""
    import matplotlib.pyplot as plt

    plan = mp.plan("replan", show_progress=False)
    doc = plan.to_dict()
    events = doc["execution"]["replans"]
    assert events
    t_nodes = plan.series["node_times"]
    times = sorted(float(t_nodes[min(ev["step"], len(t_nodes) - 1)]) for ev in events)
    figs = plan.figures()
    ax = figs["energy.png"].axes[0]
    vertical = sorted(float(line.get_xdata()[0]) for line in ax.get_lines()
                      if len(set(np.atleast_1d(line.get_xdata()))) == 1
                      and line.get_linestyle() == "--")
    assert vertical == pytest.approx(times, abs=1e-12)
    labels = [t.get_text() for t in ax.texts]
    for ev in events:
        assert any(name in lab for lab in labels for name in ev["revealed"])
    for name in ("path.png", "energy.png"):
        assert "Table 7 motor" in figs[name].axes[0].get_title(), name
    for fig in figs.values():
        plt.close(fig)
