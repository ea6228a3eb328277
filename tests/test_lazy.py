"""Lazy energy roadmaps (docs/design.md §4g, §5f): the lazy optimum is the eager one.

References: an eager roadmap and its MPD* Lite path (the same roadmap fully simulated),
networkx Dijkstra on random graphs with random true costs, and sequences of single
``update_edge`` calls for the batched ``update_edges``.
"""

import math
from dataclasses import replace
from types import SimpleNamespace

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.plan import plan_path, plan_shortest, prepare
from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EdgeOutcomes, EnergyCost, edge_outcomes
from mpd_pin.dynamics.bound import EnergyBound
from mpd_pin.planning.lazy import SAFETY, LazyEdges, lazy_plan
from mpd_pin.planning.roadmap import Roadmap, RoadmapOptions, build_roadmap, feasibility
from mpd_pin.search import Graph, MPDStarLite
from mpd_pin.world import Box, World

START = np.array([0.6, 0.3, 0.2])
GOAL = np.array([2.4, -0.3, -0.2])
WALL = World((Box.planar((0.0, 0.9), 0.3, 0.4, name="wall"),))


@pytest.fixture(scope="module")
def planar():
    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(9.0), kp=40.0, kd=4.0)
    return arm, drive


def _roadmaps(arm, drive, options, cache=None):
    cost = EnergyCost(drive, options.dt)
    checker = CollisionChecker(arm, WALL)
    eager = build_roadmap(cost, checker, START, GOAL, options, show_progress=False)
    lazy = build_roadmap(cost, checker, START, GOAL, options, show_progress=False,
                         evaluate=False, cache=cache)
    return cost, eager, lazy


# ----------------------------------------------------------------- lazy == eager
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_lazy_equals_eager_on_small_roadmaps(planar, seed):
    arm, drive = planar
    opts = RoadmapOptions(num_nodes=60, k=8, seed=seed, duration=0.5, dt=0.01)
    cost, eager, lazy_rm = _roadmaps(arm, drive, opts)
    assert lazy_rm.key == eager.key  # one key: a lazy file serves an eager run and back
    ref = MPDStarLite(eager.graph(), eager.start, eager.goal).plan()
    lz = LazyEdges(lazy_rm, cost, opts)
    path, _ = lazy_plan(lz, MPDStarLite)
    assert path.nodes == ref.nodes
    e_lazy, e_eager = lazy_rm.path_energy(path.nodes), eager.path_energy(ref.nodes)
    np.testing.assert_array_equal(e_lazy, e_eager)  # bit-identical rows in any batch
    assert path.cost == pytest.approx(ref.cost, rel=1e-12)
    # evaluated edges carry exactly the eager energies; far from all were simulated
    ev = np.flatnonzero(lazy_rm.evaluated)
    lookup = {(u, v): e for e, (u, v) in enumerate(zip(eager.src, eager.dst, strict=True))}
    rows = [lookup[(lazy_rm.src[e], lazy_rm.dst[e])] for e in ev]
    np.testing.assert_array_equal(lazy_rm.energy[ev], eager.energy[rows])
    assert 0 < lz.count.simulated < 0.5 * lazy_rm.num_edges
    assert lz.count.violations == 0
    rec = lz.record()
    assert rec["rounds"] >= 1 and 0 < rec["bound_median_ratio"] < 1


# ------------------------------------------------------- random graphs vs networkx
class _TableCost:
    """The 'simulator' of a random graph: its true edge costs (J) looked up by node pair;
    nodes are 1-D points, so a row of Q0 names its node."""

    def __init__(self, true: dict, nq: int = 1):
        self.true = true
        self.calls = 0
        model = SimpleNamespace(effortLimit=np.full(nq, np.inf))
        self.drive = SimpleNamespace(arm=SimpleNamespace(model=model))

    def outcomes(self, Q0, Q1, durations, progress=None):
        self.calls += 1
        e = np.array([[self.true[(int(a), int(b))]] for a, b in zip(Q0[:, 0], Q1[:, 0],
                                                                     strict=True)])
        z = np.zeros_like(e)
        return EdgeOutcomes(e, e, z, z, z, np.zeros((len(e), 2)))


