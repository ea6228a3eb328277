"""Pick-and-place cycles (issue 33): payload legs on one roadmap, dwells, one cycle time
shared across the legs (docs/design.md §4i, §8b; ``mpd_pin/app/cycle.py``).

The references are independent of the code under test:

* the allocation against a brute-force grid over the split of a 2-leg cycle, each grid
  point planned with ``max_duration``, and against the split proportional to the legs'
  fastest durations, planned the same way;
* every leg's simulated samples checked by a ``CollisionChecker`` carrying the leg's part;
* the dwell energy by hand: R·i² with i = G(q)/(n Kt), G from ``pin.computeGeneralizedGravity``
  on a model built here from the URDF text with the part written in as a fixed link;
* payload energies in roadmap files against ``mp.edge_energies`` of the loaded and the bare
  drive, edge by edge;
* workers: the same edges through a ``concurrent.futures`` executor (the seam a Dask
  cluster uses) against the in-process batch.

Small roadmaps (quickstart's 3-link arm, 40 nodes, no refinement or optimisation) and
module-scoped fixtures keep the module fast; the Panda appears once (pick_place parses).
"""

import concurrent.futures as cf
import json
import math
import shutil

import numpy as np
import pinocchio as pin
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.planner import configure
from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario
from mpd_pin.dynamics import EnergyCost
from mpd_pin.dynamics.remote import DriveSpec, model_digest
from mpd_pin.dynamics.simulate import edge_outcomes
from mpd_pin.planning.payloads import payload_cache_path
from mpd_pin.planning.roadmap import Roadmap

NODES = 40
#: the pick pose (rad) of the planar cell, and a pose where the part (not the arm) touches
#: the block
C = np.array([0.7, -1.0, 0.3])
D = np.array([-0.52, 1.91, 0.76])
PART = mp.Payload(1.0, com=(0.12, 0.0, 0.0), size=(0.25, 0.05, 0.05), name="part")
#: s: the cycle time of the 2-leg cycle (its fastest cycle is about 3.6 s)
CYCLE_TIME = 5.5
GRID = 7  # brute-force split points


def _scenario():
    return configure(mp.load_scenario("quickstart"), num_nodes=NODES, refine=False,
                     optimize=False)


@pytest.fixture(scope="module")
def cell():
    """quickstart's arm and block: A (start) → C unloaded, dwell 0.5 s → B carrying the
    1 kg part, dwell 0.3 s; one planner for every query of the module."""
    scn = _scenario()
    planner = mp.EnergyPlanner.from_scenario(scn, show_progress=False)
    legs = [mp.Leg(goal=C, dwell=0.5, name="to pick"),
            mp.Leg(goal=scn.goal, payload=PART, dwell=0.3, name="carry")]
    return scn, planner, legs


@pytest.fixture(scope="module")
def allocated(cell):
    scn, planner, legs = cell
    return planner.plan_cycle(legs, start=scn.start, cycle_time=CYCLE_TIME)


def _floor(t, dt=0.005):
    return dt * math.floor(t / dt + 1e-9)


def _split(planner, scn, legs, T1, T2):
    """Motion energy (J) of the 2-leg cycle with each leg planned within its share (s)."""
    a = planner.plan(scn.start, legs[0].goal, max_duration=T1)
    b = planner.plan(legs[0].goal, legs[1].goal, max_duration=T2, payload=legs[1].payload)
    return a.total_energy + b.total_energy


# --------------------------------------------------------------------------- allocation
def test_allocation_against_a_brute_force_grid_and_the_proportional_split(cell, allocated):
    scn, planner, legs = cell
    alloc = allocated.allocation
    f = alloc["fastest"]
    budget = CYCLE_TIME - sum(leg.dwell for leg in legs)
    assert alloc["minimum_cycle_time"] == pytest.approx(sum(f) + 0.8)
    grid = []
    for s in np.linspace(0.0, 1.0, GRID):
        T1 = _floor(f[0] + s * (budget - sum(f)))
        grid.append(_split(planner, scn, legs, T1, _floor(budget - T1)))
    best = min(grid)
    got = allocated.motion_energy
    assert got <= 1.01 * best, (got, grid)
    T1 = _floor(f[0] / sum(f) * budget)
    proportional = _split(planner, scn, legs, T1, _floor(budget - T1))
    assert got <= proportional, (got, proportional)
    # the cell is one where the split matters: the proportional one costs clearly more
    assert proportional > 1.02 * got


