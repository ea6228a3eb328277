"""A shared DC bus with regeneration, planned (docs/design.md §3i).

The references are independent of the planner: networkx Bellman–Ford on the saved roadmap's
raw supply energies (negative ones included, no reweighting), and ``simulate_edge`` edge by
edge for the reported energies. The supply energy itself is checked against a sympy model
of the bus power in ``test_supply_sympy.py``.
"""

from __future__ import annotations

import dataclasses
import functools
import json

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.dynamics.bound import node_potential
from mpd_pin.motion.refine import OPTIMIZED
from mpd_pin.planning.roadmap import Roadmap
from mpd_pin.planning.supply_costs import reweighted

try:  # tests/ is on sys.path under pytest's default import mode
    from conftest import run_cli, run_once
except ImportError:  # pragma: no cover
    from tests.conftest import run_cli, run_once

SHARED = mp.Supply("shared", 0.6)


def _shared_scenario(supply: mp.Supply = SHARED):
    return dataclasses.replace(mp.load_scenario("quickstart"), supply=supply)


@functools.cache
def _eager_shared(tmp_dir: str):
    """Quickstart on a shared bus with η = 0.6, every edge simulated, verified with
    simulate_edge; the roadmap saved."""
    cache = f"{tmp_dir}/rm.npz"
    plan = mp.plan(_shared_scenario(), cache=cache, show_progress=False, evaluation="eager",
                   collision="eager", verify=True)
    return plan, Roadmap.load(cache)


@pytest.fixture(scope="module")
def eager_shared(tmp_path_factory):
    return _eager_shared(str(tmp_path_factory.mktemp("supply")))


def test_optimum_equals_bellman_ford_on_the_raw_supply_energies(eager_shared):
    """The planner searches c + φ(u) − φ(v); Bellman–Ford on the raw costs c (some < 0) must
    find a path of the same cost, and the planner's path costs exactly that."""
    plan, rm = eager_shared
    eta = SHARED.regeneration
    c = rm.bus[:, 0] - eta * rm.bus[:, 1]
    assert np.isfinite(c).all()
    assert (c < 0).sum() > 20  # regeneration makes many edges pay back: the case is real
    G = nx.DiGraph()
    for u, v, w in zip(rm.src.tolist(), rm.dst.tolist(), c.tolist(), strict=True):
        G.add_edge(u, v, weight=w)
    ref_cost, ref_path = nx.single_source_bellman_ford(G, rm.start, rm.goal)
    nodes = plan.roadmap_path.nodes
    ids = rm.edge_ids(nodes)
    assert float(c[ids].sum()) == pytest.approx(ref_cost, rel=1e-9, abs=1e-9)
    assert plan.roadmap_path.total_energy == pytest.approx(ref_cost, rel=1e-9, abs=1e-9)
    assert plan.roadmap_path.nodes == ref_path or float(c[rm.edge_ids(ref_path)].sum()) \
        == pytest.approx(ref_cost, rel=1e-12)


def test_reweighted_costs_are_non_negative_and_shift_every_path_equally(eager_shared):
    """c′ = c + φ(u) − φ(v) ≥ 0 on every simulated edge (the potential of §3i is a true
    lower bound there), and a path's c′ is its c plus φ(start) − φ(goal)."""
    plan, rm = eager_shared
    drive = _shared_scenario().drive()
    phi = node_potential(drive, rm.nodes)
    c = rm.bus[:, 0] - SHARED.regeneration * rm.bus[:, 1]
    raw = c + phi[rm.src] - phi[rm.dst]
    assert raw.min() > 0.0  # measured: no edge needs the round-off rule
    rng = np.random.default_rng(0)
    G = nx.DiGraph()
    G.add_edges_from(zip(rm.src.tolist(), rm.dst.tolist(), strict=True))
    for _ in range(5):
        path = nx.shortest_path(G, rm.start, int(rng.integers(2, rm.num_nodes)))
        ids = rm.edge_ids(path)
        shift = phi[path[0]] - phi[path[-1]]
        assert raw[ids].sum() == pytest.approx(c[ids].sum() + shift, rel=1e-12, abs=1e-9)


