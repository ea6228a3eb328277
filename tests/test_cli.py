"""The mpd-pin command: built-in scenarios end to end, result consistency, bad input."""

import dataclasses
import json
import math
import textwrap

import numpy as np
import pinocchio as pin
import pytest
from conftest import _no_constant, read_result, run_cli, run_cli_subprocess, run_once
from replay_helpers import animation_clips, decode_commands, screenshots, track
from scenario_texts import SMALL_2LINK

import mpd_pin as mp
from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario
from mpd_pin.collision import CollisionChecker
from mpd_pin.viz import replay as rp
from mpd_pin.world import World

#: one query each (a scenario with a [cycle] writes legs and cycle.json: tests/test_cycle.py)
ENERGY_SCENARIOS = [n for n, p in builtin_scenarios().items()
                    if load_scenario_data(p).get("kind", "energy") == "energy"
                    and "cycle" not in load_scenario_data(p)]


def test_scenarios_lists_all_builtins():
    res = run_cli("scenarios")
    assert res.returncode == 0, res.stderr
    names = [line.split()[0] for line in res.stdout.strip().splitlines()]
    assert names == list(builtin_scenarios())
    for expected in ("case1", "case2", "case3", "case4", "replan", "hazard", "panda"):
        assert expected in names


@pytest.fixture(scope="module")
def builtin_run(tmp_path_factory):
    """``mpd-pin run NAME --out DIR --quiet`` once per built-in scenario (a run shared with
    other test files: conftest.run_once) → (process, DIR)."""

    def run(name):
        return run_once(tmp_path_factory, name, "--quiet")

    return run


@pytest.mark.parametrize("name", ENERGY_SCENARIOS)
def test_builtin_energy_scenario_end_to_end(name, builtin_run):
    res, out = builtin_run(name)
    assert res.returncode == 0, res.stderr
    result = read_result(out)
    for fname in ("path.png", "joint_angles.png", "energy.png", "replay.html"):
        assert (out / fname).stat().st_size > 1000, fname
    scn = parse_energy_scenario(load_scenario_data(builtin_scenarios()[name]))
    drive = scn.drive()
    Q = np.array(result["path"]["configurations"])
    np.testing.assert_allclose(Q[0], scn.start, atol=1e-12)
    np.testing.assert_allclose(Q[-1], scn.goal, atol=1e-12)
    # Energies = sum over the path's edges, recomputed here with simulate_edge.
    opts = scn.options
    vlim = scn.arm.model.velocityLimit
    durations = opts.durations(Q[:-1], Q[1:], vlim)
    E = np.zeros(drive.nq)
    for k in range(len(Q) - 1):
        sim = mp.simulate_edge(drive, Q[k], Q[k + 1], durations[k], opts.dt)
        E += sim.energy
        # a feasible edge: it arrives, its reference respects the URDF velocity limits and
        # its motor torque the effort limits (docs/design.md §4e)
        assert np.abs(sim.q[-1] - Q[k + 1]).max() <= opts.arrival_tolerance
        assert np.all(1.875 * np.abs(Q[k + 1] - Q[k]) / durations[k] <= vlim * (1 + 1e-9))
        peak = np.abs(sim.i).max(axis=0) * drive.torque_per_amp
        assert np.all(peak <= scn.arm.model.effortLimit)
    np.testing.assert_allclose(result["roadmap_path"]["energy_per_joint"], E, rtol=1e-8)
    assert result["roadmap_path"]["total_energy"] == pytest.approx(E.sum(), rel=1e-8)
    motion = result["motion"]
    assert result["total_energy"] == motion["total_energy"]
    if scn.motion.refine:  # the returned motion never costs more than the roadmap path
        assert motion["total_energy"] <= E.sum() * (1 + 1e-9)
    else:  # the paper's answer: the roadmap path itself
        np.testing.assert_allclose(result["energy_per_joint"], E, rtol=1e-8)
    assert result["path"]["length_nodes"] == len(Q)
    assert result["roadmap"]["num_nodes"] == opts.num_nodes + 2
    for phase in ("roadmap_edge_energies", "search", "verification", "total"):
        assert result["seconds_per_phase"][phase] >= 0
    # CPU seconds (time.process_time) per phase, beside the wall-clock ones: disjoint phases
    # inside the total, so they sum to at most the total.
    phases = ("roadmap", "search", "verification", "comparison", "refinement", "trajectory",
              "plots", "replay")
    cpu = result["cpu_seconds_per_phase"]
    assert set(cpu) == {*phases, "total"}
    assert all(cpu[k] >= 0 for k in cpu), cpu
    assert sum(cpu[k] for k in phases) <= cpu["total"]
    assert cpu["roadmap"] > 0  # the edge energies take CPU time, whatever the machine
    assert result["cpu_seconds_total"] == cpu["total"]
    wall = result["seconds_per_phase"]
    assert sum(wall[k] for k in ("roadmap_total", *phases[1:])) <= wall["total"]
    # The replay ends at the goal: its last sample is the last simulated one.
    node_times = result["path"]["node_times"]
    assert len(node_times) == len(Q) and node_times[0] == 0.0
    rep = result["replay"]
    assert rep["samples"] == len(rep["times"]) == len(rep["sample_indices"])
    assert rep["times"][0] == 0.0
    assert rep["times"][-1] == pytest.approx(motion["duration"], abs=1e-9)  # the motion's end
    # The path is collision-free against the full world (hidden obstacles included).
    world = World.from_dict({k: v for k, v in result["world"].items()})
    truth = CollisionChecker(scn.arm, world, include_hidden=True)
    for k in range(len(Q) - 1):
        assert truth.edge_free(Q[k], Q[k + 1], opts.resolution / 10), k
    # ... and so is the motion returned, at every sample of trajectory.csv
    header = (out / "trajectory.csv").read_text(encoding="utf-8").split("\n", 1)[0].split(",")
    table = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    q = table[:, [header.index(f"q_{n}") for n in scn.arm.joint_names]]
    assert truth.is_free_batch(q).all()
    assert np.abs(q[-1] - Q[-1] - np.round((q[-1] - Q[-1]) / (2 * np.pi)) * 2 * np.pi).max() \
        <= opts.arrival_tolerance
    if world.hidden_names() or result["world"]["revealed"]:
        assert result["execution"]["replans"], "a hidden obstacle must trigger a replan"
    if any(h["clearance"] > 0 for h in result["world"]["hazards"]):
        assert result["hazard_replanning"]["final_margin"] >= 0


