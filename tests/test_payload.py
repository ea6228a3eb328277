"""Payloads (issue 33, item 1): ``mp.Payload``, ``Drive.with_payload`` and the checker's
payload, against independent references.

* Dynamics: the same arm with the part written into its URDF by hand, as a fixed link with
  that inertia (``<link name="part"><inertial>…`` on a ``<joint type="fixed">`` whose
  origin is the com), loaded by ``mp.Arm.from_urdf``: RNEA torques and edge energies
  agree, for a box part (inertia from its size, written out here) and an explicit inertia.
* Collision: coal shapes built here from the parameters (the part's box at the frame
  placement of ``pin.updateFramePlacements``, the obstacles, the links the part may touch)
  and ``coal.collide`` / ``coal.distance`` on each pair, combined with the checker without
  the part (tested against exact geometry in tests/test_collision.py).
"""

import math

import coal
import numpy as np
import pinocchio as pin
import pytest

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics.remote import DriveSpec, model_digest
from mpd_pin.world import Box, Cylinder, Sphere, World

PANDA_MOTOR = mp.DCMotor(R=1.0, L=0.01, Kt=0.1, Ke=0.1, B=1e-4, J=1e-4, gear_ratio=50.0)
PLANAR_MOTOR = mp.PAPER_MOTOR.with_gear_ratio(9.0)
NEAR = 1e-6  # m: configurations this close to contact may go either way (GJK tolerance)

#: An explicit inertia about the com (kg·m²): not diagonal, positive definite.
INERTIA = np.array([[2.0e-3, 1.0e-4, -2.0e-4],
                    [1.0e-4, 3.0e-3, 5.0e-5],
                    [-2.0e-4, 5.0e-5, 4.0e-3]])


@pytest.fixture(scope="module")
def arms():
    return {"planar_3link": mp.builtin_arm("planar_3link"),
            "panda": mp.Arm.from_example_robot_data("panda")}


def _drive(arm):
    if arm.name == "panda":
        return mp.Drive(arm, PANDA_MOTOR, kp=20.0, kd=1.0)
    return mp.Drive(arm, PLANAR_MOTOR, kp=40.0, kd=4.0)


# ------------------------------------------------------------------- the reference URDF
def _f(x) -> str:
    return repr(float(x))


def urdf_with_part(xml: str, parent: str, mass: float, com, inertia) -> str:
    """``xml`` with a link "part" (``mass`` kg, ``inertia`` kg·m² about its origin) fixed to
    the link ``parent`` at ``com`` (m, parent coordinates, no rotation)."""
    I = np.asarray(inertia, dtype=float)  # noqa: E741
    part = (
        '<link name="part"><inertial><origin xyz="0 0 0" rpy="0 0 0"/>'
        f'<mass value="{_f(mass)}"/>'
        f'<inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
        f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/></inertial></link>'
        f'<joint name="part_joint" type="fixed"><parent link="{parent}"/><child link="part"/>'
        f'<origin xyz="{_f(com[0])} {_f(com[1])} {_f(com[2])}" rpy="0 0 0"/></joint>'
    )
    end = xml.rfind("</robot>")
    assert end > 0
    return xml[:end] + part + xml[end:]


def reference_arm(arm, parent, mass, com, inertia):
    """The arm rebuilt from its URDF text with the part as a fixed link (same locked joints)."""
    xml = urdf_with_part(arm.urdf_xml, parent, mass, com, inertia)
    ref = mp.Arm.from_urdf(xml, lock=arm.locked_joints or None, name=arm.name)
    # Pinocchio skips an <inertial> it cannot parse with only a log line: check it is there.
    assert ref.model.existFrame("part")
    total = sum(ref.model.inertias[j].mass for j in range(ref.model.njoints))
    base = sum(arm.model.inertias[j].mass for j in range(arm.model.njoints))
    assert total == pytest.approx(base + mass, rel=1e-12)
    return ref


def solid_box(mass, a, b, c):
    """Inertia (kg·m²) of a solid a × b × c box (m) about its centre."""
    return mass / 12.0 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])


