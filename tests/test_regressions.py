"""Tests that catch regressions the rest of the suite let through (issue 26).

Each test fails on a deliberate small change to the code ("mutation") and passes on the
code as it is; the mutations it was checked against are named in its docstring. Those of
sections 1-3 left the rest of the suite green (issue 26); section 4 gives the stiff-current
check of tests/test_energy_sympy.py a reference that is not the code under test.

References: networkx Dijkstra on the true edge costs (lazy evaluation, docs/design.md
§4g), spies on the planner registry and result.json (scenario wiring, §7b, §4h),
``simulate_edge`` on the shorter-way targets computed here (continuous joints, §1d) and
the independent sympy RK4 of tests/test_energy_sympy.py (edge energies, §3).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.dynamics import EdgeOutcomes
from mpd_pin.planning.lazy import SAFETY, LazyEdges, lazy_plan
from mpd_pin.planning.roadmap import Roadmap, RoadmapOptions
from mpd_pin.search import PLANNERS, MPDStarLite

try:  # tests/ is on sys.path under pytest's default (rootdir-less, "prepend") import mode
    from conftest import read_result
except ImportError:  # pragma: no cover - if tests/ ever becomes a package
    from tests.conftest import read_result


# ============================================================ 1. lazy bound violations
class _KnownCost:
    """The 'simulator' of a synthetic roadmap: true E⁺ (J) per directed edge, looked up by
    node pair (nodes are 1-D points: a row of Q0 names its node). One joint, no limits."""

    def __init__(self, src, dst, true):
        self.true = {(int(u), int(v)): float(c) for u, v, c in zip(src, dst, true, strict=True)}
        model = SimpleNamespace(effortLimit=np.full(1, np.inf))
        self.drive = SimpleNamespace(arm=SimpleNamespace(model=model))

    def outcomes(self, Q0, Q1, durations, progress=None):
        e = np.array([[self.true[(int(a), int(b))]] for a, b in zip(Q0[:, 0], Q1[:, 0],
                                                                     strict=True)])
        zero = np.zeros_like(e)
        return EdgeOutcomes(e, e, zero, zero, zero, np.zeros((len(e), 2)))


def _synthetic(seed: int, ratio: tuple[float, float], n: int = 120, p: float = 0.06):
    """A random directed roadmap with random true costs and per-edge bounds
    ``true × U(*ratio)``: (networkx graph weighted by the true costs, roadmap with NaN
    energies, cost, true costs, bounds)."""
    rng = np.random.default_rng(seed)
    G = nx.gnp_random_graph(n, p, seed=seed, directed=True)
    src = np.array([u for u, _ in G.edges], dtype=np.int64)
    dst = np.array([v for _, v in G.edges], dtype=np.int64)
    true = rng.uniform(0.1, 10.0, src.size)
    lower = true * rng.uniform(*ratio, src.size)
    for u, v, c in zip(src.tolist(), dst.tolist(), true.tolist(), strict=True):
        G[u][v]["weight"] = c
    rm = Roadmap(nodes=np.arange(n, dtype=float)[:, None], start=0, goal=n - 1, src=src,
                 dst=dst, durations=np.ones(src.size), energy=np.full((src.size, 1), np.nan),
                 key=f"synthetic-{seed}")
    return G, rm, _KnownCost(src, dst, true), true, lower


_OPTIONS = RoadmapOptions(effort_limits=False, arrival_tolerance=1.0)


def _lazy(rm, cost, lower) -> LazyEdges:
    return LazyEdges(rm, cost, _OPTIONS, bound=lambda Q0, Q1, T: lower)  # edge order


def _optimum(G, goal) -> float:
    return nx.dijkstra_path_length(G, 0, goal, weight="weight")


def test_per_edge_overestimates_still_give_the_optimum():
    """Bounds that overestimate by a different factor on every edge (true × U(0.2, 2)):
    LazySP's path costs the networkx optimum on each of 40 seeds.

    Catches: after a violation, not pushing the rescaled bounds of every unevaluated
    edge to the planner (``CostView.settle``'s ``np.union1d``): the planner then keeps
    the old, too high bounds (measured: a worse path on 10 of these 40 seeds)."""
    wrong, checked, rescaled = [], 0, 0
    for seed in range(41):
        G, rm, cost, _, lower = _synthetic(seed, (0.2, 2.0))
        if not nx.has_path(G, 0, rm.goal):
            continue  # seed 40's random graph has none
        checked += 1
        lz = _lazy(rm, cost, lower)
        path, _ = lazy_plan(lz, MPDStarLite)
        ref = _optimum(G, rm.goal)
        assert path.cost == pytest.approx(rm.path_energy(path.nodes).sum(), rel=1e-12)
        if not path.cost == pytest.approx(ref, rel=1e-12):
            wrong.append((seed, path.cost, ref))
        rescaled += lz.scale < 1.0
    assert checked == 40 and rescaled >= 35  # nearly every one had a violation to correct
    assert not wrong, f"(seed, lazy cost, optimum) not optimal: {wrong}"


def test_reused_energies_below_their_bounds_rescale():
    """Energies already in the roadmap (as from a cache file) below their bounds are
    violations: counted, the scale lowered at once, and the answer is the optimum.

    Catches: not checking reused edges against their bounds (``LazyEdges.__init__``'s
    ``if self.reused: self._check(...)``)."""
    G, rm, cost, true, lower = _synthetic(3, (0.0, 1.0))  # a valid bound everywhere …
    rng = np.random.default_rng(33)
    known = rng.random(rm.num_edges) < 0.3
    ratio = rng.uniform(1.1, 1.6, rm.num_edges)
    lower = np.where(known, true * ratio, lower)  # … except on the edges read "from a file"
    rm.energy[known, 0] = true[known]
    worst = float(ratio[known].max())
    lz = _lazy(rm, cost, lower)
    assert lz.reused == int(known.sum()) > 0
    assert lz.count.violations == int(known.sum())  # each of them, before any search
    assert lz.worst_ratio == pytest.approx(worst, rel=1e-12)
    assert lz.scale == pytest.approx(SAFETY / worst, rel=1e-12)
    unknown = ~known
    np.testing.assert_allclose(lz.energy_costs()[unknown], lz.scale * lower[unknown],
                               rtol=1e-15)
    path, _ = lazy_plan(lz, MPDStarLite)
    assert path.cost == pytest.approx(_optimum(G, rm.goal), rel=1e-12)
    rec = lz.record()
    assert rec["reused"] == int(known.sum()) and rec["bound_violations"] >= int(known.sum())
    assert rec["bound_scale"] < 1.0


def test_zero_energy_edge_above_its_bound_drops_every_bound_to_zero():
    """An edge whose true E⁺ is 0 J but whose bound is positive (ratio ∞): once it is
    evaluated the scale is 0, every unevaluated bound is 0 J, and the path is still the
    optimum.

    Catches: removing the scale-to-0 rule for a ratio of ∞ in ``LazyEdges._check``."""
    G, rm, cost, true, lower = _synthetic(5, (0.0, 1.0))
    out = np.flatnonzero(rm.src == rm.start)
    assert out.size >= 2
    true[out] = 0.0  # every edge out of the start is free, but bounded at 1 J
    lower[out] = 1.0
    cost = _KnownCost(rm.src, rm.dst, true)
    for e in out.tolist():
        G[int(rm.src[e])][int(rm.dst[e])]["weight"] = 0.0
    lz = _lazy(rm, cost, lower)
    path, _ = lazy_plan(lz, MPDStarLite)  # its first edge leaves the start: evaluated
    assert lz.count.violations >= 1 and lz.worst_ratio == math.inf
    assert lz.scale == 0.0
    pending = ~rm.evaluated & ~lz.refused
    assert pending.any() and np.all(lz.energy_costs()[pending] == 0.0)
    assert path.cost == pytest.approx(_optimum(G, rm.goal), rel=1e-12, abs=1e-12)
    assert lz.record()["bound_scale"] == 0.0


# ======================================================== 2. scenario and CLI wiring
def _scenario_text(capsys, extra: str = "") -> str:
    """``mpd-pin show case1`` with a small roadmap, plus ``extra`` tables."""
    assert main(["show", "case1"]) == 0
    text = capsys.readouterr().out
    assert "num_nodes = 150" in text and "[planner]" not in text
    return text.replace("num_nodes = 150", "num_nodes = 40") + extra


@pytest.fixture
def no_plots(monkeypatch):
    """Runs without their PNG plots (seconds of matplotlib that these tests do not read)."""
    monkeypatch.setattr("mpd_pin.app.planned.write_plots", lambda *a, **k: [])


@pytest.fixture
def planner_spies(monkeypatch):
    """Every registered planner replaced by a subclass that records its instantiations
    (``PLANNERS`` is the one dict the scenario reader, the CLI and the runner share)."""
    made: list[str] = []
    for name, cls in list(PLANNERS.items()):
        def init(self, *args, _name=name, _cls=cls, **kwargs):
            made.append(_name)
            _cls.__init__(self, *args, **kwargs)

        monkeypatch.setitem(PLANNERS, name, type(f"Spy{cls.__name__}", (cls,),
                                                 {"__init__": init}))
    return made


def test_planner_named_in_the_scenario_file_and_on_the_cli_is_the_one_built(
        tmp_path, capsys, planner_spies, no_plots):
    """``[planner] algorithm = "astar"`` in a TOML file (a lazy run), and ``--planner
    dstar`` over it (an eager one), are the planners that search (every search of the
    run: plan and shortest path).

    Catches: ``_plan_lazy`` (lazy run) or ``_plan_on`` (eager run) using
    ``PLANNERS["mpdstar"]`` whatever the scenario says."""
    scn = tmp_path / "astar.toml"
    scn.write_text(_scenario_text(capsys, '\n[planner]\nalgorithm = "astar"\n'))
    for label, extra, expected in (("file", [], "astar"),
                                   ("cli", ["--planner", "dstar", "--evaluation", "eager"],
                                    "dstar")):
        planner_spies.clear()
        out = tmp_path / label
        assert main(["run", str(scn), "--out", str(out), "--quiet", "--no-replay",
                     *extra]) == 0
        capsys.readouterr()
        assert planner_spies and set(planner_spies) == {expected}, planner_spies
        res = read_result(out)
        assert res["planner"] == expected, res["planner"]
        assert res["roadmap"]["evaluation"] == ("lazy" if label == "file" else "eager")


def test_compute_scheduler_from_the_scenario_file_reaches_the_run(tmp_path, capsys, no_plots):
    """``[compute] scheduler = "local:1"`` read from a TOML file starts a LocalCluster of
    one worker: result.json ``compute`` says so.

    Catches: ``app/scenario.py``'s ``_compute`` ignoring the key."""
    scn = tmp_path / "local.toml"
    text = _scenario_text(capsys, '\n[compute]\nscheduler = "local:1"\n')
    scn.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(scn), "--out", str(out), "--quiet", "--no-replay"]) == 0
    capsys.readouterr()
    compute = read_result(out)["compute"]
    assert compute["scheduler"] == "local:1" and compute["workers"] == 1, compute