def test_hazard_result_is_strict_json_with_null_for_infinity(builtin_run):
    """The hazard scenario removes edges (penalty ∞, floor unused): result.json parses with
    a strict parser and says null there (HazardResult.to_dict), never "inf" or Infinity."""
    res, out = builtin_run("hazard")
    assert res.returncode == 0, res.stderr
    text = (out / "result.json").read_text()
    with pytest.raises(ValueError, match="strict JSON"):
        json.loads('{"x": Infinity}', parse_constant=_no_constant)  # the parser is strict
    result = read_result(out)
    hz = result["hazard_replanning"]
    assert hz["penalty"] is None and hz["penalty_floor"] is None
    assert hz["penalised_edges"] and math.isfinite(hz["first_margin"])
    assert result["motor"]["v_max"] is None  # no voltage limit
    assert not any(t in text for t in ('"inf"', '"-inf"', '"nan"', "Infinity", "NaN"))
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]  # atomic write, no leftover


def _ee_positions(arm, Q):
    model, data = arm.model, arm.model.createData()
    fid = model.getFrameId("ee")
    out = []
    for q in Q:
        pin.framesForwardKinematics(model, data, q)
        out.append(data.oMf[fid].translation.copy())
    return np.array(out)


def _line_points(commands, name):
    """Points of the path line ``name``; a growing trace (segments ``<name>/000``, …, each
    starting where the previous one ends) joined into one."""
    node = f"/meshcat/{rp.PATHS_NODE}/{name}"
    cmds = sorted((c for c in commands if c["type"] == "set_object"
                   and (c["path"] == node or c["path"].startswith(node + "/"))),
                  key=lambda c: c["path"])
    assert cmds and (len(cmds) == 1 or all(c["path"] != node for c in cmds))
    pieces = []
    for cmd in cmds:
        pos = cmd["object"]["geometries"][0]["data"]["attributes"]["position"]
        assert pos["itemSize"] == 3
        arr = pos["array"]  # msgpack extension 0x17: little-endian float32 array
        assert arr.type == 0x17
        pts = np.frombuffer(arr.data, dtype="<f4").reshape(-1, 3)
        if pieces:
            np.testing.assert_array_equal(pieces[-1][-1], pts[0])
            pts = pts[1:]
        pieces.append(pts)
    return np.concatenate(pieces)


def _orange(img):
    r, g, b = img.astype(int).transpose(2, 0, 1)
    return (r > 180) & (g > 90) & (g < 190) & (b < 60)  # replay.HIDDEN_COLOR 0xF08C00