# name, payload, the URDF link it is fixed to, the inertia written into the URDF
CASES = {
    "planar-box-at-ee": ("planar_3link", dict(mass=0.4, com=(0.05, 0.0, 0.01),
                                              size=(0.1, 0.06, 0.08)),
                         "ee", solid_box(0.4, 0.1, 0.06, 0.08)),
    "planar-inertia-on-link2": ("planar_3link", dict(mass=0.3, com=(0.2, 0.01, -0.02),
                                                     inertia=INERTIA, frame="link2"),
                                "link2", INERTIA),
    "panda-box-on-hand": ("panda", dict(mass=0.8, com=(0.01, -0.02, 0.12),
                                        size=(0.06, 0.05, 0.12), frame="panda_hand"),
                          "panda_hand", solid_box(0.8, 0.06, 0.05, 0.12)),
    "panda-inertia-at-tcp": ("panda", dict(mass=0.6, com=(0.0, 0.01, 0.03), inertia=[
        INERTIA[0, 0], INERTIA[0, 1], INERTIA[0, 2], INERTIA[1, 1], INERTIA[1, 2],
        INERTIA[2, 2]]), "panda_hand_tcp", INERTIA),
}


def _random_edges(arm, rng, k, scale=0.5):
    lo, hi = arm.lower_limits, arm.upper_limits
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    Q0 = mid + half * rng.uniform(-0.8, 0.8, (k, arm.nq))
    Q1 = np.clip(Q0 + rng.normal(0.0, scale, (k, arm.nq)), lo, hi)
    return Q0, Q1


def _lift_edges(arm, frame):
    """Edges that raise ``frame`` by ≥ 0.2 m (m), checked by forward kinematics."""
    if arm.name == "panda":
        q = np.array(arm.q_reference)
        Q0 = np.array([q + [0, 0.9, 0, 0.3, 0, 0, 0], q + [0.5, 0.7, 0, -0.2, 0, 0.3, 0]])
        Q1 = np.array([q + [0, -0.5, 0, 0.3, 0, 0, 0], q + [0.5, -0.4, 0, 0.3, 0, -0.3, 0]])
    else:
        Q0 = np.array([[-1.5, 0.0, 0.0], [-1.2, -0.2, 0.1]])
        Q1 = np.array([[0.2, 0.1, 0.0], [0.4, 0.3, 0.2]])
    for a, b in zip(Q0, Q1, strict=True):
        assert arm.frame_position(b, frame)[2] - arm.frame_position(a, frame)[2] > 0.2
    return Q0, Q1


@pytest.mark.parametrize("case", sorted(CASES))
def test_dynamics_equal_the_part_written_into_the_urdf(arms, case):
    name, fields, link, inertia = CASES[case]
    arm = arms[name]
    part = mp.Payload(**fields)
    ref = reference_arm(arm, link, part.mass, part.com, inertia)
    drive = _drive(arm)
    loaded = drive.with_payload(part)
    ref_drive = _drive(ref)
    assert loaded.payload == part and drive.payload is None
    # RNEA at random states, on the arm model and on the drive's (armature) model.
    rng = np.random.default_rng(3)
    for model, ref_model in ((loaded.arm.model, ref.model), (loaded.model, ref_drive.model)):
        data, ref_data = model.createData(), ref_model.createData()
        for _ in range(20):
            q = rng.uniform(arm.lower_limits, arm.upper_limits)
            v, a = rng.normal(0, 1.0, arm.nq), rng.normal(0, 2.0, arm.nq)
            tau = pin.rnea(model, data, q, v, a)
            tau_ref = pin.rnea(ref_model, ref_data, q, v, a)
            np.testing.assert_allclose(tau, tau_ref, rtol=1e-12,
                                       atol=1e-12 * np.abs(tau_ref).max())
    # Edge energies (J) on random edges.
    Q0, Q1 = _random_edges(arm, rng, 6)
    E = mp.edge_energies(loaded, Q0, Q1, 1.0, 5e-3)
    E_ref = mp.edge_energies(ref_drive, Q0, Q1, 1.0, 5e-3)
    np.testing.assert_allclose(E, E_ref, rtol=1e-9, atol=1e-9 * E_ref.max())
    # A lift against gravity costs more with the part.
    frame = part.frame or ("ee" if arm.model.existFrame("ee") else arm.model.frames[-1].name)
    L0, L1 = _lift_edges(arm, frame)
    lift = mp.edge_energies(loaded, L0, L1, 1.0, 5e-3).sum(axis=1)
    bare = mp.edge_energies(drive, L0, L1, 1.0, 5e-3).sum(axis=1)
    assert np.all(lift > bare * 1.01), (lift, bare)


