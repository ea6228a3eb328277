"""Batched RNEA with exact time derivative vs Pinocchio (the independent reference)."""

from __future__ import annotations

import example_robot_data  # a declared dependency: a plain import, never a skip
import numpy as np
import pinocchio as pin
import pytest

from mpd_pin.dynamics.batch import BatchRneaDerivative, _sincos, rnea_with_derivative

N_SAMPLES = 250
RTOL = 1e-10
ATOL = 1e-10


# ---------------------------------------------------------------------------- models


def planar_arm_xml(lengths=(0.5, 0.4, 0.3), masses=(2.0, 1.5, 1.0), radius=0.03) -> str:
    """Planar arm in the vertical x–z plane: axes 0 -1 0, links along +x, uniform cylinders."""
    links = ['<link name="base"/>']
    joints = []
    parent, offset = "base", 0.0
    for k, (l, m) in enumerate(zip(lengths, masses, strict=True)):
        ixx = 0.5 * m * radius**2  # about the cylinder (x) axis
        iyy = m * (3 * radius**2 + l**2) / 12.0  # about the centre of mass
        links.append(
            f'<link name="link{k + 1}"><inertial><origin xyz="{l / 2} 0 0" rpy="0 0 0"/>'
            f'<mass value="{m}"/><inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" '
            f'izz="{iyy}"/></inertial></link>'
        )
        joints.append(
            f'<joint name="joint{k + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link{k + 1}"/><origin xyz="{offset} 0 0" rpy="0 0 0"/>'
            f'<axis xyz="0 -1 0"/><limit lower="-3.14" upper="3.14" effort="100" '
            f'velocity="10"/></joint>'
        )
        parent, offset = f"link{k + 1}", l
    return '<robot name="planar3">' + "".join(links + joints) + "</robot>"


def mixed_joints_xml(prismatic_root: bool = False) -> str:
    """Prismatic joints and revolute joints about unaligned axes, off-centre inertias."""
    spec = [
        ("revolute", "0 0 1", "0 0 0.1", "0 0 0"),
        ("prismatic", "1 0 0", "0.1 0.2 0.3", "0.3 -0.2 0.1"),
        ("revolute", "0.6 0 0.8", "0.2 0 0.1", "0.1 0.4 -0.3"),
        ("prismatic", "0 0.6 -0.8", "-0.1 0.15 0.05", "-0.5 0.2 0.7"),
        ("revolute", "0 -1 0", "0.3 0 0", "0 0 0"),
        ("prismatic", "0 0 -1", "0 0.1 0", "0.2 0.3 0.4"),
    ]
    if prismatic_root:
        spec = [("prismatic", "0.6 0.8 0", "0.1 0 0", "0.2 0 0.3"), *spec[1:]]
    rng = np.random.default_rng(7)
    links = ['<link name="base"/>']
    joints = []
    parent = "base"
    for k, (typ, axis, xyz, rpy) in enumerate(spec):
        c = rng.normal(scale=0.1, size=3)
        d = rng.uniform(0.01, 0.05, size=3)
        links.append(
            f'<link name="l{k}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" rpy="0.3 -0.2 0.5"/>'
            f'<mass value="{1.0 + 0.5 * k}"/><inertia ixx="{d[0]}" ixy="0.001" ixz="-0.002" '
            f'iyy="{d[1]}" iyz="0.003" izz="{d[2]}"/></inertial></link>'
        )
        joints.append(
            f'<joint name="j{k}" type="{typ}"><parent link="{parent}"/><child link="l{k}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            f'<limit lower="-1" upper="1" effort="100" velocity="10"/></joint>'
        )
        parent = f"l{k}"
    return '<robot name="mixed">' + "".join(links + joints) + "</robot>"


