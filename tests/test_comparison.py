"""Energy-optimal vs shortest joint-space path, trajectory.csv / trajectory.json
(docs/design.md §7c): recomputed with networkx on the roadmap file and from the CSV."""

import json

import networkx as nx
import numpy as np
import pytest

from mpd_pin.app.cli import main
from mpd_pin.app.trajectory import joint_trajectory, trajectory_columns
from mpd_pin.planning.roadmap import Roadmap


def _run(tmp_path_factory, name, *extra):
    base = tmp_path_factory.mktemp(name)
    out, cache = base / "out", base / "roadmap.npz"
    # eager: networkx below searches every roadmap energy (lazy == eager: tests/test_lazy.py);
    # --verify: the paths re-simulated with simulate_edge, which the checks below read
    status = main(["run", name, "--out", str(out), "--quiet", "--no-replay",
                   "--cache", str(cache), "--evaluation", "eager", "--verify", *extra])
    assert status == 0
    result = json.loads((out / "result.json").read_text())
    return result, out, Roadmap.load(cache)


@pytest.fixture(scope="module")
def replan(tmp_path_factory):
    return _run(tmp_path_factory, "replan")


@pytest.fixture(scope="module")
def case4(tmp_path_factory):
    return _run(tmp_path_factory, "case4")


def _digraph(rm: Roadmap) -> nx.DiGraph:
    g = nx.DiGraph()
    for e, (u, v) in enumerate(zip(rm.src.tolist(), rm.dst.tolist(), strict=True)):
        dq = rm.nodes[v] - rm.nodes[u]
        g.add_edge(u, v, length=float(np.sqrt(dq @ dq)), energy=float(rm.energy[e].sum()),
                   row=e)
    return g


def _energy(g, rm, nodes):
    rows = [g[u][v]["row"] for u, v in zip(nodes[:-1], nodes[1:], strict=True)]
    return rm.energy[rows].sum(axis=0)


def _length(rm, nodes):
    return sum(float(np.linalg.norm(rm.nodes[v] - rm.nodes[u]))
               for u, v in zip(nodes[:-1], nodes[1:], strict=True))


def test_plain_scenario_against_networkx(case4):
    result, _, rm = case4
    g = _digraph(rm)
    opt = nx.dijkstra_path(g, rm.start, rm.goal, weight="energy")
    short = nx.dijkstra_path(g, rm.start, rm.goal, weight="length")
    cmp = result["comparison"]
    assert cmp["basis"] == "planned"
    assert result["path"]["nodes"] == opt
    assert cmp["shortest_path"]["nodes"] == short
    e_opt, e_short = _energy(g, rm, opt), _energy(g, rm, short)
    np.testing.assert_allclose(cmp["shortest_path"]["energy_per_joint"], e_short, rtol=1e-12)
    assert cmp["shortest_path"]["total_energy"] == pytest.approx(e_short.sum(), rel=1e-12)
    assert cmp["shortest_path"]["length_rad"] == pytest.approx(_length(rm, short), rel=1e-12)
    assert result["path"]["length_rad"] == pytest.approx(_length(rm, opt), rel=1e-12)
    saved = 100.0 * (1.0 - e_opt.sum() / e_short.sum())
    assert cmp["energy_saved_percent"] == pytest.approx(saved, rel=1e-9, abs=1e-9)
    assert cmp["energy_saved_percent"] >= 0.0  # the optimum costs no more than any path
    assert _length(rm, short) <= _length(rm, opt) + 1e-12
    # the re-simulation (simulate_edge) of the shortest path agrees with its roadmap energy
    np.testing.assert_allclose(cmp["shortest_path"]["energy_per_joint_simulate_edge"],
                               e_short, rtol=1e-6)


def test_replan_scenario_before_obstacle_and_executed(replan):
    result, _, rm = replan
    g = _digraph(rm)
    cmp = result["comparison"]
    assert cmp["basis"] == "executed"
    before = cmp["before_obstacle"]
    opt0 = nx.dijkstra_path(g, rm.start, rm.goal, weight="energy")
    short0 = nx.dijkstra_path(g, rm.start, rm.goal, weight="length")
    assert before["optimal"]["nodes"] == opt0 == result["execution"]["initial_path"]
    assert before["shortest_path"]["nodes"] == short0
    e0, s0 = _energy(g, rm, opt0).sum(), _energy(g, rm, short0).sum()
    assert before["energy_saved_percent"] == pytest.approx(100 * (1 - e0 / s0), rel=1e-9)
    assert opt0 != short0 and before["energy_saved_percent"] > 0
    # executed motions: each a roadmap path start -> goal; energies are its edges' sums
    travelled = cmp["shortest_path"]["nodes"]
    assert travelled[0] == rm.start and travelled[-1] == rm.goal
    assert travelled != short0  # the shortest plan met the hidden obstacle too, and was repaired
    e_short = _energy(g, rm, travelled)
    np.testing.assert_allclose(cmp["shortest_path"]["energy_per_joint"], e_short, rtol=1e-12)
    e_opt = _energy(g, rm, result["path"]["nodes"]).sum()
    assert result["total_energy"] == pytest.approx(e_opt, rel=1e-12)
    assert cmp["energy_saved_percent"] == pytest.approx(100 * (1 - e_opt / e_short.sum()),
                                                        rel=1e-9)


