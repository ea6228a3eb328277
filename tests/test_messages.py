"""Messages a new user meets first (issue 23): no path, start or goal in collision, unknown
keys, angles in degrees, and the ROS time of trajectory.json points."""

import json
import math
import tomllib

import numpy as np
import pytest
from scenario_texts import SMALL_2LINK

from mpd_pin.app import cli
from mpd_pin.app.config import ConfigError, Table
from mpd_pin.app.pathfile import read_waypoints
from mpd_pin.app.trajectory import joint_trajectory, ros_duration
from mpd_pin.arm import builtin_arm
from mpd_pin.collision import CollisionChecker
from mpd_pin.world import Box, Hazard, World

#: A 3-link scenario with one named obstacle above the base and one unnamed to the right.
THREE_LINK = """\
[arm]
builtin = "planar_3link"
[roadmap]
num_nodes = 30
k = 6
duration = 0.5
dt = 0.01
[[obstacles]]
type = "box"
name = "divider"
center = [0.0, 0.75]
width = 0.2
height = 0.5
[[obstacles]]
type = "box"
center = [0.8, 0.0]
width = 0.2
height = 0.2
[task]
start = START
goal = [-2.0, 0.0, 0.0]
"""

#: A folded 3-link posture where link3 lies across link1 (their one self-collision pair).
FOLDED = [0.0, 2.45, 2.73]


def run(capsys, *args):
    """``mpd-pin ARGS`` in-process → (exit status, stderr lines)."""
    status = cli.main([str(a) for a in args])
    return status, capsys.readouterr().err.strip().splitlines()


def run_text(capsys, tmp_path, text):
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return run(capsys, "run", path, "--out", tmp_path / "out", "--quiet")


def three_link(start):
    return THREE_LINK.replace("START", json.dumps(start))


# ------------------------------------------------------------------------ no path
def test_no_path_names_start_and_goal_and_what_to_try(capsys, tmp_path):
    """case1 with seed 5: its 150 nodes do not join the two sides of the divider."""
    status, err = run(capsys, "run", "case1", "--seed", "5", "--out", tmp_path / "x", "--quiet")
    assert status == 3
    assert len(err) == 1
    assert err[0].startswith("mpd-pin: no path: no path from the start to the goal: ")
    assert "node 0" not in err[0] and "node 1" not in err[0]
    assert "[roadmap] num_nodes = 150, k = 10, seed = 5" in err[0]
    assert err[0].endswith("try more nodes or neighbours ([roadmap] num_nodes, k) or another "
                           "seed ([roadmap] seed, or --seed; in Python the same fields of "
                           "RoadmapOptions)")


def _no_path(text, *, src=(0, 2, 1, 2), dst=(2, 0, 2, 1), revealed=(), hazard=None,
             penalty=math.inf):
    """no_path_message on stand-ins: a 3-node roadmap (start 0, goal 1) and a world."""
    from types import SimpleNamespace as NS

    from mpd_pin.app.plan import no_path_message
    from mpd_pin.planning.roadmap import RoadmapOptions

    roadmap = NS(start=0, goal=1, src=np.array(src, int), dst=np.array(dst, int))
    world = NS(revealed=frozenset(revealed), hazards=[] if hazard is None else [hazard])
    scn = NS(options=RoadmapOptions(num_nodes=40, k=7, seed=3), hazard_penalty=penalty)
    return no_path_message(text, scn, NS(roadmap=roadmap, world=world))


