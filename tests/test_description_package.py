"""An arm from a robot description package: package:// meshes, xacro, SRDF, locked joints
(docs/design.md §1c), from the Python API and from a scenario file through the CLI."""

from __future__ import annotations

import json
import math
import shutil
import struct
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_cli

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.collision.checker import CollisionChecker
from mpd_pin.world.scene import World
from mpd_pin.world.shapes import Sphere

#: link1's mesh box (m): x in [0, 0.5], y and z in [-HALF, HALF]
LINK1, LINK2, HALF = 0.5, 0.3, 0.05


def write_box_stl(path: Path, lo, hi) -> None:
    """Binary STL of the axis-aligned box [lo, hi] (m): 12 triangles."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))]
    out = bytearray(b"box".ljust(80, b" ") + struct.pack("<I", len(tris)))
    for t in tris:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for i in t:
            out += struct.pack("<3f", *v[i])
        out += struct.pack("<H", 0)
    path.write_bytes(bytes(out))


def _inertial(mass: float, x: float) -> str:
    return (f'<inertial><origin xyz="{x} 0 0"/><mass value="{mass}"/>'
            f'<inertia ixx="0.001" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>')


def _mesh(name: str) -> str:
    geom = f'<geometry><mesh filename="package://box_arm/meshes/{name}.stl"/></geometry>'
    return f"<visual>{geom}</visual><collision>{geom}</collision>"


def robot_xml(length: str = str(LINK1), link2_mesh: str = "link2", head: str = "") -> str:
    """Two revolute joints about z and a prismatic finger (to be locked)."""
    return f"""<?xml version="1.0"?>
<robot name="box_arm" {head}>
  <link name="base_link"/>
  <link name="link1">{_inertial(1.0, 0.25)}{_mesh("link1")}</link>
  <link name="link2">{_inertial(0.6, 0.15)}{_mesh(link2_mesh)}</link>
  <link name="finger">{_inertial(0.05, 0.0)}{_mesh("finger")}</link>
  <link name="tool"/>
  <joint name="joint1" type="revolute"><parent link="base_link"/><child link="link1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="100" velocity="10"/></joint>
  <joint name="joint2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="{length} 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="10"/></joint>
  <joint name="finger_joint" type="prismatic"><parent link="link2"/><child link="finger"/>
    <origin xyz="{LINK2} 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="link2"/><child link="tool"/>
    <origin xyz="{LINK2} 0 0"/></joint>
</robot>
"""


XACRO_HEAD = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
XACRO_DEFS = (
    '<xacro:arg name="length" default="0.5"/>\n'
    '  <xacro:property name="L" value="$(arg length)"/>'
)

SRDF = """<?xml version="1.0"?>
<robot name="box_arm">
  <disable_collisions link1="link1" link2="link2" reason="Adjacent"/>
  <disable_collisions link1="link2" link2="finger" reason="Adjacent"/>
  <disable_collisions link1="{other}" link2="finger" reason="Never"/>
