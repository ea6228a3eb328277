"""``mp.PlannerOptions``: one options value for ``EnergyPlanner`` (issue 35; docs/design.md §8b).

The keywords stay as shorthands: an options value and the same keywords plan the same
query bit for bit, a keyword replaces one field of the options given, and each bad field
gets one error naming it.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.config import ConfigError


@pytest.fixture(scope="module")
def quickstart():
    return mp.load_scenario("quickstart")


def _settings(scn) -> dict:
    """A small stop-and-go plan of quickstart (no refinement: fast, and the roadmap
    energies are what differ when a setting is lost)."""
    return {"roadmap": replace(scn.options, num_nodes=40),
            "motion": mp.MotionOptions(refine=False, execution="stop", optimize=False),
            "show_progress": False, "name": "opts"}


def test_options_and_keywords_plan_the_same_query_bit_for_bit(quickstart):
    scn = quickstart
    kw = _settings(scn)
    by_options = mp.EnergyPlanner(scn.drive(), scn.world, mp.PlannerOptions(**kw))
    by_keywords = mp.EnergyPlanner(scn.drive(), scn.world, **kw)
    a = by_options.plan(scn.start, scn.goal)
    b = by_keywords.plan(scn.start, scn.goal)
    assert a.total_energy == b.total_energy
    assert np.array_equal(a.energy_per_joint, b.energy_per_joint)
    assert a.roadmap_path.nodes == b.roadmap_path.nodes
    assert by_options.options == by_keywords.options
    # a different roadmap seed is a different roadmap: the setting is really used
    other = mp.EnergyPlanner(scn.drive(), scn.world, mp.PlannerOptions(**kw),
                             roadmap=replace(kw["roadmap"], seed=kw["roadmap"].seed + 1))
    assert other.options.roadmap.seed == kw["roadmap"].seed + 1
    c = other.plan(scn.start, scn.goal)
    assert c.total_energy != a.total_energy


def test_a_keyword_replaces_one_field_of_the_options(quickstart):
    scn = quickstart
    base = mp.PlannerOptions(**_settings(scn), verify=True)
    planner = mp.EnergyPlanner(scn.drive(), scn.world, base, name="renamed")
    assert planner.options.name == "renamed"
    assert planner.options.verify is True  # kept from the options
    assert planner.options.roadmap == base.roadmap
    plan = planner.plan(scn.start, scn.goal)
    record = plan.to_dict()
    assert record["scenario"] == "renamed"
    # the reference re-simulation ran (verify kept from the options) and agrees
    assert record["verification"]["max_relative_difference"] < 1e-6
    unverified = mp.EnergyPlanner(scn.drive(), scn.world, base, verify=False)
    assert "verification" not in unverified.plan(scn.start, scn.goal).to_dict()


def test_options_of_a_planner_from_a_scenario_are_the_scenarios(quickstart):
    scn = quickstart
    planner = mp.EnergyPlanner.from_scenario(scn, show_progress=False)
    opts = planner.options
    assert opts.roadmap == scn.options and opts.motion == scn.motion
    assert opts.name == scn.name and opts.show_progress is False
    assert {f.name for f in fields(opts)} >= {"roadmap", "motion", "verify", "planner"}


@pytest.mark.parametrize("key, value", [
    ("evaluation", "sometimes"), ("collision", "never"), ("planner", "rrt"),
    ("sensor_range", -1.0), ("sensor_range", math.nan), ("hazard_penalty", 0.5),
    ("hazard_penalty", math.nan), ("trajectory_rate", 0.0), ("name", ""),
    ("verify", "yes"), ("show_progress", 1),
])
def test_each_bad_field_is_one_error_naming_it(key, value):
    with pytest.raises(ConfigError, match=f"PlannerOptions.{key}:"):
        mp.PlannerOptions(**{key: value})


def test_wrong_types_and_unknown_keywords(quickstart):
    scn = quickstart
    with pytest.raises(TypeError, match="roadmap must be mpd_pin.RoadmapOptions"):
        mp.PlannerOptions(roadmap={"num_nodes": 10})
    with pytest.raises(TypeError, match="motion must be mpd_pin.MotionOptions"):
        mp.PlannerOptions(motion="fast")
    with pytest.raises(TypeError, match="options must be mpd_pin.PlannerOptions"):
        mp.EnergyPlanner(scn.drive(), scn.world, {"verify": True})
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'nodes' \(valid: "
                                        r"roadmap, evaluation"):
        mp.EnergyPlanner(scn.drive(), scn.world, nodes=40)
    # a keyword is checked like a field
    with pytest.raises(ConfigError, match="PlannerOptions.planner:"):
        mp.EnergyPlanner(scn.drive(), scn.world, mp.PlannerOptions(), planner="rrt")