def _random_lazy(seed, n=120, p=0.06, overestimate=None):
    rng = np.random.default_rng(seed)
    G = nx.gnp_random_graph(n, p, seed=seed, directed=True)
    src = np.array([u for u, _ in G.edges], dtype=np.int64)
    dst = np.array([v for _, v in G.edges], dtype=np.int64)
    true = rng.uniform(0.1, 10.0, src.size)
    lower = true * rng.uniform(0.0, 1.0, src.size)
    if overestimate is not None:
        lower = true * overestimate
    rm = Roadmap(nodes=np.arange(n, dtype=float)[:, None], start=0, goal=n - 1, src=src,
                 dst=dst, durations=np.ones(src.size), energy=np.full((src.size, 1), np.nan),
                 key="random")
    cost = _TableCost({(int(u), int(v)): float(c) for u, v, c in zip(src, dst, true,
                                                                   strict=True)})
    opts = RoadmapOptions(effort_limits=False, arrival_tolerance=1.0)
    bound = lambda Q0, Q1, T: lower  # noqa: E731 - one bound value per edge, in edge order
    for u, v, c in zip(src.tolist(), dst.tolist(), true.tolist(), strict=True):
        G[u][v]["weight"] = c
    return G, LazyEdges(rm, cost, opts, bound=bound), cost


@pytest.mark.parametrize("seed", range(8))
def test_lazy_on_random_graphs_equals_networkx(seed):
    G, lz, cost = _random_lazy(seed)
    try:
        ref = nx.dijkstra_path(G, 0, lz.roadmap.goal)
    except nx.NetworkXNoPath:
        pytest.fail("no path in this random graph: choose another seed")  # seeds chosen
    path, _ = lazy_plan(lz, MPDStarLite)
    assert path.nodes == ref
    assert path.cost == pytest.approx(nx.path_weight(G, ref, "weight"), rel=1e-12)
    assert lz.count.simulated < lz.roadmap.num_edges and cost.calls == lz.count.rounds
    assert lz.count.violations == 0 and lz.worst_ratio is None


@pytest.mark.parametrize("seed", range(4))
def test_injected_violation_is_detected_and_the_answer_stays_optimal(seed):
    G, lz, _ = _random_lazy(seed, overestimate=1.3)  # every bound 30 % above the truth
    ref = nx.dijkstra_path(G, 0, lz.roadmap.goal)
    path, _ = lazy_plan(lz, MPDStarLite)
    assert path.nodes == ref
    assert lz.count.violations >= 1
    assert lz.worst_ratio == pytest.approx(1.3, rel=1e-12)
    assert lz.scale == pytest.approx(SAFETY / 1.3, rel=1e-12)
    rec = lz.record()
    assert rec["bound_violations"] == lz.count.violations
    assert rec["bound_worst_ratio"] == pytest.approx(1.3)


def test_injected_violation_on_a_real_roadmap(planar):
    arm, drive = planar
    opts = RoadmapOptions(num_nodes=60, k=8, seed=4, duration=0.5, dt=0.01)
    cost, eager, lazy_rm = _roadmaps(arm, drive, opts)
    ref = MPDStarLite(eager.graph(), eager.start, eager.goal).plan()
    real = EnergyBound(drive, arrival_tolerance=opts.arrival_tolerance)
    lz = LazyEdges(lazy_rm, cost, opts, bound=lambda *a: 4.0 * real(*a))  # overestimates
    path, _ = lazy_plan(lz, MPDStarLite)
    assert lz.count.violations >= 1 and lz.worst_ratio > 1.0 and lz.scale < 1.0
    assert path.nodes == ref.nodes
    assert lazy_rm.path_energy(path.nodes).sum() == pytest.approx(ref.cost, rel=1e-12)