</robot>
"""


@pytest.fixture(scope="module")
def package(tmp_path_factory) -> Path:
    """``src/box_arm/{urdf,meshes,srdf}``: the usual layout of a description package."""
    root = tmp_path_factory.mktemp("src") / "box_arm"
    for sub in ("urdf", "meshes", "srdf"):
        (root / sub).mkdir(parents=True)
    write_box_stl(root / "meshes" / "link1.stl", (0, -HALF, -HALF), (LINK1, HALF, HALF))
    write_box_stl(root / "meshes" / "link2.stl", (0, -0.03, -0.03), (LINK2, 0.03, 0.03))
    write_box_stl(root / "meshes" / "finger.stl", (-0.01, -0.01, -0.01), (0.01, 0.01, 0.01))
    (root / "urdf" / "box_arm.urdf").write_text(robot_xml())
    xacro = robot_xml("${L}", head=XACRO_HEAD).replace(
        '<link name="base_link"/>', XACRO_DEFS + '\n  <link name="base_link"/>'
    )
    (root / "urdf" / "box_arm.urdf.xacro").write_text(xacro)
    (root / "urdf" / "missing_mesh.urdf").write_text(robot_xml(link2_mesh="nothere"))
    (root / "srdf" / "box_arm.srdf").write_text(SRDF.format(other="link1"))
    (root / "srdf" / "bad.srdf").write_text(SRDF.format(other="gripper_palm"))
    return root


def ee_reference(length: float, q1: float, q2: float) -> np.ndarray:
    return np.array([
        length * math.cos(q1) + LINK2 * math.cos(q1 + q2),
        length * math.sin(q1) + LINK2 * math.sin(q1 + q2),
        0.0,
    ])


def test_package_uris_resolve_from_ancestor_and_package_dirs(package, tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    arm = mp.Arm.from_urdf(package / "urdf" / "box_arm.urdf")  # box_arm/ is an ancestor
    geoms = arm.collision_model.geometryObjects
    paths = {g.name.rsplit("_", 1)[0]: Path(g.meshPath) for g in geoms}
    assert paths["link1"] == (package / "meshes" / "link1.stl").resolve()
    # the same text elsewhere: found through package_dirs, or through ROS_PACKAGE_PATH
    copy = tmp_path / "my_arm.urdf"
    copy.write_text(robot_xml())
    with pytest.raises(ValueError, match="package://box_arm/meshes/link1.stl"):
        mp.Arm.from_urdf(copy)
    by_dirs = mp.Arm.from_urdf(copy, package_dirs=[package.parent])
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(package.parent))
    by_env = mp.Arm.from_urdf(copy)
    assert arm.fingerprint() == by_dirs.fingerprint() == by_env.fingerprint()
    # visual meshes (drawn by the replay) are the package's files too
    assert {Path(g.meshPath) for g in by_env.visual_model.geometryObjects} == {
        (package / "meshes" / f"{n}.stl").resolve() for n in ("link1", "link2", "finger")
    }


def test_collision_geometry_is_the_mesh(package):
    """A sphere near link1 collides exactly when it meets the mesh box (brute force)."""
    arm = mp.Arm.from_urdf(package / "urdf" / "box_arm.urdf", lock={"finger_joint": 0.0})
    geo = {g.name: type(g.geometry).__name__ for g in arm.collision_model.geometryObjects}
    assert all("BVH" in t or "Convex" in t for t in geo.values()), geo
    centre, r = np.array([0.25, 0.12, 0.0]), 0.05
    checker = CollisionChecker(arm, World(obstacles=(Sphere(r, tuple(centre), "ball"),)),
                               self_collision=False)
    checked = 0
    for q1 in np.linspace(-0.6, 0.9, 61):
        c, s = math.cos(q1), math.sin(q1)
        local = np.array([c * centre[0] + s * centre[1], -s * centre[0] + c * centre[1], 0.0])
        nearest = np.clip(local, [0, -HALF, -HALF], [LINK1, HALF, HALF])
        gap = float(np.linalg.norm(local - nearest)) - r
        if abs(gap) < 2e-3:
            continue  # too close to call in float32 mesh coordinates
        assert checker.is_free([q1, 0.0]) == (gap > 0), (q1, gap)
        checked += 1
    assert checked > 50
    assert not checker.is_free([0.3, 0.0]) and checker.is_free([0.0, 0.0])


def test_xacro_args_change_the_arm(package):
    path = package / "urdf" / "box_arm.urdf.xacro"
    short = mp.Arm.from_urdf(path, srdf_path=package / "srdf" / "box_arm.srdf",
                             lock={"finger_joint": 0.02})
    long = mp.Arm.from_urdf(path, xacro_args={"length": 0.7}, lock={"finger_joint": 0.02})
    q = [0.4, -0.9]
    np.testing.assert_allclose(short.frame_position(q, "tool"), ee_reference(0.5, *q), atol=1e-12)
    np.testing.assert_allclose(long.frame_position(q, "tool"), ee_reference(0.7, *q), atol=1e-12)
    assert short.joint_names == ["joint1", "joint2"]
    assert short.locked_joints == {"finger_joint": 0.02}
    # the locked finger sits 0.02 m along link2's y
    fid = short.model.getFrameId("finger")
    pin.framesForwardKinematics(short.model, short.data, np.array(q))
    np.testing.assert_allclose(
        short.data.oMf[fid].translation,
        ee_reference(0.5, *q) + 0.02 * np.array([-math.sin(q[0] + q[1]), math.cos(q[0] + q[1]), 0]),
        atol=1e-12,
    )
    # the fingerprint (the roadmap key) follows the expanded URDF
    again = mp.Arm.from_urdf(path, xacro_args={"length": "0.7"}, lock={"finger_joint": 0.02})
    assert long.fingerprint() == again.fingerprint() != short.fingerprint()
    moved = mp.Arm.from_urdf(path, xacro_args={"length": 0.7}, lock={"finger_joint": 0.03})
    assert moved.fingerprint() != long.fingerprint()


def _scenario(tmp_path: Path, arm: str, name: str = "s.toml", task: str = "") -> Path:
    text = f"""name = "box_arm"