def test_no_path_message_in_other_situations():
    tail = ("([roadmap] num_nodes = 40, k = 7, seed = 3); try more nodes or neighbours "
            "([roadmap] num_nodes, k) or another seed ([roadmap] seed, or --seed; in Python "
            "the same fields of RoadmapOptions)")
    assert _no_path("no path from node 0 to node 1") == (
        f"no path from the start to the goal: the roadmap's edges do not connect them {tail}")
    assert _no_path("no path from node 0 to node 1", src=(2, 1), dst=(1, 2)) == (
        "no path from the start to the goal: the roadmap's edges do not connect them (the "
        f"start has no collision-free edge at all) {tail}")
    assert _no_path("no path from node 0 to node 1", src=(2,), dst=(2,)) == (
        "no path from the start to the goal: the roadmap's edges do not connect them (the "
        f"start and the goal have no collision-free edge at all) {tail}")
    # re-planning after sensing a hidden obstacle, from where the arm stands
    assert _no_path("no path from node 2 to node 1", revealed={"crate", "box0"}) == (
        "no path from roadmap node 2 (reached on the way) to the goal: the roadmap's edges do "
        "not connect them once the hidden obstacle(s) 'box0', 'crate' were sensed " + tail)
    zone = Hazard(Box.planar([-0.8, 0.0], 0.2, 0.2, name="zone"), 0.05)
    assert _no_path("no path from node 0 to node 1", hazard=zone) == (
        "no path from the start to the goal: the roadmap's edges do not connect them without "
        "the edges closer to a hazard than its clearance ([planner] hazard_penalty = inf) "
        + tail)
    assert "hazard" not in _no_path("no path from node 0 to node 1", hazard=zone, penalty=10.0)
    # a message in another form is kept as it is
    assert _no_path("D* path does not end at the goal").startswith(
        "D* path does not end at the goal: the roadmap's edges do not connect them ")


# ------------------------------------------------------------ endpoint in collision
def test_start_in_collision_names_the_links_and_the_obstacle(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path, three_link([math.pi / 2, 0.0, 0.0]))
    assert status == 2
    assert err == ["mpd-pin: error: start [1.570796, 0.0, 0.0] is in collision: links 'link1', "
                   "'link2' and 'link3' touch obstacle 'divider'"]


def test_unnamed_obstacle_is_named_by_type_and_index(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path, three_link([0.0, 0.0, 0.0]))
    assert status == 2
    assert err == ["mpd-pin: error: start [0.0, 0.0, 0.0] is in collision: links 'link2' and "
                   "'link3' touch obstacle 'box1'"]


def test_self_collision_names_both_links(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path, three_link(FOLDED))
    assert status == 2
    assert err == [f"mpd-pin: error: start {FOLDED} is in collision: link 'link1' touches "
                   "link 'link3'"]


def test_goal_ee_whose_ik_solutions_collide_names_the_pair(capsys, tmp_path):
    text = three_link([2.0, 0.0, 0.0]).replace("goal = [-2.0, 0.0, 0.0]", "goal_ee = [0.0, 0.7]")
    status, err = run_text(capsys, tmp_path, text)
    assert status == 2
    assert len(err) == 1
    assert err[0].startswith("mpd-pin: error: task.goal_ee: every IK solution found for "
                             "[0.0, 0.0, 0.7] is in collision (at [")
    assert err[0].endswith(": link 'link3' touches obstacle 'divider')")


def test_checker_colliding_pairs():
    arm = builtin_arm("planar_3link")
    world = World((Box.planar([0.0, 0.75], 0.2, 0.5, name="divider"),),
                  (Hazard(Box.planar([-0.8, 0.0], 0.2, 0.2, name="zone"), 0.05),))
    checker = CollisionChecker(arm, world, hazard_clearance=True)
    assert checker.colliding_pairs([math.pi / 2, 0.0, 0.0]) == [
        ("link 'link1'", "obstacle 'divider'"), ("link 'link2'", "obstacle 'divider'"),
        ("link 'link3'", "obstacle 'divider'")]
    assert checker.colliding_pairs(FOLDED) == [("link 'link1'", "link 'link3'")]
    assert checker.colliding_pairs([math.pi - 0.3, 0.0, 0.0]) == []
    assert checker.describe_collision([math.pi - 0.3, 0.0, 0.0]) == ""
    # the hazard is 0.05 m away at most: within its clearance, not entered
    assert checker.describe_collision([math.pi, 0.0, 0.0]) == (
        "links 'link2' and 'link3' come within 0.05 m of hazard 'zone'")
    assert checker.describe_collision([math.pi / 2, 0.0, 0.0], limit=0) == "and 1 more"


