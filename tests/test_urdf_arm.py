"""Generated planar URDFs and the Arm loader (docs/design.md §1–2)."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

import mpd_pin as mp

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("name", sorted(mp.BUILTIN_ARMS))
def test_committed_urdf_equals_regenerated(name):
    committed = (ROOT / "robots" / f"{name}.urdf").read_text(encoding="utf-8")
    assert committed == mp.builtin_arm_urdf(name)


def test_generation_script_reproduces_files(tmp_path):
    """The script writes exactly the committed files (run on a copy of the tree layout)."""
    script = ROOT / "scripts" / "generate_robots.py"
    (tmp_path / "scripts").mkdir()
    (tmp_path / "scripts" / "generate_robots.py").write_text(script.read_text())
    subprocess.run([sys.executable, str(tmp_path / "scripts" / "generate_robots.py")], check=True,
                   capture_output=True)
    for name in mp.BUILTIN_ARMS:
        assert (tmp_path / "robots" / f"{name}.urdf").read_text() == (
            ROOT / "robots" / f"{name}.urdf"
        ).read_text()


def test_planar_urdf_follows_conventions():
    lengths, masses, r = [0.5, 0.4, 0.3], [2.0, 1.5, 1.0], 0.04
    urdf = yourdfpy.URDF.load(
        __import__("io").BytesIO(mp.planar_arm_urdf(lengths, masses, radius=r).encode()),
        build_scene_graph=False, load_meshes=False,
    )
    joints = {j.name: j for j in urdf.robot.joints}
    links = {lk.name: lk for lk in urdf.robot.links}
    for k, (l, m) in enumerate(zip(lengths, masses, strict=True), start=1):
        j = joints[f"joint{k}"]
        assert j.type == "revolute"
        np.testing.assert_array_equal(j.axis, [0.0, -1.0, 0.0])
        np.testing.assert_allclose(j.origin[:3, 3], [0.0 if k == 1 else lengths[k - 2], 0, 0])
        assert j.limit.lower == -math.pi and j.limit.upper == math.pi
        inertial = links[f"link{k}"].inertial
        assert inertial.mass == m
        np.testing.assert_allclose(inertial.origin[:3, 3], [l / 2, 0, 0])
        # Solid cylinder about its centre of mass, axis along x.
        np.testing.assert_allclose(
            inertial.inertia, np.diag([m * r * r / 2, m * (3 * r * r + l * l) / 12,
                                       m * (3 * r * r + l * l) / 12])
        )
        col = links[f"link{k}"].collisions[0]
        assert col.geometry.cylinder.radius == r and col.geometry.cylinder.length == l
        # Rotated so the cylinder's z axis lies along the link's x axis, centred at l/2.
        np.testing.assert_allclose(col.origin[:3, 2], [1.0, 0.0, 0.0], atol=1e-15)
        np.testing.assert_allclose(col.origin[:3, 3], [l / 2, 0, 0])
    np.testing.assert_allclose(joints["ee_joint"].origin[:3, 3], [lengths[-1], 0, 0])


def test_end_effector_formula_and_gravity_nonzero():
    arm = mp.builtin_arm("planar_3link")
    lengths = mp.BUILTIN_ARMS["planar_3link"].lengths
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = rng.uniform(-math.pi, math.pi, 3)
        c = np.cumsum(q)
        expect = [sum(l * math.cos(a) for l, a in zip(lengths, c, strict=True)), 0.0,
                  sum(l * math.sin(a) for l, a in zip(lengths, c, strict=True))]
        np.testing.assert_allclose(arm.frame_position(q, "ee"), expect, atol=1e-14)
    # Horizontal arm: the first joint holds every link's weight, m g × lever.
    specs = mp.BUILTIN_ARMS["planar_3link"]
    l, m = specs.lengths, specs.masses
    g1 = 9.81 * (m[0] * l[0] / 2 + m[1] * (l[0] + l[1] / 2) + m[2] * (l[0] + l[1] + l[2] / 2))
    assert arm.gravity(np.zeros(3))[0] == pytest.approx(g1, rel=1e-12)


def test_arm_shapes_and_limits():
    arm = mp.builtin_arm("planar_7link")
    assert arm.nq == 7
    np.testing.assert_allclose(arm.lower_limits, -math.pi)
    np.testing.assert_allclose(arm.upper_limits, math.pi)
    D = arm.mass_matrix(np.zeros(7))
    np.testing.assert_allclose(D, D.T)
    assert np.all(np.linalg.eigvalsh(D) > 0)


def test_panda_from_example_robot_data_locks_fingers():
    arm = mp.Arm.from_example_robot_data("panda")
    assert arm.nq == 7
    assert all("finger" not in n for n in arm.joint_names)
    assert arm.srdf_path is not None and Path(arm.srdf_path).is_file()
    assert len(arm.collision_model.collisionPairs) > 0
    q = arm.q_reference
    D = arm.mass_matrix(q)
    assert np.all(np.linalg.eigvalsh(D) > 0)


def test_urdf_from_file_path(tmp_path):
    path = tmp_path / "a.urdf"
    path.write_text(mp.planar_arm_urdf([1.0], [1.0]))
    arm = mp.Arm.from_urdf(path)
    assert arm.nq == 1
    # G = ∂V/∂q with V = m g (l/2) sin q: +m g l/2 holds the horizontal link up.
    assert arm.gravity(np.zeros(1))[0] == pytest.approx(9.81 * 0.5, rel=1e-12)


SRDF = """<?xml version="1.0"?>
<robot name="planar_arm">
  <disable_collisions link1="base_link" link2="link1" reason="Adjacent"/>
  <disable_collisions link1="link1" link2="link2" reason="Adjacent"/>
  <disable_collisions link1="link2" link2="link3" reason="Adjacent"/>
  <disable_collisions link1="link3" link2="link4" reason="Adjacent"/>
  <disable_collisions link1="link1" link2="link3" reason="Never"/>