def test_default_frame_is_the_scenario_end_effector_frame(arms):
    """No ``frame``: "ee" on the planar arms, the last frame (panda_hand_tcp) on the Panda;
    a point mass (no size, no inertia) is a pin.Inertia with zero rotational inertia."""
    part = mp.Payload(0.5, com=(0.0, 0.0, 0.02))
    for name, frame in (("planar_3link", "ee"), ("panda", "panda_hand_tcp")):
        arm = arms[name]
        loaded = _drive(arm).with_payload(part)
        fid = arm.model.getFrameId(frame)
        j = arm.model.frames[fid].parentJoint
        expect = arm.model.inertias[j] + arm.model.frames[fid].placement.act(
            pin.Inertia(0.5, np.array([0.0, 0.0, 0.02]), np.zeros((3, 3))))
        got = loaded.arm.model.inertias[j]
        assert got.mass == pytest.approx(expect.mass, rel=1e-15)
        np.testing.assert_allclose(got.lever, expect.lever, rtol=0, atol=1e-15)
        np.testing.assert_allclose(got.inertia, expect.inertia, rtol=0, atol=1e-15)
        for k in range(arm.model.njoints):
            if k != j:
                assert loaded.arm.model.inertias[k] == arm.model.inertias[k]
        # a point mass has no collision shape
        assert loaded.arm.collision_model.ngeoms == arm.collision_model.ngeoms
    np.testing.assert_array_equal(part.inertia_matrix, np.zeros((3, 3)))
    # "ee" even when it is not the last frame (a tool frame after it)
    xml = mp.builtin_arm_urdf("planar_3link").replace("</robot>", (
        '<link name="tool"/><joint name="tool_joint" type="fixed"><parent link="link3"/>'
        '<child link="tool"/><origin xyz="0.1 0 0.05" rpy="0 0 0"/></joint></robot>'))
    tooled = mp.Arm.from_urdf(xml)
    assert tooled.model.frames[-1].name == "tool"
    on_ee = _drive(tooled).with_payload(part).arm.model
    explicit = _drive(tooled).with_payload(mp.Payload(0.5, com=(0.0, 0.0, 0.02), frame="ee"))
    assert model_digest(on_ee) == model_digest(explicit.arm.model)