#: Two links; the upper one has two collision boxes (Pinocchio names them upper_0, upper_1).
TWO_BOX_URDF = """<robot name="two_boxes">
  <link name="base"/>
  <link name="upper">
    <inertial><mass value="1"/><origin xyz="0.5 0 0"/>
      <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.25 0 0"/><geometry><box size="0.4 0.05 0.05"/></geometry></collision>
    <collision><origin xyz="0.75 0 0"/><geometry><box size="0.4 0.05 0.05"/></geometry></collision>
  </link>
  <link name="fore">
    <inertial><mass value="1"/><origin xyz="0.25 0 0"/>
      <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.25 0 0"/><geometry><box size="0.4 0.05 0.05"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 1 0"/><limit lower="-3.14" upper="3.14" effort="10" velocity="2"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="1 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3.14" upper="3.14" effort="10" velocity="2"/></joint>
</robot>"""


def test_a_link_with_several_geometries_is_named_once():
    from mpd_pin.arm import Arm

    arm = Arm.from_urdf(TWO_BOX_URDF)
    checker = CollisionChecker(arm, World((Box.planar([0.5, 0.0], 1.0, 0.3, name="wall"),)))
    assert checker.in_collision_pairs([0.0, 0.0]) == [("upper_0", "obstacle:wall"),
                                                      ("upper_1", "obstacle:wall")]
    assert checker.colliding_pairs([0.0, 0.0]) == [("link 'upper'", "obstacle 'wall'")]
    assert checker.describe_collision([0.0, 0.0]) == "link 'upper' touches obstacle 'wall'"


# ------------------------------------------------------------------- unknown keys
def test_unknown_key_suggests_the_nearest(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path, SMALL_2LINK.replace("num_nodes", "num_node"))
    assert status == 2
    assert len(err) == 1
    assert err[0].startswith("mpd-pin: error: roadmap: unknown key(s) 'num_node' (known here: ")
    assert err[0].endswith("; did you mean 'num_nodes'?")


def test_unknown_keys_suggestions_name_each_key_and_only_close_ones():
    t = Table({"num_node": 1, "sed": 2, "colour": 3, "k": 4}, "roadmap")
    for key in ("num_nodes", "seed", "k"):
        t.raw(key, None)
    with pytest.raises(ConfigError) as exc:
        t.done()
    assert str(exc.value).endswith(
        "; did you mean 'num_nodes' for 'num_node', 'seed' for 'sed'?")
    t = Table({"colour": 3}, "task")
    t.raw("start", None)
    with pytest.raises(ConfigError) as exc:
        t.done()
    assert "did you mean" not in str(exc.value)


def test_unknown_joint_in_limits_suggests_the_nearest(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path,
                           SMALL_2LINK + "[limits]\njoint_1 = { velocity = 2.0 }\n")
    assert status == 2
    assert err[0].startswith("mpd-pin: error: limits.joint_1: the arm has no movable joint "
                             "'joint_1'")
    assert err[0].endswith("did you mean 'joint1'?")


# ---------------------------------------------------------------- radians hint
def test_degrees_get_the_radians_hint(capsys, tmp_path):
    status, err = run_text(capsys, tmp_path, three_link([90, 0, 0]))
    assert status == 2
    assert err == ["mpd-pin: error: task.start[0] = 90 is outside the limits of joint 'joint1' "
                   "[-3.14159, 3.14159]; the angles are in radians (did you give degrees?)"]


def test_angles_at_the_limits_within_the_tolerance_are_accepted():
    from mpd_pin.app.scenario import parse_energy_scenario

    text = SMALL_2LINK.replace("start = [0.3, 0.2]", f"start = [{math.pi + 5e-10!r}, 0.0]")
    scn = parse_energy_scenario(tomllib.loads(text))
    assert scn.start[0] == math.pi + 5e-10