def test_allocation_is_the_grid_optimum_of_given_fronts():
    """The dynamic programme alone, on fronts given in closed form: the optimum of
    a/T² + b/T under Σ T ≤ budget, brute-forced over a fine grid, and a non-convex front
    (a step) where equal marginal energy would be wrong."""
    from mpd_pin.app.cycle import allocate

    fronts = [lambda T: 40.0 / T**2, lambda T: 5.0 / T**2 + 3.0 / T]
    T, E = allocate(fronts, [0.5, 0.4], 4.0, steps=400)
    assert sum(T) <= 4.0 + 1e-12 and T[0] >= 0.5 and T[1] >= 0.4
    t1 = np.linspace(0.5, 3.6, 200001)
    brute = (fronts[0](t1) + fronts[1](4.0 - t1)).min()
    assert sum(E) == pytest.approx(brute, rel=1e-3)
    step = [lambda T: np.where(np.asarray(T) < 2.0, 10.0, 1.0), lambda T: 4.0 / np.asarray(T)]
    T, E = allocate(step, [1.0, 1.0], 4.0, steps=400)
    assert T[0] == pytest.approx(2.0, abs=0.02) and sum(E) == pytest.approx(1.0 + 2.0, rel=0.01)


def test_cycle_fits_and_each_leg_starts_where_the_last_ended(cell, allocated):
    scn, _, legs = cell
    cyc = allocated
    assert sum(leg.duration + leg.dwell for leg in cyc.legs) <= CYCLE_TIME + 1e-9
    assert cyc.duration <= CYCLE_TIME + 1e-9
    t = 0.0
    prev = scn.start
    for leg, spec in zip(cyc.legs, legs, strict=True):
        assert leg.start_time == pytest.approx(t, abs=1e-12)
        assert leg.duration <= leg.max_duration + 1e-9
        assert leg.duration == pytest.approx(leg.plan.motion.duration, abs=1e-12)
        assert np.array_equal(leg.plan.path[0], prev)
        np.testing.assert_allclose(leg.plan.path[-1], spec.goal, atol=1e-12)
        q = leg.plan.series["q"]
        np.testing.assert_allclose(q[0], prev, atol=1e-9)
        assert np.abs(q[-1] - spec.goal).max() <= scn.options.arrival_tolerance
        assert leg.plan.series["t"][-1] == pytest.approx(leg.duration, abs=1e-9)
        assert leg.payload == spec.payload and leg.dwell == spec.dwell
        t += leg.duration + leg.dwell
        prev = leg.plan.path[-1]
    d = cyc.to_dict()
    json.dumps(d)
    assert d["total_energy"] == pytest.approx(
        sum(leg.plan.total_energy + leg.dwell_energy for leg in cyc.legs), rel=1e-12)
    assert cyc.total_energy == pytest.approx(cyc.motion_energy + cyc.dwell_energy)
    assert [leg["start_time"] for leg in d["legs"]] == [leg.start_time for leg in cyc.legs]
    assert d["legs"][1]["payload"]["mass"] == 1.0 and d["legs"][0]["payload"] is None


def test_legs_are_collision_free_with_their_part(cell, allocated):
    """Every simulated sample (5 ms apart) of every leg, checked with the leg's part; the
    bare arm's optimum of the carrying leg would hit the block with it."""
    scn, _, legs = cell
    for leg in allocated.legs:
        checker = mp.CollisionChecker(scn.arm, scn.world, payload=leg.payload)
        Q = leg.plan.series["q"]
        assert Q.shape[0] > 100 and checker.is_free_batch(Q).all(), leg.name
        W = leg.plan.path
        dense = np.concatenate([W[k] + np.linspace(0, 1, 400)[:, None] * (W[k + 1] - W[k])
                                for k in range(len(W) - 1)])
        if leg.plan.motion.execution == "stop":
            assert checker.is_free_batch(dense).all()
    # on a new planner, the bare arm first: its optimum would hit the block with the part,
    # and its certificates are not the part's, so the carrying leg goes round
    fresh = mp.EnergyPlanner.from_scenario(_scenario(), show_progress=False)
    bare = fresh.plan(C, scn.goal)
    loaded = mp.CollisionChecker(scn.arm, scn.world, payload=PART)
    assert not loaded.is_free_batch(bare.series["q"]).all()
    again = fresh.plan(C, scn.goal, payload=PART)
    assert loaded.is_free_batch(again.series["q"]).all()