# --------------------------------------------------------------- the original is untouched
@pytest.mark.parametrize("name", ["planar_3link", "panda"])
def test_the_original_drive_is_unchanged(arms, name):
    arm = arms[name]
    drive = _drive(arm)
    rng = np.random.default_rng(11)
    Q0, Q1 = _random_edges(arm, rng, 5)
    before = mp.edge_energies(drive, Q0, Q1, 0.5, 5e-3)
    digest, fingerprint = model_digest(drive.model), arm.fingerprint()
    ngeoms, npairs = arm.collision_model.ngeoms, len(arm.collision_model.collisionPairs)
    small = mp.Payload(0.3, com=(0, 0, 0.02), size=0.04)
    big = mp.Payload(1.2, com=(0, 0, 0.05), size=(0.05, 0.05, 0.1))
    loaded = drive.with_payload(big)
    E_loaded = mp.edge_energies(loaded, Q0, Q1, 0.5, 5e-3)
    after = mp.edge_energies(drive, Q0, Q1, 0.5, 5e-3)
    assert np.array_equal(before, after)
    assert model_digest(drive.model) == digest and arm.fingerprint() == fingerprint
    assert arm.collision_model.ngeoms == ngeoms
    assert len(arm.collision_model.collisionPairs) == npairs
    assert drive.payload is None and loaded.payload == big
    # the copy's keys differ from the original's
    assert model_digest(loaded.model) != digest
    assert model_digest(loaded.arm.model) != model_digest(arm.model)
    assert loaded.arm.fingerprint() != fingerprint
    assert not np.array_equal(E_loaded, before)
    # everything else is the drive's
    assert loaded.motor_list == drive.motor_list and loaded.supply is drive.supply
    assert loaded.feedforward == drive.feedforward
    np.testing.assert_array_equal(loaded.kp_vec, drive.kp_vec)
    np.testing.assert_array_equal(loaded.kd_vec, drive.kd_vec)
    np.testing.assert_array_equal(loaded.armature, drive.armature)
    # None removes the payload; a second payload replaces the first (no stacking)
    bare = loaded.with_payload(None)
    assert bare.payload is None and bare.arm is arm
    assert np.array_equal(mp.edge_energies(bare, Q0, Q1, 0.5, 5e-3), before)
    swapped = drive.with_payload(small).with_payload(big)
    assert swapped.payload == big
    assert np.array_equal(mp.edge_energies(swapped, Q0, Q1, 0.5, 5e-3), E_loaded)
    assert swapped.arm.fingerprint() == loaded.arm.fingerprint()


def test_workers_never_get_the_arm_without_its_part(arms):
    """A drive with a payload is either refused by DriveSpec (its URDF text is the arm's,
    without the part) or rebuilt with the payload's model: never silently without it."""
    loaded = _drive(arms["planar_3link"]).with_payload(mp.Payload(0.5, com=(0.05, 0, 0)))
    try:
        spec = DriveSpec.of(loaded)
    except ValueError as exc:
        assert "rebuild" in str(exc)
    else:
        assert model_digest(spec.build().arm.model) == model_digest(loaded.arm.model)


# ------------------------------------------------------------------------- bad input
BAD = [
    ("mass", dict(mass=0.0)),
    ("mass", dict(mass=-1.0)),
    ("mass", dict(mass=math.nan)),
    ("mass", dict(mass=math.inf)),
    ("mass", dict(mass="heavy")),
    ("mass", dict(mass=True)),
    ("com", dict(mass=1.0, com=(0.0, 0.0))),
    ("com", dict(mass=1.0, com=(0.0, math.nan, 0.0))),
    ("com", dict(mass=1.0, com="centre")),
    ("size", dict(mass=1.0, size=(0.1, 0.0, 0.1))),
    ("size", dict(mass=1.0, size=-0.1)),
    ("size", dict(mass=1.0, size=(0.1, 0.1))),
    ("size", dict(mass=1.0, size=(0.1, math.inf, 0.1))),
    ("inertia.*symmetric", dict(mass=1.0, inertia=[[1e-3, 1e-4, 0], [0, 1e-3, 0],
                                                   [0, 0, 1e-3]])),
    ("inertia.*positive semi-definite", dict(mass=1.0, inertia=np.diag([1e-3, 1e-3, -1e-4]))),
    ("inertia.*triangle", dict(mass=1.0, inertia=np.diag([1e-3, 1e-3, 3e-3]))),  # 1 + 1 < 3
    ("inertia", dict(mass=1.0, inertia=np.eye(2))),
    ("inertia", dict(mass=1.0, inertia=[1e-3, 0, 0, 1e-3, 0])),
    ("inertia", dict(mass=1.0, inertia=[1e-3, 0, 0, 1e-3, 0, math.nan])),
    ("frame", dict(mass=1.0, frame="")),
    ("frame", dict(mass=1.0, frame=3)),
]


@pytest.mark.parametrize("field,kwargs", BAD,
                         ids=[f"{f.split('.')[0]}-{i}" for i, (f, _) in enumerate(BAD)])
def test_bad_fields_name_the_field(field, kwargs):
    with pytest.raises(ValueError, match=rf"Payload\.{field}"):
        mp.Payload(**kwargs)


