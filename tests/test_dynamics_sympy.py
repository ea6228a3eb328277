"""Rigid-body terms of the planar arms against a sympy Lagrangian (docs/design.md §1-2).

The reference model is built here from the committed URDF files, read with
``xml.etree`` (never through Pinocchio): joint offsets, link masses, centres of
mass and inertia tensors about the COM, joint axes. The arm moves in the
vertical x–z plane; gravity is g = 9.81 m/s² along −z (Pinocchio's default,
checked below). From the Lagrangian L = T − V sympy gives

    D(q) = ∂²T/∂q̇∂q̇,   G(q) = ∂V/∂q,
    C_kj = Σ_i ½ (∂D_kj/∂q_i + ∂D_ki/∂q_j − ∂D_ij/∂q_k) q̇_i      (Christoffel),

which are compared with :class:`mpd_pin.Arm` (``pin.crba``,
``pin.computeCoriolisMatrix``, ``pin.computeGeneralizedGravity``).

``test_energy_sympy.py`` reuses :func:`sympy_arm` for its motor-augmented ODE.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

import mpd_pin as mp

ROOT = Path(__file__).resolve().parent.parent
ARMS = ("planar_2link", "planar_3link")
GRAVITY = 9.81  # m/s², along −z
N_STATES = 120  # random states per arm
ATOL = 1e-10  # absolute; D ~ 0.1–1 kg·m², C q̇ ~ 1 N·m, G ≤ ~12 N·m: all O(1)–O(10)


# ------------------------------------------------------------------ URDF, read by hand
@dataclass(frozen=True)
class PlanarLink:
    """One revolute joint and the link it moves, as read from the URDF."""

    joint: str
    offset: tuple[float, float]  # joint origin (x, z) in the parent link frame (m)
    axis_y: float  # y component of the joint axis (±1)
    mass: float  # kg
    com: tuple[float, float]  # COM (x, z) in the link frame (m)
    inertia: np.ndarray  # 3×3 tensor about the COM, link axes (kg·m²)


@dataclass(frozen=True)
class PlanarArmData:
    name: str
    links: tuple[PlanarLink, ...]
    ee_offset: tuple[float, float]  # 'ee' frame origin in the last link frame (m)

    @property
    def lengths(self) -> list[float]:
        """l_k: distance from joint k to joint k+1 (or to 'ee' for the last link)."""
        return [lk.offset[0] for lk in self.links[1:]] + [self.ee_offset[0]]


def _floats(text: str | None, default: str) -> list[float]:
    return [float(x) for x in (text or default).split()]


def _origin(elem: ET.Element | None) -> tuple[list[float], list[float]]:
    if elem is None:
        return [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    return _floats(elem.get("xyz"), "0 0 0"), _floats(elem.get("rpy"), "0 0 0")


def parse_planar_urdf(path: Path) -> PlanarArmData:
    """Walk the kinematic chain from the root link; check the planar conventions on the way."""
    root = ET.parse(path).getroot()
    assert root.tag == "robot"
    links = {lk.get("name"): lk for lk in root.findall("link")}
    joints = root.findall("joint")
    children = {j.find("child").get("link") for j in joints}
    (base,) = [name for name in links if name not in children]
    by_parent = {j.find("parent").get("link"): j for j in joints}
    chain: list[PlanarLink] = []
    ee_offset = None
    current = base
    while current in by_parent:
        j = by_parent[current]
        xyz, rpy = _origin(j.find("origin"))
        assert rpy == [0.0, 0.0, 0.0] and xyz[1] == 0.0, f"{j.get('name')} leaves the x–z plane"
        child = j.find("child").get("link")
        if j.get("type") == "fixed":
            assert child == "ee" and child not in by_parent
            ee_offset = (xyz[0], xyz[2])
        else:
            assert j.get("type") == "revolute"
            axis = _floats(j.find("axis").get("xyz"), "1 0 0")
            assert axis[0] == 0.0 and axis[2] == 0.0 and abs(axis[1]) == 1.0
            inertial = links[child].find("inertial")
            cxyz, crpy = _origin(inertial.find("origin"))
            assert crpy == [0.0, 0.0, 0.0] and cxyz[1] == 0.0
            a = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
            inertia = np.array(
                [
                    [a["ixx"], a["ixy"], a["ixz"]],
                    [a["ixy"], a["iyy"], a["iyz"]],
                    [a["ixz"], a["iyz"], a["izz"]],
                ]
            )
            chain.append(
                PlanarLink(
                    joint=j.get("name"),
                    offset=(xyz[0], xyz[2]),
                    axis_y=axis[1],
                    mass=float(inertial.find("mass").get("value")),
                    com=(cxyz[0], cxyz[2]),
                    inertia=inertia,
                )
            )
        current = child
    assert ee_offset is not None, "no fixed 'ee' frame"
    return PlanarArmData(name=root.get("name"), links=tuple(chain), ee_offset=ee_offset)


# --------------------------------------------------------------------- sympy Lagrangian
def _rot(phi, p):
    """Rotate the in-plane vector p = (x, z) by the angle φ measured from +x towards +z."""
    c, s = sp.cos(phi), sp.sin(phi)
    return sp.Matrix([p[0] * c - p[1] * s, p[0] * s + p[1] * c])


@dataclass
class SympyArm:
    """Symbolic D, C, G (and kinematics) of a planar arm, with numpy-lambdified versions."""

    data: PlanarArmData
    q: sp.Matrix
    qd: sp.Matrix
    D: sp.Matrix
    C: sp.Matrix
    G: sp.Matrix
    Ddot: sp.Matrix
    ee: sp.Matrix  # (x, z) of the 'ee' frame
    el_residual: sp.Matrix  # d/dt ∂L/∂q̇ − ∂L/∂q − (D q̈ + C q̇ + G), with q̈ symbols
    qdd: sp.Matrix

    @property
    def nq(self) -> int:
        return len(self.q)

    def __post_init__(self) -> None:
        q, qd = list(self.q), list(self.qd)
        self.D_f = sp.lambdify([q], self.D, "numpy", cse=True)
        self.C_f = sp.lambdify([q, qd], self.C, "numpy", cse=True)
        self.G_f = sp.lambdify([q], self.G, "numpy", cse=True)
        self.Ddot_f = sp.lambdify([q, qd], self.Ddot, "numpy", cse=True)
        self.ee_f = sp.lambdify([q], self.ee, "numpy", cse=True)
        self.el_f = sp.lambdify([q, qd, list(self.qdd)], self.el_residual, "numpy", cse=True)

    # numpy front ends (float arrays in, float arrays out)
    def mass_matrix(self, q) -> np.ndarray:
        return np.asarray(self.D_f(q), dtype=float)

    def coriolis_matrix(self, q, v) -> np.ndarray:
        return np.asarray(self.C_f(q, v), dtype=float)

    def gravity(self, q) -> np.ndarray:
        return np.asarray(self.G_f(q), dtype=float).ravel()


def build_sympy_arm(data: PlanarArmData) -> SympyArm:
    n = len(data.links)
    q = sp.Matrix(sp.symbols(f"q1:{n + 1}", real=True))
    qd = sp.Matrix(sp.symbols(f"qd1:{n + 1}", real=True))
    qdd = sp.Matrix(sp.symbols(f"qdd1:{n + 1}", real=True))
    g = sp.Float(GRAVITY)
    T = sp.Integer(0)
    V = sp.Integer(0)
    joint_pos = sp.Matrix([0, 0])
    phi = sp.Integer(0)  # in-plane angle of the parent link frame, from +x towards +z
    phid = sp.Integer(0)
    for k, lk in enumerate(data.links):
        joint_pos = joint_pos + _rot(phi, sp.Matrix(lk.offset))
        # A rotation q about the axis (0, a_y, 0) is a rotation a_y·q about +y, which turns
        # +x towards −z; the in-plane angle towards +z therefore grows by −a_y·q.
        phi = phi - sp.Integer(round(lk.axis_y)) * q[k]
        phid = phid - sp.Integer(round(lk.axis_y)) * qd[k]
        com = joint_pos + _rot(phi, sp.Matrix(lk.com))
        com_vel = com.jacobian(q) * qd
        # The link rotates about the world y axis, which its own frame shares: its angular
        # velocity (world = body frame components) is d(angle about +y)/dt = −φ̇ along y.
        omega = sp.Matrix([0, -phid, 0])
        T += sp.Rational(1, 2) * lk.mass * (com_vel.T * com_vel)[0]
        T += sp.Rational(1, 2) * (omega.T * sp.Matrix(lk.inertia) * omega)[0]
        V += lk.mass * g * com[1]
    ee = joint_pos + _rot(phi, sp.Matrix(data.ee_offset))
    D = sp.hessian(T, list(qd))
    G = sp.Matrix([sp.diff(V, qk) for qk in q])
    C = sp.zeros(n, n)
    for k in range(n):
        for j in range(n):
            C[k, j] = sum(
                sp.Rational(1, 2)
                * (sp.diff(D[k, j], q[i]) + sp.diff(D[k, i], q[j]) - sp.diff(D[i, j], q[k]))
                * qd[i]
                for i in range(n)
            )
    Ddot = sp.zeros(n, n)
    for a in range(n):
        for b in range(n):
            Ddot[a, b] = sum(sp.diff(D[a, b], q[i]) * qd[i] for i in range(n))
    # Euler–Lagrange directly from L (chain rule for d/dt), to check D, C, G among themselves.
    L = T - V
    dL_dqd = sp.Matrix([sp.diff(L, v) for v in qd])
    ddt = dL_dqd.jacobian(q) * qd + dL_dqd.jacobian(qd) * qdd
    el = ddt - sp.Matrix([sp.diff(L, qk) for qk in q])
    residual = el - (D * qdd + C * qd + G)
    return SympyArm(data, q, qd, D, C, G, Ddot, ee, residual, qdd)


@functools.cache
def sympy_arm(name: str) -> SympyArm:
    """The sympy model of ``robots/<name>.urdf`` (cached: derivation + lambdify once)."""
    return build_sympy_arm(parse_planar_urdf(ROOT / "robots" / f"{name}.urdf"))


@functools.cache
def pin_arm(name: str) -> mp.Arm:
    return mp.Arm.from_urdf(ROOT / "robots" / f"{name}.urdf")


def random_states(nq: int, seed: int, count: int = N_STATES):
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-math.pi, math.pi, (count, nq))
    V = rng.uniform(-3.0, 3.0, (count, nq))
    A = rng.uniform(-5.0, 5.0, (count, nq))
    return Q, V, A


# ----------------------------------------------------------------------------- tests
def test_pinocchio_default_gravity_is_9_81_down():
    np.testing.assert_array_equal(pin.Model().gravity.linear, [0.0, 0.0, -GRAVITY])
    assert pin_arm("planar_2link").model.gravity.linear[2] == -GRAVITY


@pytest.mark.parametrize("name", ARMS)
def test_urdf_read_by_hand_matches_spec(name):
    """The hand parser reads what the generator was asked for (guards the parser itself)."""
    data = parse_planar_urdf(ROOT / "robots" / f"{name}.urdf")
    spec = mp.BUILTIN_ARMS[name]
    assert len(data.links) == len(spec.lengths) == pin_arm(name).nq
    np.testing.assert_allclose(data.lengths, spec.lengths, rtol=0, atol=1e-15)
    for lk, l, m in zip(data.links, spec.lengths, spec.masses, strict=True):
        assert lk.axis_y == -1.0
        assert lk.mass == pytest.approx(m, abs=1e-15)
        np.testing.assert_allclose(lk.com, (l / 2, 0.0), atol=1e-15)
        # uniform solid cylinder along x, about its COM
        r = spec.radius
        expect = np.diag([m * r**2 / 2, m * (3 * r**2 + l**2) / 12, m * (3 * r**2 + l**2) / 12])
        np.testing.assert_allclose(lk.inertia, expect, rtol=1e-12, atol=0)


@pytest.mark.parametrize("name", ARMS)
def test_sympy_euler_lagrange_equals_d_c_g(name):
    """Self-check of the reference: EL equations of L = T − V equal D q̈ + C q̇ + G."""
    s = sympy_arm(name)
    Q, V, A = random_states(s.nq, seed=7)
    worst = max(
        float(np.max(np.abs(np.asarray(s.el_f(q, v, a), dtype=float))))
        for q, v, a in zip(Q, V, A, strict=True)
    )
    assert worst < 1e-11, worst


@pytest.mark.parametrize("name", ARMS)
def test_mass_matrix_matches_sympy(name):
    s, arm = sympy_arm(name), pin_arm(name)
    Q, _, _ = random_states(s.nq, seed=1)
    errs = []
    for q in Q:
        D_ref = s.mass_matrix(q)
        D = arm.mass_matrix(q)
        np.testing.assert_allclose(D, D_ref, rtol=0, atol=ATOL)
        np.testing.assert_array_equal(D, D.T)
        assert np.all(np.linalg.eigvalsh(D_ref) > 0)
        errs.append(np.max(np.abs(D - D_ref)))
    assert max(errs) < ATOL


@pytest.mark.parametrize("name", ARMS)
def test_coriolis_matrix_matches_christoffel(name):
    s, arm = sympy_arm(name), pin_arm(name)
    Q, V, _ = random_states(s.nq, seed=2)
    for q, v in zip(Q, V, strict=True):
        C_ref = s.coriolis_matrix(q, v)
        C = arm.coriolis_matrix(q, v)
        np.testing.assert_allclose(C @ v, C_ref @ v, rtol=0, atol=ATOL)
        np.testing.assert_allclose(C, C_ref, rtol=0, atol=ATOL)


@pytest.mark.parametrize("name", ARMS)
def test_gravity_matches_sympy(name):
    s, arm = sympy_arm(name), pin_arm(name)
    Q, _, _ = random_states(s.nq, seed=3)
    for q in Q:
        np.testing.assert_allclose(arm.gravity(q), s.gravity(q), rtol=0, atol=ATOL)
    # and it is not trivially zero (vertical plane): horizontal arm, all links pull down
    G0 = s.gravity(np.zeros(s.nq))
    assert np.all(G0 > 0.1)


def _mass_matrix_rate(arm: mp.Arm, q: np.ndarray, v: np.ndarray, eps: float = 1e-3) -> np.ndarray:
    """Ḋ = dD(q + s v)/ds at s = 0 from the Arm alone: central differences + Richardson (O(ε⁴))."""

    def central(e):
        return (arm.mass_matrix(q + e * v) - arm.mass_matrix(q - e * v)) / (2 * e)

    return (4 * central(eps / 2) - central(eps)) / 3


@pytest.mark.parametrize("name", ARMS)
def test_ddot_minus_2c_is_skew(name):
    s, arm = sympy_arm(name), pin_arm(name)
    Q, V, _ = random_states(s.nq, seed=4)
    for q, v in zip(Q, V, strict=True):
        # sympy side: exact Ḋ
        N_ref = np.asarray(s.Ddot_f(q, v), dtype=float) - 2 * s.coriolis_matrix(q, v)
        np.testing.assert_allclose(N_ref, -N_ref.T, rtol=0, atol=1e-12)
        # Arm side: Ḋ by differencing arm.mass_matrix, C from arm.coriolis_matrix
        Ddot = _mass_matrix_rate(arm, q, v)
        np.testing.assert_allclose(Ddot, np.asarray(s.Ddot_f(q, v), dtype=float), atol=1e-9)
        N = Ddot - 2 * arm.coriolis_matrix(q, v)
        np.testing.assert_allclose(N, -N.T, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", ARMS)
def test_end_effector_forward_kinematics(name):
    s, arm = sympy_arm(name), pin_arm(name)
    lengths = np.array(s.data.lengths)
    Q, _, _ = random_states(s.nq, seed=5)
    for q in Q:
        cum = np.cumsum(q)
        x = np.sum(lengths * np.cos(cum))
        z = np.sum(lengths * np.sin(cum))
        p = arm.frame_position(q, "ee")
        np.testing.assert_allclose(p, [x, 0.0, z], rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(s.ee_f(q), dtype=float).ravel(), [x, z], atol=1e-12)