def test_replan_replay_html_decoded_and_rendered(builtin_run, tmp_path):
    """The command's own replay.html for the replan scenario: one keyframe per recorded
    sample, the last one at the end of the motion, the hidden obstacle switched on at the
    replan (the time of node_times[step]), the end-effector traces, and a real picture."""
    res, out = builtin_run("replan")
    assert res.returncode == 0, res.stderr
    result = read_result(out)
    page = (out / "replay.html").read_text(encoding="utf-8")
    scn = parse_energy_scenario(load_scenario_data(builtin_scenarios()["replan"]))
    arm, drive, opts = scn.arm, scn.drive(), scn.options

    # The motion, simulated here edge by edge; the replay records the samples at indices.
    Q = np.array(result["path"]["configurations"])
    qs = [Q[:1]]
    for k in range(len(Q) - 1):
        qs.append(mp.simulate_edge(drive, Q[k], Q[k + 1], opts.duration, opts.dt).q[1:])
    q_sim = np.concatenate(qs)
    t_sim = np.arange(len(q_sim)) * opts.dt
    rep = result["replay"]
    idx = np.array(rep["sample_indices"])
    times = np.array(rep["times"])
    assert idx[0] == 0 and idx[-1] == len(q_sim) - 1  # ends with the last simulated sample
    np.testing.assert_allclose(times, t_sim[idx], atol=1e-9)
    assert times[-1] == pytest.approx((len(Q) - 1) * opts.duration, abs=1e-9)

    clips = animation_clips(page)
    (fps,) = {c["fps"] for c in clips.values()}
    expected = np.floor((times - times[0]) * fps + 0.5).astype(int)
    assert np.all(np.diff(expected) > 0)
    data, gdata = arm.model.createData(), arm.visual_model.createData()
    names = [g.name for g in arm.visual_model.geometryObjects]
    assert len(names) == arm.nq
    for gid, name in enumerate(names):
        clip = clips[f"/meshcat/{rp.ARM_NODE}/visuals/{name}"]
        frames, pos = track(clip, "position")
        assert len(frames) == rep["samples"] == len(idx)  # one keyframe per recorded sample
        assert frames == expected.tolist()
        for k in (0, len(idx) // 2, len(idx) - 1):  # first, middle and final pose
            pin.forwardKinematics(arm.model, data, q_sim[idx[k]])
            pin.updateGeometryPlacements(arm.model, data, arm.visual_model, gdata)
            np.testing.assert_allclose(pos[k], gdata.oMg[gid].translation, atol=1e-9)

    # The hidden obstacle appears at the replan: the frame of node_times[step].
    (event,) = result["execution"]["replans"]
    assert event["revealed"] == ["newcomer"]
    t_reveal = result["path"]["node_times"][event["step"]]
    assert rep["reveal_times"] == {"newcomer": t_reveal}
    on = int(np.floor((t_reveal - times[0]) * fps + 0.5))
    assert 0 < on < expected[-1]  # revealed mid-motion
    frames, visible = track(clips[f"/meshcat/{rp.WORLD_NODE}/obstacles/newcomer"], "visible")
    assert frames[visible.index(True)] == on
    assert all(v is (f >= on) for f, v in zip(frames, visible, strict=True))
    commands = decode_commands(page)
    assert {"type": "set_property", "path": f"/meshcat/{rp.WORLD_NODE}/obstacles/newcomer",
            "property": "visible", "value": False} in commands

    # End-effector traces: the travelled motion at the recorded samples, and the initial
    # plan along its straight joint-space edges.
    travelled = _line_points(commands, "end effector (travelled)")
    np.testing.assert_allclose(travelled, _ee_positions(arm, q_sim[idx]), atol=1e-6)
    initial = _line_points(commands, "end effector (initial plan (before the new obstacle))")
    assert result["execution"]["initial_path"] != result["path"]["nodes"]
    assert len(initial) > len(result["execution"]["initial_path"])
    np.testing.assert_allclose(initial[0], travelled[0], atol=1e-6)  # both from the start
    assert np.linalg.norm(initial[-1] - _ee_positions(arm, Q[-1:])[0]) < 1e-6  # to the goal
    # ... and the shortest joint-space path (executed with the same sensing), named in the
    # page's legend (docs/design.md §7c)
    short = _line_points(commands, "end effector (shortest joint-space path)")
    nodes = result["comparison"]["shortest_path"]["nodes"]
    assert len(short) > len(nodes)
    np.testing.assert_allclose(short[0], travelled[0], atol=1e-6)
    assert np.linalg.norm(short[-1] - _ee_positions(arm, Q[-1:])[0]) < 1e-6
    assert "&#9472;&#9472;</span> end effector (shortest joint-space path)" in page

    # Rendered: before the reveal no orange obstacle; after the motion a real picture
    # with the revealed obstacle on screen.
    early = screenshots({"early": out / "replay.html"}, tmp_path, virtual_time_ms=1000)["early"]
    late_ms = int(1000 * (times[-1] + 2.0))
    late = screenshots({"late": out / "replay.html"}, tmp_path, virtual_time_ms=late_ms)["late"]
    for img in (early, late):
        assert img.shape == (600, 800, 3)
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 200  # not blank
        assert img.astype(int).std() > 20.0
    assert _orange(early).sum() == 0
    assert _orange(late).sum() > 500, _orange(late).sum()


def _write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(textwrap.dedent(text))
    return path


GOOD = "\n" + textwrap.indent(SMALL_2LINK, "    ")


#: The exit status of bad input and of no path, and the prefix of their one stderr line
#: (mpd_pin/app/cli.py).
PREFIX = {2: "mpd-pin: error: ", 3: "mpd-pin: no path: "}


def _assert_one_line_error(res, pattern, code=2):
    assert res.returncode == code, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    assert lines[0].startswith(PREFIX[code]), lines[0]
    assert pattern in lines[0], lines[0]
    assert res.stdout == ""


#: The flags of the small custom run (a --seed override, no replay).
SMALL_FLAGS = ("--quiet", "--no-replay", "--seed", "4")


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """``mpd-pin run s.toml --out DIR SMALL_FLAGS`` (GOOD) once → (scenario file, process,
    DIR)."""
    scn = _write(tmp_path_factory.mktemp("small"), GOOD)
    return (scn, *run_once(tmp_path_factory, str(scn), *SMALL_FLAGS))


def test_small_custom_scenario_runs(small_run):
    _, res, out = small_run
    assert res.returncode == 0, res.stderr
    result = read_result(out)
    assert result["roadmap"]["options"]["seed"] == 4


@pytest.mark.parametrize(
    "text, pattern",
    [
        (GOOD.replace("[roadmap]", "[roadmap]\n    nodes = 3"), "roadmap: unknown key(s) 'nodes'"),
        (GOOD + "\n    colour = 'red'\n", "task: unknown key(s) 'colour'"),
        (GOOD.replace("num_nodes = 30", "num_nodes = 'many'"), "roadmap.num_nodes"),
        (GOOD + "\n    [[obstacles]]\n    type = 'box'\n    center = [0.6, 0.1]\n"
                "    width = 0.2\n    height = 0.2\n    wobble = 2\n",
         "obstacles[0]: unknown key(s) 'wobble'"),
        (GOOD + "\n    [[obstacles]]\n    type = 'box'\n    center = [0.6, 0.1]\n"
                "    width = -0.2\n    height = 0.2\n", "obstacles[0].width: must be > 0"),
        ("[arm\nbuiltin = 'x'", "malformed TOML"),
        (GOOD.replace("planar_2link", "planar_9link"), "arm.builtin"),
        (GOOD.replace("start = [0.3, 0.2]", "start = [0.3]"), "task.start: expected 2 numbers"),
        (GOOD.replace("dt = 0.01", "dt = 0.003"), "whole number"),
    ],
)
def test_bad_scenario_files(tmp_path, text, pattern):
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, pattern)