@pytest.mark.parametrize("frame", ["no_such_frame", "base_link", "universe"])
def test_bad_frames_name_the_field(arms, frame):
    drive = _drive(arms["planar_3link"])
    part = mp.Payload(1.0, frame=frame, size=0.05)
    with pytest.raises(ValueError, match=r"Payload\.frame"):
        drive.with_payload(part)
    with pytest.raises(ValueError, match=r"Payload\.frame"):
        CollisionChecker(arms["planar_3link"], payload=part)
    with pytest.raises(ValueError, match="payload must be"):
        drive.with_payload("a brick")


def test_good_inertias_are_accepted():
    """A thin rod (triangle equality), a point mass and 6 values in URDF order."""
    rod = mp.Payload(1.0, inertia=np.diag([0.0, 1e-2, 1e-2]))
    np.testing.assert_array_equal(rod.inertia_matrix, np.diag([0.0, 1e-2, 1e-2]))
    assert mp.Payload(1.0, inertia=np.zeros((3, 3))).inertia_matrix.max() == 0.0
    six = mp.Payload(1.0, inertia=[1, 0.1, 0.2, 2, 0.3, 2.5])
    np.testing.assert_array_equal(six.inertia_matrix,
                                  [[1, 0.1, 0.2], [0.1, 2, 0.3], [0.2, 0.3, 2.5]])
    assert mp.Payload(2.0, size=0.1).size == (0.1, 0.1, 0.1)
    np.testing.assert_allclose(mp.Payload(2.0, size=(0.1, 0.2, 0.3)).inertia_matrix,
                               solid_box(2.0, 0.1, 0.2, 0.3), rtol=1e-15)


# ------------------------------------------------------------------------- collision
def _coal_tf(M: pin.SE3) -> coal.Transform3s:
    return coal.Transform3s(np.array(M.rotation), np.array(M.translation))


def _obstacle_shapes(world):
    """(coal shape, placement) of each obstacle, built here from its parameters."""
    out = []
    for ob in world.obstacles:
        if isinstance(ob, Box):
            shape = coal.Box(*ob.size)
        elif isinstance(ob, Cylinder):
            shape = coal.Cylinder(ob.radius, ob.length)
        elif isinstance(ob, Sphere):
            shape = coal.Sphere(ob.radius)
        else:  # pragma: no cover - the tests use these three
            raise AssertionError(type(ob))
        M = pin.SE3(pin.rpy.rpyToMatrix(*ob.rpy), np.array(ob.position))
        out.append((shape, M))
    return out


def _signed(s1, M1, s2, M2):
    """(collide, distance) of two coal shapes at placements M1, M2 (m)."""
    res = coal.CollisionResult()
    hit = coal.collide(s1, _coal_tf(M1), s2, _coal_tf(M2), coal.CollisionRequest(), res) > 0
    dres = coal.DistanceResult()
    d = coal.distance(s1, _coal_tf(M1), s2, _coal_tf(M2), coal.DistanceRequest(), dres)
    return hit, d


def part_brute_force(arm, part, frame, Q, obstacles, links):
    """(part hits something (K,), near contact (K,)): the part's box at the frame placement
    of ``pin.updateFramePlacements`` against each obstacle and each of ``links``
    ((joint, coal shape, placement in the joint frame))."""
    model, data = arm.model, arm.model.createData()
    fid = model.getFrameId(frame)
    box = coal.Box(*part.size)
    at_com = pin.SE3(np.eye(3), np.array(part.com))
    hit = np.zeros(len(Q), dtype=bool)
    near = np.zeros(len(Q), dtype=bool)
    for k, q in enumerate(Q):
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        M = data.oMf[fid] * at_com
        others = list(obstacles) + [(s, data.oMi[j] * P) for j, s, P in links]
        for shape, S in others:
            h, d = _signed(box, M, shape, S)
            hit[k] |= h
            near[k] |= abs(d) < NEAR
    return hit, near


