"""The fastest duration and the energy–time front (issue 32; docs/design.md §9c, §9d).

What backs the claims (none of it computed by the code under test):

* the fastest duration: the candidate's own spline stretched uniformly and priced as a
  *timed* trajectory (``trajectory_energy(..., "timed")``, its own simulation and limit
  checks, no duration search) at that duration and over a sweep of shorter ones; TOPP-RA
  (``toppra``, the time-optimal law along the same curve) as a lower bound;
* the fronts: every simulated point priced again as a timed trajectory, every stop-and-go
  point by ``trajectory_energy(..., "stop")``;
* the cycle time: ``mpd-pin run --max-duration`` between the velocity limits' bound and the
  true fastest (exit 3, the line naming it), at the true fastest (a motion);
* the figure: the matplotlib lines it holds, against result.json.

quickstart with a 40-node roadmap; one planner builds it once for every query.
"""

import re
from dataclasses import replace

import numpy as np
import pytest
from conftest import read_result

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.motion.energy import CAPPED_RULE, NONSTOP_RULE, check_waypoints
from mpd_pin.motion.spline import unit_knots, via_spline

NODES = 40


@pytest.fixture(scope="module")
def quick():
    scn = mp.load_scenario("quickstart")
    scn = replace(scn, options=replace(scn.options, num_nodes=NODES))
    return scn, mp.EnergyPlanner.from_scenario(scn, show_progress=False)


@pytest.fixture(scope="module")
def planned(quick):
    scn, planner = quick
    return planner.plan(scn.start, scn.goal)


def _spline(scn, W):
    W = check_waypoints(scn.drive(), W)
    return W, via_spline(W, unit_knots(W, scn.arm.model.velocityLimit))


def _timed(scn, W, T):
    """The non-stop spline through ``W`` stretched uniformly to ``T`` (s), priced as a
    timed trajectory: its knots scaled, simulated and checked as given."""
    W, vs = _spline(scn, W)
    return mp.trajectory_energy(scn.drive(), W, "timed", times=vs.knots * (T / vs.knots[-1]),
                                options=scn.options,
                                checker=mp.CollisionChecker(scn.arm, scn.world))


def _single_piece_fronts(record):
    """(candidate row, its non-stop front) of every waypoint candidate run in one piece."""
    return [(r, r["nonstop"]) for r in record["candidates"]
            if r["nonstop"] is not None and len(r["nonstop"]["pieces"]) == 1
            and r["name"] != "optimised"]


def test_fastest_duration_is_the_fastest_feasible_stretch(quick, planned):
    """A candidate whose effort limits bind (its fastest well above the velocity limits'
    bound): feasible priced as timed at its fastest duration, infeasible (effort) 2 % below
    and at every duration of a sweep down to the velocity bound; trajectory_energy with
    max_duration at it is feasible and 2 % below it is not; TOPP-RA's time-optimal law
    along the same curve is faster still."""
    scn, _ = quick
    fronts = _single_piece_fronts(planned.energy_duration)
    bound = [(r, f) for r, f in fronts if f["fastest_duration"] > 1.05 * f["velocity_bound"]]
    assert bound, [(r["name"], r["nonstop"]) for r in planned.energy_duration["candidates"]]
    row, front = bound[0]
    W, T = np.array(row["waypoints"]), front["fastest_duration"]
    at = _timed(scn, W, T)
    assert at.feasible, at.reason
    assert at.effort_ratio > 0.97  # the effort limits are what bind
    shorter = _timed(scn, W, 0.98 * T)
    assert not shorter.feasible and "effort" in shorter.reason
    for t in np.linspace(front["velocity_bound"], 0.98 * T, 6):
        assert not _timed(scn, W, t).feasible, t
    checker = mp.CollisionChecker(scn.arm, scn.world)
    drive = scn.drive()
    capped = mp.trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker,
                                  max_duration=T)
    assert capped.feasible and capped.duration == pytest.approx(T, abs=1e-9)
    assert capped.total_energy == pytest.approx(at.total_energy, rel=1e-9)
    assert not mp.trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker,
                                    max_duration=0.98 * T).feasible
    free = mp.trajectory_energy(drive, W, "nonstop", options=scn.options, checker=checker)
    assert free.fastest_duration == pytest.approx(T, abs=1e-12)
    assert free.velocity_fastest == pytest.approx(front["velocity_bound"], abs=1e-12)
    pytest.importorskip("toppra", reason="toppra (the test extra)")
    from mpd_pin.motion.topp import time_optimal_duration

    t_opt = time_optimal_duration(drive, _spline(scn, W)[1], scn.options)
    assert t_opt is not None and 0 < t_opt < T