# ===================================================================== 3. continuous joints
#: A planar 2-link arm whose first joint is continuous (docs/design.md §1d). Its nodes: S
#: and G on either side of ±π with the arm straight, B1 → B2 and C1 → C2 across ±π with
#: the elbow bent down (+1.5 rad) or up (−1.5 rad). Routes S → G (11.5 kJ with the paper
#: motor) < S B1 B2 G (94.8 kJ) < S C1 C2 G (102.8 kJ). The short way of S → G passes the
#: hazard "hot" (margin −0.02 m), its long way is 0.33 m clear; the short way of B1 → B2
#: goes through the hidden "rock", its long way and S → B1 stay ≥ 0.13 m from it.
TURN_NODES = np.array([[2.7, 0.0], [-2.7, 0.0], [np.pi - 0.45, 1.5], [0.45 - np.pi, 1.5],
                       [np.pi - 0.45, -1.5], [0.45 - np.pi, -1.5]])
TURN_PAIRS = [(0, 1), (0, 2), (2, 3), (3, 1), (0, 4), (4, 5), (5, 1)]
TURN_SCENARIO = """\
name = "turn2"
[arm]
urdf = "turn2.urdf"
[motor]
preset = "paper"
gear_ratio = 9.0
[controller]
kp = 40.0
kd = 4.0
[roadmap]
num_nodes = 0   # start and goal only: the other nodes are TURN_NODES
k = 1
duration = 1.0
dt = 0.005
resolution = 0.02
[[obstacles]]
type = "cylinder"
name = "rock"
center = [-0.5354, -0.4987]   # the tip of B1 -> B2 at +-pi
radius = 0.02
hidden = true
[sensor]
range = 0.05
[[hazards]]
type = "cylinder"
name = "hot"
center = [-1.08, 0.0]         # beyond the tip of the straight arm at +-pi
radius = 0.02
clearance = 0.08
[task]
start = [2.7, 0.0]
goal = [-2.7, 0.0]
"""


