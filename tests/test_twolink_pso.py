"""PSO (paper 002 eqs. 8-9) and the via-point spline smoother of the D* motion."""

import tomllib
from dataclasses import replace
from importlib import resources

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from mpd_pin.twolink.planner import plan_dynamic
from mpd_pin.twolink.pso import PSOOptions, pso_minimize
from mpd_pin.twolink.scenario import parse_dynamic_scenario


def _sphere(X):
    return np.sum((X - 0.3) ** 2, axis=1)


def test_pso_minimises_a_sphere():
    r = pso_minimize(_sphere, -np.ones(5), np.ones(5), PSOOptions(particles=20, iterations=100),
                     np.random.default_rng(0))
    assert r.cost < 5e-3
    assert np.abs(r.x - 0.3).max() < 0.06
    assert len(r.cost_curve) == 101
    assert np.all(np.diff(r.cost_curve) <= 0)  # global best never gets worse
    assert r.cost == r.cost_curve[-1] == pytest.approx(_sphere(r.x[None])[0])
    assert r.evaluations == 20 * 101


def test_pso_is_reproducible_with_a_seed():
    opts = PSOOptions(particles=10, iterations=30)
    a = pso_minimize(_sphere, -np.ones(3), np.ones(3), opts, np.random.default_rng(42))
    b = pso_minimize(_sphere, -np.ones(3), np.ones(3), opts, np.random.default_rng(42))
    c = pso_minimize(_sphere, -np.ones(3), np.ones(3), opts, np.random.default_rng(43))
    assert a.cost_curve == b.cost_curve and np.array_equal(a.x, b.x)
    assert a.cost_curve != c.cost_curve


@pytest.mark.parametrize("k", [0.1, 0.5, 1.0])
def test_velocity_clamp_and_bounds(k):
    seen = []

    def cost(X):
        seen.append(X.copy())
        return _sphere(X)

    lo, hi = np.array([-2.0, 0.0]), np.array([2.0, 4.0])
    pso_minimize(cost, lo, hi, PSOOptions(particles=8, iterations=25, k=k),
                 np.random.default_rng(1))
    pos = np.stack(seen)  # (iterations + 1, P, D)
    vmax = k * np.maximum(np.abs(lo), np.abs(hi))  # vmax = k * posmax (paper 002)
    assert np.all(np.abs(np.diff(pos, axis=0)) <= vmax + 1e-12)
    assert np.all(pos >= lo) and np.all(pos <= hi)


def test_pso_options_validation():
    with pytest.raises(ValueError, match="k must be in"):
        PSOOptions(k=0.05)
    with pytest.raises(ValueError, match="c1"):
        PSOOptions(c1=-1.0)
    assert (PSOOptions().c1, PSOOptions().c2, PSOOptions().w) == (1.0, 3.0, 1.0)


@pytest.fixture(scope="module")
def env1_small():
    path = resources.files("mpd_pin") / "scenarios" / "env1.toml"
    scn = parse_dynamic_scenario(tomllib.loads(path.read_text()))
    prob = replace(scn.problem, pso=PSOOptions(particles=16, iterations=15))
    return prob, plan_dynamic(prob, seed=5)


def test_plan_dynamic_pso_is_reproducible(env1_small):
    prob, a = env1_small
    b = plan_dynamic(prob, seed=5)
    assert a.pso.cost_curve == b.pso.cost_curve
    assert np.array_equal(a.motion.q, b.motion.q)
    assert np.array_equal(a.pso.x, b.pso.x)


def test_smoother_spline_through_the_chosen_dstar_samples(env1_small):
    _, res = env1_small
    sm = res.smoother
    d = res.dstar
    x = sm.even_particle()
    m = sm.motion(x)
    kn = m.knots
    assert kn[0] == 0 and kn[-1] == d.num_samples - 1 and np.all(np.diff(kn) > 0)
    # The spline passes through the D* positions at its knots, at the D* times.
    np.testing.assert_allclose(m.points[kn], d.points[kn], atol=1e-12)
    cs = CubicSpline(kn.astype(float), d.points[kn], bc_type="clamped", axis=0)
    np.testing.assert_allclose(m.points, cs(np.arange(d.num_samples)), atol=1e-12)
    # Cost of a particle = its path length when feasible, inf otherwise (and why).
    c = sm.costs(x[None])[0]
    if m.feasible:
        assert c == pytest.approx(m.length, rel=1e-12)
        np.testing.assert_allclose(res.kin.fk(m.q), m.points, atol=1e-12)
    else:
        assert c == np.inf and m.reason


def test_smoother_rejects_colliding_shortcuts(env1_small):
    _, res = env1_small
    sm = res.smoother
    # Only the two ends as knots: a straight cut through the obstacle's sweep, which the
    # D* motion avoided by stopping and returning backward (samples 17-32).
    m = sm.motion(knots=np.array([0, sm.K]))
    assert not m.feasible and m.reason.startswith("collision")
    k = int(m.reason.split()[-1])
    if m.reason.startswith("collision at sample"):
        assert not res.checker.is_free(m.q[k], k)
    else:
        # It first fails *between* samples k-1 and k, with both earlier samples free: the
        # sub-step check (joints interpolated, obstacle at the sub-step's time) caught it.
        assert m.reason == f"collision between samples {k - 1} and {k}"
        assert all(res.checker.is_free(m.q[j], j) for j in range(k))
        n = sm.substeps
        assert n == 4 and not res.checker.is_free_between(m.q[k - 1], m.q[k], k - 1, n)
        # Independently (plain geometry): at some sub-step a link comes within margin + link
        # radius of the disc (0.03 + 0.03 m), the cylinder-with-margin collision condition.
        ob = res.problem.scene.obstacles[0]
        gaps = []
        for j in range(1, n):
            q = m.q[k - 1] + (j / n) * (m.q[k] - m.q[k - 1])
            c = ob.center((k - 1 + j / n) * res.problem.ts)
            e, p = res.kin.elbow(q), res.kin.fk(q)
            d = [np.linalg.norm(c - (a + np.clip(np.dot(c - a, b - a) / np.dot(b - a, b - a),
                                                 0, 1) * (b - a)))
                 for a, b in ((np.zeros(2), e), (e, p))]
            gaps.append(min(d) - ob.radius)
        assert min(gaps) < 0.06 + 1e-9, gaps
    # A particle through costs(): infinite exactly when its motion is infeasible.
    x = np.zeros((1, sm.num_via))  # every via point clipped to sample 1
    assert sm.costs(x)[0] == (np.inf if not sm.motion(x[0]).feasible else sm.motion(x[0]).length)


def test_best_motion_is_free_and_not_longer(env1_small):
    _, res = env1_small
    assert res.motion.length <= res.dstar.length
    q = res.motion.q
    for k in range(len(q)):
        assert res.checker.is_free(q[k], k)
        if k:
            assert res.checker.is_free_between(q[k - 1], q[k], k - 1, res.problem.substeps)
    assert np.abs(np.diff(q, axis=0)).max() <= res.problem.joint_step_limit + 1e-12
    if res.pso_improved:
        assert res.motion.length == pytest.approx(res.pso.cost)