def panda_model() -> pin.Model:
    full = example_robot_data.load("panda").model
    lock = [full.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    return pin.buildReducedModel(full, lock, pin.neutral(full))


def ur5_model() -> pin.Model:
    return example_robot_data.load("ur5").model


def panda_with_armature() -> pin.Model:
    model = panda_model()
    model.armature = np.linspace(0.05, 0.6, model.nv)
    return model


def planar_model() -> pin.Model:
    return pin.buildModelFromXML(planar_arm_xml())


def mixed_model() -> pin.Model:
    return pin.buildModelFromXML(mixed_joints_xml())


def prismatic_root_model() -> pin.Model:
    return pin.buildModelFromXML(mixed_joints_xml(prismatic_root=True))


def panda_tree_model() -> pin.Model:
    """Panda with both (prismatic) finger joints: a branching kinematic tree."""
    return example_robot_data.load("panda").model


MODELS = {
    "planar3": planar_model,
    "panda": panda_model,
    "ur5": ur5_model,
    "panda_armature": panda_with_armature,
    "prismatic_unaligned": mixed_model,
    "prismatic_root": prismatic_root_model,
    "panda_tree": panda_tree_model,
}


# ------------------------------------------------------------------------- reference


def random_states(model: pin.Model, n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    nv = model.nv
    Q = rng.uniform(-np.pi, np.pi, size=(nv, n))
    V = rng.normal(scale=2.0, size=(nv, n))
    A = rng.normal(scale=5.0, size=(nv, n))
    J = rng.normal(scale=20.0, size=(nv, n))
    return Q, V, A, J


def symmetric(m: np.ndarray) -> np.ndarray:
    """Pinocchio may fill only the upper triangle of M: mirror it."""
    return np.triu(m) + np.triu(m, 1).T


def pinocchio_reference(model: pin.Model, Q, V, A, J):
    data = model.createData()
    tau = np.empty_like(Q)
    tau_dot = np.empty_like(Q)
    for k in range(Q.shape[1]):
        q, v, a, j = Q[:, k], V[:, k], A[:, k], J[:, k]
        tau[:, k] = pin.rnea(model, data, q, v, a)
        pin.computeRNEADerivatives(model, data, q, v, a)
        # data.M from computeRNEADerivatives is ∂τ/∂q̈ and includes the armature
        # (checked in test_rnea_derivatives_mass_matrix_includes_armature)
        tau_dot[:, k] = data.dtau_dq @ v + data.dtau_dv @ a + symmetric(data.M) @ j
    return tau, tau_dot


# ----------------------------------------------------------------------------- tests


@pytest.mark.parametrize("name", list(MODELS))
def test_matches_pinocchio(name):
    model = MODELS[name]()
    Q, V, A, J = random_states(model, N_SAMPLES, seed=list(MODELS).index(name))
    tau, tau_dot = rnea_with_derivative(model, Q, V, A, J, chunk=64)
    tau_ref, tau_dot_ref = pinocchio_reference(model, Q, V, A, J)
    np.testing.assert_allclose(tau, tau_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(tau_dot, tau_dot_ref, rtol=RTOL, atol=ATOL)
    assert np.abs(tau_dot_ref).max() > 1.0  # the comparison is not vacuous


def test_rnea_derivatives_mass_matrix_includes_armature():
    """Pitfall check: after computeRNEADerivatives, data.M = ∂τ/∂q̈ = crba (with armature)."""
    model = panda_with_armature()
    Q, V, A, _ = random_states(model, 3)
    data = model.createData()
    for k in range(3):
        pin.computeRNEADerivatives(model, data, Q[:, k], V[:, k], A[:, k])
        m_deriv = symmetric(data.M)
        m_crba = symmetric(pin.crba(model, model.createData(), Q[:, k]))
        np.testing.assert_allclose(m_deriv, m_crba, rtol=1e-12, atol=1e-12)
        assert np.all(np.diag(m_crba) >= model.armature)


def test_armature_enters_tau_and_tau_dot():
    model = panda_model()
    Q, V, A, J = random_states(model, 20)
    tau0, tau_dot0 = rnea_with_derivative(model, Q, V, A, J)
    model.armature = np.linspace(0.1, 0.7, model.nv)
    tau1, tau_dot1 = rnea_with_derivative(model, Q, V, A, J)
    np.testing.assert_allclose(tau1 - tau0, model.armature[:, None] * A, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(
        tau_dot1 - tau_dot0, model.armature[:, None] * J, rtol=1e-10, atol=1e-10
    )


@pytest.mark.parametrize("name", ["planar3", "prismatic_unaligned", "prismatic_root"])
def test_custom_gravity(name):
    model = MODELS[name]()
    model.gravity = pin.Motion(np.array([1.0, -2.0, -9.0, 0.0, 0.0, 0.0]))
    Q, V, A, J = random_states(model, 50)
    tau, tau_dot = rnea_with_derivative(model, Q, V, A, J)
    tau_ref, tau_dot_ref = pinocchio_reference(model, Q, V, A, J)
    np.testing.assert_allclose(tau, tau_ref, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(tau_dot, tau_dot_ref, rtol=RTOL, atol=ATOL)


def test_gravity_with_angular_part_rejected():
    """As computeRNEADerivatives (pin.rnea itself accepts it; τ̇ would need extra terms)."""
    model = planar_model()
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.81, 0.0, 0.3, 0.0]))
    q = np.zeros(model.nq)
    with pytest.raises(ValueError, match="angular"):
        pin.computeRNEADerivatives(model, model.createData(), q, q, q)
    with pytest.raises(ValueError, match="angular"):
        rnea_with_derivative(model, q, q, q, q)


def test_planar_arm_gravity_only():
    """At rest the planar arm holds G(q) ≠ 0 and τ̇ = 0."""
    model = planar_model()
    q = np.array([0.3, -0.5, 0.2])
    zero = np.zeros(3)
    tau, tau_dot = rnea_with_derivative(model, q, zero, zero, zero)
    np.testing.assert_allclose(
        tau, pin.computeGeneralizedGravity(model, model.createData(), q), rtol=1e-12, atol=1e-12
    )
    assert np.abs(tau).min() > 0.1
    np.testing.assert_allclose(tau_dot, 0.0, atol=1e-12)


def smooth_trajectory(model: pin.Model, t: np.ndarray, seed: int = 3):
    """q(t) = q0 + amp·sin(ω t + φ) per joint, with exact q̇, q̈, q⃛ (arrays (nv, len(t)))."""
    rng = np.random.default_rng(seed)
    nv = model.nv
    q0 = rng.uniform(-1, 1, (nv, 1))
    amp = rng.uniform(0.3, 1.0, (nv, 1))
    om = rng.uniform(0.5, 3.0, (nv, 1))
    ph = rng.uniform(0, 2 * np.pi, (nv, 1))
    arg = om * t[None, :] + ph
    return (
        q0 + amp * np.sin(arg),
        amp * om * np.cos(arg),
        -amp * om**2 * np.sin(arg),
        -amp * om**3 * np.cos(arg),
    )


@pytest.mark.parametrize("name", ["planar3", "panda", "prismatic_unaligned"])
def test_tau_dot_matches_central_difference(name):
    model = MODELS[name]()
    model.armature = np.full(model.nv, 0.2)
    t = np.linspace(0.0, 2.0, 41)
    errors = []
    for h in (1e-3, 5e-4):
        Qm, Vm, Am, Jm = smooth_trajectory(model, t - h)
        Qp, Vp, Ap, Jp = smooth_trajectory(model, t + h)
        Q, V, A, J = smooth_trajectory(model, t)
        tau_m, _ = rnea_with_derivative(model, Qm, Vm, Am, Jm)
        tau_p, _ = rnea_with_derivative(model, Qp, Vp, Ap, Jp)
        _, tau_dot = rnea_with_derivative(model, Q, V, A, J)
        fd = (tau_p - tau_m) / (2 * h)
        scale = np.abs(tau_dot).max()
        errors.append(np.abs(fd - tau_dot).max() / scale)
    assert errors[0] < 1e-5  # O(h²) with h = 1e-3
    ratio = errors[0] / errors[1]
    assert 3.5 < ratio < 4.5, (errors, ratio)  # halving h quarters the error


def test_chunking_layouts_and_out():
    model = panda_model()
    Q, V, A, J = random_states(model, 301)
    ref = rnea_with_derivative(model, Q, V, A, J, chunk=301)
    for chunk in (1, 7, 100, 4096):
        got = rnea_with_derivative(model, Q, V, A, J, chunk=chunk)
        np.testing.assert_allclose(got[0], ref[0], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(got[1], ref[1], rtol=1e-13, atol=1e-13)
    # several threads: the same numbers
    got = rnea_with_derivative(model, Q, V, A, J, chunk=50, threads=3)
    np.testing.assert_array_equal(got[0], rnea_with_derivative(model, Q, V, A, J, chunk=50)[0])
    np.testing.assert_allclose(got[1], ref[1], rtol=1e-13, atol=1e-13)
    # Fortran-ordered / transposed inputs give the same result
    got = rnea_with_derivative(model, *(np.asfortranarray(x) for x in (Q, V, A, J)))
    np.testing.assert_allclose(got[0], ref[0], rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got[1], ref[1], rtol=1e-13, atol=1e-13)
    # preallocated outputs
    out = (np.empty_like(Q), np.empty_like(Q))
    got = rnea_with_derivative(model, Q, V, A, J, out=out)
    assert got[0] is out[0] and got[1] is out[1]
    np.testing.assert_allclose(out[1], ref[1], rtol=1e-13, atol=1e-13)
    # one configuration as 1-D arrays
    tau, tau_dot = rnea_with_derivative(model, Q[:, 5], V[:, 5], A[:, 5], J[:, 5])
    assert tau.shape == (model.nv,)
    np.testing.assert_allclose(tau_dot, ref[1][:, 5], rtol=1e-13, atol=1e-13)
    # empty batch
    empty = np.zeros((model.nv, 0))
    tau, tau_dot = rnea_with_derivative(model, empty, empty, empty, empty)
    assert tau.shape == tau_dot.shape == (model.nv, 0)


def test_reusable_evaluator():
    model = ur5_model()
    evaluate = BatchRneaDerivative(model, chunk=128)
    for n, seed in ((1, 0), (37, 1), (128, 2), (300, 3), (37, 4)):
        Q, V, A, J = random_states(model, n, seed=seed)
        tau, tau_dot = evaluate(Q, V, A, J)
        tau_ref, tau_dot_ref = pinocchio_reference(model, Q, V, A, J)
        np.testing.assert_allclose(tau, tau_ref, rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(tau_dot, tau_dot_ref, rtol=RTOL, atol=ATOL)
    # NaN in one call does not leak into the next (padding columns are reset)
    Q, V, A, J = random_states(model, 10, seed=5)
    evaluate(np.full_like(Q, np.nan), V, A, J)
    tau, _ = evaluate(Q[:, :3], V[:, :3], A[:, :3], J[:, :3])
    assert np.all(np.isfinite(tau))


def test_bad_shapes_raise():
    model = planar_model()
    Q, V, A, J = random_states(model, 5)
    with pytest.raises(ValueError, match="shape"):
        rnea_with_derivative(model, Q[:2], V, A, J)
    with pytest.raises(ValueError, match="batch"):
        rnea_with_derivative(model, Q, V[:, :3], A, J)
    with pytest.raises(ValueError, match="threads"):
        rnea_with_derivative(model, Q, V, A, J, threads=0)
    with pytest.raises(ValueError, match="chunk"):
        BatchRneaDerivative(model, chunk=0)
    with pytest.raises(ValueError, match="out"):
        rnea_with_derivative(model, Q, V, A, J, out=(np.empty((3, 4)), np.empty((3, 5))))


def _model_with(joint: pin.JointModel) -> pin.Model:
    model = pin.Model()
    inertia = pin.Inertia(1.0, np.array([0.1, 0.0, 0.0]), np.diag([0.01, 0.02, 0.03]))
    jid = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "ok")
    model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    jid = model.addJoint(jid, joint, pin.SE3(np.eye(3), np.array([0.2, 0, 0])), "bad")
    model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    return model


@pytest.mark.parametrize(
    "joint",
    [
        pin.JointModelFreeFlyer(),
        pin.JointModelSpherical(),
        pin.JointModelRUBZ(),  # URDF "continuous"
        pin.JointModelPlanar(),
        pin.JointModelTranslation(),
        pin.JointModelSphericalZYX(),
    ],
    ids=lambda j: j.shortname(),
)
def test_unsupported_joint_types_raise(joint):
    model = _model_with(joint)
    Q = np.zeros((model.nv, 2))
    with pytest.raises(ValueError, match=r"joint 2 'bad' is JointModel"):
        rnea_with_derivative(model, Q, Q, Q, Q)


def test_continuous_urdf_joint_raises():
    xml = planar_arm_xml().replace('type="revolute"', 'type="continuous"', 1)
    model = pin.buildModelFromXML(xml)
    Q = np.zeros((model.nv, 1))
    with pytest.raises(ValueError, match="JointModelRevoluteUnbounded.*nq=2, nv=1"):
        rnea_with_derivative(model, Q, Q, Q, Q)


def test_sincos_within_one_ulp_of_numpy():
    rng = np.random.default_rng(11)
    q = np.concatenate(
        [
            rng.uniform(-4, 4, 20000),
            rng.uniform(-1e4, 1e4, 20000),
            np.arange(-40, 41) * (np.pi / 4),  # near quadrant boundaries
            [0.0, -0.0, 1e-300, -1e-12, 5e-9, np.nextafter(np.pi / 4, 0)],
        ]
    ).reshape(1, -1)
    cos, sin = np.empty_like(q), np.empty_like(q)
    _sincos(q, cos, sin, np.empty((3, *q.shape)))
    for got, ref in ((cos, np.cos(q)), (sin, np.sin(q))):
        err = np.abs(got - ref)
        big = np.abs(ref) > 0.01
        assert np.all(err[big] <= np.spacing(np.abs(ref[big])))  # at most 1 ulp
        assert np.all(err[~big] <= 1.2e-16)  # near the zeros: absolute
    # beyond the reduction range numpy's own functions are used
    big = np.array([[1e6, -3e7, 1e300]])
    cos, sin = np.empty_like(big), np.empty_like(big)
    _sincos(big, cos, sin, np.empty((3, *big.shape)))
    np.testing.assert_array_equal(cos, np.cos(big))
    np.testing.assert_array_equal(sin, np.sin(big))
