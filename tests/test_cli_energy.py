"""``mpd-pin energy SCENARIO PATHFILE``: pricing a path planned elsewhere (CSV or
JointTrajectory JSON) on the quickstart arm; energies checked against
``trajectory_energy`` and, independently, the roadmap's ``edge_energies``; every bad input
one ``mpd-pin: error:`` line naming the row or joint, exit status 2."""

import csv
import json
import math
import stat
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import _no_constant, run_cli

import mpd_pin as mp
from mpd_pin.app import cli
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.pathfile import check_path, read_waypoints
from mpd_pin.app.trajectory import (
    joint_trajectory,
    write_trajectory_csv,
    write_trajectory_json,
)
from mpd_pin.collision import CollisionChecker
from mpd_pin.motion import trajectory_energy


@pytest.fixture(scope="module")
def qs():
    """The quickstart scenario, its checker, a free 3-waypoint path W (start, a free
    midpoint, an end point; both segments certified free) and a configuration in collision."""
    scn = load_scenario("quickstart")
    checker = CollisionChecker(scn.arm, scn.world)
    rng = np.random.default_rng(1)
    r = scn.options.resolution
    W = None
    for _ in range(50):
        mid = scn.start + rng.uniform(-0.6, 0.6, 3)
        end = mid + rng.uniform(-0.6, 0.6, 3)
        if checker.is_free(mid) and checker.is_free(end) and checker.edges_free(
                np.array([scn.start, mid]), np.array([mid, end]), r).all():
            W = np.array([scn.start, mid, end])
            break
    assert W is not None, "no free midpoint found near the quickstart start"
    lo, hi = scn.arm.model.lowerPositionLimit, scn.arm.model.upperPositionLimit
    assert np.all((W > lo) & (W < hi))
    C = rng.uniform(lo, hi, (200, 3))
    hit = C[~checker.is_free_batch(C)][0]
    assert checker.in_collision_pairs(hit)
    return scn, checker, W, hit


def write_csv(path, rows, header=None):
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        if header is not None:
            w.writerow(header)
        w.writerows([[repr(float(x)) if isinstance(x, float) else x for x in row]
                     for row in rows])
    return path


def load(path):
    return json.loads(path.read_text(), parse_constant=_no_constant)