# ---------------------------------------------------------------- the bound itself
def _random_edges(arm, K, seed):
    rng = np.random.default_rng(seed)
    lo, hi = arm.lower_limits, arm.upper_limits
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    Q0 = rng.uniform(lo, hi, (K, arm.nq))
    Q1 = np.clip(Q0 + rng.normal(0.0, 0.5, (K, arm.nq)), lo, hi)
    return Q0, Q1


@pytest.mark.parametrize("case", ["paper", "servo", "sized", "panda"])
def test_bound_below_true_energy_on_simulated_edges(case):
    if case == "panda":
        arm = mp.Arm.from_example_robot_data("panda")
        motor = mp.DCMotor(R=1.0, L=0.01, Kt=0.1, Ke=0.1, B=1e-6, J=1e-4, gear_ratio=100.0,
                           v_max=24.0)
        drive, K = mp.Drive(arm, motor, kp=20.0, kd=1.0), 150
    else:
        arm = mp.builtin_arm("planar_3link")
        motors = {"paper": mp.PAPER_MOTOR.with_gear_ratio(9.0), "servo": mp.SERVO_MOTOR,
                  "sized": mp.sized_motors(arm)}[case]
        gains = {"paper": (40.0, 4.0), "servo": (20.0, 1.0), "sized": (20.0, 1.0)}[case]
        drive, K = mp.Drive(arm, motors, kp=gains[0], kd=gains[1]), 300
    opts = RoadmapOptions(duration=1.0, dt=5e-3)
    Q0, Q1 = _random_edges(arm, K, seed=len(case))
    T, _ = opts.timing(Q0, Q1, arm.model.velocityLimit)
    out = edge_outcomes(drive, Q0, Q1, T, opts.dt)
    over, missed = feasibility(out, opts, arm.model)
    ok = ~(over | missed)
    assert ok.sum() >= K // 3  # enough feasible edges to test on
    bound = EnergyBound(drive, arrival_tolerance=opts.arrival_tolerance)
    lb = bound(Q0[ok], Q1[ok], T[ok])
    true = out.energy[ok].sum(axis=1)
    assert np.all(lb >= 0)
    assert np.all(lb <= true), (lb / true).max()
    assert np.median(lb / np.maximum(true, 1e-300)) > 0.05  # and it is not trivial


def test_bound_parts_and_moments(planar):
    _, drive = planar
    Q0, Q1 = _random_edges(drive.arm, 50, seed=9)
    T = np.full(50, 1.0)
    one = EnergyBound(drive)
    two = EnergyBound(drive, moments=2)
    # Bessel: more Legendre moments of the current can only raise the copper term
    assert np.all(two.parts(Q0, Q1, T)["copper"] >= one.parts(Q0, Q1, T)["copper"] - 1e-9)
    assert one.uniform_ratio and one.rho == pytest.approx(2.0)
    with pytest.raises(ValueError, match="moments"):
        EnergyBound(drive, moments=0)
    # the PE margin's |G_k| bound holds at random configurations (and is nearly reached)
    rng = np.random.default_rng(0)
    arm = drive.arm
    G = np.array([arm.gravity(rng.uniform(arm.lower_limits, arm.upper_limits))
                  for _ in range(500)])
    gmax = one._gmax
    assert np.all(np.abs(G) <= gmax) and np.all(np.abs(G).max(axis=0) >= 0.9 * gmax)