def test_unknown_scenario(tmp_path):
    _assert_one_line_error(run_cli("run", "case99", "--out", str(tmp_path)), "unknown scenario")


def test_start_in_collision(tmp_path):
    text = GOOD + """
    [[obstacles]]
    type = "cylinder"
    center = [0.45, 0.14]
    radius = 0.1
    """
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, "start [0.3, 0.2] is in collision")


def test_unreachable_goal(tmp_path):
    # The 2-link arm starts inside a tight horizontal tunnel it cannot turn out of.
    text = GOOD.replace("start = [0.3, 0.2]", "start = [0.0, 0.0]").replace(
        "goal = [1.2, -0.4]", "goal = [3.0, 0.0]") + """
    [[obstacles]]
    type = "box"
    center = [0.6, 0.1]
    width = 0.9
    height = 0.1
    [[obstacles]]
    type = "box"
    center = [0.6, -0.1]
    width = 0.9
    height = 0.1
    """
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, "no path", code=3)


def test_bad_urdf_path(tmp_path):
    text = GOOD.replace('builtin = "planar_2link"', 'urdf = "missing.urdf"')
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, "URDF file not found")


def test_out_is_an_existing_file(tmp_path):
    """``--out`` naming a regular file: exit 2, the line names --out, the file untouched."""
    blocker = tmp_path / "o"
    blocker.write_text("keep me")
    res = run_cli("run", str(_write(tmp_path, GOOD)), "--out", str(blocker), "--quiet")
    _assert_one_line_error(res, f"--out {str(blocker)!r} exists and is not a directory")
    assert blocker.read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "s.toml"]


@pytest.mark.parametrize(
    "task, line",
    [
        # an unknown frame for the IK of goal_ee: the key and the frame named
        ('start = [0.3, 0.2]\n    goal_ee = [0.5, 0.3]\n    ee_frame = "nosuch"',
         "task.ee_frame: arm 'planar_2link' has no frame 'nosuch'"),
        # ee_frame without start_ee/goal_ee is never read: an unknown key
        ('start = [0.3, 0.2]\n    goal = [1.2, -0.4]\n    ee_frame = "ee"',
         "task: unknown key(s) 'ee_frame'"),
        # goal_seed (with goal_ee) needs one angle per joint
        ("start = [0.3, 0.2]\n    goal_ee = [0.5, 0.3]\n    goal_seed = [0.1, 0.2, 0.3]",
         "task.goal_seed: expected 2 numbers, got 3"),
        ("start = [0.3, 0.2]\n    goal_ee = [0.5, 0.3]\n    goal_seed = [0.1]",
         "task.goal_seed: expected 2 numbers, got 1"),
    ],
)
def test_bad_ik_task_keys(tmp_path, task, line):
    text = GOOD.replace("start = [0.3, 0.2]\n    goal = [1.2, -0.4]", task)
    assert task in text
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, line)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "motor, line",
    [
        ('preset = "turbo"', "mpd-pin: error: motor.preset: 'turbo' is not one of "
                             "['paper', 'servo', 'sized']"),
        ("R = 'one'", "mpd-pin: error: motor.R: expected a number, got 'one'"),
        ("R = 0.0",
         "mpd-pin: error: motor.R = 0 Ω is outside the motor resistance range [1e-06, 10000] Ω"),
    ],
)
def test_motor_errors_have_one_prefix(tmp_path, motor, line):
    text = GOOD + f"\n    [motor]\n    {motor}\n"
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    _assert_one_line_error(res, line)
    assert res.stderr.strip() == line


def _parse(text, tmp_path):
    path = _write(tmp_path, text)
    return parse_energy_scenario(load_scenario_data(path), source=str(path))