def test_certificates_pass_from_the_part_to_the_bare_arm_only():
    """share_certificates marks checked in the bare roadmap exactly the edges the part's
    roadmap certified free (checked, not refused), matched by their end configurations."""
    from mpd_pin.planning.payloads import share_certificates

    nodes = np.arange(12.0).reshape(4, 3)
    src, dst = np.array([0, 1, 1, 2, 2, 3]), np.array([1, 0, 2, 1, 3, 2])

    def roadmap(order, checked):
        inv = np.argsort(order)  # the same configurations under other ids
        return Roadmap(nodes=nodes[order], start=0, goal=1, src=inv[src], dst=inv[dst],
                       durations=np.ones(6), energy=np.full((6, 3), np.nan), key="k",
                       checked=np.array(checked, bool))

    part = roadmap([0, 1, 2, 3], [True, True, True, True, False, False])
    refused = np.array([False, False, True, True, False, False])
    base = roadmap([3, 2, 1, 0], [False] * 6)
    assert share_certificates(part, refused, base) == 2
    assert base.checked.tolist() == [True, True, False, False, False, False]
    bare_checked = roadmap([0, 1, 2, 3], [True] * 6)
    fresh = roadmap([0, 1, 2, 3], [False] * 6)
    assert share_certificates(fresh, None, bare_checked) == 0  # nothing the other way
    assert share_certificates(bare_checked, None, fresh) == 6


def _urdf_with_part(xml, link, part):
    """``xml`` with the part as a fixed link on ``link`` at its com (inertia about it)."""
    I = part.inertia_matrix  # noqa: E741
    f = repr
    block = (
        f'<link name="part"><inertial><origin xyz="0 0 0" rpy="0 0 0"/>'
        f'<mass value="{f(float(part.mass))}"/>'
        f'<inertia ixx="{f(I[0, 0])}" ixy="{f(I[0, 1])}" ixz="{f(I[0, 2])}" '
        f'iyy="{f(I[1, 1])}" iyz="{f(I[1, 2])}" izz="{f(I[2, 2])}"/></inertial></link>'
        f'<joint name="part_joint" type="fixed"><parent link="{link}"/><child link="part"/>'
        f'<origin xyz="{" ".join(f(float(x)) for x in part.com)}" rpy="0 0 0"/></joint>')
    end = xml.rfind("</robot>")
    return xml[:end] + block + xml[end:]


def test_dwell_energy_by_hand(cell, allocated):
    """R·i² over each dwell, i = G(q)/(n Kt), G by pin.computeGeneralizedGravity on a
    model built from the URDF text here, with the part as a fixed link on the carrying
    leg; the part adds to the dwell at the same pose."""
    scn, _, legs = cell
    motors = scn.motor if isinstance(scn.motor, list) else [scn.motor] * scn.arm.nq
    R = np.array([m.R for m in motors])
    nKt = np.array([m.gear_ratio * m.Kt for m in motors])

    def by_hand(q, part, dwell):
        xml = scn.arm.urdf_xml if part is None else _urdf_with_part(scn.arm.urdf_xml, "ee", part)
        model = pin.buildModelFromXML(xml)
        G = pin.computeGeneralizedGravity(model, model.createData(), np.asarray(q, float))
        i = G / nKt
        return R * i**2 * dwell

    for leg, spec in zip(allocated.legs, legs, strict=True):
        ref = by_hand(spec.goal, spec.payload, spec.dwell)
        np.testing.assert_allclose(leg.dwell_energy_per_joint, ref, rtol=1e-9, atol=1e-15)
        assert leg.dwell_energy == pytest.approx(ref.sum(), rel=1e-9)
    carried = allocated.legs[1]
    assert carried.dwell_energy > by_hand(legs[1].goal, None, legs[1].dwell).sum() * 1.05
    assert allocated.dwell_energy == pytest.approx(sum(by_hand(s.goal, s.payload, s.dwell).sum()
                                                       for s in legs), rel=1e-9)