def test_lazy_search_finds_the_eager_optimum(eager_shared, tmp_path):
    """Lazy evaluation (bounds of the reweighted cost) gives the same path and energy."""
    plan, rm = eager_shared
    lazy = mp.plan(_shared_scenario(), show_progress=False, evaluation="lazy",
                   collision="eager", refine=False)
    assert lazy.roadmap_path.nodes == plan.roadmap_path.nodes
    assert lazy.roadmap_path.total_energy == pytest.approx(plan.roadmap_path.total_energy,
                                                           rel=1e-12)
    rec = lazy.to_dict()["roadmap"]["lazy"]
    assert rec["simulated"] < 0.2 * rm.num_edges
    assert rec["bound_violations"] == 0


def test_reported_energies_resimulated_edge_by_edge(eager_shared):
    """The acceptance of the issue: the roadmap path re-simulated edge by edge gives the
    reported energy, the returned motion re-priced gives its total, and result.json says
    which supply priced them."""
    plan, rm = eager_shared
    drive = _shared_scenario().drive()
    nodes = plan.roadmap_path.nodes
    total = 0.0
    for e in rm.edge_ids(nodes):
        sim = mp.simulate_edge(drive, rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]],
                               float(rm.durations[e]), 5e-3)
        total += sim.supply_energy
    assert total == pytest.approx(plan.roadmap_path.total_energy, rel=1e-9)
    d = plan.to_dict()
    assert d["supply"] == {"bus": "shared", "regeneration": 0.6}
    assert d["verification"]["total_energy_simulate_edge"] == pytest.approx(total, rel=1e-12)
    by = d["energy_by_supply"]
    assert by["shared_regeneration"] == pytest.approx(plan.total_energy, rel=1e-12)
    assert by["shared_regeneration"] < by["shared"] < by["per_joint"]
    m = plan.motion
    options = _shared_scenario().options
    # the returned motion is the optimum of its cheapest candidates (docs/design.md §9g),
    # which follows its own spline: re-simulated, it draws its total from the bus
    refined = plan._parts.motion.refined
    assert refined.candidate == OPTIMIZED and d["motion"]["optimization"]["kept_seed"] is False
    bp, bm = mp.motion_series(drive, m, options.dt)["bus_energy_t"][-1]
    assert bp - 0.6 * bm == pytest.approx(plan.total_energy, rel=1e-9)
    # its seed, a refined candidate, re-priced from its waypoints gives that candidate's
    # total, and costs more on the bus
    seed = refined.by_name[d["motion"]["optimization"]["seed"]]
    again = mp.trajectory_energy(drive, seed.waypoints, seed.execution, options=options)
    assert again.total_energy == pytest.approx(seed.total_energy, rel=1e-9)
    assert plan.total_energy < seed.total_energy
    b = np.asarray(d["motion"]["bus_energy"])
    assert b[0] - 0.6 * b[1] == pytest.approx(plan.total_energy, rel=1e-12)


def test_scenario_file_supply_and_trajectory_power(tmp_path_factory):
    """``[supply]`` in a TOML file reaches the run; trajectory.csv has P_bus = Σ V·i, and its
    integral over the file's samples gives the motion's energy."""
    from mpd_pin.app.scenario import resolve_scenario

    text = resolve_scenario("quickstart").read_text()
    path = tmp_path_factory.mktemp("bus") / "qs_bus.toml"
    path.write_text(text + '\n[supply]\nbus = "shared"\nregeneration = 0.6\n')
    res, out = run_once(tmp_path_factory, path, "--no-replay", "--quiet", "--no-refine")
    assert res.returncode == 0, res.stderr

    r = json.loads((out / "result.json").read_text())
    assert r["supply"] == {"bus": "shared", "regeneration": 0.6}
    data = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    names = r["joint_names"]
    V = np.stack([data[f"V_{n}"] for n in names], axis=1)
    i = np.stack([data[f"i_{n}"] for n in names], axis=1)
    np.testing.assert_allclose(data["P_bus"], (V * i).sum(axis=1), rtol=1e-8, atol=1e-8)
    p = data["P_bus"]
    drawn = np.trapezoid(np.maximum(p, 0) - 0.6 * np.maximum(-p, 0), data["t"])
    assert drawn == pytest.approx(r["total_energy"], rel=2e-2)  # trapezoid over the samples