def test_per_joint_motor_arrays(tmp_path):
    text = GOOD + "\n    [motor]\n    preset = 'paper'\n    gear_ratio = [9.0, 5.0]\n" \
                  "    Kt = [0.02, 0.01]\n    R = 2.0\n"
    scn = _parse(text, tmp_path)
    assert [m.gear_ratio for m in scn.motor] == [9.0, 5.0]
    assert [m.Kt for m in scn.motor] == [0.02, 0.01]
    assert [m.R for m in scn.motor] == [2.0, 2.0]
    assert all(m.L == mp.PAPER_MOTOR.L and m.B == mp.PAPER_MOTOR.B for m in scn.motor)
    drive = scn.drive()
    np.testing.assert_array_equal(drive.n, [9.0, 5.0])
    np.testing.assert_array_equal(drive.armature, [81.0 * 0.01, 25.0 * 0.01])
    np.testing.assert_array_equal(drive.torque_per_amp, [9.0 * 0.02, 5.0 * 0.01])


def test_per_joint_motor_tables(tmp_path):
    text = GOOD + "\n    [[motors]]\n    preset = 'servo'\n    gear_ratio = 50.0\n" \
                  "    R = 1.0\n    L = 0.01\n" \
                  "\n    [[motors]]\n    preset = 'paper'\n    gear_ratio = 9.0\n"
    scn = _parse(text, tmp_path)
    assert scn.motor == [dataclasses.replace(mp.SERVO_MOTOR, gear_ratio=50.0, R=1.0, L=0.01),
                         dataclasses.replace(mp.PAPER_MOTOR, gear_ratio=9.0)]
    drive = scn.drive()
    np.testing.assert_array_equal(drive.Kt, [mp.SERVO_MOTOR.Kt, mp.PAPER_MOTOR.Kt])
    np.testing.assert_array_equal(drive.v_max, [mp.SERVO_MOTOR.v_max, math.inf])
    # Through the command: result.json lists one motor per joint.
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet",
                  "--no-replay")
    assert res.returncode == 0, res.stderr
    result = read_result(tmp_path / "o")
    assert [m["gear_ratio"] for m in result["motor"]] == [50.0, 9.0]
    assert [m["Kt"] for m in result["motor"]] == [mp.SERVO_MOTOR.Kt, mp.PAPER_MOTOR.Kt]


@pytest.mark.parametrize(
    "motor, line",
    [
        ("\n    [motor]\n    gear_ratio = [9.0, 5.0, 3.0]\n",
         "motor.gear_ratio: expected one value or 2 values (one per joint), got 3"),
        ("\n    [motor]\n    R = [1.0, 0.0]\n",
         "motor.R[1] = 0 Ω is outside the motor resistance range [1e-06, 10000] Ω "
         "(joint 'joint2')"),
        ("\n    [[motors]]\n    gear_ratio = 9.0\n",
         "motors: expected one [[motors]] table per joint (2), got 1"),
        ("\n    [[motors]]\n    R = 1.0\n    [[motors]]\n    gear = 2.0\n",
         "motors[1]: unknown key(s) 'gear' (known here: B, J, Ke, Kt, L, R, gear_ratio, "
         "preset, v_max)"),
        ("\n    [[motors]]\n    gear_ratio = [9.0, 5.0]\n    [[motors]]\n",
         "motors[0].gear_ratio: expected a number, got [9.0, 5.0]"),
        ("\n    [motor]\n    R = 1.0\n    [[motors]]\n    R = 1.0\n    [[motors]]\n",
         "give [motor] (shared or per-joint arrays) or [[motors]], not both"),
    ],
)
def test_per_joint_motor_errors(tmp_path, motor, line):
    res = run_cli("run", str(_write(tmp_path, GOOD + motor)), "--out", str(tmp_path / "o"),
                  "--quiet")
    _assert_one_line_error(res, line)
    assert res.stderr.strip() == f"mpd-pin: error: {line}"


@pytest.mark.parametrize(
    "change, line",
    [
        (("num_nodes = 30", "num_nodes = 99999999999999999"),
         "roadmap.num_nodes: must be ≤ 50000, got 99999999999999999"),
        (("k = 6", "k = 1000000"), "roadmap.k: must be ≤ 100, got 1000000"),
        (("k = 6", "k = 6\n    max_attempts = 10000000000"),
         "roadmap.max_attempts: must be ≤ 100000, got 10000000000"),
        (("k = 6", "k = 6\n    resolution = 1e-9"),
         "roadmap.resolution: must be ≥ 0.001, got 1e-09"),
        (("duration = 0.5", "duration = 1e9"), "roadmap.duration: must be ≤ 60, got 1e+09"),
        (("dt = 0.01", "dt = 1e-7"),
         "roadmap.dt: duration / dt = 0.5 s / 1e-07 s exceeds 100000 RK4 steps per edge"),
        (("[task]", "[task]\n    ik_seed = -1"), "task.ik_seed: must be ≥ 0, got -1"),
    ],
)
def test_absurd_sizes_are_refused(tmp_path, change, line):
    res = run_cli("run", str(_write(tmp_path, GOOD.replace(*change))), "--out",
                  str(tmp_path / "o"), "--quiet")
    assert res.returncode == 2
    assert res.stderr.strip() == f"mpd-pin: error: {line}"