def test_continuous_joint_run_with_hazard_and_hidden_obstacle_goes_the_short_way(tmp_path):
    """A lazy run on a 2-link arm with a continuous joint, start and goal on either side
    of ±π, a hazard and a hidden obstacle (sensor): hazard re-planning drops S → G, the
    sensor finds the rock on B1 → B2 at B1, and the arm goes back to S and on by C1, C2.
    Every travelled edge goes the short way round, is free of the rock and clear of the
    hazard, no bound is violated, and the energies equal ``simulate_edge`` to the
    short-way targets.

    Catches: dropping ``arm.edge_target`` (the raw node instead) in
    ``planning/execution.py`` (sensing along the long way misses the rock: the arm drives
    through it to B2, where it is stuck: NoPathError from node 3), ``planning/hazards.py``
    (the long way of S → G is far from the hazard: the arm passes it) or
    ``planning/lazy.py`` (edges simulated the long way, or bounded the long way: the
    bounds then exceed the true energies)."""
    from dataclasses import replace

    from mpd_pin.app.plan import plan_path, prepare
    from mpd_pin.app.scenario import load_scenario_data, parse_energy_scenario
    from mpd_pin.arm.urdf import planar_arm_urdf
    from mpd_pin.collision import CollisionChecker
    from mpd_pin.collision.motion import edge_configurations

    xml = planar_arm_urdf((0.5, 0.5), (1.0, 1.0), radius=0.03, name="turn2")
    (tmp_path / "turn2.urdf").write_text(xml.replace('type="revolute"', 'type="continuous"', 1))
    path = tmp_path / "turn2.toml"
    path.write_text(TURN_SCENARIO)
    scn = parse_energy_scenario(load_scenario_data(path), source=str(path), base_dir=tmp_path)
    arm, opts = scn.arm, scn.options
    assert arm.continuous_joints == ("joint1",) and scn.evaluation == "lazy"
    setup = prepare(scn, show_progress=False)
    # the roadmap by hand: every pair both ways, free in the known world, timed and
    # bounded on the short way round (as build_roadmap does, §1d)
    src = np.array([u for a, b in TURN_PAIRS for u in (a, b)])
    dst = np.array([v for a, b in TURN_PAIRS for v in (b, a)])
    Q0, Q1 = TURN_NODES[src], TURN_NODES[dst]
    assert np.all(setup.checker.edges_free(Q0, Q1, opts.resolution))
    T, _ = opts.timing(Q0, arm.edge_target(Q0, Q1), arm.model.velocityLimit)
    rm = Roadmap(nodes=TURN_NODES.copy(), start=0, goal=1, src=src, dst=dst, durations=T,
                 energy=np.full((src.size, arm.nq), np.nan), key="turn2 by hand")
    setup = replace(setup, roadmap=rm, lazy=LazyEdges(rm, setup.cost, opts))
    plan = plan_path(scn, setup)
    travelled = plan.path
    assert travelled[0] == 0 and travelled[-1] == 1
    edges = rm.edge_ids(travelled)

    # hidden obstacle: every travelled edge free of it (the sensor saw it in time)
    truth = CollisionChecker(arm, scn.world, include_hidden=True)
    hit = [(int(rm.src[e]), int(rm.dst[e])) for e in edges
           if not truth.edge_free(rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]], opts.resolution)]
    assert not hit, f"travelled edges through the hidden rock: {hit}"
    # hazard: every travelled edge, the short way round, keeps the clearance
    for e in edges:
        q0 = rm.nodes[rm.src[e]]
        Q = edge_configurations(q0, arm.edge_target(q0, rm.nodes[rm.dst[e]]), opts.resolution)
        margin = min(truth.hazard_margin(q) for q in Q)
        assert margin >= 0.0, (int(rm.src[e]), int(rm.dst[e]), margin)
    # lazy: no violation, and the energies of the short way round
    lz = setup.lazy
    assert lz.count.violations == 0 and lz.scale == 1.0
    crossings = 0
    for e in edges:
        q0, q1 = rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]]
        target = arm.edge_target(q0, q1)
        assert np.all(np.abs(target - q0)[arm.continuous_mask] <= np.pi)
        crossings += bool(np.abs(q1 - q0)[0] > np.pi)
        sim = mp.simulate_edge(setup.drive, q0, target, float(rm.durations[e]), opts.dt)
        assert np.max(np.abs(sim.q[-1] - target)) <= opts.arrival_tolerance
        np.testing.assert_allclose(rm.energy[e], sim.energy, rtol=1e-9)
    assert crossings == 1  # the travelled path turns across ±π once
    np.testing.assert_allclose(plan.energy, rm.energy[edges].sum(axis=0), rtol=1e-12)
    # the run went as designed: the hazard changed the plan, the rock was found on the way
    assert plan.hazard.first_path == [0, 1] and plan.hazard.final_path == [0, 2, 3, 1]
    assert [r.revealed for r in plan.execution.replans] == [["rock"]]
    assert plan.execution.replans[0].node == 2
    assert travelled == [0, 2, 0, 4, 5, 1]