def test_cycle_time_below_the_fastest_cycle_is_a_planning_outcome(cell, allocated):
    scn, planner, legs = cell
    minimum = allocated.allocation["minimum_cycle_time"]
    with pytest.raises(mp.CycleTimeTooShort) as info:
        planner.plan_cycle(legs, start=scn.start, cycle_time=0.9 * minimum)
    exc = info.value
    assert isinstance(exc, mp.NoMotionWithinDuration) and isinstance(exc, mp.MpdPinError)
    assert exc.minimum == pytest.approx(minimum, rel=1e-9)
    assert f"{minimum:.3f} s" in str(exc) and "\n" not in str(exc)


# --------------------------------------------------------------------- the shared roadmap
def test_payload_roadmap_shares_the_nodes(cell, allocated):
    """The carrying leg's roadmap has the base's nodes (same ids), a subset of its edges,
    none at a node where the part collides, and its edges priced with the part."""
    scn, planner, legs = cell
    planner.plan(C, scn.goal, payload=PART)
    loaded = planner.roadmap
    base = planner._base.roadmap
    assert np.array_equal(loaded.nodes, base.nodes)
    pairs = set(zip(base.src.tolist(), base.dst.tolist(), strict=True))
    assert set(zip(loaded.src.tolist(), loaded.dst.tolist(), strict=True)) <= pairs
    part_free = mp.CollisionChecker(scn.arm, scn.world, payload=PART).is_free_batch(loaded.nodes)
    assert not part_free.all()  # some nodes are excluded for the part ...
    ends = np.concatenate([loaded.src, loaded.dst])
    assert part_free[ends].all()  # ... and have no edge
    ids = np.flatnonzero(loaded.evaluated)[:12]
    assert ids.size
    drive = scn.drive().with_payload(PART)
    Q0, Q1 = loaded.nodes[loaded.src[ids]], loaded.nodes[loaded.dst[ids]]
    for e, q0, q1 in zip(ids, Q0, Q1, strict=True):
        ref = mp.edge_energies(drive, q0[None], q1[None], float(loaded.durations[e]),
                               scn.options.dt)[0]
        np.testing.assert_allclose(loaded.energy[e], ref, rtol=1e-9)


def test_payload_energies_have_their_own_file(tmp_path):
    """With a cache file: the bare roadmap in it, the part's edges in their own file, each
    holding its own drive's energies; a part's file read for another part is refused, read
    again for the same part its energies are reused."""
    scn = _scenario()
    cache = tmp_path / "roadmap.npz"
    other = mp.Payload(0.4, com=(0.05, 0.0, 0.0), size=(0.1, 0.05, 0.05), name="other")
    planner = mp.EnergyPlanner.from_scenario(scn, cache=cache, show_progress=False)
    planner.plan(scn.start, C)  # the first query: the bare roadmap's file
    first = planner.plan(scn.start, C, payload=PART)
    loaded_file = payload_cache_path(cache, PART)
    assert cache.is_file() and loaded_file.is_file()
    assert first.to_dict()["roadmap"]["cache"]["path"] == str(loaded_file)
    assert payload_cache_path(cache, other) != loaded_file
    bare_rm = Roadmap.load(cache)
    part_rm = Roadmap.load(loaded_file)
    assert bare_rm.key != part_rm.key
    for rm, drive in ((bare_rm, scn.drive()), (part_rm, scn.drive().with_payload(PART))):
        ids = np.flatnonzero(rm.evaluated)
        assert ids.size
        ids = ids[:10]
        for e in ids:
            q0, q1 = rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]]
            ref = mp.edge_energies(drive, q0[None], q1[None], float(rm.durations[e]),
                                   scn.options.dt)[0]
            np.testing.assert_allclose(rm.energy[e], ref, rtol=1e-9)
    # another part reading this part's file: refused, one line
    shutil.copy(loaded_file, payload_cache_path(cache, other))
    again = mp.EnergyPlanner.from_scenario(scn, cache=cache, show_progress=False)
    with pytest.raises(ValueError, match="other parameters") as info:
        again.plan(scn.start, C, payload=other)
    assert "\n" not in str(info.value)
    # the same part: its energies are reused
    again = mp.EnergyPlanner.from_scenario(scn, cache=cache, show_progress=False)
    plan = again.plan(scn.start, C, payload=PART)
    record = plan.to_dict()["roadmap"]
    assert record["cache"] == {"path": str(loaded_file), "reused": True}
    assert record["lazy"]["reused"] > 0
    assert plan.total_energy == pytest.approx(first.total_energy, rel=1e-9)