# ------------------------------------------------------------ batched edge updates
@pytest.mark.parametrize("seed", range(6))
def test_update_edges_equals_sequence_of_update_edge(seed):
    rng = np.random.default_rng(seed)
    n = 200
    G = nx.gnp_random_graph(n, 0.05, seed=seed, directed=True)
    edges = [(u, v, float(rng.uniform(0.1, 5.0))) for u, v in G.edges]
    a = MPDStarLite(Graph(n, edges), 0, n - 1)
    b = MPDStarLite(Graph(n, edges), 0, n - 1)
    pa, pb = a.plan(), b.plan()
    assert pa.nodes == pb.nodes
    for rnd in range(5):
        picks = rng.choice(len(edges), size=40, replace=False)
        changes = []
        for j in picks:
            u, v, _ = edges[j]
            c = math.inf if rng.random() < 0.3 else float(rng.uniform(0.0, 6.0))
            changes.append((u, v, c))
        changes += changes[:3]  # repeated edges: the last cost wins in both
        for u, v, c in changes:
            a.update_edge(u, v, c)
        if rnd % 2:
            b.update_edges(changes)
        else:  # the array form
            b.update_edges(tuple(np.array(x) for x in zip(*changes, strict=True)))
        if rnd == 3:  # the robot moved: km once per batch in both
            nxt = pa.nodes[1] if len(pa.nodes) > 1 else pa.nodes[0]
            a.move_start(nxt)
            b.move_start(nxt)
        try:
            pa = a.plan()
        except mp.NoPathError:
            with pytest.raises(mp.NoPathError):
                b.plan()
            continue
        pb = b.plan()
        assert pa.nodes == pb.nodes and pa.cost == pb.cost
        for s in range(n):
            assert a.g(s) == b.g(s)
        # and both are optimal on the changed graph
        H = nx.DiGraph()
        for u, v, c in zip(*a.graph.to_arrays(), strict=True):
            if math.isfinite(c):
                H.add_edge(int(u), int(v), weight=float(c))
        assert pa.cost == pytest.approx(
            nx.dijkstra_path_length(H, a.start, n - 1), rel=1e-12)


def test_update_edges_validates_before_changing_anything():
    g = Graph(3, [(0, 1, 1.0), (1, 2, 1.0), (0, 2, 5.0)])
    p = MPDStarLite(g, 0, 2)
    assert p.plan().nodes == [0, 1, 2]
    with pytest.raises(ValueError, match="NaN"):
        p.update_edges([(0, 1, 2.0), (1, 2, float("nan"))])
    with pytest.raises(KeyError, match="no edge 2 -> 0"):
        p.update_edges([(0, 1, 2.0), (2, 0, 1.0)])
    assert g.cost(0, 1) == 1.0  # nothing changed
    p.update_edges([(0, 1, math.inf)])
    assert p.plan().nodes == [0, 2]
    big = [(0, 1, 3.0)] * 60 + [(1, 2, 0.5)]  # numpy look-up path
    p.update_edges(big)
    assert p.plan().nodes == [0, 1, 2] and p.plan().cost == 3.5


# ------------------------------------------------------------------ roadmap files
def test_nan_energies_round_trip_and_a_second_query_reuses_them(planar, tmp_path):
    arm, drive = planar
    opts = RoadmapOptions(num_nodes=60, k=8, seed=5, duration=0.5, dt=0.01)
    cache = tmp_path / "rm.npz"
    cost, eager, rm = _roadmaps(arm, drive, opts, cache=cache)
    assert np.isnan(rm.energy).all() and cache.exists()
    lz = LazyEdges(rm, cost, opts)
    path, _ = lazy_plan(lz, MPDStarLite)
    first = lz.count.simulated - lz.count.refused  # refused edges are dropped from the file
    lz.save(cache)
    back = Roadmap.load(cache, expected_key=rm.key, nq=3)
    assert int(back.evaluated.sum()) == first
    assert back.num_edges == rm.num_edges - lz.count.refused
    assert back.edge_counts == rm.edge_counts
    np.testing.assert_array_equal(back.energy[back.evaluated], rm.energy[rm.evaluated])
    np.testing.assert_array_equal(back.src[back.evaluated], rm.src[rm.evaluated])
    assert np.isnan(back.energy[~back.evaluated]).all()
    # a second lazy query on the file simulates nothing and finds the same path
    again = build_roadmap(cost, CollisionChecker(arm, WALL), START, GOAL, opts,
                          show_progress=False, evaluate=False, cache=cache)
    lz2 = LazyEdges(again, cost, opts)
    path2, _ = lazy_plan(lz2, MPDStarLite)
    assert path2.nodes == path.nodes and lz2.count.simulated == 0 and lz2.reused == first
    assert lz2.edges_evaluated == first
    # an eager run on the lazy file evaluates the rest and equals a fresh eager build
    full = build_roadmap(cost, CollisionChecker(arm, WALL), START, GOAL, opts,
                         show_progress=False, cache=cache)
    assert full.evaluated.all()
    order = np.lexsort((full.dst, full.src))
    ref = np.lexsort((eager.dst, eager.src))
    np.testing.assert_array_equal(full.src[order], eager.src[ref])
    np.testing.assert_array_equal(full.energy[order], eager.energy[ref])
    assert Roadmap.load(cache, expected_key=rm.key).evaluated.all()