def test_paper_supply_keeps_the_old_key_and_costs():
    """The default supply adds nothing to the roadmap key or the cost: paper energies and
    cache files stay what they were."""
    scn = mp.load_scenario("case1")
    d0 = scn.drive()
    assert "supply" not in d0.describe()
    d1 = dataclasses.replace(scn, supply=mp.Supply("shared", 0.0)).drive()
    assert d1.describe()["supply"] == {"bus": "shared", "regeneration": 0.0}


def test_reweighted_refuses_a_real_negative_and_zeroes_round_off():
    """A reweighted cost below 0 by more than round-off is an error (clipping would change
    the optimum); one below 0 by round-off only becomes 0."""
    src, dst = np.array([0, 1]), np.array([1, 2])
    ok = reweighted(np.array([1.0, 2.5]), np.array([0.0, 1.0 + 1e-15, 3.5]), src, dst)
    assert ok[0] == 0.0  # 1 − (1 + 1e-15): below 0 by round-off only
    assert 0.0 <= ok[1] < 1e-14  # 2.5 + (1 + 1e-15) − 3.5
    with pytest.raises(ValueError, match="from node 1 to node 2 costs -5 J"):
        reweighted(np.array([1.0, -5.0]), np.array([0.0, 1.0, 3.0]), src, dst)
    assert reweighted(np.array([-1.0]), None, src[:1], dst[:1]).tolist() == [-1.0]


@pytest.mark.parametrize("body, key", [
    ('bus = "dc"', "supply.bus"),
    ('bus = "shared"\nregeneration = 1.5', "supply.regeneration"),
    ('bus = "shared"\nregeneration = -0.1', "supply.regeneration"),
    ("regeneration = 0.3", "supply.regeneration"),
    ('bus = "shared"\nregen = 0.3', "supply: unknown key(s) 'regen'"),
])
def test_bad_supply_gets_one_line_naming_the_key(tmp_path, body, key):
    from mpd_pin.app.scenario import resolve_scenario

    path = tmp_path / "bad.toml"
    path.write_text(resolve_scenario("quickstart").read_text() + f"\n[supply]\n{body}\n")
    res = run_cli("run", path, "--out", tmp_path / "out")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mpd-pin: error: "), res.stderr
    assert key in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_planning_for_the_bus_never_loses_to_repricing(eager_shared):
    """The motion planned for the bus costs no more on it than the paper's per-joint plan's
    motion priced on the same bus: each candidate is also refined per joint (§3i)."""
    plan, _ = eager_shared
    per_joint = mp.plan(mp.load_scenario("quickstart"), show_progress=False)
    b_plus, b_minus = per_joint.motion.bus_energy
    assert plan.total_energy <= b_plus - 0.6 * b_minus + 1e-9
    names = [c["name"] for c in plan.to_dict()["motion"]["refinement"]["candidates"]]
    assert "energy optimum (refined per joint)" in names, names
    # the refinement alone (no optimisation, docs/design.md §9g): the same, and the bus is
    # worth it here
    plain = mp.plan(_shared_scenario(), show_progress=False, optimize=False)
    plain_per_joint = mp.plan(mp.load_scenario("quickstart"), show_progress=False,
                              optimize=False)
    b_plus, b_minus = plain_per_joint.motion.bus_energy
    assert plain.total_energy <= b_plus - 0.6 * b_minus + 1e-9
    assert plain.total_energy < 0.6 * plain_per_joint.total_energy
    # and the optimised motions cost less than the refined ones, on either supply
    assert plan.total_energy < plain.total_energy
    assert per_joint.total_energy < plain_per_joint.total_energy


