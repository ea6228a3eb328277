"""The verify step is opt-in (issue 34, docs/design.md §7c).

Without it, the roadmap path's series comes from the batched integrator the roadmap priced
the edges with: its energies are the roadmap's, bit for bit, and result.json has no
``verification``. With ``[run] verify`` / ``--verify`` / ``verify=True``, every edge is
re-simulated by the independent per-edge reference ``simulate_edge``; the two series agree
sample by sample, and result.json records the agreement.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.app.config import ConfigError
from mpd_pin.app.plan import plan_path, prepare
from mpd_pin.app.planner import configure
from mpd_pin.app.scenario import parse_energy_scenario
from mpd_pin.app.scenario_files import builtin_scenarios, load_scenario_data
from mpd_pin.app.verify import verify_path


@pytest.fixture(scope="module")
def case2_path():
    """case2 (4 links, six obstacles) on a small roadmap: its setup and energy path."""
    scn = configure(mp.load_scenario("case2"), num_nodes=40)
    setup = prepare(scn, show_progress=False)
    return scn, setup, plan_path(scn, setup)


def test_batched_series_is_the_roadmaps_and_matches_the_reference(case2_path):
    scn, setup, result = case2_path
    rm, dt = setup.roadmap, scn.options.dt
    assert len(result.path) >= 3  # several edges, so the joins are exercised
    fast = verify_path(setup.drive, rm, result.path, dt, result.energy, reference=False)
    ref = verify_path(setup.drive, rm, result.path, dt, result.energy)
    assert not fast.checked and ref.checked
    # the batched series prices each edge exactly as the roadmap did (rows never mix)
    ids = rm.edge_ids(result.path)
    np.testing.assert_array_equal(fast.series["edge_energy"], rm.energy[ids])
    assert fast.max_relative_difference <= 1e-15
    # and the independent reference integrator agrees with it at every sample
    for key in ("t", "node_times"):
        np.testing.assert_allclose(fast.series[key], ref.series[key], rtol=1e-12, atol=1e-12)
    for key in ("q", "v", "i", "V", "energy_t"):
        a, b = fast.series[key], ref.series[key]
        assert a.shape == b.shape, key
        scale = max(float(np.abs(b).max()), 1e-12)
        assert float(np.abs(a - b).max()) <= 1e-8 * scale, key
    assert 0 < ref.max_relative_difference < 1e-9  # two integrators: close, not identical


def test_result_json_has_verification_only_when_asked(tmp_path):
    outs = {}
    for flag in ((), ("--verify",)):
        out = tmp_path / ("verified" if flag else "plain")
        argv = ["run", "case1", "--out", str(out), "--quiet", "--no-replay", "--no-plots",
                "--nodes", "60", *flag]
        assert main(argv) == 0
        outs[bool(flag)] = json.loads((out / "result.json").read_text())
    plain, verified = outs[False], outs[True]
    assert "verification" not in plain
    assert "energy_saved_percent_simulate_edge" not in plain["comparison"]
    assert "energy_per_joint_simulate_edge" not in plain["comparison"]["shortest_path"]
    v = verified["verification"]
    assert v["max_relative_difference"] < 1e-9
    np.testing.assert_allclose(v["energy_per_joint_simulate_edge"],
                               verified["roadmap_path"]["energy_per_joint"], rtol=1e-9)
    assert v["duration"] == pytest.approx(verified["path"]["node_times"][-1], rel=1e-12)
    sp = verified["comparison"]["shortest_path"]
    np.testing.assert_allclose(sp["energy_per_joint_simulate_edge"], sp["energy_per_joint"],
                               rtol=1e-9)
    # the paper's energies do not depend on the verify step
    assert plain["total_energy"] == verified["total_energy"]
    assert plain["energy_per_joint"] == verified["energy_per_joint"]


def test_run_verify_key_and_bad_values():
    data = load_scenario_data(builtin_scenarios()["case1"])
    assert parse_energy_scenario(data).verify is False
    data["run"] = {"verify": True}
    assert parse_energy_scenario(data).verify is True
    data["run"] = {"verify": "yes"}
    with pytest.raises(ConfigError, match=r"run\.verify"):
        parse_energy_scenario(data)
    data["run"] = {"verfy": True}
    with pytest.raises(ConfigError, match="verfy"):
        parse_energy_scenario(data)
    with pytest.raises(ConfigError, match="verify"):
        configure(mp.load_scenario("case1"), verify="yes")
    assert configure(mp.load_scenario("case1"), verify=True).verify is True