# ============================================================ 4. an independent reference
def test_package_energy_equals_the_independent_sympy_rk4():
    """E⁺ per joint of a planar 2-link edge against the sympy model of
    tests/test_energy_sympy.py, which shares no code with the package: 1e-6 relative at a
    resolved step where the package runs classical RK4 (``edge_energies`` and
    ``simulate_edge``), and within the 0.1 % that test_stiff_current_matches_resolved_rk4
    claims at 5 ms, where the stiff joint's current is updated exponentially (the
    partitioned step: one stiff servo-like motor, one slow one).

    That test's reference is the package's own ``edge_energies`` at a fine step, and the
    file's sympy comparisons give every joint the same R, Kt, Ke, B, J and gear ratio, so
    a slip in the per-joint motor constants the package integrates with goes unseen in
    that file. Here every motor constant differs between the two joints. Catches (checked):
    ``Drive.emf_per_rad_s`` taking joint 1's Ke for every joint (``n * Ke[:1]``)."""
    try:
        from test_energy_sympy import reference_edge
    except ImportError:  # pragma: no cover - if tests/ ever becomes a package
        from tests.test_energy_sympy import reference_edge
    from mpd_pin.dynamics.current import current_model

    tau_e = 1.9e-3  # L/R (s) of the stiff joint
    motors = [mp.DCMotor(R=2.0, L=2.0 * tau_e, Kt=0.03, Ke=0.03, B=1e-6, J=5e-6,
                         gear_ratio=100.0),
              mp.DCMotor(R=1.5, L=0.2, Kt=0.02, Ke=0.025, B=2e-6, J=3e-6, gear_ratio=60.0)]
    drive = mp.Drive(mp.builtin_arm("planar_2link"), motors, kp=20.0, kd=1.0, feedforward=True)
    q0, q1, T = np.array([-0.3, 0.8]), np.array([0.9, -0.4]), 0.5
    dt_fine = T / math.ceil(T / (0.2 * tau_e))
    assert current_model(drive, dt_fine)["name"] == "rk4"
    assert current_model(drive, 5e-3)["stiff_joints"] == [0]
    ref = reference_edge(drive, "planar_2link", q0, q1, T, dt_fine)
    assert np.all(ref.energy > 1.0)  # J: 32.6 and 3.8
    fine = mp.edge_energies(drive, q0[None], q1[None], T, dt_fine)[0]
    np.testing.assert_allclose(fine, ref.energy, rtol=1e-6)  # measured: 4e-16
    np.testing.assert_allclose(mp.simulate_edge(drive, q0, q1, T, dt_fine).energy,
                               ref.energy, rtol=1e-6)
    fast = mp.edge_energies(drive, q0[None], q1[None], T, 5e-3)[0]
    np.testing.assert_allclose(fast, ref.energy, rtol=1e-3)  # measured: 3e-5, 3.6e-4