@pytest.mark.parametrize("value", [4.0, -3.15, 3.14159 + 2 * math.pi - 1e-3])
def test_angles_a_little_outside_get_no_hint(capsys, tmp_path, value):
    status, err = run_text(capsys, tmp_path, three_link([0.0, value, 0.0]))
    assert status == 2
    assert err == [f"mpd-pin: error: task.start[1] = {value:g} is outside the limits of joint "
                   "'joint2' [-3.14159, 3.14159]"]


def test_ik_seed_in_degrees_gets_the_hint(capsys, tmp_path):
    text = three_link([0.0, 0.0, 0.0]).replace(
        "start = [0.0, 0.0, 0.0]", "start_ee = [0.42, 0.55]\nstart_seed = [0, -45, 0]")
    status, err = run_text(capsys, tmp_path, text)
    assert status == 2
    assert err == ["mpd-pin: error: task.start_seed[1] = -45 is outside the limits of joint "
                   "'joint2' [-3.14159, 3.14159]; the angles are in radians (did you give "
                   "degrees?)"]


# ------------------------------------------------------------ trajectory.json time
@pytest.mark.parametrize("seconds, expected", [
    (0.0, (0, 0)), (0.01, (0, 10_000_000)), (1.0, (1, 0)), (2.9999999999, (3, 0)),
    (123.456789, (123, 456_789_000)), (3599.99, (3599, 990_000_000)),
])
def test_ros_duration(seconds, expected):
    d = ros_duration(seconds)
    assert (d["sec"], d["nanosec"]) == expected
    assert type(d["sec"]) is int and type(d["nanosec"]) is int


def test_trajectory_points_carry_the_ros_time_beside_the_float(tmp_path):
    t = np.linspace(0.0, 2.345, 470)  # the last sample off the 100 Hz grid
    q = np.column_stack([np.sin(t), np.cos(t)])
    series = {"t": t, "q": q, "v": np.gradient(q, t, axis=0), "i": np.zeros_like(q),
              "V": np.ones_like(q)}
    traj = json.loads(json.dumps(_plain(joint_trajectory(["joint1", "joint2"], series,
                                                         np.ones(2)))))
    points = traj["points"]
    assert len(points) == 236 and points[-1]["time_from_start"] == pytest.approx(2.345)
    for p in points:
        ros = p["time_from_start_ros"]
        assert set(ros) == {"sec", "nanosec"}
        assert isinstance(ros["sec"], int) and isinstance(ros["nanosec"], int)
        assert 0 <= ros["nanosec"] < 1_000_000_000
        assert abs(ros["sec"] + ros["nanosec"] * 1e-9 - p["time_from_start"]) <= 1e-9
    assert points[-1]["time_from_start_ros"] == {"sec": 2, "nanosec": 345_000_000}
    # the file reads back for `mpd-pin energy`, with either form of the time
    path = tmp_path / "trajectory.json"
    path.write_text(json.dumps(traj))
    W = read_waypoints(path, ["joint1", "joint2"])
    np.testing.assert_array_equal(W, [p["positions"] for p in points])
    for p in points:
        p["time_from_start"] = p.pop("time_from_start_ros")  # ROS's own shape only
    path.write_text(json.dumps(traj))
    np.testing.assert_array_equal(read_waypoints(path, ["joint1", "joint2"]), W)


def _plain(obj):
    """Arrays as lists, for json.dumps."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return obj


def test_scenario_duration_comments_say_edges_are_lengthened():
    """Every built-in scenario that sets ``[roadmap] duration`` says on that line that
    edges are lengthened where the joint velocity limits need it (issue 23 item 6)."""
    from mpd_pin.app.scenario_files import builtin_scenarios

    seen = 0
    for name, path in builtin_scenarios().items():
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("duration ="):
                seen += 1
                assert "lengthened" in line and "velocity limits" in line, (name, line)
    assert seen >= 8
