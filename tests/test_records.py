"""Records are built without side effects (issue 35, "Structure"): result.json's record of a
query can be built again and again, and building it changes nothing it reads."""

from __future__ import annotations

import copy
import json
from dataclasses import replace

import mpd_pin as mp
from mpd_pin.app.outputs import result_record, roadmap_timings
from mpd_pin.app.results import to_jsonable


def test_result_record_twice_is_equal_and_leaves_the_setup_unchanged():
    scn = mp.load_scenario("quickstart")
    planner = mp.EnergyPlanner(scn.drive(), scn.world, roadmap=replace(scn.options,
                                                                       num_nodes=40),
                               motion=mp.MotionOptions(refine=False, execution="stop"),
                               show_progress=False)
    plan = planner.plan(scn.start, scn.goal)
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
