"""``mpd-pin energy SCENARIO PATHFILE``: pricing a path planned elsewhere (CSV or
JointTrajectory JSON) on the quickstart arm; energies checked against
``trajectory_energy`` and, independently, the roadmap's ``edge_energies``; a file with
times priced with them ("timed"): a run's own trajectory.json against that run's
result.json, and node times against the non-stop motion; every bad input one
``mpd-pin: error:`` line naming the row or joint, exit status 2; an infeasible motion one
line, exit status 3."""

import csv
import json
import math
import os
import re
import stat
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import _no_constant, read_result, run_cli, run_once

import mpd_pin as mp
from mpd_pin.app import cli
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.pathfile import check_path, read_path_file, read_waypoints
from mpd_pin.app.scenario_files import builtin_scenarios
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
    assert stdout == (f"quickstart {path}: {e:.4g} J stop, "
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


def test_infeasible_pricing_exits_3_without_an_energy(qs, tmp_path, capsys):
    """An infeasible motion: exit status 3, one line on stderr with the reason and no
    energy (a non-stop motion with no duration within the cap has E⁺ 0), the JSON written
    saying why."""
    _, _, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    for execution, cap in (("stop", "0.5"), ("nonstop", "0.05"), ("auto", "0.05")):
        status, stdout, err = energy_cli(capsys, "quickstart", path, "--execution", execution,
                                         "--max-duration", cap)
        assert status == 3, err
        assert stdout == "" and err.count("\n") == 1, err
        assert err.startswith(f"mpd-pin: quickstart {path}: infeasible: "), err
        if execution != "auto":
            assert f"infeasible: {execution}: " in err
        assert "max_duration" in err and not re.search(r"\d J\b", err), err
        doc = load(tmp_path / "path_energy.json")
        assert doc["feasible"] is False and "max_duration" in doc["reason"]
        assert doc["reason"] in err
    assert "stop: takes" in err and "nonstop: " in err  # auto: why neither runs


def test_nonstop_line_names_only_nonstop(qs, tmp_path, capsys):
    """--execution nonstop with a cap the stop-and-go motion exceeds: the line gives the
    non-stop energy only (no "(stop infeasible, …)")."""
    scn, checker, W, _ = qs
    drive = scn.drive()
    free = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
    cap = (free.fastest + free.alternative.duration) / 2
    ref = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker,
                            max_duration=cap)
    assert ref.feasible and ref.energy_by_execution["stop"] is None
    path = write_csv(tmp_path / "path.csv", W.tolist())
    status, stdout, err = energy_cli(capsys, "quickstart", path, "--execution", "nonstop",
                                     "--max-duration", repr(cap))
    assert status == 0, err
    doc = load(tmp_path / "path_energy.json")
    assert doc["total_energy"] == pytest.approx(ref.total_energy, rel=1e-12)
    e = doc["total_energy"]
    out = tmp_path / "path_energy.json"
    assert stdout == f"quickstart {path}: {e:.4g} J nonstop, {ref.duration:.2f} s, 0 stops " \
                     f"-> {out}\n"
    assert "stop infeasible" not in stdout and "(" not in stdout


def test_scenario_max_duration_is_the_default(qs, tmp_path, capsys):
    """Without --max-duration the scenario's ``[motion] max_duration`` (s) applies: a real
    scenario file (quickstart with max_duration = 0.5 s) refuses the 2 s stop-and-go motion,
    and --max-duration overrides it."""
    _, _, W, _ = qs
    text = builtin_scenarios()["quickstart"].read_text(encoding="utf-8")
    toml = tmp_path / "capped.toml"
    toml.write_text(text + "\n[motion]\nmax_duration = 0.5\n", encoding="utf-8")
    assert load_scenario(str(toml)).motion.max_duration == 0.5
    path = write_csv(tmp_path / "path.csv", W.tolist())
    status, _, err = energy_cli(capsys, toml, path, "--execution", "stop")
    assert status == 3 and "takes" in err and "max_duration 0.5 s" in err, err
    assert load(tmp_path / "path_energy.json")["feasible"] is False
    status, _, err = energy_cli(capsys, toml, path, "--execution", "stop",
                                "--max-duration", "100")
    assert status == 0, err
    assert load(tmp_path / "path_energy.json")["feasible"] is True