def test_fronts_are_the_simulated_energies(quick, planned):
    """result.json ``energy_duration``: the motion returned and one entry per candidate
    priced; each single-piece non-stop front runs from its fastest to its longest duration,
    and every simulated point is what a timed re-pricing of its waypoints gives; each
    stop-and-go point is the stop-and-go pricing; the returned front is the motion's."""
    scn, _ = quick
    doc = planned.to_dict()
    record = doc["energy_duration"]
    assert record == planned.energy_duration
    motion = doc["motion"]
    priced = [c["name"] for c in motion["refinement"]["candidates"] if "execution" in c]
    if motion.get("optimization", {}).get("kept_seed") is False:
        priced.append("optimised")
    assert [r["name"] for r in record["candidates"]] == priced
    ret = record["returned"]
    assert ret["candidate"] == motion["refinement"]["candidate"]
    assert ret["duration"] == motion["duration"]
    assert ret["total_energy"] == motion["total_energy"]
    assert ret["fastest_duration"] == motion["fastest_duration"] <= motion["duration"] + 1e-9
    assert ret["duration_rule"] == motion["duration_rule"]
    assert [T for T, _ in ret["simulated"]].count(motion["duration"]) == 1
    assert dict(map(tuple, ret["simulated"]))[motion["duration"]] == pytest.approx(
        motion["total_energy"], rel=1e-12)
    if ret["candidate"] == "optimised":
        assert "optimised at that duration" in ret["duration_rule"]
    else:
        assert ret["duration_rule"] == NONSTOP_RULE
    fronts = _single_piece_fronts(record)
    assert fronts
    checked = 0
    for row, front in fronts:
        W = np.array(row["waypoints"])
        screen = np.array(front["screen"])
        assert screen[0, 0] == pytest.approx(front["fastest_duration"], abs=1e-12)
        assert screen[-1, 0] == pytest.approx(front["longest_duration"], abs=1e-12)
        assert np.all(np.diff(screen[:, 0]) > 0)
        assert front["simulated"], row["name"]
        for T, E in front["simulated"]:
            assert front["fastest_duration"] - 1e-9 <= T <= front["longest_duration"] + 1e-9
            again = _timed(scn, W, T)
            assert again.feasible, (row["name"], T, again.reason)
            assert again.total_energy == pytest.approx(E, rel=1e-9), (row["name"], T)
            e_screen = screen[np.argmin(np.abs(screen[:, 0] - T))]
            assert e_screen[0] == pytest.approx(T, abs=1e-12)  # the screen has every point
            assert e_screen[1] == pytest.approx(E, rel=0.05)
            checked += 1
        stop = row["stop"]
        if stop is not None and stop["feasible"]:
            again = mp.trajectory_energy(scn.drive(), W, "stop", options=scn.options)
            assert stop["simulated"] == [[again.duration, pytest.approx(again.total_energy,
                                                                        rel=1e-12)]]
            assert stop["fastest_duration"] == stop["duration"] == again.duration
    assert checked >= 3


def test_a_cap_between_the_velocity_bound_and_the_fastest_exits_3_naming_it(quick, tmp_path,
                                                                             capsys):
    """The fastest motion found below any cap (``NoMotionWithinDuration.fastest``) is above
    its velocity limits' bound. ``mpd-pin run --max-duration`` between the two: exit 3, one
    line naming that fastest duration; at that duration a motion is returned, not refused;
    its waypoints stretched 2 % shorter are infeasible."""
    scn, planner = quick
    with pytest.raises(mp.NoMotionWithinDuration) as info:
        planner.plan(scn.start, scn.goal, max_duration=0.5)
    fastest = info.value.fastest
    ret = info.value.plan.energy_duration["returned"]
    assert ret["fastest_duration"] == pytest.approx(fastest, abs=1e-12)
    vb = ret["velocity_bound"]
    assert vb < 0.95 * fastest  # the effort limits, not the velocity limits, bind
    D = round(0.5 * (vb + fastest), 3)
    out = tmp_path / "out"
    code = main(["run", "quickstart", "--out", str(out), "--nodes", str(NODES),
                 "--max-duration", str(D), "--quiet", "--no-replay"])
    err = capsys.readouterr().err
    assert code == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    hit = re.match(rf"mpd-pin: no motion within max_duration {D:g} s: the fastest motion "
                   r"found takes ([0-9.]+) s", lines[0])
    assert hit, lines[0]
    assert float(hit.group(1)) == pytest.approx(fastest, abs=5e-4)
    result = read_result(out)
    assert result["motion"]["fastest_duration"] == pytest.approx(fastest, abs=1e-9)
    assert result["energy_duration"]["max_duration"] == D
    assert result["energy_duration"]["returned"]["duration"] == pytest.approx(fastest,
                                                                              abs=1e-9)
    met = planner.plan(scn.start, scn.goal, max_duration=fastest)
    assert met.feasible and met.motion.duration <= fastest + 1e-9
    found = info.value.plan.motion  # one non-stop piece here: its spline, stretched
    assert found.execution == "nonstop" and len(found.pieces) == 1, found.pieces
    assert _timed(scn, found.waypoints, fastest).feasible
    assert not _timed(scn, found.waypoints, 0.98 * fastest).feasible