def test_unequal_ke_over_kt_lazy_falls_back_to_eager_and_reweights_exactly(tmp_path):
    """Motors whose Ke/Kt differ by ±20 % between joints have no exact physical potential
    (§3i): some edges stay negative after φ, and the lazy search meets one. The run then
    evaluates every edge; Johnson's shift on top of φ makes the costs non-negative, the run
    says why, and the optimum is Bellman–Ford's on the raw costs of the saved roadmap — the
    same as a run asked to be eager."""
    scn = mp.load_scenario("quickstart")
    motors = [dataclasses.replace(m, Ke=m.Kt * (0.8 if k % 2 else 1.2))
              for k, m in enumerate(scn.drive().motor_list)]
    scn = dataclasses.replace(scn, motor=motors, supply=mp.Supply("shared", 1.0))
    cache = tmp_path / "rm.npz"
    plan = mp.plan(scn, show_progress=False, cache=cache, refine=False)  # lazy, the default
    record = plan.to_dict()["roadmap"]
    assert record["evaluation"] == "eager"
    (note,) = record["evaluation_notes"]
    assert note.startswith("the lazy search met an edge") and "every edge evaluated" in note
    rm = Roadmap.load(cache)
    assert rm.evaluated.all() and record["edges_evaluated"] >= rm.num_edges
    c = rm.bus[:, 0] - rm.bus[:, 1]
    phi = node_potential(scn.drive(), rm.nodes)
    assert (c + phi[rm.src] - phi[rm.dst] < -1e-6).sum() > 0  # φ alone is not enough here
    G = nx.DiGraph()
    for u, v, w in zip(rm.src.tolist(), rm.dst.tolist(), c.tolist(), strict=True):
        G.add_edge(u, v, weight=w)
    ref = nx.bellman_ford_path_length(G, rm.start, rm.goal)
    assert plan.roadmap_path.total_energy == pytest.approx(ref, rel=1e-9)
    eager = mp.plan(scn, show_progress=False, evaluation="eager", cache=cache, refine=False)
    assert eager.roadmap_path.nodes == plan.roadmap_path.nodes
    assert eager.roadmap_path.total_energy == plan.roadmap_path.total_energy


def test_johnson_shift_and_negative_cycles():
    from mpd_pin.planning.supply_costs import johnson_shift

    src, dst = np.array([0, 1, 2]), np.array([1, 2, 0])
    c = np.array([2.0, -1.5, 0.25])
    psi = johnson_shift(c, src, dst, 3)
    assert np.all(c + psi[src] - psi[dst] >= -1e-12) and psi.max() <= 0.0
    assert johnson_shift(np.abs(c), src, dst, 3).tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="negative cycle"):
        johnson_shift(np.array([1.0, -1.5, 0.25]), src, dst, 3)


@pytest.mark.parametrize("eta", [0.0, 0.6])
def test_bus_bound_is_below_the_simulated_cost_and_tight(eta):
    """The lazy search's bound of a shared bus's (reweighted) cost, against the simulated
    cost of 60 random quickstart edges: never above it, and not a trivial 0."""
    from mpd_pin.dynamics.bound import EnergyBound
    from mpd_pin.dynamics.simulate import edge_outcomes

    scn = _shared_scenario(mp.Supply("shared", eta))
    d = scn.drive()
    rng = np.random.default_rng(5)
    lo, hi = d.arm.lower_limits, d.arm.upper_limits
    Q0 = rng.uniform(lo, hi, (60, d.nq))
    Q1 = np.clip(Q0 + rng.uniform(-0.5, 0.5, Q0.shape), lo, hi)
    T, _ = scn.options.timing(Q0, Q1, d.arm.model.velocityLimit)
    out = edge_outcomes(d, Q0, Q1, T, scn.options.dt)
    c = out.bus_energy[:, 0] - eta * out.bus_energy[:, 1]
    if eta:
        c = c + node_potential(d, Q0) - node_potential(d, Q1)
    b = EnergyBound(d)(Q0, Q1, T)
    assert np.all(b <= c)
    assert np.median(b / c) > 0.85  # measured 0.94 (η 0.6) on 300 edges