def _planar_links(spec, joints):
    """The planar links on ``joints`` (1-based) as coal cylinders along +x of their joint."""
    R = pin.rpy.rpyToMatrix(0.0, math.pi / 2, 0.0)
    return [(j, coal.Cylinder(spec.radius, spec.lengths[j - 1]),
             pin.SE3(R, np.array([spec.lengths[j - 1] / 2, 0.0, 0.0]))) for j in joints]


PLANAR_WORLD = World([
    Box.planar((0.0, 1.25), 0.8, 0.1, name="ceiling"),
    Cylinder.planar((1.05, -0.45), 0.1, name="post"),
    Sphere.planar((-0.8, 0.5), 0.12, name="ball"),
    Box.planar((0.45, 0.55), 0.2, 0.15, angle=0.3, name="block"),
])


def test_planar_part_collisions_match_brute_force(arms):
    arm = arms["planar_3link"]
    spec = mp.BUILTIN_ARMS["planar_3link"]
    part = mp.Payload(0.4, com=(0.08, 0.0, 0.0), size=(0.16, 0.08, 0.12), name="crate")
    bare = CollisionChecker(arm, PLANAR_WORLD)
    loaded = CollisionChecker(arm, PLANAR_WORLD, payload=part)
    assert loaded.payload == part and bare.payload is None and loaded.arm is not arm
    rng = np.random.default_rng(5)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(400, arm.nq))
    free_bare = bare.is_free_batch(Q)
    free_loaded = loaded.is_free_batch(Q)
    # the part rides on joint 3: it may touch link 1 only (links 2 and 3 are adjacent)
    hit, near = part_brute_force(arm, part, "ee", Q, _obstacle_shapes(PLANAR_WORLD),
                                 _planar_links(spec, [1]))
    expect = free_bare & ~hit
    disagree = (free_loaded != expect) & ~near
    assert not np.any(disagree), np.flatnonzero(disagree)[:10]
    only_part = free_bare & hit & ~near
    assert only_part.sum() >= 10, only_part.sum()  # the part, not the arm, hits
    assert not np.any(free_loaded[only_part])
    assert np.all(free_loaded <= free_bare)
    # single queries and messages name the part
    k = int(np.flatnonzero(only_part)[0])
    assert not loaded.is_free(Q[k]) and bare.is_free(Q[k])
    assert all(a == "payload 'crate'" for a, _ in loaded.colliding_pairs(Q[k]))
    assert loaded.describe_collision(Q[k]).startswith("payload 'crate' touches")


def test_planar_part_against_its_own_arm(arms):
    """Folded back, the part meets link 1 (a self collision); it never collides with links 2
    and 3 (adjacent), even when it overlaps them."""
    arm = arms["planar_3link"]
    spec = mp.BUILTIN_ARMS["planar_3link"]
    part = mp.Payload(0.4, com=(-0.05, 0.0, 0.0), size=(0.1, 0.08, 0.1))  # overlaps link 3
    loaded = CollisionChecker(arm, None, payload=part)
    bare = CollisionChecker(arm, None)
    rng = np.random.default_rng(8)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(1000, arm.nq))
    Q[:, 1] = rng.choice([-1.0, 1.0], 1000) * rng.uniform(1.8, math.pi, 1000)  # folded back
    hit, near = part_brute_force(arm, part, "ee", Q, [], _planar_links(spec, [1]))
    free_bare = bare.is_free_batch(Q)
    expect = free_bare & ~hit
    assert not np.any((loaded.is_free_batch(Q) != expect) & ~near)
    assert np.sum(free_bare & hit & ~near) >= 8, np.sum(free_bare & hit & ~near)
    hit_adjacent, _ = part_brute_force(arm, part, "ee", Q[:5], [], _planar_links(spec, [3]))
    assert hit_adjacent.all()  # overlaps link 3 everywhere: adjacent, so not checked
    # the rule as pairs: the box is paired with link 1 only
    names = [g.name for g in loaded.geom_model.geometryObjects]
    pairs = {tuple(sorted((names[p.first], names[p.second])))
             for p in (loaded.geom_model.collisionPairs[k] for k in loaded.self_pairs)}
    assert {p for p in pairs if "payload:payload" in p} == {("link1_0", "payload:payload")}