def test_execution_choices_are_trajectory_energys():
    assert cli.EXECUTIONS == mp.motion.EXECUTIONS
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices["energy"]
    choices = next(a for a in sub._actions if a.dest == "execution").choices
    assert tuple(choices) == mp.motion.PRICINGS


def test_out_equal_to_the_path_file_is_refused_before_any_work(qs, tmp_path, capsys,
                                                                monkeypatch):
    _, _, W, _ = qs
    path = write_csv(tmp_path / "path.csv", W.tolist())
    before = path.read_bytes()
    (tmp_path / "link.csv").symlink_to(path)
    os.link(path, tmp_path / "hard.csv")

    def no_work(*args, **kwargs):
        raise AssertionError("the scenario was loaded")

    monkeypatch.setattr("mpd_pin.app.kinds.load_scenario", no_work)
    for out in (path, tmp_path / "link.csv", tmp_path / "hard.csv",
                tmp_path / "sub" / ".." / "path.csv"):
        status, stdout, err = energy_cli(capsys, "quickstart", path, "--out", out)
        assert status == 2 and stdout == "", err
        assert err.startswith("mpd-pin: error: --out ") and "is the path file itself" in err
        assert err.count("\n") == 1
    assert path.read_bytes() == before


# ----------------------------------------------------------------------------- timed
def test_a_runs_own_trajectory_is_priced_at_its_own_times(tmp_path_factory, capsys):
    """mpd-pin run quickstart, then mpd-pin energy on its trajectory.json (and .csv): by
    default priced with their times, within 1 % of the run's total_energy (the files hold
    the simulated positions, not the reference), over the run's duration."""
    res, run_dir = run_once(tmp_path_factory, "quickstart", "--quiet", "--no-replay")
    assert res.returncode == 0, res.stderr
    result = read_result(run_dir)
    work = tmp_path_factory.mktemp("priced")
    for name in ("trajectory.json", "trajectory.csv"):
        status, stdout, err = energy_cli(capsys, "quickstart", run_dir / name, "--out",
                                         work / f"{name}.priced.json")
        assert status == 0, err
        doc = load(work / f"{name}.priced.json")
        assert doc["execution"] == "timed" and doc["feasible"] is True
        assert doc["total_energy"] == pytest.approx(result["total_energy"], rel=0.01)
        assert doc["duration"] == pytest.approx(result["motion"]["duration"], rel=1e-9)
        assert doc["stops"] == 0 and stdout.count("\n") == 1
        assert f": {doc['total_energy']:.4g} J timed, " in stdout
    # the positions without their times are priced another way (the motion's own timing)
    pf = read_path_file(run_dir / "trajectory.json", result["joint_names"])
    assert pf.times is not None and pf.times.size == pf.waypoints.shape[0]


def test_node_times_give_the_nonstop_energy(qs, tmp_path, capsys):
    """A CSV with a t column holding the non-stop motion's own node times is priced at the
    non-stop motion's energy; with --execution nonstop the same file ignores its times."""
    scn, checker, W, _ = qs
    from mpd_pin.motion.series import motion_series

    drive = scn.drive()
    non = trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
    t = motion_series(drive, non, scn.options.dt)["node_times"]
    names = scn.arm.joint_names
    path = write_csv(tmp_path / "timed.csv", [[t[k], *W[k]] for k in range(3)],
                     header=["t", *names])
    status, _, err = energy_cli(capsys, "quickstart", path)
    assert status == 0, err
    doc = load(tmp_path / "timed_energy.json")
    assert doc["execution"] == "timed" and doc["energy_by_execution"] == {
        "timed": doc["total_energy"]}
    assert doc["total_energy"] == pytest.approx(non.total_energy, rel=1e-9)
    np.testing.assert_allclose(doc["piece_durations"], np.diff(t), rtol=1e-15)
    # slower times cost another energy; the same file priced non-stop ignores them
    slow = write_csv(tmp_path / "slow.csv", [[2 * t[k], *W[k]] for k in range(3)],
                     header=["t", *names])
    status, _, err = energy_cli(capsys, "quickstart", slow)
    assert status == 0, err
    assert abs(load(tmp_path / "slow_energy.json")["total_energy"] / non.total_energy - 1) > 0.01
    status, _, err = energy_cli(capsys, "quickstart", slow, "--execution", "nonstop")
    assert status == 0, err
    assert load(tmp_path / "slow_energy.json")["total_energy"] == pytest.approx(
        non.total_energy, rel=1e-12)