def _fail_with(exc):
    def run(*args, **kwargs):
        raise exc
    return run


@pytest.mark.parametrize(
    "exc, code, line",
    [
        (MemoryError("Unable to allocate 7.3 PiB\nfor an array"), 1,
         "mpd-pin: internal error: MemoryError: Unable to allocate 7.3 PiB for an array"),
        (RuntimeError(), 1, "mpd-pin: internal error: RuntimeError: (no message)"),
        (KeyboardInterrupt(), 130, "mpd-pin: interrupted"),
    ],
)
def test_unexpected_exceptions_are_one_line(tmp_path, monkeypatch, capsys, exc, code, line):
    import mpd_pin.app.runner
    from mpd_pin.app.cli import main

    monkeypatch.setattr(mpd_pin.app.runner, "run_energy_scenario", _fail_with(exc))
    status = main(["run", str(_write(tmp_path, GOOD)), "--out", str(tmp_path / "o"), "--quiet"])
    captured = capsys.readouterr()
    assert status == code
    assert captured.err == line + "\n"
    assert captured.out == ""


# ------------------------------------------------------------------ the real entry point
# The other tests run the command in-process (conftest.run_cli); these start
# ``python -m mpd_pin`` (the console script ``mpd-pin``: tests/test_readme.py) in a fresh
# interpreter and check that both give the same answers.


def _same(a, b):
    assert (a.returncode, a.stdout, a.stderr) == (b.returncode, b.stdout, b.stderr)


def test_python_m_mpd_pin_end_to_end(tmp_path, small_run):
    """A run, bad input (status 2) and a bad argument (argparse, status 2) through the real
    entry point: the statuses reach the shell, and they, stdout and stderr equal the
    in-process helper's; the run's result equals the in-process run's (small_run)."""
    scn, res_in, out_in = small_run
    for args in (["run", "case99", "--out", str(tmp_path / "x")],
                 ["run", str(scn), "--quiet", "--planner", "bogus"]):
        sub = run_cli_subprocess(*args)
        assert sub.returncode == 2 and sub.stderr.startswith(
            ("mpd-pin: error: ", "usage: mpd-pin run")), sub.stderr
        _same(sub, run_cli(*args))
    out = tmp_path / "o"
    sub = run_cli_subprocess("run", str(scn), "--out", str(out), *SMALL_FLAGS)
    for res in (sub, res_in):
        assert res.returncode == 0, res.stderr
        assert res.stderr == "" and res.stdout.count("\n") == 1
    assert sub.stdout.replace(str(out), str(out_in)) == res_in.stdout
    a, b = read_result(out), read_result(out_in)
    assert a["path"] == b["path"] and a["total_energy"] == b["total_energy"]
    assert a["roadmap"]["key"] == b["roadmap"]["key"]


def test_in_process_helper_hides_nothing_a_process_shows(tmp_path, monkeypatch):
    """conftest.run_cli shows what ``python -m mpd_pin`` would: a RuntimeWarning raised in
    the command on stderr (where pytest would record and hide it; a DeprecationWarning stays
    hidden, as in a fresh interpreter), what native code writes to file descriptors 1 and
    2, the working directory asked for (and back after), ``--help`` as status 0."""
    import os
    import warnings
    from pathlib import Path

    from mpd_pin.app import cli

    def noisy(_args):
        warnings.warn("overflow ahead", RuntimeWarning, stacklevel=1)
        warnings.warn("old", DeprecationWarning, stacklevel=1)
        os.write(2, b"native err\n")
        os.write(1, b"native out\n")
        print(Path.cwd())
        return 0

    monkeypatch.setattr(cli, "cmd_scenarios", noisy)
    here = Path.cwd()
    res = run_cli("scenarios", cwd=tmp_path)
    assert res.returncode == 0
    lines = res.stderr.splitlines()
    assert len(lines) == 3 and lines[0].endswith("RuntimeWarning: overflow ahead"), lines
    assert lines[2] == "native err" and "old" not in res.stderr
    assert res.stdout == f"native out\n{tmp_path}\n"
    assert Path.cwd() == here
    res = run_cli("run", "--help")
    assert res.returncode == 0 and res.stdout.startswith("usage: mpd-pin run") and not res.stderr


def test_ctrl_c_interrupts_a_real_run(tmp_path):
    """SIGINT to ``python -m mpd_pin run case1`` while it builds the roadmap (after its
    first progress output): status 130, ``mpd-pin: interrupted`` ends stderr, no output
    folder."""
    import os
    import select
    import signal
    import subprocess
    import sys

    out = tmp_path / "o"
    # The child starts as from a terminal even when this process ignores SIGINT (a
    # background job of a script: an ignored signal stays ignored across exec, a handler
    # does not), so that Python installs its KeyboardInterrupt handler there.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        proc = subprocess.Popen([sys.executable, "-m", "mpd_pin", "run", "case1", "--out",
                                 str(out), "--no-replay"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE)
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 300)
        assert ready, "no progress output within 300 s"
        first = os.read(proc.stderr.fileno(), 1)  # the progress bar: main() is running
        assert first and proc.poll() is None
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    err = (first + stderr).decode()
    assert proc.returncode == 130, err
    # (the message may follow a progress bar drawn on the same line, without a newline)
    assert err.endswith("mpd-pin: interrupted\n") and err.count("mpd-pin:") == 1, err
    assert "Traceback" not in err and stdout == b""
    assert not out.exists()


