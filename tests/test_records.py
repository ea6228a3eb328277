"""Records are built without side effects (issue 35, "Structure"): result.json's record of a
query can be built again and again, and building it changes nothing it reads."""

from __future__ import annotations

import copy
import json
from dataclasses import replace

import mpd_pin as mp
from mpd_pin.app.outputs import result_record, roadmap_timings
from mpd_pin.app.results import to_jsonable


def _small_plan() -> mp.Plan:
    """Quickstart on 40 nodes, lazy, the roadmap path as it is (stop-and-go)."""
    scn = mp.load_scenario("quickstart")
    planner = mp.EnergyPlanner(scn.drive(), scn.world, roadmap=replace(scn.options,
                                                                       num_nodes=40),
                               motion=mp.MotionOptions(refine=False, execution="stop"),
                               show_progress=False)
    return planner.plan(scn.start, scn.goal)


def test_result_record_twice_is_equal_and_leaves_the_setup_unchanged():
    plan = _small_plan()
    p = plan._parts
    assert p.setup.lazy is not None  # the lazy run, whose timings were once written back
    before = copy.deepcopy(p.setup.roadmap.timings)
    assert "edge_bounds" not in before  # the build's own timings only

    def record():
        r = result_record(p.scenario, p.setup, p.result, p.check, None, p.clock,
                          p.comparison, cache=p.cache, motion=p.motion)
        return json.dumps(to_jsonable(r), sort_keys=True)

    first, second = record(), record()
    assert first == second
    assert p.setup.roadmap.timings == before
    # the lazy sub-phases are in the record all the same, from the searches' counters
    seconds = json.loads(first)["seconds_per_phase"]
    assert seconds["roadmap_edge_energies"] == p.setup.lazy.count.simulate_seconds
    assert seconds["roadmap_edge_bounds"] == p.setup.lazy.bound_seconds
    assert roadmap_timings(p.setup)["edge_bounds"] == p.setup.lazy.bound_seconds
    assert p.setup.roadmap.timings == before


#: The timings of the writing phases: measured again by each save (a save times itself).
WRITING = ("trajectory", "plots", "replay", "total")


def _without_writing_times(record: dict) -> dict:
    out = copy.deepcopy(record)
    for key in ("seconds_per_phase", "cpu_seconds_per_phase"):
        for phase in WRITING:
            out[key].pop(phase, None)
    out.pop("cpu_seconds_total")
    return out


def test_saving_twice_writes_the_same_record_and_changes_nothing(tmp_path):
    """A Plan saved twice writes the same result.json but for the timings of the writing
    phases (trajectory, plots, replay and the totals, which each save measures for itself);
    the query's own timings, ``seconds`` and to_dict() are the same before and after, and
    the second save's total is the query's plus that save alone."""
    import time

    plan = _small_plan()
    before, seconds = plan.to_dict(), plan.seconds
    query_total = before["seconds_per_phase"]["total"]
    assert query_total == seconds
    saved, files, took = [], [], []
    for name in ("a", "b"):
        w0 = time.perf_counter()
        saved.append(plan.save(tmp_path / name, replay=False, plots=False))
        took.append(time.perf_counter() - w0)
        files.append(json.loads((tmp_path / name / "result.json").read_text()))
        assert files[-1] == saved[-1] == plan.to_dict()
        assert plan.seconds == seconds  # the query's time, no files (the docstring)
    a, b = (_without_writing_times(r) for r in files)
    assert a == b
    # the record before saving: the same but for what only a save writes
    assert {k: v for k, v in a.items() if k not in ("outputs", "replay")} == \
        _without_writing_times(before)
    for record, dt in zip(files, took, strict=True):
        total = record["seconds_per_phase"]["total"]
        assert query_total + record["seconds_per_phase"]["trajectory"] <= total
        assert total <= query_total + dt  # this save's time only, not the one before
    assert plan.to_dict() == saved[1]