</robot>
"""


def test_srdf_removes_disabled_pairs(tmp_path):
    """All pairs minus the SRDF's: (link1, link3) disabled leaves (1, 4) and (2, 4); the
    checker then ignores link 1 × link 3 overlaps (exact 2-D geometry decides which)."""
    from planar_geometry import link_rectangles, sd_polygons

    from mpd_pin.collision import CollisionChecker

    lengths, radius = [0.5, 0.4, 0.35, 0.3], 0.03
    urdf = tmp_path / "arm4.urdf"
    urdf.write_text(mp.planar_arm_urdf(lengths, [1.0] * 4, radius=radius))
    srdf = tmp_path / "arm4.srdf"
    srdf.write_text(SRDF)
    arm = mp.Arm.from_urdf(urdf, srdf_path=srdf)
    plain = mp.Arm.from_urdf(urdf)
    names = [g.name for g in arm.collision_model.geometryObjects]
    pairs = {(names[p.first], names[p.second]) for p in arm.collision_model.collisionPairs}
    assert pairs == {("link1_0", "link4_0"), ("link2_0", "link4_0")}
    assert arm.srdf_path == str(srdf) and len(plain.collision_model.collisionPairs) == 0
    assert arm.fingerprint() != plain.fingerprint()
    with_srdf = CollisionChecker(arm)
    default = CollisionChecker(plain)  # non-adjacent links: (1, 3), (1, 4), (2, 4)
    assert len(with_srdf.self_pairs) == 2 and len(default.self_pairs) == 3
    rng = np.random.default_rng(12)
    Q = rng.uniform(arm.lower_limits, arm.upper_limits, size=(6000, 4))
    corners = link_rectangles(Q, lengths, radius)[0]
    d = {(i, j): sd_polygons(corners[:, i], corners[:, j]) for i, j in [(0, 2), (0, 3), (1, 3)]}
    kept = np.minimum(d[0, 3], d[1, 3])
    every = np.minimum(kept, d[0, 2])
    only_13 = (d[0, 2] < -1e-3) & (kept > 1e-3)
    assert only_13.sum() > 100
    for checker, ref in ((with_srdf, kept), (default, every)):
        free = checker.is_free_batch(Q)
        assert not np.any((free != (ref > 0)) & (np.abs(ref) >= 1e-6))
    assert with_srdf.is_free_batch(Q[only_13]).all() and not default.is_free_batch(Q[only_13]).any()


def _write_tetrahedron_stl(path, apex):
    """Binary STL of the tetrahedron (0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), ``apex`` (m)."""
    import struct

    pts = [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0), apex]
    tris = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    out = bytearray(80) + struct.pack("<I", len(tris))
    for tri in tris:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for i in tri:
            out += struct.pack("<3f", *pts[i])
        out += b"\0\0"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(bytes(out))


def test_fingerprint_covers_mesh_scale_and_file_contents(tmp_path):
    def arm_with_mesh(mesh, scale):
        xml = mp.planar_arm_urdf([0.5], [1.0]).replace(
            '<cylinder radius="0.03" length="0.5"/>', f'<mesh filename="{mesh}" scale="{scale}"/>'
        )
        arm = mp.Arm.from_urdf(xml)
        (go,) = arm.collision_model.geometryObjects
        assert go.meshPath == str(mesh) and go.geometry.num_vertices == 4
        np.testing.assert_array_equal(go.meshScale, [float(v) for v in scale.split()])
        return arm

    a, b = tmp_path / "a" / "tet.stl", tmp_path / "b" / "tet.stl"
    _write_tetrahedron_stl(a, (0.0, 0.0, 0.1))
    _write_tetrahedron_stl(b, (0.0, 0.0, 0.1))
    arm = arm_with_mesh(a, "1 1 1")
    before = arm.fingerprint()
    assert arm_with_mesh(a, "1 1 1").fingerprint() == before  # deterministic
    assert arm_with_mesh(a, "1 2 1").fingerprint() != before  # scale counts
    assert arm_with_mesh(b, "1 1 1").fingerprint() == before  # same bytes elsewhere: same
    _write_tetrahedron_stl(a, (0.0, 0.0, 0.2))  # same path, other contents
    assert arm.fingerprint() != before
    assert arm.fingerprint() != arm_with_mesh(b, "1 1 1").fingerprint()


@pytest.mark.parametrize(
    "srdf, match",
    [
        (None, "SRDF file not found"),
        ("<robot name='x'><disable_collisions link1='link1'", "malformed SRDF"),
        ("<robot name='x'><disable_collisions link1='link1' link2='link9'/></robot>",
         r"links the URDF does not have: \['link9'\]"),
    ],
)
def test_bad_srdf(tmp_path, srdf, match):
    path = tmp_path / "a.srdf"
    if srdf is not None:
        path.write_text(srdf)
    with pytest.raises(ValueError, match=match):
        mp.Arm.from_urdf(mp.planar_arm_urdf([0.5, 0.4], [1.0, 1.0]), srdf_path=path)


@pytest.mark.parametrize(
    "text, match",
    [
        ("<robot name='x'><link name='a'>", "malformed URDF XML"),
        ("<robot name='x'><link name='a'/></robot>", "no movable joint"),
        ("<robt name='x'/>", "not <robot>"),
        ("/definitely/not/here.urdf", "not found"),
    ],
)
def test_bad_urdf(text, match):
    with pytest.raises(ValueError, match=match):
        mp.Arm.from_urdf(text)


def test_bad_generator_input():
    with pytest.raises(ValueError, match="masses"):
        mp.planar_arm_urdf([0.5, 0.5], [1.0])
    with pytest.raises(ValueError, match="> 0"):
        mp.planar_arm_urdf([0.5, -0.5], [1.0, 1.0])
    with pytest.raises(ValueError, match="lower joint limit"):
        mp.planar_arm_urdf([0.5], [1.0], lower=1.0, upper=0.0)


def test_unknown_example_robot():
    with pytest.raises(ValueError, match="unknown example-robot-data robot 'pandaa'"):
        mp.Arm.from_example_robot_data("pandaa")


def test_configuration_checks():
    arm = mp.builtin_arm("planar_2link")
    with pytest.raises(ValueError, match="2 joint values"):
        arm.gravity([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="NaN"):
        arm.mass_matrix([0.0, float("nan")])


def _loader_model(name):
    from example_robot_data import robots_loader

    return robots_loader.loader(name).robot.model


def test_continuous_joints_are_planned_as_angles():
    """Kinova Gen2 (three continuous joints) loads with one angle per joint, limits [−π, π],
    and the same rigid-body terms as Pinocchio's own (cos, sin) model at that angle."""
    import pinocchio as pin

    arm = mp.Arm.from_example_robot_data("kinova")
    assert arm.nq == arm.model.nv == 6
    assert arm.continuous_joints == ("j2s6s200_joint_1", "j2s6s200_joint_4", "j2s6s200_joint_6")
    ref = _loader_model("kinova")
    assert ref.nq > ref.nv  # the loader's model keeps cos/sin coordinates
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(arm.lower_limits, arm.upper_limits)
        qr = np.empty(ref.nq)
        for k, jname in enumerate(arm.joint_names):
            joint = ref.joints[ref.getJointId(jname)]
            if joint.nq == 2:
                qr[joint.idx_q : joint.idx_q + 2] = np.cos(q[k]), np.sin(q[k])
            else:
                qr[joint.idx_q] = q[k]
            if jname in arm.continuous_joints:
                j = arm.model.getJointId(jname)
                assert arm.model.lowerPositionLimit[arm.model.joints[j].idx_q] == -math.pi
                assert arm.model.upperPositionLimit[arm.model.joints[j].idx_q] == math.pi
        data = ref.createData()
        np.testing.assert_allclose(arm.mass_matrix(q), pin.crba(ref, data, qr), atol=1e-12)
        np.testing.assert_allclose(arm.gravity(q), pin.computeGeneralizedGravity(ref, data, qr),
                                   atol=1e-10)