def test_certified_edges_with_a_part_are_sound(arms):
    """An edge certified free with the part has no configuration where the part hits
    (brute force at 100 points along it); some edges are refused only for the part."""
    arm = arms["planar_3link"]
    spec = mp.BUILTIN_ARMS["planar_3link"]
    part = mp.Payload(0.4, com=(0.08, 0.0, 0.0), size=(0.16, 0.08, 0.12))
    loaded = CollisionChecker(arm, PLANAR_WORLD, payload=part)
    bare = CollisionChecker(arm, PLANAR_WORLD)
    rng = np.random.default_rng(2)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(600, arm.nq))
    Q = Q[loaded.is_free_batch(Q)]
    Q0, Q1 = Q[:60], np.clip(Q[:60] + rng.normal(0, 0.6, (60, arm.nq)), arm.lower_limits,
                             arm.upper_limits)
    ok = loaded.edges_free(Q0, Q1, 0.05)
    ok_bare = bare.edges_free(Q0, Q1, 0.05)
    assert np.all(ok <= ok_bare)
    obstacles, links = _obstacle_shapes(PLANAR_WORLD), _planar_links(spec, [1])
    s = np.linspace(0.0, 1.0, 100)[:, None]
    for k in np.flatnonzero(ok):
        path = Q0[k] + s * (Q1[k] - Q0[k])
        hit, _ = part_brute_force(arm, part, "ee", path, obstacles, links)
        assert not hit.any(), k
    assert np.any(ok_bare & ~ok)


PANDA_WORLD = World([
    Box(size=(0.3, 0.3, 0.3), position=(0.5, 0.0, 0.45), name="crate"),
    Sphere(radius=0.12, position=(0.0, 0.5, 0.6), name="ball"),
    Cylinder(radius=0.06, length=0.6, position=(-0.45, -0.3, 0.5), name="pole"),
])


def test_panda_part_collisions_match_brute_force(arms):
    arm = arms["panda"]
    part = mp.Payload(0.8, com=(0.0, 0.0, 0.08), size=(0.1, 0.08, 0.16), frame="panda_hand_tcp")
    drive = _drive(arm).with_payload(part)
    loaded = CollisionChecker(drive.arm, PANDA_WORLD)  # the drive's arm carries the part
    bare = CollisionChecker(arm, PANDA_WORLD)
    assert loaded.payload == part
    assert loaded.fingerprint() == CollisionChecker(arm, PANDA_WORLD,
                                                    payload=part).fingerprint()
    assert loaded.with_payload(None).fingerprint() == bare.fingerprint()
    assert loaded.copy().fingerprint() == loaded.fingerprint()
    # the SRDF pairs gain the part against the links of joints 0-5: not joint 7 (link 7,
    # hand, fingers: it rides on joint 7) nor joint 6 (link 6, adjacent)
    cm = loaded.arm.collision_model
    names = [g.name for g in cm.geometryObjects]
    partners = sorted(names[p.first] for p in cm.collisionPairs
                      if names[p.second] == "payload:payload")
    assert partners == [f"panda_link{i}_0" for i in range(6)]
    links = [(int(g.parentJoint), g.geometry, g.placement)
             for g in arm.collision_model.geometryObjects if g.parentJoint <= 5]
    rng = np.random.default_rng(4)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(300, arm.nq))
    free_bare = bare.is_free_batch(Q)
    hit, near = part_brute_force(arm, part, "panda_hand_tcp", Q, _obstacle_shapes(PANDA_WORLD),
                                 links)
    expect = free_bare & ~hit
    free_loaded = loaded.is_free_batch(Q)
    disagree = (free_loaded != expect) & ~near
    assert not np.any(disagree), np.flatnonzero(disagree)[:10]
    only_part = free_bare & hit & ~near
    assert only_part.sum() >= 5, only_part.sum()
    assert not np.any(free_loaded[only_part])