def test_roadmap_file_refuses_inf_and_partial_nan(planar, tmp_path):
    arm, drive = planar
    opts = RoadmapOptions(num_nodes=20, k=4, seed=0, duration=0.5, dt=0.01)
    _, _, rm = _roadmaps(arm, drive, opts)
    for bad, what in ((math.inf, "finite"), ("partial", "NaN in every joint")):
        e = np.array(rm.energy)
        e[0] = 1.0
        if bad == "partial":
            e[0, 1] = np.nan
        else:
            e[0, 0] = bad
        path = replace(rm, energy=e).save(tmp_path / f"bad_{what[:3]}.npz")
        with pytest.raises(ValueError, match=what):
            Roadmap.load(path)


# --------------------------------------------------------------- scenarios, CLI
def _scenario(name, evaluation):
    scn = parse_energy_scenario(load_scenario_data(builtin_scenarios()[name]))
    return replace(scn, evaluation=evaluation)


@pytest.mark.parametrize("name", ["replan", "hazard"])
def test_replan_and_hazard_scenarios_lazy_equal_eager(name):
    res = {}
    for ev in ("eager", "lazy"):
        scn = _scenario(name, ev)
        setup = prepare(scn, show_progress=False)
        plan = plan_path(scn, setup)
        short = plan_shortest(scn, setup)
        res[ev] = (setup, plan, short)
    (se, pe, she), (sl, pl, shl) = res["eager"], res["lazy"]
    assert sl.lazy is not None and se.lazy is None
    assert pl.path == pe.path
    np.testing.assert_allclose(pl.energy, pe.energy, rtol=1e-12)
    assert shl.path == she.path
    np.testing.assert_allclose(shl.energy, she.energy, rtol=1e-12)
    if name == "replan":
        assert pl.execution.initial_path == pe.execution.initial_path
        assert len(pl.execution.replans) == len(pe.execution.replans) >= 1
        for a, b in zip(pl.execution.replans, pe.execution.replans, strict=True):
            assert a.path_after == b.path_after
    else:
        assert pl.hazard.first_path == pe.hazard.first_path
        assert pl.hazard.final_path == pe.hazard.final_path
    assert sl.lazy.count.simulated < 0.2 * sl.roadmap.num_edges


