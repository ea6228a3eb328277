"""Edge energies against an independent sympy model of the motor-augmented ODE (docs/design.md §3).

The reference here shares no code with ``mpd_pin.dynamics.simulate``: the rigid-body terms
D, C, G come from the sympy Lagrangian of ``test_dynamics_sympy`` (built from
the URDF files by hand), the quintic reference, the feed-forward
(``d i_ff/dt`` by sympy differentiation of τ_ff along the reference with
respect to t) and the motor equations are written in sympy and lambdified once
per arm; a plain classic RK4 below integrates

    (D(q) + diag(n²J)) q̈ = n Kt i − n² B q̇ − C(q, q̇) q̇ − G(q)
    L di/dt = V − R i − n Ke q̇
    dE⁺/dt = max(V i, 0),  dE/dt = V i
    V = sat(V_ff + Kp (q_ref − q) + Kd (q̇_ref − q̇), ±V_max)

with the controller evaluated at every stage time.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import simpson

import mpd_pin as mp

try:  # tests/ is on sys.path under pytest's default (rootdir-less, "prepend") import mode
    from test_dynamics_sympy import SympyArm, pin_arm, sympy_arm
except ImportError:  # pragma: no cover - if tests/ ever becomes a package
    from tests.test_dynamics_sympy import SympyArm, pin_arm, sympy_arm

RTOL_RK4 = 1e-8  # sympy RK4 vs simulate_edge, per joint
RTOL_BALANCE = 1e-6  # power balance by quadrature of the returned series

GEARED_PAPER = replace(mp.PAPER_MOTOR, gear_ratio=5.0)
SERVO_FREE = replace(mp.SERVO_MOTOR, v_max=None)


# ------------------------------------------------------------------ sympy ODE model
@dataclass
class SympyDrive:
    """Lambdified motor-augmented dynamics and feed-forward of one planar arm.

    Motor parameters are symbols too (one per joint), so each arm is derived once.
    """

    arm: SympyArm
    vff: object  # (t, T, q0, dq, motor) -> V_ff (nq)
    iff: object  # (t, T, q0, dq, motor) -> i_ff (nq)
    ref: object  # (t, T, q0, dq) -> q_ref, q̇_ref (2 nq)
    mass: object  # (q, motor) -> D + diag(n²J), nq×nq flat
    force: object  # (q, v, i, motor) -> n Kt i − n² B q̇ − C q̇ − G
    didt: object  # (v, i, V, motor) -> (V − R i − n Ke q̇)/L

    @property
    def nq(self) -> int:
        return self.arm.nq


def _motor_args(drive: mp.Drive) -> list[list[float]]:
    """The motor parameter vectors in the order the lambdified functions take them."""
    return [
        list(map(float, a))
        for a in (drive.R, drive.L, drive.Kt, drive.Ke, drive.B, drive.J, drive.n)
    ]


@functools.cache
def sympy_drive(name: str) -> SympyDrive:
    s = sympy_arm(name)
    n = s.nq
    q, qd = list(s.q), list(s.qd)
    cur = list(sp.symbols(f"i1:{n + 1}", real=True))
    volt = list(sp.symbols(f"V1:{n + 1}", real=True))
    R, L, Kt, Ke, B, J, N = (
        list(sp.symbols(f"{p}1:{n + 1}", positive=True))
        for p in ("R", "L", "Kt", "Ke", "B", "J", "n")
    )
    motor = [R, L, Kt, Ke, B, J, N]
    armature = sp.diag(*[N[k] ** 2 * J[k] for k in range(n)])
    damping = sp.diag(*[N[k] ** 2 * B[k] for k in range(n)])
    qdv = sp.Matrix(qd)
    mass = s.D + armature
    force = sp.Matrix([N[k] * Kt[k] * cur[k] for k in range(n)]) - damping * qdv - s.C * qdv - s.G
    didt = [(volt[k] - R[k] * cur[k] - N[k] * Ke[k] * qd[k]) / L[k] for k in range(n)]

    # Quintic rest-to-rest reference q_r(t) = q0 + dq s(t/T).
    t, T = sp.symbols("t T", positive=True)
    q0 = list(sp.symbols(f"q0_1:{n + 1}", real=True))
    dq = list(sp.symbols(f"dq1:{n + 1}", real=True))
    tau = t / T
    s_t = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    qr = sp.Matrix([q0[k] + dq[k] * s_t for k in range(n)])
    qrd = qr.diff(t)
    qrdd = qrd.diff(t)
    on_ref = dict(zip(q + qd, list(qr) + list(qrd), strict=True))
    D_r = s.D.xreplace(on_ref)
    C_r = s.C.xreplace(on_ref)
    G_r = s.G.xreplace(on_ref)
    tau_ff = D_r * qrdd + C_r * qrd + G_r + armature * qrdd + damping * qrd
    i_ff = [tau_ff[k] / (N[k] * Kt[k]) for k in range(n)]
    di_ff = [sp.diff(i_ff[k], t) for k in range(n)]  # symbolic d/dt along the reference
    v_ff = [R[k] * i_ff[k] + L[k] * di_ff[k] + N[k] * Ke[k] * qrd[k] for k in range(n)]

    def lam(args, exprs):
        return sp.lambdify(args, list(exprs), modules="math", cse=True)

    return SympyDrive(
        arm=s,
        vff=lam([t, T, q0, dq, motor], v_ff),
        iff=lam([t, T, q0, dq, motor], i_ff),
        ref=lam([t, T, q0, dq], list(qr) + list(qrd)),
        mass=lam([q, motor], list(mass)),
        force=lam([q, qd, cur, motor], list(force)),
        didt=lam([qd, cur, volt, motor], didt),
    )


@dataclass
class RefRun:
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    i: np.ndarray
    V: np.ndarray
    energy: np.ndarray
    net_energy: np.ndarray
    extra_t: np.ndarray | None = None  # the ``extra`` states at every step point


def reference_edge(drive: mp.Drive, name: str, q0, q1, T: float, dt: float,
                   extra=None) -> RefRun:
    """Classic RK4 on the sympy model, state [q, q̇, i, E⁺, E] and, with ``extra`` (a
    function of the stage's V and i giving m derivatives), m more states."""
    sd = sympy_drive(name)
    nq = sd.nq
    q0 = [float(x) for x in q0]
    dq = [float(b) - a for a, b in zip(q0, q1, strict=True)]
    mot = _motor_args(drive)
    kp, kd = drive.kp_vec, drive.kd_vec
    vmax = np.array([math.inf if m.v_max is None else m.v_max for m in drive.motor_list])
    ff = drive.feedforward
    steps = round(T / dt)
    assert abs(steps * dt - T) < 1e-12
    h = T / steps

    def voltage(t, q, v):
        r = np.array(sd.ref(t, T, q0, dq))
        V = kp * (r[:nq] - q) + kd * (r[nq:] - v)
        if ff:
            V = V + np.array(sd.vff(t, T, q0, dq, mot))
        return np.clip(V, -vmax, vmax)

    def rate(t, x):
        q, v, i = x[:nq], x[nq : 2 * nq], x[2 * nq : 3 * nq]
        V = voltage(t, q, v)
        M = np.array(sd.mass(q, mot)).reshape(nq, nq)
        a = np.linalg.solve(M, np.array(sd.force(q, v, i, mot)))
        di = np.array(sd.didt(v, i, V, mot))
        P = V * i
        more = [] if extra is None else list(extra(V, i))
        return np.concatenate([v, a, di, np.maximum(P, 0.0), P, more]), V

    i0 = sd.arm.gravity(np.array(q0)) / (drive.n * drive.Kt)  # holding current G(q0)/(n Kt)
    m = 0 if extra is None else len(extra(np.zeros(nq), np.zeros(nq)))
    x = np.concatenate([q0, np.zeros(nq), i0, np.zeros(2 * nq + m)])
    X = [x]
    Vs = []
    for k in range(steps):
        t = k * h
        k1, V0 = rate(t, x)
        k2, _ = rate(t + h / 2, x + h / 2 * k1)
        k3, _ = rate(t + h / 2, x + h / 2 * k2)
        k4, _ = rate(t + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        X.append(x)
        Vs.append(V0)
    Vs.append(voltage(T, x[:nq], x[nq : 2 * nq]))
    X = np.array(X)
    return RefRun(
        t=np.arange(steps + 1) * h,
        q=X[:, :nq],
        v=X[:, nq : 2 * nq],
        i=X[:, 2 * nq : 3 * nq],
        V=np.array(Vs),
        energy=X[-1, 3 * nq : 4 * nq],
        net_energy=X[-1, 4 * nq : 5 * nq],
        extra_t=X[:, 5 * nq :] if m else None,
    )


# ------------------------------------------------------------------------- scenarios
EDGES = {
    "planar_2link": ([-0.3, 0.8], [0.9, -0.4]),
    "planar_3link": ([-0.5, 0.7, 0.3], [0.6, -0.2, 1.0]),
}
# motor, kp (V/rad), kd (V·s/rad), T (s), dt (s), v_max used for the saturated runs (V)
SETUPS = {
    "paper_n5": (GEARED_PAPER, 200.0, 150.0, 1.0, 5e-3, 250.0),
    "servo": (SERVO_FREE, 50.0, 1.0, 0.5, 5e-4, 15.0),
}


def _drive(name: str, setup: str, *, feedforward: bool, saturate: bool) -> mp.Drive:
    motor, kp, kd, _, _, vmax = SETUPS[setup]
    motor = replace(motor, v_max=vmax if saturate else None)
    return mp.Drive(pin_arm(name), motor, kp, kd, feedforward=feedforward)


def _rel(a, b) -> np.ndarray:
    return np.abs(np.asarray(a) - np.asarray(b)) / np.abs(np.asarray(b))


# ----------------------------------------------------------- RK4: sympy vs simulate_edge
@pytest.mark.parametrize("saturate", [False, True], ids=["free", "sat"])
@pytest.mark.parametrize("feedforward", [False, True], ids=["pd", "ff"])
@pytest.mark.parametrize("setup", sorted(SETUPS))
@pytest.mark.parametrize("name", sorted(EDGES))
def test_simulate_edge_matches_sympy_rk4(name, setup, feedforward, saturate):
    drive = _drive(name, setup, feedforward=feedforward, saturate=saturate)
    _, _, _, T, dt, vmax = SETUPS[setup]
    q0, q1 = EDGES[name]
    sim = mp.simulate_edge(drive, q0, q1, duration=T, dt=dt)
    ref = reference_edge(drive, name, q0, q1, T, dt)

    # Purely relative, no absolute floor: the smallest per-joint energy here is 3.3e-4 J
    # (servo, PD only, saturated, joint 2) against ~20 J on joint 1, and it still agrees
    # to ~1e-13 relative.
    assert np.all(np.abs(ref.energy) > 1e-4) and np.all(np.abs(ref.net_energy) > 1e-4)
    err_p, err_n = _rel(sim.energy, ref.energy), _rel(sim.net_energy, ref.net_energy)
    assert np.all(err_p < RTOL_RK4), f"E+ sim {sim.energy} ref {ref.energy} rel {err_p}"
    assert np.all(err_n < RTOL_RK4), f"E sim {sim.net_energy} ref {ref.net_energy} rel {err_n}"
    np.testing.assert_allclose(sim.energy_t[-1], sim.energy, rtol=0, atol=0)
    np.testing.assert_allclose(sim.net_energy_t[-1], sim.net_energy, rtol=0, atol=0)
    assert np.all(sim.energy >= 0)

    # The whole trajectories agree too.
    np.testing.assert_allclose(sim.t, ref.t, rtol=0, atol=1e-12)
    for what in ("q", "v", "i", "V"):
        a, b = getattr(sim, what), getattr(ref, what)
        np.testing.assert_allclose(a, b, rtol=0, atol=RTOL_RK4 * np.max(np.abs(b)), err_msg=what)
    s = np.array(sympy_drive(name).ref(0.0, T, q0, [b - a for a, b in zip(q0, q1, strict=True)]))
    np.testing.assert_allclose(sim.q_ref[0], s[: len(q0)], atol=1e-15)
    np.testing.assert_allclose(sim.q_ref[-1], q1, atol=1e-12)

    # Saturation is really exercised (or really absent).
    peak = np.max(np.abs(sim.V), axis=0)
    if saturate:
        assert np.all(peak <= vmax * (1 + 1e-15))
        assert np.any(peak >= vmax * (1 - 1e-12)), f"never saturated: peak |V| {peak}"
        assert np.any(np.max(np.abs(ref.V), axis=0) >= vmax * (1 - 1e-12))
    else:
        assert not np.any(np.isfinite(drive.v_max))
        assert np.any(peak > vmax), "the saturated twin of this run would not saturate"


@pytest.mark.parametrize("saturate", [False, True], ids=["free", "sat"])
@pytest.mark.parametrize("feedforward", [False, True], ids=["pd", "ff"])
@pytest.mark.parametrize("setup", sorted(SETUPS))
def test_batched_edge_energies_match_sympy_rk4(setup, feedforward, saturate):
    """``edge_energies`` (abaInParallel, batched feed-forward) on an edge and its reverse."""
    name = "planar_3link"
    drive = _drive(name, setup, feedforward=feedforward, saturate=saturate)
    _, _, _, T, dt, _ = SETUPS[setup]
    q0, q1 = EDGES[name]
    Ep, En = mp.edge_energies(drive, [q0, q1], [q1, q0], duration=T, dt=dt, net=True, threads=2)
    assert Ep.shape == En.shape == (2, 3)
    for k, (a, b) in enumerate([(q0, q1), (q1, q0)]):
        ref = reference_edge(drive, name, a, b, T, dt)
        assert np.all(_rel(Ep[k], ref.energy) < RTOL_RK4), (k, Ep[k], ref.energy)
        assert np.all(_rel(En[k], ref.net_energy) < RTOL_RK4), (k, En[k], ref.net_energy)


@pytest.mark.parametrize("name", sorted(EDGES))
def test_feedforward_tracks_exactly_and_ideal_energy_matches_sympy(name):
    """With the exact model, V_ff from the sympy d/dt makes q follow q_ref (a check of V_ff)."""
    q0, q1 = EDGES[name]
    T, dt = 0.5, 5e-4
    drive = _drive(name, "servo", feedforward=True, saturate=False)
    sim = mp.simulate_edge(drive, q0, q1, duration=T, dt=dt)
    assert np.max(np.abs(sim.q - sim.q_ref)) < 1e-8
    # Ideal energy: V_ff·i_ff of the sympy model, Simpson on the half-step grid (RK4's rule).
    sd = sympy_drive(name)
    dq = [b - a for a, b in zip(q0, q1, strict=True)]
    mot = _motor_args(drive)
    steps = round(T / dt)
    th = np.linspace(0.0, T, 2 * steps + 1)
    P = np.array([np.multiply(sd.vff(t, T, q0, dq, mot), sd.iff(t, T, q0, dq, mot)) for t in th])
    w = np.ones(th.size)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    w *= dt / 6
    ideal_p, ideal_n = w @ np.maximum(P, 0.0), w @ P
    got_p, got_n = mp.ideal_edge_energy(drive, q0, q1, duration=T, dt=dt, net=True)
    assert np.all(_rel(got_p, ideal_p) < RTOL_RK4), (got_p, ideal_p)
    assert np.all(_rel(got_n, ideal_n) < RTOL_RK4), (got_n, ideal_n)
    # the holding current and rest-to-rest reference
    np.testing.assert_allclose(
        sd.iff(0.0, T, q0, dq, mot), sd.arm.gravity(np.array(q0)) / (drive.n * drive.Kt)
    )
    np.testing.assert_allclose(sim.i[0], sd.iff(0.0, T, q0, dq, mot), rtol=1e-12)


# ---------------------------------------------------------------------- power balance
@pytest.mark.parametrize(
    ("setup", "feedforward", "saturate", "dt"),
    [
        ("paper_n5", False, False, 2e-4),
        ("paper_n5", True, False, 2e-4),
        ("paper_n5", True, True, 2e-4),
        ("servo", False, False, 1e-4),
        ("servo", True, True, 1e-4),
    ],
)
def test_power_balance_of_returned_series(setup, feedforward, saturate, dt):
    """∫V i = ∫R i² + ½L(i(T)² − i(0)²) + (Ke/Kt)∫ n Kt i q̇, per joint, from (t, V, i, v) alone."""
    name = "planar_2link"
    q0, q1 = EDGES[name]
    drive = _drive(name, setup, feedforward=feedforward, saturate=saturate)
    sim = mp.simulate_edge(drive, q0, q1, duration=0.5, dt=dt)
    t, V, i, v = sim.t, sim.V, sim.i, sim.v
    joule = simpson(drive.R * i**2, x=t, axis=0)
    magnetic = 0.5 * drive.L * (i[-1] ** 2 - i[0] ** 2)
    mechanical = simpson(drive.n * drive.Kt * i * v, x=t, axis=0)  # motor torque × joint rate
    balance = joule + magnetic + drive.Ke / drive.Kt * mechanical
    err_bal = _rel(balance, sim.net_energy)
    assert np.all(err_bal < RTOL_BALANCE), f"net {sim.net_energy} balance {balance} rel {err_bal}"
    if saturate:
        # sat() puts kinks in V(t): Simpson on V·i is only O(dt²) across them and lands
        # anywhere in 1e-8 … 2e-6 (measured) depending on where the kinks fall in the
        # panels, so ∫V·i is taken from the balance terms above (i², i·q̇ are C¹).
        assert np.any(np.abs(V) >= drive.v_max * (1 - 1e-12)), "never saturated"
    else:
        supplied = simpson(V * i, x=t, axis=0)
        err = _rel(balance, supplied)
        assert np.all(err < RTOL_BALANCE), f"∫Vi {supplied} balance {balance} rel {err}"
        err_net = _rel(sim.net_energy, supplied)
        assert np.all(err_net < RTOL_BALANCE), f"net {sim.net_energy} ∫Vi {supplied} rel {err_net}"
    assert np.all(sim.energy >= sim.net_energy - 1e-12 * np.abs(sim.net_energy))


# ----------------------------------------------------------------- perfect tracking
def test_energy_converges_to_ideal_as_gains_grow():
    """Feed-forward off: PD alone. As Kp, Kd → ∞ the tracking becomes perfect, E⁺ → ideal.

    A servo (L/R = 0.5 ms) is used: its fast electrical pole damps the loop. (With the
    paper motor, L/R = 0.5 s, the high-gain loop rings for the whole edge and E⁺ of the
    rectified oscillation does not converge.) dt = 1e-4 s keeps RK4 stable at 10⁴×.
    """
    name = "planar_2link"
    q0, q1 = EDGES[name]
    T, dt = 0.5, 1e-4
    kp0, kd0 = 50.0, 1.0
    ideal = None
    errs, errs_joint = [], []
    for scale in (10, 100, 1000, 10000):
        drive = mp.Drive(pin_arm(name), SERVO_FREE, kp0 * scale, kd0 * scale, feedforward=False)
        if ideal is None:
            ideal = mp.ideal_edge_energy(drive, q0, q1, duration=T, dt=dt)
        sim = mp.simulate_edge(drive, q0, q1, duration=T, dt=dt)
        errs.append(abs(sim.energy.sum() - ideal.sum()) / ideal.sum())
        errs_joint.append(_rel(sim.energy, ideal))
    errs_joint = np.array(errs_joint)
    msg = f"relative |E+ - ideal| (sum): {errs}; per joint: {errs_joint.tolist()}"
    assert all(b < a for a, b in zip(errs, errs[1:], strict=False)), msg
    assert np.all(np.diff(errs_joint, axis=0) < 0), msg
    assert errs[-1] < 1e-3 and np.all(errs_joint[-1] < 1e-3), msg


# --------------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def servo_drive() -> mp.Drive:
    return _drive("planar_2link", "servo", feedforward=True, saturate=False)


def test_duration_not_whole_number_of_steps(servo_drive):
    with pytest.raises(ValueError, match="whole number of steps"):
        mp.simulate_edge(servo_drive, [0.0, 0.0], [0.1, 0.1], duration=1.0, dt=0.003)
    with pytest.raises(ValueError, match="whole number of steps"):
        mp.ideal_edge_energy(servo_drive, [0.0, 0.0], [0.1, 0.1], duration=1.0, dt=0.003)


def test_nan_and_wrong_length_configurations(servo_drive):
    with pytest.raises(ValueError, match=r"q0 contains NaN"):
        mp.simulate_edge(servo_drive, [math.nan, 0.0], [0.1, 0.1], duration=0.5, dt=5e-4)
    with pytest.raises(ValueError, match=r"q1 must have 2 joint values"):
        mp.simulate_edge(servo_drive, [0.0, 0.0], [0.1, 0.1, 0.1], duration=0.5, dt=5e-4)
    with pytest.raises(ValueError, match="NaN or infinite"):
        mp.edge_energies(servo_drive, [[0.0, math.nan]], [[0.1, 0.1]], duration=0.5, dt=5e-4)


@pytest.mark.parametrize("field", ["R", "L", "Kt", "gear_ratio"])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_dc_motor_rejects_non_positive_constants(field, value):
    with pytest.raises(ValueError, match=rf"DCMotor\.{field} must be a finite number > 0"):
        mp.DCMotor(**{field: value})


def test_urdf_without_movable_joint():
    xml = (
        '<robot name="rigid"><link name="a"/><link name="b"/>'
        '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>'
    )
    with pytest.raises(ValueError, match="no movable joint"):
        mp.Arm.from_urdf(xml)


def test_malformed_urdf_xml():
    with pytest.raises(ValueError, match="malformed URDF XML"):
        mp.Arm.from_urdf('<robot name="x"><link name="a"></robot>')


def test_unknown_example_robot_data_name():
    with pytest.raises(ValueError, match="unknown example-robot-data robot 'no_such_robot'"):
        mp.Arm.from_example_robot_data("no_such_robot")


def test_stiff_servo_runs_at_5ms(servo_drive):
    """The servo preset (L/R = 0.5 ms, dt·R/L = 10 at 5 ms) is integrated at dt = 5 ms, and the
    paper motor (L/R = 0.5 s) stays on classical RK4."""
    from mpd_pin.dynamics.current import current_model

    assert servo_drive.L[0] / servo_drive.R[0] == pytest.approx(5e-4)
    assert current_model(servo_drive, 5e-3)["name"] == "exponential"
    paper = mp.Drive(servo_drive.arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    assert current_model(paper, 5e-3)["name"] == "rk4"
    assert current_model(paper, 5e-3)["stiff_joints"] == []
    sim = mp.simulate_edge(servo_drive, [0.0, 0.0], [0.1, 0.1], duration=0.5, dt=5e-3)
    E = mp.edge_energies(servo_drive, [[0.0, 0.0]], [[0.1, 0.1]], duration=0.5, dt=5e-3)[0]
    np.testing.assert_allclose(sim.energy, E, rtol=1e-12)
    np.testing.assert_allclose(sim.q[-1], [0.1, 0.1], atol=1e-4)


@pytest.mark.parametrize("tau_e", [5e-5, 5e-4, 1.9e-3])
def test_stiff_current_matches_resolved_rk4(tau_e):
    """E⁺ per joint at dt = 5 ms within 0.1 % of classical RK4 resolved at dt·R/L ≤ 0.2
    (docs/design.md §3e), for electrical time constants L/R of 0.05 to 1.9 ms (dt·R/L = 100 to
    2.6). One joint keeps a slow motor, so the step is partitioned (RK4 current beside
    exponential ones).
    Measured: ≤ 3.6e-4 relative (joint 2), ≤ 1e-4 on the others."""
    from mpd_pin.dynamics.current import current_model

    arm = mp.builtin_arm("planar_3link")
    motors = [mp.DCMotor(R=2.0, L=2.0 * tau_e, Kt=0.03, Ke=0.03, B=1e-6, J=5e-6,
                         gear_ratio=100.0) for _ in range(2)]
    motors.append(mp.DCMotor(R=2.0, L=0.2, Kt=0.03, Ke=0.03, B=1e-6, J=5e-6, gear_ratio=100.0))
    # the panda scenario's gains; with kp = 200, kd = 10 this light arm's fastest closed-loop
    # mechanical pole alone makes RK4 at 5 ms err by 2e-3 (converging as dt⁴), whatever L/R
    drive = mp.Drive(arm, motors, kp=20.0, kd=1.0, feedforward=True)
    assert current_model(drive, 5e-3)["stiff_joints"] == [0, 1]
    q0, q1, T = np.array([0.3, 0.2, -0.1]), np.array([1.0, -0.4, 0.5]), 0.5
    dt_ref = T / math.ceil(T / (0.2 * tau_e))
    assert current_model(drive, dt_ref)["name"] == "rk4"
    ref = mp.edge_energies(drive, q0[None], q1[None], T, dt_ref)[0]
    fast = mp.edge_energies(drive, q0[None], q1[None], T, 5e-3)[0]
    np.testing.assert_allclose(fast, ref, rtol=1e-3)
    sim = mp.simulate_edge(drive, q0, q1, T, 5e-3)
    np.testing.assert_allclose(sim.energy, fast, rtol=1e-12)