def test_fixed_base_urdf_loads_fixed_base_although_its_loader_adds_a_free_flyer():
    """so100's example-robot-data loader adds a free-flyer the URDF does not have; the arm
    is fixed-base (gripper locked) and its D(q) is the loader model's arm block."""
    import pinocchio as pin

    arm = mp.Arm.from_example_robot_data("so100")
    assert arm.joint_names == ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex",
                               "wrist_roll"]
    ref = _loader_model("so100")
    assert ref.joints[1].shortname() == "JointModelFreeFlyer"
    q = np.array([0.3, -0.5, 0.8, 0.2, -1.0])
    qr = pin.neutral(ref)
    idx = [ref.joints[ref.getJointId(n)].idx_v for n in arm.joint_names]
    for k, n in enumerate(arm.joint_names):
        qr[ref.joints[ref.getJointId(n)].idx_q] = q[k]
    M = pin.crba(ref, ref.createData(), qr)
    M = np.triu(M) + np.triu(M, 1).T
    np.testing.assert_allclose(arm.mass_matrix(q), M[np.ix_(idx, idx)], atol=1e-12)


def test_floating_joint_urdf_is_refused():
    xml = mp.planar_arm_urdf([0.5, 0.5], [1.0, 1.0]).replace(
        '<joint name="joint1" type="revolute">', '<joint name="joint1" type="floating">', 1)
    assert 'type="floating"' in xml
    with pytest.raises(ValueError, match="floating joint"):
        mp.Arm.from_urdf(xml)


def test_fingerprint_covers_unaligned_joint_axes():
    """Two arms that differ only in a joint axis off x, y and z have different fingerprints
    (docs/design.md §1c); the same axis gives the same one."""
    from mpd_pin.arm.urdf import planar_arm_urdf

    xml = planar_arm_urdf([0.5, 0.4], [1.0, 1.0])
    tilted = [mp.Arm.from_urdf(xml.replace('xyz="0.0 -1.0 0.0"', f'xyz="{a}"', 1))
              for a in ("0 0.6 0.8", "0 0.8 0.6", "0 0.6 0.8")]
    assert "Unaligned" in tilted[0].model.joints[1].shortname()
    assert tilted[0].fingerprint() == tilted[2].fingerprint() != tilted[1].fingerprint()
