"""Shared test set-up: the Agg backend, the ``mpd-pin`` command helpers (in-process
:func:`run_cli`, the real entry point :func:`run_cli_subprocess`, runs shared across test
files :func:`run_once`), the check that every result.json a test produces matches the
shipped JSON Schema, and (``MPD_PIN_NO_SKIPS=1``, set by ``.ci/run``) the refusal of any
skipped test whose reason does not name an optional extra."""

import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


def _no_constant(name):
    raise ValueError(f"result.json holds {name}, which strict JSON has not")


def read_result(out: Path) -> dict:
    """``out/result.json`` parsed by a strict parser: Infinity, -Infinity or NaN raise."""
    return json.loads((Path(out) / "result.json").read_text(), parse_constant=_no_constant)


# ------------------------------------------------------------------ the mpd-pin command
def run_cli_subprocess(*args, cwd=None) -> subprocess.CompletedProcess:
    """``python -m mpd_pin ARGS`` in a subprocess (stdout/stderr captured as text): the real
    entry point, for the tests of the entry point itself and of signals."""
    return subprocess.run([sys.executable, "-m", "mpd_pin", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=900)


#: The warning filters of a fresh interpreter started without -W or PYTHONWARNINGS
#: (``python -c "import warnings; print(warnings.filters)"``): what ``python -m mpd_pin``
#: runs with, where pytest's own filters would record and hide warnings instead.
_FRESH_FILTERS = (
    ("default", DeprecationWarning, "__main__"),
    ("ignore", DeprecationWarning, ""),
    ("ignore", PendingDeprecationWarning, ""),
    ("ignore", ImportWarning, ""),
    ("ignore", ResourceWarning, ""),
)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """As the interpreter shows an uncaught warning: formatted, on (the current) stderr."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


@contextlib.contextmanager
def _warnings_as_in_a_fresh_interpreter():
    with warnings.catch_warnings():
        warnings.resetwarnings()
        for action, category, module in reversed(_FRESH_FILTERS):
            warnings.filterwarnings(action, category=category, module=module)
        warnings.showwarning = _show_warning
        yield


def _pipe_text(data: bytes) -> str:
    """Bytes as ``subprocess.run(..., text=True)`` gives them: UTF-8, universal newlines."""
    return data.decode("utf-8", errors="replace").replace("\r\n", "\n").replace("\r", "\n")


@contextlib.contextmanager
def _captured_output(texts: dict):
    """File descriptors 1 and 2 — and ``sys.stdout``/``sys.stderr``, written straight
    through to them — into two temporary files, as a child process's pipes would get them
    (what C++ libraries such as urdfdom print included); their text lands in ``texts``
    (keys ``stdout``, ``stderr``) on exit."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    streams = sys.stdout, sys.stderr
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        saved = os.dup(1), os.dup(2)
        try:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            sys.stdout, sys.stderr = (
                io.TextIOWrapper(io.FileIO(fd, "w", closefd=False), encoding="utf-8",
                                 errors=errors, write_through=True)
                for fd, errors in ((1, "strict"), (2, "backslashreplace")))
            yield
        finally:
            for stream in (sys.stdout, sys.stderr):
                stream.flush()
            sys.stdout, sys.stderr = streams
            for fd, copy in zip((1, 2), saved, strict=True):
                os.dup2(copy, fd)
                os.close(copy)
            for key, f in (("stdout", out), ("stderr", err)):
                f.seek(0)
                texts[key] = _pipe_text(f.read())


@contextlib.contextmanager
def _working_directory(cwd):
    if cwd is None:
        yield
        return
    before = os.getcwd()
    os.chdir(cwd)
    try:
        yield
    finally:
        os.chdir(before)


def _figure_numbers() -> set:
    plt = sys.modules.get("matplotlib.pyplot")
    return set(plt.get_fignums()) if plt is not None else set()


def run_cli(*args, cwd=None) -> subprocess.CompletedProcess:
    """``mpd-pin ARGS`` run in this process — :func:`mpd_pin.app.cli.main` — as
    ``python -m mpd_pin ARGS`` would run (:func:`run_cli_subprocess`), without the second
    of interpreter start-up: stdout and stderr captured at the file descriptors (text, as
    ``subprocess.run(..., text=True)`` gives it), the working directory ``cwd``, warnings
    shown on stderr under a fresh interpreter's filters, and ``SystemExit`` (argparse:
    ``--help``, a bad argument) turned into the return code as ``sys.exit`` would.
    Figures the run leaves open are closed. Returns a ``subprocess.CompletedProcess``."""
    from mpd_pin.app.cli import main

    argv = [str(a) for a in args]
    texts: dict[str, str] = {}
    figures = _figure_numbers()
    try:
        with _working_directory(cwd), _captured_output(texts), \
                _warnings_as_in_a_fresh_interpreter():
            try:
                status = main(argv)
            except SystemExit as exc:
                status = exc.code
                if status is not None and not isinstance(status, int):
                    print(status, file=sys.stderr)  # as sys.exit("message") does
                    status = 1
    finally:
        plt = sys.modules.get("matplotlib.pyplot")
        for num in _figure_numbers() - figures:
            plt.close(num)
    return subprocess.CompletedProcess(["mpd-pin", *argv], 0 if status is None else status,
                                       texts["stdout"], texts["stderr"])


#: (scenario, flags) → (CompletedProcess, output folder) of the runs shared by tests.
_SHARED_RUNS: dict[tuple, tuple] = {}


def run_once(tmp_path_factory, scenario, *flags):
    """``mpd-pin run SCENARIO --out DIR FLAGS`` once per test session for each (scenario,
    flags) → (``CompletedProcess``, DIR). For tests that only read the outputs of the same
    run; a test that changes the folder or needs other flags makes its own run."""
    key = (str(scenario), *map(str, flags))
    if key not in _SHARED_RUNS:
        out = tmp_path_factory.mktemp(f"shared_{Path(scenario).stem}") / "out"
        _SHARED_RUNS[key] = (run_cli("run", scenario, "--out", out, *flags), out)
    return _SHARED_RUNS[key]


@pytest.fixture(scope="session")
def case1_cached(tmp_path_factory):
    """``mpd-pin run case1 --out DIR --quiet --no-replay --collision eager --cache FILE``
    once a session (the scenario's lazy evaluation, every edge collision-checked first, the
    roadmap saved to FILE) → (process, DIR, FILE). A test that runs again on the roadmap
    file copies it first (a run may add energies to it)."""
    cache = tmp_path_factory.mktemp("case1_cache") / "roadmap.npz"
    res, out = run_once(tmp_path_factory, "case1", "--quiet", "--no-replay", "--collision",
                        "eager", "--cache", cache)
    assert res.returncode == 0, res.stderr
    assert cache.is_file()
    return res, out, cache


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


# ------------------------------------------------------------------ no unexpected skips
#: A skip is allowed under ``MPD_PIN_NO_SKIPS=1`` only when its reason names an optional
#: extra that the ``test`` extra does not install (pyproject.toml): ``bench`` (OMPL).
OPTIONAL_EXTRA_WORDS = ("ompl", "bench extra")

#: (test id, reason) of every skip whose reason names no optional extra.
_REFUSED_SKIPS: list[tuple[str, str]] = []


def _no_skips() -> bool:
    return os.environ.get("MPD_PIN_NO_SKIPS", "") not in ("", "0")


def _note_skip(report) -> None:
    if not report.skipped or hasattr(report, "wasxfail"):
        return
    longrepr = report.longrepr
    reason = str(longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3
                 else longrepr)
    if not any(word in reason.lower() for word in OPTIONAL_EXTRA_WORDS):
        _REFUSED_SKIPS.append((report.nodeid, reason))


def pytest_runtest_logreport(report):
    _note_skip(report)


def pytest_collectreport(report):
    _note_skip(report)


def pytest_sessionfinish(session, exitstatus):
    """With ``MPD_PIN_NO_SKIPS=1`` (``.ci/run``) a run with a skip whose reason names no
    optional extra fails (exit status 1) even when every test that ran passed."""
    if _no_skips() and _REFUSED_SKIPS and exitstatus == pytest.ExitCode.OK:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if _no_skips() and _REFUSED_SKIPS:
        terminalreporter.section("skips refused (MPD_PIN_NO_SKIPS=1)", sep="=", red=True)
        for nodeid, reason in _REFUSED_SKIPS:
            terminalreporter.line(f"{nodeid}: {reason}")
        terminalreporter.line(f"{len(_REFUSED_SKIPS)} skip(s) whose reason names no optional "
                              f"extra ({', '.join(OPTIONAL_EXTRA_WORDS)}): a declared "
                              "dependency is missing or a test skipped itself; the run fails")