def test_interrupted_completion_of_a_lazy_file_resumes_from_its_chunks(tmp_path, monkeypatch):
    """A lazy roadmap file completed eagerly (build_roadmap with evaluate=True on a file
    holding unevaluated edges) and interrupted by Ctrl-C keeps its finished chunks in
    <cache>.partial/; the rerun reuses them — only the rest is simulated — and gives the
    roadmap of an uninterrupted completion, array for array."""
    from mpd_pin.app.plan import prepare
    from mpd_pin.app.planner import configure
    from mpd_pin.dynamics.cost import EnergyCost
    from mpd_pin.planning import roadmap as rmod
    from mpd_pin.planning.resume import partial_dir
    from mpd_pin.planning.roadmap import Roadmap, build_roadmap

    scn = configure(mp.load_scenario("quickstart"), num_nodes=30, collision="eager")
    cache = tmp_path / "rm.npz"
    setup = prepare(scn, cache=cache, show_progress=False)  # lazy: NaN energies on file
    lazy_file = Roadmap.load(cache)
    todo = int((~lazy_file.evaluated).sum())
    assert todo > 200
    cost = EnergyCost(setup.drive, scn.options.dt, chunk_size=40)
    ref = build_roadmap(cost, setup.checker, scn.start, scn.goal, scn.options,
                        show_progress=False)  # a plain eager build of the same roadmap

    class Interrupt:  # the bar class: Ctrl-C once 120 edge energies are done
        def __init__(self, *a, total=None, **kw):
            self.n = 0

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, d):
            self.n += d
            if self.n >= 120:
                raise KeyboardInterrupt

    monkeypatch.setattr(rmod, "_tqdm", lambda show: Interrupt)
    with pytest.raises(KeyboardInterrupt):
        build_roadmap(cost, setup.checker, scn.start, scn.goal, scn.options, cache=cache,
                      show_progress=False, evaluate=True)
    monkeypatch.undo()
    saved = sorted(partial_dir(cache).glob("chunk-*.npz"))
    assert len(saved) >= 3 and not Roadmap.load(cache).evaluated.all()
    done = build_roadmap(cost, setup.checker, scn.start, scn.goal, scn.options, cache=cache,
                         show_progress=False, evaluate=True)
    assert done.chunks_reused == len(saved)
    assert not partial_dir(cache).exists()
    key = lambda r: {(u, v): e for u, v, e in  # noqa: E731
                     zip(r.src.tolist(), r.dst.tolist(), r.energy.tolist(), strict=True)}
    assert key(done) == key(ref)