def test_workers_rebuild_the_payload():
    """DriveSpec carries the part (plain JSON) and the worker puts it back: the same edges
    through a concurrent.futures executor equal the in-process batch bit for bit."""
    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.sized_motors(arm), kp=40.0, kd=4.0)
    loaded = drive.with_payload(PART)
    spec = DriveSpec.of(loaded)
    assert json.loads(spec.payload)["mass"] == 1.0 and DriveSpec.of(drive).payload == ""
    assert model_digest(spec.build().arm.model) == model_digest(loaded.arm.model)
    assert spec.key != DriveSpec.of(drive).key
    rng = np.random.default_rng(3)
    Q0 = rng.uniform(-1.0, 1.0, (6, 3))
    Q1 = Q0 + rng.uniform(-0.4, 0.4, Q0.shape)
    T = np.full(6, 0.5)
    local = edge_outcomes(loaded, Q0, Q1, T, 5e-3)
    with cf.ThreadPoolExecutor(2) as pool:
        remote = EnergyCost(loaded, 5e-3, executor=pool, chunk_size=2).outcomes(Q0, Q1, T)
    assert np.array_equal(remote.energy, local.energy)
    assert not np.array_equal(remote.energy, edge_outcomes(drive, Q0, Q1, T, 5e-3).energy)


# ------------------------------------------------------------------------- files and CLI
CYCLE_TOML = """
[payloads.part]
mass = {mass}
com = {com}
size = [0.25, 0.05, 0.05]

[cycle]
cycle_time = {cycle_time}

[[cycle.legs]]
name = "to pick"
goal = {pick}
dwell = 0.5

[[cycle.legs]]
name = "carry"
goal = {goal}
payload = "{payload}"
dwell = 0.3
"""


def _toml(tmp_path, name="cell", mass="1.0", com="[0.12, 0.0, 0.0]", cycle_time=CYCLE_TIME,
          pick="[0.7, -1.0, 0.3]", goal="[1.8945, 1.219, -1.053]", payload="part"):
    """quickstart.toml with ``[payloads.part]`` and a 2-leg ``[cycle]`` (A → pick → goal
    carrying the part)."""
    text = builtin_scenarios()["quickstart"].read_text(encoding="utf-8")
    path = tmp_path / f"{name}.toml"
    path.write_text(text + CYCLE_TOML.format(mass=mass, com=com, cycle_time=cycle_time,
                                             pick=pick, goal=goal, payload=payload),
                    encoding="utf-8")
    return path


CLI = ("--quiet", "--no-replay", "--nodes", str(NODES), "--no-refine", "--no-optimize")