def _csv(out):
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    return header, np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)


@pytest.mark.parametrize("which", ["case4", "replan"])
def test_trajectory_csv(which, request):
    result, out, rm = request.getfixturevalue(which)
    names = result["joint_names"]
    header, a = _csv(out)
    assert header == trajectory_columns(names)
    col = {h: a[:, k] for k, h in enumerate(header)}
    t = col["t"]
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    dt = result["roadmap"]["options"]["dt"]
    np.testing.assert_allclose(np.diff(t), dt, rtol=1e-6)  # one time base, no duplicates
    assert t[-1] == pytest.approx(result["verification"]["duration"], rel=1e-9)
    q = np.column_stack([col[f"q_{n}"] for n in names])
    np.testing.assert_allclose(q[0], result["start"], atol=1e-9)
    tol = result["roadmap"]["options"]["arrival_tolerance"]
    assert np.abs(q[-1] - np.array(result["goal"])).max() <= tol
    # E⁺ = ∫ max(V·i, 0) dt by the trapezoid rule on the step samples, against the RK4
    # integral: measured relative differences ≤ 1.2e-3 on the built-in scenarios (the
    # trapezoid's O(dt²) error on a power that has kinks where V·i changes sign and jumps
    # at the edge joins, where each edge restarts its reference); 3e-3 leaves margin.
    E = np.array([np.trapezoid(np.maximum(col[f"V_{n}"] * col[f"i_{n}"], 0.0), t)
                  for n in names])
    ref = np.array(result["verification"]["energy_per_joint_simulate_edge"])
    np.testing.assert_allclose(E, ref, rtol=3e-3)
    # and it is the E⁺ of the path reported (roadmap energies)
    np.testing.assert_allclose(ref, result["energy_per_joint"], rtol=1e-6)


@pytest.mark.parametrize("which", ["case4", "replan"])
def test_trajectory_json(which, request):
    result, out, _ = request.getfixturevalue(which)
    traj = json.loads((out / "trajectory.json").read_text())
    names = result["joint_names"]
    assert traj["joint_names"] == names
    rate = traj["rate_hz"]
    assert rate == 100.0 == result["trajectory"]["json_rate_hz"]
    ts = np.array([p["time_from_start"] for p in traj["points"]])
    steps = np.diff(ts)
    assert np.all(steps > 0)
    np.testing.assert_allclose(steps[:-1], 1.0 / rate, rtol=1e-9)
    assert 0 < steps[-1] <= 1.0 / rate + 1e-12
    header, a = _csv(out)
    col = {h: a[:, k] for k, h in enumerate(header)}
    assert ts[-1] == pytest.approx(col["t"][-1], abs=1e-9)
    for k, n in enumerate(names):
        P = np.array([p["positions"][k] for p in traj["points"]])
        np.testing.assert_allclose(P, np.interp(ts, col["t"], col[f"q_{n}"]), atol=1e-8)
        eff = np.array([p["effort"][k] for p in traj["points"]])
        np.testing.assert_allclose(eff, np.interp(ts, col["t"], col[f"tau_{n}"]),
                                   rtol=1e-7, atol=1e-8)
    assert all(len(p["accelerations"]) == len(names) for p in traj["points"])


def test_joint_trajectory_rate_and_accelerations():
    # q = t³ on [0, 1.234] s at 1 kHz: sampled at 50 Hz, then the end sample
    t = np.arange(1235) * 1e-3
    series = {"t": t, "q": (t**3)[:, None], "v": (3 * t**2)[:, None],
              "i": np.ones((len(t), 1)), "V": np.zeros((len(t), 1))}
    traj = joint_trajectory(["j"], series, np.array([2.0]), rate=50.0)
    ts = np.array([p["time_from_start"] for p in traj["points"]])
    np.testing.assert_allclose(ts[:-1], np.arange(62) / 50.0, atol=1e-12)
    assert ts[-1] == pytest.approx(1.234)
    acc = np.array([p["accelerations"][0] for p in traj["points"]])
    np.testing.assert_allclose(acc[1:-1], 6 * ts[1:-1], atol=1e-3)  # central differences
    assert all(p["effort"] == [2.0] for p in traj["points"])  # n·Kt·i
    with pytest.raises(ValueError, match="rate"):
        joint_trajectory(["j"], series, np.array([2.0]), rate=0.0)


def test_unwritable_output_folder(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    status = main(["run", "case1", "--out", str(blocker / "sub"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert status == 2
    assert len(err.splitlines()) == 1 and "cannot be written" in err
    assert blocker.read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