def test_evaluation_key_and_cli(tmp_path, capsys):
    data = load_scenario_data(builtin_scenarios()["case1"])
    assert parse_energy_scenario(data).evaluation == "lazy"
    data["roadmap"]["evaluation"] = "bogus"
    with pytest.raises(ConfigError, match=r"roadmap\.evaluation: 'bogus' is not one of"):
        parse_energy_scenario(data)
    toml = builtin_scenarios()["case1"].read_text().replace(
        "[roadmap]", '[roadmap]\nevaluation = "bogus"')
    f = tmp_path / "bogus.toml"
    f.write_text(toml)
    assert main(["run", str(f), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "roadmap.evaluation" in err
    # --evaluation overrides the key; it does not apply to paper-002 scenarios
    assert main(["run", "env1", "--out", str(tmp_path / "e"), "--quiet",
                 "--evaluation", "eager"]) == 2
    assert "--evaluation does not apply" in capsys.readouterr().err


def test_result_json_fields_lazy_eager_and_cache_reuse(tmp_path, case1_cached):
    """case1 lazy with a roadmap file (the session's shared run, conftest.case1_cached),
    again on (a copy of) that file, and eager."""
    import json
    import shutil

    _, lazy_out, shared_cache = case1_cached
    cache = tmp_path / "rm.npz"
    shutil.copyfile(shared_cache, cache)
    runs = {"lazy": json.loads((lazy_out / "result.json").read_text())}
    # evaluation only: the shared run checks every edge first (--collision eager), so that
    # the edge counts compare (lazy collision checking: tests/test_lazy_collision.py)
    for tag, extra in (("again", ["--cache", str(cache), "--collision", "eager"]),
                       ("eager", ["--evaluation", "eager"])):
        out = tmp_path / tag
        assert main(["run", "case1", "--out", str(out), "--quiet", "--no-replay", *extra]) == 0
        runs[tag] = json.loads((out / "result.json").read_text())
    lazy, again, eager = (runs[k]["roadmap"] for k in ("lazy", "again", "eager"))
    assert lazy["evaluation"] == again["evaluation"] == "lazy" and eager["evaluation"] == "eager"
    assert lazy["num_edges"] == again["num_edges"] == eager["num_edges"]  # none refused here
    assert eager["edges_evaluated"] == eager["num_edges"]
    assert eager["lazy"] == {"rounds": 0, "bound_median_ratio": None, "bound_violations": 0,
                             "bound_worst_ratio": None}
    assert 0 < lazy["edges_evaluated"] == lazy["lazy"]["simulated"] < 0.05 * lazy["num_edges"]
    assert lazy["lazy"]["rounds"] >= 1 and lazy["lazy"]["bound_violations"] == 0
    assert 0 < lazy["lazy"]["bound_median_ratio"] < 1
    # the second query reuses the file: nothing simulated, the same answer
    assert again["lazy"]["simulated"] == 0 and again["lazy"]["rounds"] == 0
    assert again["edges_evaluated"] == again["lazy"]["reused"] == lazy["edges_evaluated"]
    for r in (runs["again"], runs["eager"]):
        assert r["path"]["nodes"] == runs["lazy"]["path"]["nodes"]
        assert r["total_energy"] == runs["lazy"]["total_energy"]
        assert r["comparison"]["shortest_path"]["total_energy"] == \
            runs["lazy"]["comparison"]["shortest_path"]["total_energy"]
    assert runs["lazy"]["seconds_per_phase"]["roadmap_edge_energies"] > 0


def test_finite_hazard_penalty_runs_eagerly():
    scn = replace(_scenario("hazard", "lazy"), hazard_penalty=5.0)
    setup = prepare(scn, show_progress=False)
    assert setup.evaluation == "eager" and setup.lazy is None and setup.notes
    assert setup.roadmap.evaluated.all()


@pytest.mark.parametrize("motor", ["paper", "servo"])
def test_rigorous_bound_without_feedforward(motor):
    arm = mp.builtin_arm("planar_3link")
    m, kp, kd = {"paper": (mp.PAPER_MOTOR.with_gear_ratio(9.0), 400.0, 40.0),
                 "servo": (mp.SERVO_MOTOR, 200.0, 5.0)}[motor]
    opts = RoadmapOptions(arrival_tolerance=0.1)
    Q0, Q1 = _random_edges(arm, 300, seed=1)
    T, _ = opts.timing(Q0, Q1, arm.model.velocityLimit)
    for ff in (False, True):
        drive = mp.Drive(arm, m, kp=kp, kd=kd, feedforward=ff)
        out = edge_outcomes(drive, Q0, Q1, T, opts.dt)
        over, missed = feasibility(out, opts, arm.model)
        ok = ~(over | missed)
        assert ok.sum() >= 10
        bound = EnergyBound(drive, arrival_tolerance=opts.arrival_tolerance, rigorous=True)
        assert bound.proven and EnergyBound(drive).rigorous == (not ff)
        lb = bound(Q0[ok], Q1[ok], T[ok])
        assert np.all(lb <= out.energy[ok].sum(axis=1))