[arm]
{arm}
[motor]
preset = "servo"
gear_ratio = 50.0
[controller]
kp = 20.0
kd = 1.0
[roadmap]
num_nodes = 30
k = 6
seed = 3
resolution = 0.1
[[obstacles]]
type = "sphere"
name = "ball"
radius = 0.05
position = [0.25, 0.12, 0.0]
[task]
{task or 'start = [-0.5, 0.4]' + chr(10) + 'goal = [-1.6, 1.0]'}
"""
    path = tmp_path / name
    path.write_text(text)
    return path


def test_scenario_end_to_end_through_the_cli(package, tmp_path, capsys):
    shutil.copytree(package.parent, tmp_path / "src")
    rel = "../src/box_arm"  # relative paths are relative to the scenario file
    work = tmp_path / "scenes"
    work.mkdir()
    scn = _scenario(work, f"""urdf = "{rel}/urdf/box_arm.urdf.xacro"
srdf = "{rel}/srdf/box_arm.srdf"
xacro_args = {{ length = 0.6 }}
lock = {{ finger_joint = 0.01 }}""")
    out = tmp_path / "out"
    proc = run_cli("run", scn, "--out", out, "--quiet", "--no-replay", cwd="/")
    assert proc.returncode == 0, proc.stderr
    res = json.loads((out / "result.json").read_text())
    assert res["joint_names"] == ["joint1", "joint2"]
    assert res["locked_joints"] == {"finger_joint": 0.01}
    assert res["total_energy"] > 0 and math.isfinite(res["total_energy"])
    nodes = np.array(res["path"]["configurations"])
    np.testing.assert_allclose(nodes[0], [-0.5, 0.4])
    np.testing.assert_allclose(nodes[-1], [-1.6, 1.0])
    # every node is clear of the ball (mesh geometry)
    arm = mp.Arm.from_urdf(package / "urdf" / "box_arm.urdf.xacro", xacro_args={"length": 0.6},
                           lock={"finger_joint": 0.01})
    checker = CollisionChecker(arm, World(obstacles=(Sphere(0.05, (0.25, 0.12, 0.0), "b"),)))
    assert all(checker.is_free(q) for q in nodes)
    # a start that only the mesh's width puts in collision is refused
    bad = _scenario(work, scn.read_text().split("[arm]\n")[1].split("[motor]")[0].strip(),
                    "bad.toml", "start = [0.3, 0.0]\ngoal = [-1.6, 1.0]")
    assert main(["run", str(bad), "--out", str(tmp_path / "o2"), "--quiet", "--no-replay"]) == 2
    assert "collision" in capsys.readouterr().err


def _error(tmp_path, arm: str, capsys) -> str:
    scn = _scenario(tmp_path, arm, "err.toml")
    status = main(["run", str(scn), "--out", str(tmp_path / "o"), "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert status == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o" / "result.json").exists()
    return err


def test_bad_description_packages(package, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    u = package / "urdf"
    err = _error(tmp_path, f'urdf = "{u / "missing_mesh.urdf"}"', capsys)
    assert "package://box_arm/meshes/nothere.stl" in err and str(package) in err
    broken = tmp_path / "broken.urdf.xacro"
    broken.write_text(f"<robot {XACRO_HEAD}>\n  <link name='a'>\n</robot>\n")
    err = _error(tmp_path, f'urdf = "{broken}"', capsys)
    assert str(broken) in err and "line 3" in err
    undefined = tmp_path / "undefined.urdf.xacro"
    undefined.write_text((u / "box_arm.urdf.xacro").read_text().replace("${L}", "${LL}"))
    err = _error(tmp_path, f'urdf = "{undefined}"', capsys)
    assert str(undefined) in err and "LL" in err
    err = _error(tmp_path, f'urdf = "{u / "box_arm.urdf"}"\nsrdf = "{package}/srdf/bad.srdf"',
                 capsys)
    assert "gripper_palm" in err
    err = _error(tmp_path, f'urdf = "{u / "box_arm.urdf"}"\nlock = {{ thumb = 0.0 }}', capsys)
    assert "thumb" in err
    err = _error(tmp_path, f'urdf = "{u / "box_arm.urdf"}"\nlock = {{ finger_joint = 0.1 }}',
                 capsys)
    assert "finger_joint" in err and "limits" in err
    err = _error(tmp_path, f'urdf = "{u / "box_arm.urdf"}"\nxacro_args = {{ a = 1 }}', capsys)
    assert "xacro" in err
    err = _error(tmp_path, 'builtin = "planar_2link"\nsrdf = "x.srdf"', capsys)
    assert "arm.srdf" in err


def _visual_summary(arm: mp.Arm, q) -> list[tuple]:
    """(name, mesh path, parent joint, world placement at q) of every visual object."""
    data, gdata = arm.model.createData(), arm.visual_model.createData()
    pin.forwardKinematics(arm.model, data, np.asarray(q, float))
    pin.updateGeometryPlacements(arm.model, data, arm.visual_model, gdata)
    return [(g.name, g.meshPath, g.parentJoint, np.round(gdata.oMg[k].homogeneous, 12).tolist())
            for k, g in enumerate(arm.visual_model.geometryObjects)]


def test_visual_geometry_is_built_when_first_read_and_equals_the_eager_one(package, monkeypatch):
    """Loading an arm builds no visual geometry (only the replay draws it, docs/design.md
    §1c); reading ``visual_model`` builds it once, equal to Pinocchio's own build of the
    URDF's visual geometry with the locked joints removed (``pin.buildReducedModel``),
    for a locked finger at 0.02 m and for example-robot-data's Panda (gripper locked)."""
    import example_robot_data as erd

    built = []
    real = pin.buildGeomFromUrdfString

    def spy(model, xml, kind, *rest):
        built.append(kind)
        return real(model, xml, kind, *rest)

    monkeypatch.setattr(pin, "buildGeomFromUrdfString", spy)
    path = package / "urdf" / "box_arm.urdf"
    arm = mp.Arm.from_urdf(path, lock={"finger_joint": 0.02})
    panda = mp.Arm.from_example_robot_data("panda")
    assert pin.GeometryType.VISUAL not in built
    q = [0.4, -0.3]
    lazy = _visual_summary(arm, q)
    assert built.count(pin.GeometryType.VISUAL) == 1
    _visual_summary(arm, q)
    assert built.count(pin.GeometryType.VISUAL) == 1  # kept

    full = pin.buildModelFromUrdf(str(path))
    visual = real(full, path.read_text(), pin.GeometryType.VISUAL, None, [str(package.parent)])
    q_full = pin.neutral(full)
    q_full[full.joints[full.getJointId("finger_joint")].idx_q] = 0.02
    _, (reduced,) = pin.buildReducedModel(full, [visual], [full.getJointId("finger_joint")],
                                          q_full)
    eager = mp.Arm(model=arm.model, collision_model=arm.collision_model, visual_model=reduced)
    assert lazy == _visual_summary(eager, q)
    assert {Path(g[1]).name for g in lazy} == {"link1.stl", "link2.stl", "finger.stl"}

    robot = erd.load("panda")  # its own loader: 7 joints, 2 fingers at the reference posture
    q7 = np.array([0.1, -0.5, 0.3, -2.0, 0.2, 1.6, 0.7])
    q9 = np.concatenate([q7, robot.q0[7:]])
    ref_data, ref_g = robot.model.createData(), robot.visual_model.createData()
    pin.forwardKinematics(robot.model, ref_data, q9)
    pin.updateGeometryPlacements(robot.model, ref_data, robot.visual_model, ref_g)
    ref = {g.name: np.round(ref_g.oMg[k].homogeneous, 9).tolist()
           for k, g in enumerate(robot.visual_model.geometryObjects)}
    got = {name: np.round(np.array(pose), 9).tolist()
           for name, _, _, pose in _visual_summary(panda, q7)}
    assert got.keys() == ref.keys() and got == ref