def test_ctrl_c_during_a_lazy_search_keeps_what_was_simulated(tmp_path, monkeypatch):
    """Ctrl-C in the middle of a lazy search with a roadmap file: the energies simulated so
    far are written back (the search's ``finally``), and the rerun reuses them — the same
    optimum, fewer simulations."""
    from mpd_pin.app.plan import plan_path, prepare
    from mpd_pin.app.planner import configure

    scn = configure(mp.load_scenario("quickstart"), collision="eager")
    cache = tmp_path / "rm.npz"
    real = LazyEdges.evaluate
    batches = []

    def counted(self, ids):
        batches.append(len(ids))
        return real(self, ids)

    monkeypatch.setattr(LazyEdges, "evaluate", counted)
    ref_setup = prepare(scn, show_progress=False)
    ref = plan_path(scn, ref_setup)
    total = ref_setup.lazy.count.simulated
    assert len(batches) >= 2  # something left to simulate after the first batch
    calls = []

    def interrupted(self, ids):
        if len(calls) == len(batches) // 2:
            raise KeyboardInterrupt
        calls.append(len(ids))
        return real(self, ids)

    monkeypatch.setattr(LazyEdges, "evaluate", interrupted)
    setup = prepare(scn, cache=cache, show_progress=False)
    with pytest.raises(KeyboardInterrupt):
        plan_path(scn, setup)
    monkeypatch.undo()
    before = sum(calls)
    assert before > 0
    again = prepare(scn, cache=cache, show_progress=False)
    assert again.lazy.reused == before
    res = plan_path(scn, again)
    assert res.path == ref.path and float(res.energy.sum()) == float(ref.energy.sum())
    assert again.lazy.count.simulated == total - before


def test_partial_chunks_of_other_inputs_are_not_reused(tmp_path):
    """A finished chunk in <cache>.partial/ is reused only for the very edges it was
    simulated for: with the same key but other inputs (another duration on one of its
    rows) it is deleted, not loaded (the inputs digest of planning/resume.py)."""
    from mpd_pin.planning.resume import PartialCosts, partial_dir

    rng = np.random.default_rng(3)
    Q0, Q1 = rng.uniform(-1, 1, (6, 3)), rng.uniform(-1, 1, (6, 3))
    T = np.full(6, 1.0)
    rows = np.array([1, 2, 3])
    res = EdgeOutcomes(*(rng.uniform(0, 1, (3, 3)) for _ in range(5)), rng.uniform(0, 1, (3, 2)))
    PartialCosts(tmp_path / "rm.npz", "k", Q0, Q1, T).add(rows, res)
    same = PartialCosts(tmp_path / "rm.npz", "k", Q0, Q1, T).load()
    assert same is not None and same[0].tolist() == [False, True, True, True, False, False]
    np.testing.assert_array_equal(same[1].energy[rows], res.energy)
    T2 = T.copy()
    T2[2] = 1.5  # one of the chunk's rows now has another duration
    other = PartialCosts(tmp_path / "rm.npz", "k", Q0, Q1, T2)
    assert other.load() is None and other.chunks_reused == 0
    assert not list(partial_dir(tmp_path / "rm.npz").glob("chunk-*.npz"))