# ---------------------------------------------------------------- perfect-tracking screens
# The screens integrate supply_power (max(P, 0) − η max(−P, 0) on a shared bus) along the
# feed-forward. The reference below is written apart from the package's tables: Pinocchio's
# plain RNEA (armature zeroed, n²J q̈ and n²B q̇ added here from the motor constants), the
# time derivative of τ_ff by central differences, V_ff = R i + L di/dt + n Ke q̇ with
# i = τ_ff/(n Kt) (docs/design.md §3b, §3c, §3f), and B⁺, B⁻ by Simpson on 4001 points.

QUINTIC = np.polynomial.Polynomial([0.0, 0.0, 0.0, 10.0, -15.0, 6.0])  # s(τ), §3b

#: Quickstart edges that lower the arm in 1 s: the bus power changes sign on each, and the
#: regenerated B⁻ is a large share of B⁺ (measured 0.77–1.5), so η counts.
LOWERING = (np.array([[1.9, 1.2, -1.1], [1.2, 0.3, 0.5], [2.5, -0.5, 0.3], [0.8, 1.0, -0.2]]),
            np.array([[0.3, -0.4, 0.6], [-0.6, -0.3, -0.2], [0.9, 0.7, -0.4], [-1.2, 0.2, 0.4]]))


def _reference_bus(drive: mp.Drive, trajectory, T: float, points: int = 4001):
    """(B⁺, B⁻) (J) of the perfect-tracking bus power along ``trajectory(t)`` → (q, q̇, q̈)
    over [0, T] s."""
    import pinocchio as pin
    from scipy.integrate import simpson

    model = drive.arm.model.copy()
    model.armature[:] = 0.0
    data = model.createData()
    motors = drive.motor_list
    n, J, B, Kt, Ke, R, L = (np.array([getattr(m, a) for m in motors]) for a in
                             ("gear_ratio", "J", "B", "Kt", "Ke", "R", "L"))

    def tau_ff(t):
        q, qd, qdd = trajectory(t)
        return pin.rnea(model, data, q, qd, qdd) + n**2 * J * qdd + n**2 * B * qd

    h = 1e-5 * T
    t = np.linspace(0.0, T, points)
    P = np.empty(points)
    for k, tk in enumerate(t):
        i = tau_ff(tk) / (n * Kt)
        di = (tau_ff(tk + h) - tau_ff(tk - h)) / (2.0 * h) / (n * Kt)
        V = R * i + L * di + n * Ke * trajectory(tk)[1]
        P[k] = V @ i
    return simpson(np.maximum(P, 0.0), x=t), simpson(np.maximum(-P, 0.0), x=t)


def _quintic(q0, q1, T):
    dq, d1, d2 = q1 - q0, QUINTIC.deriv(1), QUINTIC.deriv(2)
    return lambda t: (q0 + dq * QUINTIC(t / T), dq * d1(t / T) / T, dq * d2(t / T) / T**2)


def test_edge_screen_prices_the_shared_bus_with_regeneration():
    """``ideal_costs`` of quickstart edges on a shared bus with η = 0.6 is B⁺ − η B⁻ of the
    reference (and B⁺ with η = 0): with Simpson on 1024 intervals to round-off of the
    quadrature, with the screen's default 64 within 0.2 % of B⁺ + B⁻."""
    from mpd_pin.motion.shortcut import ideal_costs

    drive, drive0 = _shared_scenario().drive(), _shared_scenario(mp.Supply("shared")).drive()
    Q0, Q1 = LOWERING
    T = _shared_scenario().options.timing(Q0, Q1, drive.arm.model.velocityLimit)[0]
    ref = np.array([_reference_bus(drive, _quintic(a, b, t), t)
                    for a, b, t in zip(Q0, Q1, T, strict=True)])
    bp, bm = ref.T
    scale = bp + bm
    assert np.all(bm > 0.5 * bp)  # the case is real: η changes every cost by a lot
    expected = bp - 0.6 * bm
    np.testing.assert_allclose(ideal_costs(drive, Q0, Q1, T, samples=1024), expected,
                               rtol=0, atol=1e-5 * scale.min())
    np.testing.assert_allclose(ideal_costs(drive0, Q0, Q1, T, samples=1024), bp,
                               rtol=0, atol=1e-5 * scale.min())
    assert np.all(np.abs(ideal_costs(drive, Q0, Q1, T) - expected) <= 2e-3 * scale)