def test_run_writes_the_legs_and_the_cycle(tmp_path, capsys):
    path = _toml(tmp_path)
    scn = mp.load_scenario(path)
    assert scn.payloads["part"].mass == 1.0 and scn.cycle.cycle_time == CYCLE_TIME
    assert [leg.payload for leg in scn.cycle.legs] == [None, scn.payloads["part"]]
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), *CLI]) == 0
    line = capsys.readouterr().out
    assert "cycle.json" in line
    doc = json.loads((out / "cycle.json").read_text())
    assert sorted(p.name for p in out.iterdir()) == ["cycle.json", "cycle.png", "leg1", "leg2"]
    for k in (1, 2):
        r = json.loads((out / f"leg{k}" / "result.json").read_text())
        assert r["total_energy"] == doc["legs"][k - 1]["total_energy"]
    assert (out / "cycle.png").stat().st_size > 5000
    assert doc["duration"] <= CYCLE_TIME + 1e-9 and doc["feasible"] is True
    assert doc["total_energy"] == pytest.approx(doc["motion_energy"] + doc["dwell_energy"])


def test_run_exits_3_when_the_cycle_time_is_too_short(tmp_path, capsys):
    path = _toml(tmp_path, cycle_time=1.0)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-plots", *CLI]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "shorter than the fastest cycle" in err
    doc = json.loads((out / "cycle.json").read_text())
    assert doc["feasible"] is False and doc["minimum_cycle_time"] > 1.0
    assert f"{doc['minimum_cycle_time']:.3f} s" in err


@pytest.mark.parametrize("change, words", [
    (dict(mass="0.0"), "payloads.part.mass"),
    (dict(mass="-2.0"), "payloads.part.mass"),
    (dict(mass="nan"), "payloads.part.mass"),
    (dict(com="[1.5, 0.0, 0.2]"), "payloads.part.com"),
    (dict(payload="bolt"), "cycle.legs[1].payload"),
    (dict(cycle_time="-3.0"), "cycle.cycle_time"),
])
def test_bad_payloads_and_cycles_are_one_line(tmp_path, change, words):
    path = _toml(tmp_path, **change)
    with pytest.raises(ConfigError, match=words.replace("[", r"\[").replace("]", r"\]")) as info:
        parse_energy_scenario(load_scenario_data(path), source=str(path), base_dir=tmp_path)
    assert "\n" not in str(info.value)


def test_a_part_in_collision_at_a_leg_start_names_the_leg_and_the_pair(cell, tmp_path, capsys):
    scn, planner, _ = cell
    legs = [mp.Leg(goal=D, dwell=0.2), mp.Leg(goal=C, payload=PART, name="carry")]
    with pytest.raises(ValueError) as info:
        planner.plan_cycle(legs, start=scn.start)
    msg = str(info.value)
    assert msg.startswith("cycle carry: start") and "\n" not in msg
    assert "payload 'part' touches obstacle 'big_block'" in msg
    with pytest.raises(ValueError, match="Leg.dwell"):
        mp.Leg(goal=C, dwell=-1.0)
    with pytest.raises(ValueError, match="Leg.payload"):
        mp.Leg(goal=C, payload="part")
    path = _toml(tmp_path, pick=str(D.tolist()))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), *CLI]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "cycle carry: start" in err
    assert "payload 'part' touches obstacle 'big_block'" in err


def test_pick_place_is_a_panda_cycle_whose_part_is_free_at_every_leg_end():
    """The built-in pick_place: the Panda with sized motors, home -> pick -> place
    carrying the 2 kg part -> home, dwells, a cycle time above its fastest cycle; the
    part is collision-free wherever a leg carrying it starts or ends."""
    scn = mp.load_scenario("pick_place")
    assert scn.arm.name == "panda" and scn.cycle is not None
    part = scn.payloads["part"]
    assert part.mass == 2.0
    legs = scn.cycle.legs
    assert [leg.payload for leg in legs] == [None, part, None]
    assert np.allclose(legs[-1].goal, scn.start) and all(leg.dwell >= 0 for leg in legs)
    assert sum(leg.dwell for leg in legs) > 0
    checker = mp.CollisionChecker(scn.arm, scn.world, payload=part)
    starts = [scn.start] + [leg.goal for leg in legs[:-1]]
    for q0, leg in zip(starts, legs, strict=True):
        if leg.payload is not None:
            assert checker.is_free(q0) and checker.is_free(leg.goal)
    loaded = scn.drive().with_payload(part)
    assert np.all(np.abs(loaded.arm.gravity(legs[1].goal)) <= scn.arm.model.effortLimit)
