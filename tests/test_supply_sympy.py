"""Supply energies (per-joint, shared DC bus, regeneration) against sympy (docs/design.md §3i).

The reference extends the independent sympy model of ``test_energy_sympy`` (rigid body from
the hand-read URDF, motor equations, quintic reference and feed-forward in sympy, a plain
classic RK4 of its own) with the two bus states

    P = Σ_k V_k i_k,   dB⁺/dt = max(P, 0),   dB⁻/dt = max(−P, 0),

where P and its two rectifications are sympy expressions (``sp.Max``) lambdified here,
evaluated at every RK4 stage exactly like the reference's E⁺. The supply energies are then

    per_joint: Σ_k E⁺_k,   shared: B⁺ − η B⁻,

and ``simulate_edge(...).supply_energy`` / ``.bus_energy`` must agree with them. The edge is
the reverse of ``test_energy_sympy``'s planar_2link edge: on it the bus power changes sign
(2–3 times) under every setup below, so B⁻ is a sizeable share of B⁺ and the four supply
models give four clearly different energies (checked, so the test cannot pass trivially).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import simpson

import mpd_pin as mp
from mpd_pin.dynamics.simulate import edge_outcomes

try:  # tests/ is on sys.path under pytest's default (rootdir-less, "prepend") import mode
    from test_energy_sympy import (
        EDGES,
        SETUPS,
        pin_arm,
        reference_edge,
        sympy_drive,
    )
except ImportError:  # pragma: no cover - if tests/ ever becomes a package
    from tests.test_energy_sympy import (
        EDGES,
        SETUPS,
        pin_arm,
        reference_edge,
        sympy_drive,
    )

RTOL_SUPPLY = 1e-6  # simulate_edge vs the sympy reference
RTOL_SAME = 1e-9  # two implementations of the same RK4 / an algebraic identity
RTOL_QUAD = 1e-3  # Simpson on the step points vs the RK4 state (see test_p_bus_series)

NAME = "planar_2link"
Q0, Q1 = EDGES[NAME][1], EDGES[NAME][0]  # the reverse edge: the bus power changes sign

SUPPLIES = {
    "per_joint": mp.Supply(),
    "shared_eta0": mp.Supply("shared", 0.0),
    "shared_eta0.6": mp.Supply("shared", 0.6),
    "shared_eta1": mp.Supply("shared", 1.0),
}
# (SETUPS key of test_energy_sympy, saturated): the paper motor geared 5:1 (slow current,
# L/R = 0.5 s, T = 1 s, dt = 5 ms) free and at ±250 V, and the servo (L/R = 0.5 ms,
# T = 0.5 s, dt = 0.5 ms).
CASES = {
    "paper_n5": ("paper_n5", False),
    "paper_n5_sat": ("paper_n5", True),
    "servo": ("servo", False),
}


def _drive(case: str, *, feedforward: bool, supply: mp.Supply = SUPPLIES["per_joint"],
           name: str = NAME) -> mp.Drive:
    setup, saturate = CASES[case]
    motor, kp, kd, _, _, vmax = SETUPS[setup]
    motor = replace(motor, v_max=vmax if saturate else None)
    return mp.Drive(pin_arm(name), motor, kp, kd, feedforward=feedforward, supply=supply)


def _timing(case: str) -> tuple[float, float]:
    _, _, _, T, dt, _ = SETUPS[CASES[case][0]]
    return T, dt


def _rel(a, b) -> np.ndarray:
    return np.abs(np.asarray(a, float) - np.asarray(b, float)) / np.abs(np.asarray(b, float))


# ------------------------------------------------------------------ sympy bus power
@functools.cache
def sympy_bus(nq: int):
    """(V, i) -> [P, max(P, 0), max(−P, 0)] with P = Σ_k V_k i_k, from sympy."""
    volt = list(sp.symbols(f"V1:{nq + 1}", real=True))
    cur = list(sp.symbols(f"i1:{nq + 1}", real=True))
    P = sp.Add(*[volt[k] * cur[k] for k in range(nq)])
    return sp.lambdify([volt, cur], [P, sp.Max(P, 0), sp.Max(-P, 0)], modules="math", cse=True)


@dataclass
class BusRun:
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    i: np.ndarray
    V: np.ndarray
    P: np.ndarray  # bus power at the step points (W)
    energy: np.ndarray  # E⁺ per joint (J)
    net_energy: np.ndarray  # E per joint (J)
    bus: np.ndarray  # [B⁺, B⁻] (J)
    bus_t: np.ndarray  # cumulative (N+1, 2)

    def supply_energy(self, supply: mp.Supply) -> float:
        if supply.bus == "per_joint":
            return float(self.energy.sum())
        return float(self.bus[0] - supply.regeneration * self.bus[1])


def reference_bus_edge(drive: mp.Drive, name: str, q0, q1, T: float, dt: float) -> BusRun:
    """``test_energy_sympy.reference_edge`` with two more states: [q, q̇, i, E⁺, E, B⁺, B⁻],
    their rates max(±P, 0) from the sympy bus power at every RK4 stage."""
    bus = sympy_bus(sympy_drive(name).nq)
    run = reference_edge(drive, name, q0, q1, T, dt,
                         extra=lambda V, i: bus(V.tolist(), i.tolist())[1:])
    return BusRun(
        t=run.t, q=run.q, v=run.v, i=run.i, V=run.V,
        P=np.array([bus(Vk.tolist(), ik.tolist())[0] for Vk, ik in
                    zip(run.V, run.i, strict=True)]),
        energy=run.energy, net_energy=run.net_energy, bus=run.extra_t[-1], bus_t=run.extra_t,
    )


@functools.cache
def reference(case: str, feedforward: bool) -> BusRun:
    """The sympy reference of the chosen edge (the supply does not change the motion)."""
    T, dt = _timing(case)
    return reference_bus_edge(_drive(case, feedforward=feedforward), NAME, Q0, Q1, T, dt)


@functools.cache
def simulation(case: str, feedforward: bool, supply: str) -> mp.EdgeSimulation:
    T, dt = _timing(case)
    drive = _drive(case, feedforward=feedforward, supply=SUPPLIES[supply])
    return mp.simulate_edge(drive, Q0, Q1, duration=T, dt=dt)


FF = pytest.mark.parametrize("feedforward", [False, True], ids=["pd", "ff"])
CASE = pytest.mark.parametrize("case", list(CASES))


# ----------------------------------------------------------- the reference itself
@FF
@CASE
def test_reference_extends_test_energy_sympy(case, feedforward):
    """The two extra states leave the motion and E⁺, E of the original reference unchanged,
    and the bus power really changes sign on this edge (B⁻ is not a rounding residue)."""
    T, dt = _timing(case)
    ref = reference(case, feedforward)
    base = reference_edge(_drive(case, feedforward=feedforward), NAME, Q0, Q1, T, dt)
    for what in ("q", "v", "i", "V", "energy", "net_energy"):
        np.testing.assert_allclose(getattr(ref, what), getattr(base, what), rtol=1e-14,
                                   atol=0, err_msg=what)
    assert ref.P.min() < 0 < ref.P.max(), f"P never changes sign: {ref.P.min()} {ref.P.max()}"
    assert ref.bus[1] > 0.01 * ref.bus[0], f"B- too small to matter: {ref.bus}"
    # the identities of the reference alone: B⁺ − B⁻ = Σ E, B⁺ < Σ E⁺ (strictly here)
    assert ref.bus[0] - ref.bus[1] == pytest.approx(ref.net_energy.sum(), rel=RTOL_SAME)
    assert ref.bus[0] < ref.energy.sum() * (1 - 1e-3)


# -------------------------------------------------- 1. supply energy vs the reference
@pytest.mark.parametrize("supply", list(SUPPLIES))
@FF
@CASE
def test_supply_energy_matches_sympy(case, feedforward, supply):
    sim = simulation(case, feedforward, supply)
    ref = reference(case, feedforward)
    model = SUPPLIES[supply]
    assert sim.supply == model

    err_bus = _rel(sim.bus_energy, ref.bus)
    assert sim.bus_energy.shape == (2,)
    assert np.all(err_bus < RTOL_SUPPLY), f"B sim {sim.bus_energy} ref {ref.bus} rel {err_bus}"
    np.testing.assert_array_equal(sim.bus_energy_t[-1], sim.bus_energy)
    np.testing.assert_array_equal(sim.bus_energy_t[0], [0.0, 0.0])
    err_t = np.abs(sim.bus_energy_t - ref.bus_t).max(axis=0) / ref.bus
    assert np.all(err_t < RTOL_SUPPLY), f"cumulative B rel {err_t}"

    want = ref.supply_energy(model)
    got = sim.supply_energy
    err = abs(got - want) / abs(want)
    assert err < RTOL_SUPPLY, f"{supply}: supply energy sim {got} ref {want} rel {err}"
    if model.bus == "per_joint":
        assert got == sim.energy.sum()

    # Not trivial: the four models differ by far more than the tolerance on this edge.
    values = sorted(ref.supply_energy(s) for s in SUPPLIES.values())
    gaps = np.diff(values) / np.abs(values[1:])
    assert np.all(gaps > 100 * RTOL_SUPPLY), f"supply energies {values} too close"


# ------------------------------------------------- 2. batched vs single-edge bus energy
@pytest.mark.parametrize(
    ("name", "case", "dt"),
    [
        ("planar_3link", "paper_n5", 5e-3),
        ("planar_3link", "paper_n5_sat", 5e-3),
        ("planar_2link", "servo", 5e-3),  # dt·R/L = 10: the stiff (exponential) current update
    ],
)
@FF
def test_batched_bus_energy_matches_simulate_edge(name, case, dt, feedforward):
    """``edge_outcomes`` (abaInParallel, tables, grouped durations) vs ``simulate_edge``."""
    drive = _drive(case, feedforward=feedforward, supply=SUPPLIES["shared_eta0.6"], name=name)
    a, b = (np.asarray(x, float) for x in EDGES[name])
    rng = np.random.default_rng(7)
    Q0 = np.array([a, b, a, b + 0.3, *rng.uniform(-1.0, 1.0, (2, a.size))])
    Q1 = np.array([b, a, 0.5 * (a + b), a - 0.2, *rng.uniform(-1.0, 1.0, (2, a.size))])
    T = np.array([1.0, 1.0, 0.5, 0.75, 1.0, 0.5]) * _timing(case)[0] / _timing("paper_n5")[0]
    out = edge_outcomes(drive, Q0, Q1, duration=T, dt=dt, threads=2)
    assert out.bus_energy.shape == (len(Q0), 2)
    negative = 0
    for k in range(len(Q0)):
        sim = mp.simulate_edge(drive, Q0[k], Q1[k], duration=T[k], dt=dt)
        np.testing.assert_allclose(out.bus_energy[k], sim.bus_energy, rtol=RTOL_SAME,
                                   atol=1e-12 * sim.bus_energy[0], err_msg=f"edge {k}")
        np.testing.assert_allclose(out.energy[k], sim.energy, rtol=RTOL_SAME)
        negative += sim.bus_energy[1] > 1e-3 * sim.bus_energy[0]
    assert negative >= 2, f"too few edges with a braking bus: {out.bus_energy}"


# ------------------------------------------------------ 3. η = 1 and shared ≤ per-joint
@FF
@CASE
def test_full_regeneration_is_net_energy_and_shared_never_costs_more(case, feedforward):
    full = simulation(case, feedforward, "shared_eta1")
    # B⁺ − B⁻ = ∫ P = Σ_k ∫ V_k i_k: max(P, 0) − max(−P, 0) = P at every stage
    assert full.supply_energy == pytest.approx(full.net_energy.sum(), rel=RTOL_SAME)
    # max(Σx, 0) ≤ Σ max(x, 0) at every stage, and RK4's weights are positive
    Bp, Bm = full.bus_energy
    Ep = full.energy.sum()
    assert Bp < Ep * (1 - 1e-3), f"B+ {Bp} not strictly below E+ {Ep}"
    assert Bm < (full.energy - full.net_energy).sum() * (1 - 1e-3)
    slack = 1e-12 * Ep
    assert np.all(full.bus_energy_t[:, 0] <= full.energy_t.sum(axis=1) + slack)
    assert np.all(np.diff(full.bus_energy_t, axis=0) >= 0)
    e = {s: simulation(case, feedforward, s).supply_energy for s in SUPPLIES}
    assert e["per_joint"] > e["shared_eta0"] > e["shared_eta0.6"] > e["shared_eta1"], e


# ------------------------------------------------------------------ 4. P_bus series
@FF
@CASE
def test_p_bus_series(case, feedforward):
    """P_bus is Σ V·i of the returned series and matches the sympy bus power at the samples.

    Simpson over the step points is only a coarse check of B±: max(±P, 0) has kinks where P
    changes sign (Simpson is O(dt²) across them, not O(dt⁴)), and RK4 integrates B± on the
    half-step grid with its stage states, not on the N+1 samples. Measured: ≤ 3.5e-5 on B⁺,
    ≤ 4e-4 on B⁻ (paper motor, dt = 5 ms); hence RTOL_QUAD = 1e-3.
    """
    sim = simulation(case, feedforward, "shared_eta0")
    ref = reference(case, feedforward)
    P = sim.P_bus
    assert P.shape == sim.t.shape
    np.testing.assert_allclose(P, (sim.V * sim.i).sum(axis=1), rtol=1e-15, atol=0)
    np.testing.assert_allclose(P, ref.P, rtol=0, atol=RTOL_SUPPLY * np.abs(ref.P).max())
    assert P.min() < 0 < P.max()
    quad = [simpson(np.maximum(P, 0.0), x=sim.t), simpson(np.maximum(-P, 0.0), x=sim.t)]
    err = _rel(quad, sim.bus_energy)
    assert np.all(err < RTOL_QUAD), f"Simpson {quad} vs B {sim.bus_energy}: rel {err}"


# --------------------------------------------------------------------- 5. bad input
@pytest.mark.parametrize(
    ("args", "key"),
    [
        (("dc",), "bus"),
        (("shared", 1.5), "regeneration"),
        (("shared", -0.1), "regeneration"),
        (("shared", float("nan")), "regeneration"),
        (("shared", None), "regeneration"),
        (("per_joint", 0.3), "regeneration"),
    ],
)
def test_bad_supply(args, key):
    with pytest.raises(ValueError, match=rf"\b{key}\b"):
        mp.Supply(*args)


def test_bad_supply_keyword_and_drive():
    with pytest.raises(ValueError, match=r"\bbus\b"):
        mp.Supply(bus="dc")
    arm = pin_arm(NAME)
    with pytest.raises(ValueError, match="supply"):
        mp.Drive(arm, mp.SERVO_MOTOR, 50.0, 1.0, feedforward=True, supply="shared")
    # the accepted edge values
    assert mp.Supply("shared", 1).regeneration == 1.0
    assert mp.Supply("shared", 0.0).regeneration == 0.0
    assert mp.Drive(arm, mp.SERVO_MOTOR, 50.0, 1.0).supply == mp.Supply("per_joint", 0.0)