def test_replay_indices_always_end_with_the_last_sample():
    from mpd_pin.app.outputs import replay_indices

    assert replay_indices(1).tolist() == [0]
    assert replay_indices(2).tolist() == [0, 1]
    assert replay_indices(600).tolist() == list(range(600))
    assert replay_indices(1201).tolist() == [*range(0, 1200, 2), 1200]  # on the grid
    assert replay_indices(1202).tolist() == [*range(0, 1200, 2), 1201]  # 1201 replaces 1200
    assert replay_indices(1801, 600).tolist() == [*range(0, 1800, 3), 1800]
    assert replay_indices(5, 2).tolist() == [0, 2, 4]
    assert replay_indices(4, 1).tolist() == [0, 3]  # stride 4 > n - 1: the two ends
    for n in range(1, 3000, 7):
        idx = replay_indices(n)
        stride = max(1, round(n / 600))
        gaps = np.diff(idx)
        assert idx[0] == 0 and idx[-1] == n - 1, n
        assert np.all(gaps[:-1] == stride), n
        if len(idx) > 2:  # the last gap: no shorter than the stride (fps kept), < 2 strides
            assert stride <= gaps[-1] <= 2 * stride - 1, n
    with pytest.raises(ValueError):
        replay_indices(0)


def test_finite_hazard_penalty_reports_unpenalised_energy(tmp_path):
    """With hazard_penalty = 1.2 the re-planned path still takes two penalised edges (each
    1.2 times dearer to the planner); the reported energy is the edges' own E⁺."""
    from mpd_pin.app.runner import run_energy_scenario
    from mpd_pin.planning.hazards import HazardClearanceWarning, penalised_cost

    data = load_scenario_data(builtin_scenarios()["hazard"])
    data["planner"] = {"hazard_penalty": 1.2}
    # A hidden obstacle far from everything: the execution path (with sensing) runs too.
    data["obstacles"] = [*data["obstacles"], {"type": "sphere", "name": "far", "hidden": True,
                                              "center": [0.0, -1.5], "radius": 0.05}]
    data["sensor"] = {"range": 0.01}
    data["run"] = {"verify": True}
    scn = parse_energy_scenario(data)
    with pytest.warns(HazardClearanceWarning):  # the mild penalty leaves the path too close
        result = run_energy_scenario(scn, tmp_path / "o", show_progress=False, replay=False)
    hz = result["hazard_replanning"]
    assert hz["penalty"] == 1.2 and hz["penalised_edges"] and hz["rounds"] >= 1
    nodes = result["path"]["nodes"]
    penalised = {tuple(e) for e in hz["penalised_edges"]}
    on_path = [(min(u, v), max(u, v)) in penalised for u, v in zip(nodes[:-1], nodes[1:],
                                                                  strict=True)]
    assert any(on_path), "the test needs a penalised edge on the reported path"
    assert hz["satisfied"] is False and hz["final_margin"] < 0  # a mild penalty: still close
    assert result["execution"]["replans"] == []
    assert result["execution"]["travelled"] == nodes
    drive = scn.drive()
    Q = np.array(result["path"]["configurations"])
    edges = [mp.simulate_edge(drive, Q[k], Q[k + 1], scn.options.duration, scn.options.dt).energy
             for k in range(len(Q) - 1)]
    E = np.sum(edges, axis=0)
    np.testing.assert_allclose(result["energy_per_joint"], E, rtol=1e-8)
    np.testing.assert_allclose(result["execution"]["energy_per_joint"], E, rtol=1e-8)
    # The execution planned on the same penalised costs as the hazard planner.
    planning_cost = sum(
        penalised_cost(float(e.sum()), 1.2, hz["penalty_floor"]) if bad else float(e.sum())
        for e, bad in zip(edges, on_path, strict=True)
    )
    assert result["execution"]["initial_cost"] == pytest.approx(planning_cost, rel=1e-8)
    assert planning_cost > E.sum()
    assert result["execution"]["total_energy"] == pytest.approx(E.sum(), rel=1e-8)
    assert result["verification"]["max_relative_difference"] < 1e-8
    if hz["final_path"] == nodes:
        np.testing.assert_allclose(hz["final_energy_per_joint"], E, rtol=1e-8)


