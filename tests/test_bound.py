"""The lower bound of an edge's E⁺ (docs/design.md §4g, ``mpd_pin/dynamics/bound.py``).

References, all independent of the bound: E⁺ simulated in batch (``edge_outcomes``, through
the lazy planner's own ``evaluate_edges``) and edge by edge (``mp.simulate_edge``, the
reference implementation), and networkx Dijkstra on the fully simulated quickstart roadmap
(the eager optimum). The quickstart scenario has the ``sized`` motors, on which the
energy balance summed over the joints (``mode="sum"``) was near 0 for most edges.
"""

import math
from types import SimpleNamespace

import networkx as nx
import numpy as np
import pytest

import mpd_pin as mp
import mpd_pin.dynamics.bound as bound_module
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.plan import prepare
from mpd_pin.dynamics import edge_outcomes
from mpd_pin.dynamics.bound import MARGIN, EnergyBound
from mpd_pin.planning.lazy import LazyEdges, evaluate_edges, lazy_plan
from mpd_pin.planning.roadmap import RoadmapOptions, feasibility
from mpd_pin.search import MPDStarLite


def _fresh(rm):
    """A copy of a roadmap with nothing evaluated."""
    copy = rm.without_edges(np.zeros(rm.num_edges, dtype=bool))
    copy.energy[:] = np.nan
    return copy


@pytest.fixture(scope="module")
def quickstart():
    """The quickstart scenario's lazy roadmap (every edge collision-checked), and a copy
    with every edge simulated."""
    import dataclasses

    scn = dataclasses.replace(load_scenario("quickstart"), collision="eager")
    setup = prepare(scn, show_progress=False)
    full = _fresh(setup.roadmap)
    refused = evaluate_edges(setup.cost, full, np.arange(full.num_edges), scn.options)
    return SimpleNamespace(scn=scn, setup=setup, full=full, feasible=~refused)


def _edges(q, ids):
    rm, arm = q.full, q.setup.drive.arm
    Q0 = rm.nodes[rm.src[ids]]
    return Q0, arm.edge_target(Q0, rm.nodes[rm.dst[ids]]), rm.durations[ids]


# ------------------------------------------------------------ below E⁺, and tight
def test_bound_holds_and_is_tight_on_quickstart_edges(quickstart):
    q = quickstart
    drive, opts = q.setup.drive, q.scn.options
    ids = np.random.default_rng(0).choice(np.flatnonzero(q.feasible), 200, replace=False)
    Q0, Q1, T = _edges(q, ids)
    true = q.full.energy[ids].sum(axis=1)
    bound = EnergyBound(drive, arrival_tolerance=opts.arrival_tolerance)
    assert bound.mode == "per_joint" and not bound.proven  # the default with feed-forward
    lb = bound(Q0, Q1, T)
    ratio = lb / true
    assert np.all(lb <= true), ratio.max()
    assert np.median(ratio) >= 0.5, np.median(ratio)  # measured 0.96 (sum mode: 0.11)
    assert np.mean(lb < 1e-3) == 0.0  # sum mode: about 40 % of the edges under 1 mJ
    # the tightest edges against the reference simulator, edge by edge
    for k in np.argsort(-ratio)[:6].tolist() + [0, 1]:
        sim = mp.simulate_edge(drive, Q0[k], Q1[k], float(T[k]), opts.dt)
        np.testing.assert_allclose(sim.energy, q.full.energy[ids[k]], rtol=1e-6, atol=1e-9)
        assert lb[k] <= sim.energy.sum(), (k, lb[k], sim.energy.sum())


def test_lazy_optimum_is_the_eager_one_on_quickstart(quickstart):
    q = quickstart
    full, ok = q.full, q.feasible
    G = nx.DiGraph()
    G.add_weighted_edges_from(zip(full.src[ok].tolist(), full.dst[ok].tolist(),
                                  full.energy[ok].sum(axis=1).tolist(), strict=True))
    ref = nx.dijkstra_path(G, full.start, full.goal)
    ref_cost = nx.path_weight(G, ref, "weight")
    rm = _fresh(q.setup.roadmap)
    lz = LazyEdges(rm, q.setup.cost, q.scn.options)
    path, _ = lazy_plan(lz, MPDStarLite)
    assert path.nodes == ref
    assert rm.path_energy(path.nodes).sum() == pytest.approx(ref_cost, rel=1e-12)
    assert lz.count.violations == 0
    # a tight bound leaves little to simulate: measured 13 of 1,672 edges (sum mode: 290)
    assert lz.edges_evaluated <= 0.05 * rm.num_edges, lz.edges_evaluated