def test_ros_durations_are_times(qs, tmp_path, capsys):
    """time_from_start as ROS 2 {sec, nanosec} and ROS 1 {secs, nsecs}: the same timed
    energy as trajectory_energy at those times."""
    scn, checker, W, _ = qs
    names = scn.arm.joint_names
    t = [0.0, 1.25, 2.5]
    ref = trajectory_energy(scn.drive(), W, "timed", times=t, options=scn.options,
                            checker=checker)
    for sec, nsec in (("sec", "nanosec"), ("secs", "nsecs")):
        traj = {"joint_names": names, "points": [
            {"positions": list(W[k]), "time_from_start": {sec: int(t[k]),
                                                          nsec: round(t[k] % 1 * 1e9)}}
            for k in range(3)]}
        path = tmp_path / f"{sec}.json"
        path.write_text(json.dumps(traj))
        status, _, err = energy_cli(capsys, "quickstart", path)
        assert status == 0, err
        doc = load(tmp_path / f"{sec}_energy.json")
        assert doc["total_energy"] == pytest.approx(ref.total_energy, rel=1e-12)


def _timed_bad(W, names):
    """name → (file name, text, words the error line must contain) for timed pricing."""
    def csv_text(times):
        rows = [",".join(["t", *names])]
        rows += [",".join([repr(x) if isinstance(x, float) else x, *map(repr, map(float, q))])
                 for x, q in zip(times, W, strict=True)]
        return "\n".join(rows) + "\n"

    def json_text(times):
        pts = [{"positions": list(W[k])} for k in range(len(W))]
        for k, x in enumerate(times):
            if x is not None:
                pts[k]["time_from_start"] = x
        return json.dumps({"joint_names": names, "points": pts})

    return {
        "not increasing": ("p.csv", csv_text([0.0, 1.0, 1.0]),
                           ["p.csv: row 3 (line 4): time 1 s is not after the time of row 2 "
                            "(line 3), 1 s"]),
        "not from 0": ("p.csv", csv_text([0.5, 1.0, 2.0]),
                       ["row 1 (line 2): the first time is 0.5 s", "starts at 0 s"]),
        "nan time": ("p.csv", csv_text([0.0, "nan", 2.0]),
                     ["row 2 (line 3)", "t = nan is not a finite number"]),
        "empty time": ("p.csv", csv_text([0.0, "", 2.0]), ["row 2 (line 3)", "empty value for t"]),
        "json partly timed": ("p.json", json_text([0.0, None, 2.0]),
                              ["row 2 (points[1]) has no time_from_start", "row 1 has one"]),
        "json bad duration": ("p.json", json_text([0.0, {"sec": 1}, 2.0]),
                              ["row 2 (points[1])", "is not a time"]),
        "json backwards": ("p.json", json_text([0.0, 2.0, 1.0]),
                           ["row 3 (points[2]): time 1 s is not after", "increase strictly"]),
        "no times": ("p.csv", "\n".join(",".join(map(repr, map(float, q))) for q in W),
                     ["p.csv: the file has no times (no t column)", "timed"]),
        "json no times": ("p.json", json_text([None, None, None]),
                          ["p.json: the file has no times (no time_from_start"]),
    }


@pytest.mark.parametrize("case", ["not increasing", "not from 0", "nan time", "empty time",
                                  "json partly timed", "json bad duration", "json backwards",
                                  "no times", "json no times"])
def test_bad_times_in_a_path_file(case, qs, tmp_path, capsys):
    scn, _, W, _ = qs
    name, text, words = _timed_bad(W, scn.arm.joint_names)[case]
    path = tmp_path / name
    path.write_text(text)
    extra = ["--execution", "timed"] if case.endswith("no times") else []
    status, stdout, err = energy_cli(capsys, "quickstart", path, *extra)
    assert status == 2 and stdout == ""
    assert err.startswith("mpd-pin: error: ") and err.count("\n") == 1, err
    for w in words:
        assert w in err, (w, err)
    assert not list(tmp_path.glob("*_energy.json"))


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