@pytest.mark.parametrize("name", ["panda", "ur5", "ur10", "kinova", "double_pendulum"])
def test_example_robot_data_files_are_the_loaders_own(name):
    """An example-robot-data arm is read from its files without making its loader (which
    builds the whole robot, meshes and all: 0.42 s of ``mpd-pin run panda``): the files
    are the ones the library's own loader names."""
    from example_robot_data import robots_loader

    from mpd_pin.arm.model import _erd_files

    ours, theirs = _erd_files(name), robots_loader.loader(name)
    for attr in ("urdf_filename", "df_path", "model_path", "srdf_path", "ref_posture"):
        assert getattr(ours, attr) == getattr(theirs, attr), attr
    assert not isinstance(ours, robots_loader.RobotLoader)  # not made


def test_a_loader_with_its_own_init_is_made():
    """A loader that changes its files in its own ``__init__`` (panda_collision drops its
    SRDF there) is made, and its files read from it."""
    from example_robot_data import robots_loader

    from mpd_pin.arm.model import _erd_files

    files = _erd_files("panda_collision")
    assert isinstance(files, robots_loader.PandaLoaderCollision) and files.srdf_path is None


def test_a_robot_whose_every_joint_is_a_gripper_joint_says_so():
    """finger_edu's three revolute joints all have "finger" in their names (read from its
    URDF text): from_example_robot_data would lock them all as gripper joints, and says
    so, naming them and the URDF that from_urdf loads whole (3 joints)."""
    import re

    from mpd_pin.arm.model import _erd_files

    path = _erd_files("finger_edu").df_path
    text = Path(path).read_text(encoding="utf-8")
    joints = re.findall(r'<joint\s+name="([^"]+)"\s+type="(?:revolute|continuous|prismatic)"',
                        text)
    assert len(joints) == 3 and all("finger" in j for j in joints)
    with pytest.raises(ValueError) as info:
        mp.Arm.from_example_robot_data("finger_edu")
    msg = str(info.value)
    assert "every joint would be locked" in msg and "as gripper joints" in msg
    assert all(repr(j) in msg for j in joints)
    urdf = re.search(r"Arm\.from_urdf\('([^']+)'\)", msg).group(1)
    assert Path(urdf).resolve() == Path(path).resolve()
    assert mp.Arm.from_urdf(urdf).joint_names == joints