def test_plot_3d_draws_obstacles_as_solids():
    """Non-planar arms: every obstacle is a Poly3DCollection whose vertices lie on the
    shape's surface (boxes: exactly its corners), not a marker at its position."""
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from mpd_pin.viz.plots import plot_arm_path
    from mpd_pin.viz.scene import shape_faces
    from mpd_pin.world import Box, Cylinder, Hazard, Polygon, Sphere

    arm = mp.Arm.from_example_robot_data("panda")
    box = Box((0.2, 0.3, 0.1), position=(0.5, 0.2, 0.3), rpy=(0.3, 0.2, 0.5), name="tilted")
    can = Cylinder(0.08, 0.4, position=(0.3, -0.4, 0.2), rpy=(0.0, 0.6, 0.0), name="can")
    ball = Sphere(0.1, position=(-0.3, 0.3, 0.5), name="ball", hidden=True)
    wedge = Polygon([(0.0, 0.0), (0.2, 0.0), (0.1, 0.2)], thickness=0.1,
                    position=(-0.4, -0.3, 0.1), name="wedge")
    zone = Sphere(0.12, position=(0.0, 0.5, 0.2), name="zone")
    world = World((box, can, ball, wedge, Hazard(zone, 0.05)))
    Q = np.array([arm.q_reference, arm.q_reference + 0.5])
    fig = plot_arm_path(arm, world, Q)
    ax = fig.axes[0]
    solids = {c.get_gid(): c for c in ax.collections if isinstance(c, Poly3DCollection)}
    assert set(solids) == {"tilted", "can", "ball", "wedge", "zone"}
    assert not [c for c in ax.collections if not isinstance(c, Poly3DCollection)]  # no dots
    # What matplotlib holds (and autoscales on) is only the shapes' own vertices: a ragged
    # face list would leave np.empty padding there (matplotlib 3.11), seen as inf limits.
    for shape in (box, can, ball, wedge, zone):
        held = solids[shape.name]._faces.reshape(-1, 3)
        assert np.all(np.isfinite(held))
        surface = {tuple(np.round(v, 12)) for v in np.concatenate(shape_faces(shape))}
        assert {tuple(np.round(v, 12)) for v in held} == surface
    plt.close(fig)

    def local(shape, P):
        return (P - np.array(shape.position)) @ shape.rotation_matrix

    faces = shape_faces(box)
    assert len(faces) == 6 and all(f.shape == (4, 3) for f in faces)
    corners = {tuple(np.round(c, 12)) for c in np.concatenate(faces)}
    expected = {tuple(np.round(box.placement.act(0.5 * np.array([sx, sy, sz]) * box.size), 12))
                for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)}
    assert corners == expected
    for f in faces:  # each face is planar: its corners span a plane
        assert np.linalg.matrix_rank(f[1:] - f[0], tol=1e-12) == 2
    P = local(can, np.concatenate(shape_faces(can)))
    np.testing.assert_allclose(np.hypot(P[:, 0], P[:, 1]), can.radius, atol=1e-12)
    np.testing.assert_allclose(np.abs(P[:, 2]), can.length / 2, atol=1e-12)
    for sph in (ball, zone):
        P = np.concatenate(shape_faces(sph))
        np.testing.assert_allclose(np.linalg.norm(P - sph.position, axis=1), sph.radius,
                                   atol=1e-12)
    P = local(wedge, np.concatenate(shape_faces(wedge)))
    np.testing.assert_allclose(np.abs(P[:, 1]), wedge.thickness / 2, atol=1e-12)
    assert {tuple(np.round(p, 12)) for p in P[:, [0, 2]]} == {
        tuple(np.round(v, 12)) for v in wedge.vertices_xz}


def test_goal_in_collision(tmp_path):
    from mpd_pin.viz.plots import arm_points

    arm = mp.builtin_arm("planar_2link")
    tip = arm_points(arm, np.array([1.2, -0.4]))[-1]  # the goal's end-effector position
    start = arm_points(arm, np.array([0.3, 0.2]))
    assert np.min(np.linalg.norm(start[:, [0, 2]] - tip[[0, 2]], axis=1)) > 0.3
    text = GOOD + f"""
    [[obstacles]]
    type = "sphere"
    center = [{tip[0]:.6f}, {tip[2]:.6f}]
    radius = 0.05
    """
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    assert res.returncode == 2
    _assert_one_line_error(res, "goal [1.2, -0.4] is in collision")


@pytest.mark.parametrize(
    "urdf, line",
    [
        ('<robot name="x"><link name="a">\n',
         "mpd-pin: error: malformed URDF XML in {path}: Premature end of data in tag link"),
        ("not xml at all",
         "mpd-pin: error: malformed URDF XML in {path}: Start tag expected, '<' not found"),
        # Well-formed XML, but not a valid URDF: urdfdom prints its reasons on the C++
        # stderr; they end up in the one line.
        ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
         '<parent link="a"/><child link="b"/><axis xyz="0 1 0"/></joint></robot>',
         "mpd-pin: error: Pinocchio could not load {path}: The XML stream does not contain a "
         "valid URDF model. (urdfdom: Joint [j] is of type REVOLUTE but it does not specify "
         "limits; joint xml is not initialized correctly)"),
    ],
)
def test_malformed_urdf(tmp_path, urdf, line):
    (tmp_path / "arm.urdf").write_text(urdf)
    text = GOOD.replace('builtin = "planar_2link"', 'urdf = "arm.urdf"')
    res = run_cli("run", str(_write(tmp_path, text)), "--out", str(tmp_path / "o"), "--quiet")
    assert res.returncode == 2
    expected = line.format(path=tmp_path / "arm.urdf")
    _assert_one_line_error(res, expected)
    assert res.stderr.startswith(expected)