def test_nonstop_screen_regeneration_is_what_the_bus_gives_back():
    """``ideal_nonstop`` of a via-point spline stretched to two durations: η = 0.6 lowers
    the screen below η = 0 by η B⁻ of the reference, and each is the reference's B⁺ − η B⁻;
    the supply prices the motion, it does not change it (same peak torques)."""
    from mpd_pin.motion.screen import ideal_nonstop
    from mpd_pin.motion.spline import via_spline

    drive, drive0 = _shared_scenario().drive(), _shared_scenario(mp.Supply("shared")).drive()
    W = np.array([[1.9, 1.2, -1.1], [1.2, 0.3, 0.5], [0.3, -0.4, 0.6], [-0.6, -0.3, -0.2]])
    vs = via_spline(W, np.array([0.0, 1.0, 1.8, 3.0]))
    durations = np.array([2.5, 4.0])

    def stretched(T):
        c = vs.unit_duration / T
        return lambda t: (vs.spline(c * t), vs.spline(c * t, 1) * c, vs.spline(c * t, 2) * c**2)

    bp, bm = np.array([_reference_bus(drive, stretched(T), T) for T in durations]).T
    assert np.all(bm > 0.5 * bp)
    e6, peak6 = ideal_nonstop(drive, vs, durations, samples=1024)
    e0, peak0 = ideal_nonstop(drive0, vs, durations, samples=1024)
    tol = 1e-5 * (bp + bm)
    assert np.all(np.abs((e6 - e0) - (-0.6 * bm)) <= tol), (e6 - e0, -0.6 * bm)
    assert np.all(np.abs(e0 - bp) <= tol) and np.all(np.abs(e6 - (bp - 0.6 * bm)) <= tol)
    np.testing.assert_array_equal(peak6, peak0)


def test_result_trajectory_difference_uses_the_regeneration(tmp_path):
    """result.json ``motion.trajectory_relative_difference`` on a shared bus with η = 0.6:
    trajectory.csv's P_bus integrated as the supply draws it (max(P, 0) − η max(−P, 0),
    trapezoid over the file's samples) against ``total_energy``. Quickstart run backwards,
    the arm lowering: the bus gives back as much as it draws (B⁻ ≈ B⁺), so a record that
    forgot η would be off by far more than its sampling (measured 1–3 %)."""
    from mpd_pin.app.scenario import resolve_scenario

    text = resolve_scenario("quickstart").read_text()
    start, goal = "start_ee = [0.85, -0.35]", "goal_ee = [-0.7, 0.75]"
    assert start in text and goal in text
    text = text.replace(start, "start_ee = [-0.7, 0.75]").replace(goal, "goal_ee = [0.85, -0.35]")
    path = tmp_path / "qs_down.toml"
    path.write_text(text + '\n[supply]\nbus = "shared"\nregeneration = 0.6\n')
    out = tmp_path / "out"
    res = run_cli("run", path, "--out", out, "--quiet", "--no-replay", "--no-plots",
                  "--no-refine")
    assert res.returncode == 0, res.stderr
    r = json.loads((out / "result.json").read_text())
    bp, bm = r["motion"]["bus_energy"]
    assert 0.6 * bm > 0.5 * abs(bp - 0.6 * bm)  # η counts: forgetting it is off by > 50 %
    assert r["total_energy"] == pytest.approx(bp - 0.6 * bm, rel=1e-12)
    data = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    p = data["P_bus"]
    drawn = np.trapezoid(np.maximum(p, 0) - 0.6 * np.maximum(-p, 0), data["t"])
    total = r["total_energy"]
    diff = r["motion"]["trajectory_relative_difference"]
    assert diff == pytest.approx(abs(drawn - total) / abs(total), rel=1e-6)
    assert diff < 0.05
