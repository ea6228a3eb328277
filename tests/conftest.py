"""Shared test set-up: the Agg backend, the one ``mpd-pin`` subprocess helper, and the check
that every result.json a test produces matches the shipped JSON Schema."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


def _no_constant(name):
    raise ValueError(f"result.json holds {name}, which strict JSON has not")


def read_result(out: Path) -> dict:
    """``out/result.json`` parsed by a strict parser: Infinity, -Infinity or NaN raise."""
    return json.loads((Path(out) / "result.json").read_text(), parse_constant=_no_constant)


def run_cli(*args, cwd=None) -> subprocess.CompletedProcess:
    """``python -m mpd_pin ARGS`` in a subprocess (stdout/stderr captured as text)."""
    return subprocess.run([sys.executable, "-m", "mpd_pin", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=900)


#: result.json files already validated → their modification time (ns).
_VALIDATED: dict[Path, int] = {}


def validate_new_results(base: Path) -> list[Path]:
    """Validate every result.json under ``base`` written since it was last validated
    against ``mpd_pin/schemas/result.schema.json``; returns the files checked. Raises
    ``pytest.fail`` naming the file, the field and the schema rule that failed."""
    import jsonschema

    from mpd_pin.app.results import result_schema

    checked = []
    validator = None
    for path in sorted(Path(base).rglob("result.json")):
        stamp = path.stat().st_mtime_ns
        if _VALIDATED.get(path) == stamp:
            continue
        if validator is None:
            schema = result_schema()
            jsonschema.Draft202012Validator.check_schema(schema)
            validator = jsonschema.Draft202012Validator(schema)
        doc = json.loads(path.read_text(), parse_constant=_no_constant)
        errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))
        if errors:
            err = errors[0]
            where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
            pytest.fail(f"{path} does not match result.schema.json at {where}: {err.message} "
                        f"({len(errors)} error(s); every field is documented in "
                        f"mpd_pin/schemas/result.schema.json)", pytrace=False)
        _VALIDATED[path] = stamp
        checked.append(path)
    return checked


@pytest.fixture(autouse=True)
def _results_match_the_schema(request):
    """After every test that has a ``tmp_path``: each result.json it wrote there (in-process
    runs and ``mpd-pin`` subprocesses alike) is validated against the schema
    (docs/design.md §7e)."""
    folder = request.getfixturevalue("tmp_path") if "tmp_path" in request.fixturenames else None
    yield
    if folder is not None and folder.exists():
        validate_new_results(folder)


@pytest.fixture(scope="module", autouse=True)
def _module_results_match_the_schema(tmp_path_factory):
    """After every test module: each result.json written anywhere under pytest's temporary
    folders (module fixtures' ``tmp_path_factory`` folders too) and not yet validated."""
    yield
    validate_new_results(tmp_path_factory.getbasetemp())