def test_a_binding_cap_ends_every_front_and_names_the_rule(quick):
    """With ``max_duration`` below the rule's longest duration: every front ends at or below
    it, the returned motion meets it, and the rule says the cap ended the range (for an
    optimised motion, its seed's rule)."""
    scn, planner = quick
    D = 3.0
    plan = planner.plan(scn.start, scn.goal, max_duration=D)
    record = plan.energy_duration
    assert record["max_duration"] == D
    assert plan.motion.duration <= D + 1e-9
    for row in record["candidates"]:
        for front in (row["nonstop"], row["stop"]):
            if front is not None and front["feasible"]:
                assert front["duration"] <= D + 1e-9
                assert all(T <= D + 1e-9 for T, _ in front["screen"] + front["simulated"])
    rule = plan.to_dict()["motion"]["duration_rule"]
    assert CAPPED_RULE in rule
    names = [r["name"] for r in record["candidates"]]
    assert "shortest path, shortcut for time" in names  # the cycle time's own candidate


def test_the_figure_draws_every_candidate_front(planned):
    """energy_duration.png: per candidate its screen (a line) and simulated points, its
    stop-and-go point, and the returned motion's star, as result.json has them; the legend
    says what the screen is."""
    import matplotlib.pyplot as plt

    figs = planned.figures()
    try:
        ax = figs["energy_duration.png"].axes[0]
        lines = {line.get_gid(): line for line in ax.get_lines()}
        record = planned.energy_duration
        drawn = 0
        for row in record["candidates"]:
            name, front = row["name"], row["nonstop"]
            if front is not None and front["screen"]:
                line = lines[f"screen:{name}"]
                np.testing.assert_allclose(np.column_stack(line.get_data()), front["screen"])
                dots = lines[f"simulated:{name}"]
                np.testing.assert_allclose(np.column_stack(dots.get_data()),
                                           front["simulated"])
                drawn += 1
            if row["stop"] is not None and row["stop"]["feasible"]:
                x, y = lines[f"stop:{name}"].get_data()
                assert (x[0], y[0]) == (row["stop"]["duration"], row["stop"]["total_energy"])
        assert drawn == sum(1 for r in record["candidates"]
                            if r["nonstop"] is not None and r["nonstop"]["screen"]) >= 2
        x, y = lines["returned"].get_data()
        assert (x[0], y[0]) == (record["returned"]["duration"],
                                record["returned"]["total_energy"])
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any("perfect-tracking screen" in t for t in texts), texts
        assert any(t.startswith("non-stop, simulated") for t in texts), texts
    finally:
        for fig in figs.values():
            plt.close(fig)


def test_no_feasible_motion_at_any_duration_exits_3_with_its_files(quick, tmp_path, capsys,
                                                                    monkeypatch):
    """No cap, and every candidate's motion infeasible (here: each priced motion flagged so,
    as an effort limit no duration meets would): a planning outcome, not bad input. Exit
    3, one line on stderr; result.json is written, ``feasible`` false, its reason naming
    every candidate's; the motion returned is the preferred candidate's as priced (its
    record in ``motion.refinement``)."""
    import mpd_pin.motion.refine as refine

    real = refine.trajectory_energy

    def infeasible(*args, **kwargs):
        m = real(*args, **kwargs)
        m.feasible, m.reason = False, "effort 1.30 × the limit (test)"
        return m

    monkeypatch.setattr(refine, "trajectory_energy", infeasible)
    out = tmp_path / "out"
    code = main(["run", "quickstart", "--out", str(out), "--nodes", str(NODES), "--quiet",
                 "--no-replay", "--no-plots"])
    err = capsys.readouterr().err
    assert code == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "mpd-pin: no feasible motion at any duration: no feasible motion among the "
        "candidates (energy optimum: effort 1.30 × the limit (test)"), err
    result = read_result(out)
    assert result["feasible"] is False
    rows = result["motion"]["refinement"]["candidates"]
    assert len(rows) >= 2 and all(r["feasible"] is False for r in rows)
    for r in rows:
        assert f"{r['name']}: effort 1.30 × the limit (test)" in result["reason"]
    first = rows[0]
    assert result["motion"]["refinement"]["candidate"] == first["name"] == "energy optimum"
    assert result["total_energy"] == pytest.approx(first["total_energy"], rel=1e-12)
    assert result["motion"]["duration"] == pytest.approx(first["duration"], abs=1e-12)