# ------------------------------------------------------------ voltage saturation
def test_saturating_joints_are_bounded_over_the_whole_edge(monkeypatch):
    """Sized motors on an 8 V supply, half-second edges: the supply clips, the joint lags,
    and the per-half estimate of that joint exceeds its E⁺; the whole-edge one does not."""
    arm = mp.builtin_arm("planar_3link")
    motors = [mp.DCMotor(**{**m.__dict__, "v_max": 8.0}) for m in mp.sized_motors(arm)]
    drive = mp.Drive(arm, motors, kp=40.0, kd=4.0)
    opts = RoadmapOptions(duration=0.5, velocity_limits=False, effort_limits=False)
    rng = np.random.default_rng(2)
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, (120, 3))
    Q1 = np.clip(Q0 + rng.normal(0.0, 0.6, (120, 3)), arm.lower_limits, arm.upper_limits)
    out = edge_outcomes(drive, Q0, Q1, 0.5, opts.dt)
    over, missed = feasibility(out, opts, arm.model)
    ok = ~(over | missed)
    Q0, Q1, E = Q0[ok], Q1[ok], out.energy[ok].sum(axis=1)
    T = np.full(Q0.shape[0], 0.5)
    bound = EnergyBound(drive)
    parts = bound.parts(Q0, Q1, T)
    lb = bound(Q0, Q1, T)
    assert parts["saturating"].any(axis=1).sum() >= 10  # measured 18 of 112 edges
    assert np.all(lb <= E), (lb / E).max()
    np.testing.assert_allclose(parts["joint"].sum(axis=1), lb, rtol=1e-12)
    # without the whole-edge fallback the halves overestimate some clipped edges
    monkeypatch.setattr(bound_module, "SATURATION_FRACTION", math.inf)
    halves = EnergyBound(drive)(Q0, Q1, T)
    assert np.sum(halves > E) >= 2  # measured 4, up to 11 % above E⁺
    assert np.all(halves >= lb - 1e-12)  # the whole edge is the weaker bound


# ------------------------------------------------------------ modes and options
def test_modes_defaults_margin_and_describe():
    arm = mp.builtin_arm("planar_3link")
    ff = mp.Drive(arm, mp.sized_motors(arm), kp=40.0, kd=4.0)
    no_ff = mp.Drive(arm, mp.sized_motors(arm), kp=40.0, kd=4.0, feedforward=False)
    assert EnergyBound(ff).mode == "per_joint" and not EnergyBound(ff).rigorous
    assert EnergyBound(no_ff).mode == "sum" and EnergyBound(no_ff).proven
    assert EnergyBound(no_ff, rigorous=False, mode="per_joint").mode == "per_joint"
    with pytest.raises(ValueError, match="mode"):
        EnergyBound(ff, mode="joint")
    with pytest.raises(ValueError, match="rigorous"):
        EnergyBound(ff, rigorous=True, mode="per_joint")
    with pytest.raises(ValueError, match="margin"):
        EnergyBound(ff, margin=1.0)
    rng = np.random.default_rng(1)
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, (40, 3))
    Q1 = np.clip(Q0 + rng.normal(0.0, 0.5, (40, 3)), arm.lower_limits, arm.upper_limits)
    T = np.full(40, 1.0)
    b = EnergyBound(ff)
    np.testing.assert_allclose(b(Q0, Q1, T), (1 - MARGIN) * EnergyBound(ff, margin=0.0)(Q0, Q1, T),
                               rtol=1e-12)
    p = b.parts(Q0, Q1, T)
    assert p["copper"].shape == p["inductor"].shape == p["mechanical"].shape == (2, 40, 3)
    assert np.all(p["joint"] >= 0)
    # Bessel: more Legendre moments per half can only raise the copper term and the bound
    two = EnergyBound(ff, moments=2)
    assert np.all(two.parts(Q0, Q1, T)["copper"] >= p["copper"] - 1e-12)
    assert np.all(two(Q0, Q1, T) >= b(Q0, Q1, T) - 1e-12)
    assert MARGIN >= 0.01  # above the per-joint overestimates measured (≤ 0.35 % of an edge)
    d = b.describe()
    assert d["mode"] == "per_joint" and d["pieces"] == 2 and d["margin"] == MARGIN
    assert d["quadrature_points"] == 8 and d["proven"] is False
    s = EnergyBound(ff, mode="sum").describe()
    assert s["mode"] == "sum" and s["pieces"] == 1 and "margin" not in s
    assert EnergyBound(ff)(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)).shape == (0,)


def test_gravity_bound_covers_prismatic_extensions():
    """Issue 35: the gravity bound of a revolute joint with a prismatic joint further out
    ignored how far that joint slides (joint 4 of the mixed model: 17.3 N·m bound against
    44 N·m sampled). Against Pinocchio's gravity at 20,000 random configurations and the
    corners of the limit box: the bound is never below."""
    import itertools

    import pinocchio as pin
    from test_batch_dynamics import mixed_model

    from mpd_pin.dynamics.bound import _gravity_torque_bound

    model = mixed_model()
    data = model.createData()
    bound = _gravity_torque_bound(model)
    rng = np.random.default_rng(0)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    Q = list(rng.uniform(lo, hi, (20000, model.nq)))
    Q += [np.array(c) for c in itertools.product(*zip(lo, hi, strict=True))]
    G = np.array([pin.computeGeneralizedGravity(model, data, q) for q in Q])
    peak = np.abs(G).max(axis=0)
    assert (bound >= peak - 1e-9).all(), (bound, peak)
    assert peak[4] > 40.0  # the case that was missed