def energy_cli(capsys, *args):
    """``main(["energy", *args])`` in-process → (status, stdout, stderr)."""
    status = main(["energy", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


def test_stop_energy_equals_trajectory_energy_and_edge_energies(qs, tmp_path, capsys):
    scn, checker, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    out = tmp_path / "priced.json"
    status, stdout, err = energy_cli(capsys, "quickstart", path, "--execution", "stop",
                                     "--out", out)
    assert status == 0, err
    doc = load(out)
    drive = scn.drive()
    ref = trajectory_energy(drive, W, "stop", options=scn.options, checker=checker)
    assert ref.feasible and ref.stops == 1
    assert doc["total_energy"] == pytest.approx(ref.total_energy, rel=1e-12)
    # independent route: the roadmap's own edge timing and batched edge energies
    durations = scn.options.timing(W[:-1], W[1:], scn.arm.model.velocityLimit)[0]
    edges = mp.edge_energies(drive, W[:-1], W[1:], durations, scn.options.dt)
    assert doc["total_energy"] == pytest.approx(float(edges.sum()), rel=1e-12)
    np.testing.assert_allclose(doc["energy_per_joint"], edges.sum(axis=0), rtol=1e-12)
    assert doc["duration"] == pytest.approx(float(durations.sum()), rel=1e-12)
    assert doc["scenario"] == "quickstart" and doc["pathfile"] == str(path)
    assert doc["joint_names"] == scn.arm.joint_names
    assert doc["execution"] == "stop" and doc["feasible"] is True and doc["stops"] == 1
    assert doc["energy_by_execution"] == {"stop": doc["total_energy"]}
    np.testing.assert_array_equal(doc["waypoints"], W)
    assert stat.S_IMODE(out.stat().st_mode) == 0o644
    e = doc["total_energy"]
    assert stdout == (f"quickstart {path}: {e:.4g} J stop (stop {e:.4g} J), "
                      f"{doc['duration']:.2f} s, 1 stop -> {out}\n")


def test_header_in_any_order_same_as_headerless(qs, tmp_path, capsys):
    scn, _, W, _ = qs
    plain = write_csv(tmp_path / "plain.csv", W.tolist())
    names = scn.arm.joint_names
    order = [2, 0, 1]
    rows = [[0.5 * k] + [W[k, j] for j in order] + ["x"] for k in range(len(W))]
    headed = write_csv(tmp_path / "headed.csv", rows,
                       header=["t"] + [names[j] for j in order] + ["note"])
    np.testing.assert_array_equal(read_waypoints(headed, names), W)
    for p in (plain, headed):
        status, _, err = energy_cli(capsys, "quickstart", p, "--execution", "stop")
        assert status == 0, err
    a, b = load(tmp_path / "plain_energy.json"), load(tmp_path / "headed_energy.json")
    assert a["total_energy"] == b["total_energy"] > 0
    assert a["energy_per_joint"] == b["energy_per_joint"]


def test_joint_trajectory_json(qs, tmp_path, capsys):
    """ROS JointTrajectory: joint_names in another order plus a joint the arm lacks; and
    the same inside a moveit_msgs/RobotTrajectory."""
    scn, _, W, _ = qs
    names = scn.arm.joint_names
    order = [1, 2, 0]
    traj = {"header": {"frame_id": "world"},
            "joint_names": ["gripper"] + [names[j] for j in order],
            "points": [{"positions": [0.01] + [W[k, j] for j in order],
                        "velocities": [0.0] * 4, "time_from_start": {"sec": k, "nanosec": 0}}
                       for k in range(len(W))]}
    (tmp_path / "traj.json").write_text(json.dumps(traj))
    (tmp_path / "robot.json").write_text(json.dumps({"joint_trajectory": traj,
                                                     "multi_dof_joint_trajectory": {}}))
    write_csv(tmp_path / "plain.csv", W.tolist())
    energies = []
    for name in ("traj.json", "robot.json", "plain.csv"):
        out = tmp_path / f"{name}.priced.json"
        status, _, err = energy_cli(capsys, "quickstart", tmp_path / name, "--execution",
                                    "stop", "--out", out)
        assert status == 0, err
        energies.append(load(out)["total_energy"])
    assert energies[0] == energies[1] == energies[2] > 0


def test_mpd_pin_trajectory_files_are_read(qs, tmp_path):
    """mpd_pin's own trajectory.json and trajectory.csv (its writers) read back as their
    sampled positions (q_<joint> columns of the CSV; the other columns ignored)."""
    scn, _, W, _ = qs
    names = scn.arm.joint_names
    t = np.linspace(0.0, 2.0, 401)
    q = np.column_stack([np.interp(t, [0.0, 1.0, 2.0], W[:, j]) for j in range(3)])
    series = {"t": t, "q": q, "v": np.gradient(q, t, axis=0), "i": np.zeros_like(q),
              "V": np.ones_like(q)}
    traj = joint_trajectory(names, series, np.ones(3))
    Q = read_waypoints(write_trajectory_json(tmp_path / "trajectory.json", traj), names)
    assert Q.shape == (201, 3)
    np.testing.assert_allclose(Q, [p["positions"] for p in traj["points"]], rtol=0, atol=0)
    np.testing.assert_allclose(Q[[0, 100, 200]], W, atol=1e-12)
    Q = read_waypoints(write_trajectory_csv(tmp_path / "trajectory.csv", names, series,
                                            np.ones(3)), names)
    np.testing.assert_allclose(Q, q, rtol=1e-9, atol=1e-12)  # written with %.10g


def test_auto_prices_both_executions(qs, tmp_path, capsys):
    scn, checker, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    status, stdout, err = energy_cli(capsys, "quickstart", path)
    assert status == 0, err
    doc = load(tmp_path / "path_energy.json")
    by = doc["energy_by_execution"]
    assert set(by) == {"stop", "nonstop"}
    feasible = [v for v in by.values() if v is not None]
    assert feasible and doc["feasible"] is True
    assert doc["total_energy"] == min(feasible) == by[doc["execution"]]
    ref = trajectory_energy(scn.drive(), W, "auto", options=scn.options, checker=checker)
    assert doc["execution"] == ref.execution
    assert doc["total_energy"] == pytest.approx(ref.total_energy, rel=1e-12)
    assert f"J {doc['execution']} (stop " in stdout and ", nonstop " in stdout


def test_infeasible_pricing_still_exits_0(qs, tmp_path, capsys):
    _, _, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    status, stdout, err = energy_cli(capsys, "quickstart", path, "--execution", "stop",
                                     "--max-duration", "0.5")
    assert status == 0, err
    doc = load(tmp_path / "path_energy.json")
    assert doc["feasible"] is False and "max_duration" in doc["reason"]
    assert doc["energy_by_execution"] == {"stop": None}
    assert stdout.startswith(f"quickstart {path}: infeasible (") and "max_duration" in stdout
    assert stdout.count("\n") == 1


def test_scenario_max_duration_is_the_default(qs, tmp_path, capsys, monkeypatch):
    """Without --max-duration the scenario's ``max_duration`` (s) applies, if it has one."""
    scn, _, W, _ = qs

    class WithLimit:
        max_duration = 0.5

        def __getattr__(self, name):
            return getattr(scn, name)

    monkeypatch.setattr("mpd_pin.app.kinds.load_scenario", lambda name: WithLimit())
    path = write_csv(tmp_path / "path.csv", W.tolist())
    feasible = {}
    for extra in ([], ["--max-duration", "100"]):
        status, _, err = energy_cli(capsys, "quickstart", path, "--execution", "stop", *extra)
        assert status == 0, err
        feasible[bool(extra)] = load(tmp_path / "path_energy.json")["feasible"]
    assert feasible == {False: False, True: True}


def test_execution_choices_are_trajectory_energys():
    assert cli.EXECUTIONS == mp.motion.EXECUTIONS


def test_limits_tolerance_and_continuous_joints():
    """Limits hold to 1e-9 (rad or m); a continuous joint has none (check_path, no checker)."""
    model = SimpleNamespace(lowerPositionLimit=np.array([-1.0, -1.0]),
                            upperPositionLimit=np.array([1.0, 1.0]))
    arm = SimpleNamespace(model=model, joint_names=["a", "b"],
                          continuous_mask=np.array([False, True]))
    check_path(np.array([[0.0, 0.0], [1.0 + 5e-10, 7.0]]), arm)
    with pytest.raises(ConfigError, match=r"f: row 2: a = -1 is outside its limits \[-1, 1\]"):
        check_path(np.array([[0.0, -9.0], [-1.0 - 2e-9, 0.0]]), arm, source="f")


def _bad_files(W, hit, names, lo, hi):
    """name → (file name, text, words the error line must contain)."""
    def line(q):
        return ",".join(repr(float(x)) for x in q)

    rows = [line(q) for q in W]
    outside = W[1].copy()
    outside[1] = hi[1] + 1e-6
    return {
        "wrong column count": ("p.csv", "\n".join([rows[0], rows[1] + ",0.1", rows[2]]),
                               ["row 2", "4 values", "expected 3"]),
        "header row too short": ("p.csv", "\n".join(["joint1,joint2,joint3", rows[0],
                                                     "0.1,0.2", rows[2]]),
                                 ["row 2 (line 3)", "2 values"]),
        "nan": ("p.csv", "\n".join([rows[0], rows[1], "0.1,nan,0.2"]),
                ["row 3", "joint2", "not a finite number"]),
        "empty value": ("p.csv", "\n".join([rows[0], "0.1,,0.2", rows[2]]),
                        ["row 2", "empty value for joint2"]),
        "not a number": ("p.csv", "\n".join([rows[0], rows[1], "0.1,0.2,abc"]),
                         ["row 3", "joint3", "'abc' is not a number"]),
        "outside limits": ("p.csv", "\n".join([rows[0], line(outside),
                                               rows[2]]),
                           ["row 2", "joint2", "outside its limits"]),
        "in collision": ("p.csv", "\n".join([rows[0], line(hit), rows[2]]),
                         ["row 2", "in collision", "obstacle 'big_block'"]),
        "missing joint column": ("p.csv", "t,joint1,joint3\n0,0.1,0.2\n1,0.2,0.3\n",
                                 ["no column for joint 'joint2'"]),
        "semicolons": ("p.csv", "0.1;0.2;0.3\n0.2;0.3;0.4\n",
                       ["no column for joint 'joint1'", "separated by commas"]),
        "one row": ("p.csv", rows[0] + "\n", ["1 waypoint", "at least 2"]),
        "bad json": ("p.json", '{"joint_names": ["joint1",', ["not valid JSON", "line 1"]),
        "json missing joint": ("p.json", json.dumps({"joint_names": ["joint1", "joint3"],
                                                     "points": []}), ["lacks joint 'joint2'"]),
        "json short point": ("p.json", json.dumps(
            {"joint_names": names, "points": [{"positions": list(W[0])},
                                              {"positions": [0.1, 0.2]}]}),
                             ["row 2 (points[1])", "2 positions"]),
        "json nan": ("p.json", json.dumps({"joint_names": names, "points": [
            {"positions": list(W[0])}, {"positions": [0.1, math.nan, 0.2]}]}),
                     ["row 2", "joint2", "not a finite number"]),
        "unknown extension": ("p.txt", "\n".join(rows), ["'.txt'", ".csv", ".json"]),
    }


BAD = ["wrong column count", "header row too short", "nan", "empty value", "not a number",
       "outside limits", "in collision", "missing joint column", "semicolons", "one row",
       "bad json", "json missing joint", "json short point", "json nan", "unknown extension"]


@pytest.mark.parametrize("case", BAD)
def test_bad_path_file(case, qs, tmp_path, capsys):
    scn, _, W, hit = qs
    model = scn.arm.model
    name, text, words = _bad_files(W, hit, scn.arm.joint_names, model.lowerPositionLimit,
                                   model.upperPositionLimit)[case]
    path = tmp_path / name
    path.write_text(text)
    status, stdout, err = energy_cli(capsys, "quickstart", path)
    assert status == 2
    assert err.startswith("mpd-pin: error: ") and err.count("\n") == 1, err
    for w in words:
        assert w in err, (w, err)
    assert stdout == ""
    assert not list(tmp_path.glob("*_energy.json"))


def test_bad_scenario_and_options(qs, tmp_path, capsys):
    _, _, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    for args, words in [
        (["env1", path], "env1' is a dynamic2link scenario"),
        (["nosuch", path], "unknown scenario 'nosuch'"),
        (["quickstart", tmp_path / "absent.csv"], "absent.csv: cannot read"),
        (["quickstart", path, "--max-duration", "0"], "--max-duration must be a number > 0"),
        (["quickstart", path, "--out", tmp_path], "is a directory"),
    ]:
        status, stdout, err = energy_cli(capsys, *args)
        assert status == 2 and stdout == ""
        assert err.startswith("mpd-pin: error: ") and err.count("\n") == 1, err
        assert words in err, err


def test_energy_command_line(qs, tmp_path):
    """``mpd-pin energy`` through conftest.run_cli (the entry point itself:
    test_cli.test_python_m_mpd_pin_end_to_end): a path file whose name has a space, the JSON
    written beside it with mode 0644, the one line it prints."""
    scn, checker, W, _ = qs
    path = write_csv(tmp_path / "my path.csv", W.tolist())
    res = run_cli("energy", "quickstart", str(path), "--execution", "stop")
    assert res.returncode == 0, res.stderr
    out = tmp_path / "my path_energy.json"
    assert stat.S_IMODE(out.stat().st_mode) == 0o644
    doc = load(out)
    ref = trajectory_energy(scn.drive(), W, "stop", options=scn.options, checker=checker)
    assert doc["total_energy"] == pytest.approx(ref.total_energy, rel=1e-12)
    assert res.stdout.startswith(f"quickstart {path}: {ref.total_energy:.4g} J stop")
    assert res.stdout.rstrip().endswith(f"-> {out}") and res.stdout.count("\n") == 1
