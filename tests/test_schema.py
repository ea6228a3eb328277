"""The JSON Schema of result.json (mpd_pin/schemas/result.schema.json, docs/design.md §7e):
shipped with the package, valid, matching real results of both kinds, and strict — a
missing key, an undocumented field or a wrong type is refused."""

import copy
import json
import re
import tomllib
from pathlib import Path

import jsonschema
import pytest
from conftest import read_result, run_cli, run_once, validate_new_results
from scenario_texts import SMALL_2LINK

from mpd_pin.app.results import result_schema, validate_result

ROOT = Path(__file__).resolve().parents[1]

SMALL = 'name = "small"\n' + SMALL_2LINK


@pytest.fixture(scope="module")
def energy_result(tmp_path_factory):
    folder = tmp_path_factory.mktemp("schema_energy")
    (folder / "s.toml").write_text(SMALL)
    res = run_cli("run", str(folder / "s.toml"), "--out", str(folder / "o"), "--quiet")
    assert res.returncode == 0, res.stderr
    return read_result(folder / "o")


@pytest.fixture(scope="module")
def dynamic_result(tmp_path_factory):
    """env1's result.json from ``mpd-pin run env1 --quiet``, a run shared with
    tests/test_twolink_scenarios.py (conftest.run_once)."""
    res, out = run_once(tmp_path_factory, "env1", "--quiet")
    assert res.returncode == 0, res.stderr
    return read_result(out)


def _fails(doc, pattern):
    with pytest.raises(jsonschema.ValidationError, match=pattern):
        validate_result(doc)


def test_schema_is_valid_and_shipped_as_package_data():
    schema = result_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$defs"].keys() >= {"energy", "dynamic2link"}
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["mpd_pin"]
    assert "schemas/*.json" in package_data
    test_extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["test"]
    assert any(r.startswith("jsonschema") for r in test_extra)


def test_real_results_of_both_kinds_validate(energy_result, dynamic_result):
    validate_result(energy_result)
    validate_result(dynamic_result)
    assert energy_result["kind"] == "energy" and dynamic_result["kind"] == "dynamic2link"
    assert energy_result["warnings"]  # the default motor preset is the paper's
    assert dynamic_result["warnings"] == []
    # every field of a real result is one the schema documents (strict top level)
    for doc, kind in ((energy_result, "energy"), (dynamic_result, "dynamic2link")):
        assert set(doc) <= set(result_schema()["$defs"][kind]["properties"])


def test_schema_is_strict(energy_result, dynamic_result):
    doc = copy.deepcopy(energy_result)
    del doc["total_energy"]
    _fails(doc, "'total_energy' is a required property")
    doc = copy.deepcopy(energy_result)
    doc["colour"] = "red"
    _fails(doc, "Additional properties are not allowed")
    doc = copy.deepcopy(energy_result)
    doc["total_energy"] = "86160.8 J"
    _fails(doc, "is not of type 'number'")
    doc = copy.deepcopy(energy_result)
    doc["roadmap"]["cache"] = {"path": None}
    _fails(doc, "'reused' is a required property")
    doc = copy.deepcopy(dynamic_result)
    del doc["path_length_pso"]
    _fails(doc, "'path_length_pso' is a required property")
    doc = copy.deepcopy(dynamic_result)
    doc["kind"] = "dynamic3link"
    _fails(doc, "is not one of")


def test_fields_other_helpers_add_are_optional_and_typed(energy_result):
    """roadmap.evaluation / edges_evaluated / lazy / chunks_reused and the top-level compute
    (docs/design.md §7e) validate when present, with their types."""
    doc = copy.deepcopy(energy_result)
    doc["roadmap"].update(evaluation="lazy", edges_evaluated=120, chunks_reused=0, lazy={
        "rounds": 3, "bound_median_ratio": 1.7, "bound_violations": 0, "bound_worst_ratio": None})
    doc["compute"] = {"scheduler": "local:2", "workers": 2, "chunk_size": 256}
    validate_result(doc)
    doc["roadmap"]["evaluation"] = "sometimes"
    _fails(doc, "'sometimes' is not one of")


def _leaves(node, path=""):
    """(path, sub-schema) of every property with a numeric type in the schema."""
    if not isinstance(node, dict):
        return
    types = node.get("type")
    types = types if isinstance(types, list) else [types]
    if "number" in types:
        yield path, node
    for key, sub in node.get("properties", {}).items():
        yield from _leaves(sub, f"{path}.{key}")
    for key in ("items", "additionalProperties"):
        yield from _leaves(node.get(key), f"{path}[]")
    for sub in node.get("oneOf", []):
        yield from _leaves(sub, path)
    for key, sub in node.get("$defs", {}).items():
        yield from _leaves(sub, key)


def test_physical_numbers_state_their_unit():
    """Energies in J, times in s, angles in rad, lengths in m: in each description."""
    units = {"energy": "(J)", "seconds": "(s)", "time": "(s)", "length_rad": "(rad)",
             "path_length": "(m)", "clearance": "m)", "margin": "(m)"}
    leaves = dict(_leaves(result_schema()))
    assert len(leaves) > 40
    for path, node in leaves.items():
        if path.endswith("[]"):  # the items of a list: the list's description has the unit
            continue
        name = path.rsplit(".", 1)[-1]
        for word, unit in units.items():
            if word in name and "percent" not in name:
                assert unit in node.get("description", ""), (path, node.get("description"))
    assert re.search(r"\(J\)", leaves["energy.total_energy"]["description"])
    num_nodes = result_schema()["$defs"]["energy"]["properties"]["roadmap"]["properties"][
        "num_nodes"]["description"]
    assert "options.num_nodes" in num_nodes and "start" in num_nodes and "goal" in num_nodes


def test_the_conftest_check_finds_a_bad_result_file(tmp_path, energy_result):
    """The check every test gets (tests/conftest.py) fails on a result.json that does not
    match, naming the file and the field, and passes a good one once."""
    good, bad = tmp_path / "good", tmp_path / "bad"
    good.mkdir()
    bad.mkdir()
    (good / "result.json").write_text(json.dumps(energy_result))
    assert validate_new_results(good) == [good / "result.json"]
    assert validate_new_results(good) == []  # already validated, unchanged
    doc = copy.deepcopy(energy_result)
    doc["path"]["node_times"] = "0 1 2 s"
    (bad / "result.json").write_text(json.dumps(doc))
    with pytest.raises(pytest.fail.Exception, match=r"bad/result.json .* at path/node_times"):
        validate_new_results(bad)
    (bad / "result.json").unlink()  # so the fixture's own check after this test passes
