"""Start-up (issue "scale", item 5; issue 34, item 4): commands import what they use.

``mpd-pin scenarios``, ``show`` and ``--help`` read TOML files and argparse only, and
``mpd-pin run --no-replay --no-plots`` imports neither meshcat nor matplotlib; a fresh
interpreter checks which heavy packages they pulled in (the timing itself is a bench
matter: bench/startup.py).
"""

import subprocess
import sys

import pytest

HEAVY = ("pinocchio", "coal", "yourdfpy", "trimesh", "matplotlib", "meshcat", "distributed",
         "scipy")

SCRIPT = """
import contextlib, io, sys
from mpd_pin.app.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    try:
        status = main({argv!r})
    except SystemExit as exc:
        status = exc.code
assert status == 0, status
assert out.getvalue().strip(), "printed nothing"
print(",".join(m for m in {heavy!r} if m in sys.modules))
"""


@pytest.mark.parametrize("argv", [["scenarios"], ["show", "case1"], ["--help"], ["--version"],
                                  ["run", "--help"]])
def test_answering_commands_import_nothing_heavy(argv):
    proc = subprocess.run([sys.executable, "-c", SCRIPT.format(argv=argv, heavy=HEAVY)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "", f"{argv} imported {proc.stdout.strip()}"


#: What only the replay (mpd_pin.viz.replay) and the plots (mpd_pin.viz.plots' figures)
#: need: a run without either imports none of them.
REPLAY_AND_PLOTS_ONLY = ("meshcat", "zmq", "pinocchio.visualize", "matplotlib",
                         "matplotlib.pyplot")

RUN_SCRIPT = """
import contextlib, io, sys
from mpd_pin.app.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    status = main({argv!r})
assert status == 0, status
assert "result.json" in out.getvalue(), out.getvalue()
print(",".join(m for m in {modules!r} if m in sys.modules))
"""


def test_run_without_replay_and_plots_imports_neither_meshcat_nor_matplotlib(tmp_path):
    """``mpd-pin run quickstart --no-replay --no-plots`` (a small roadmap, the roadmap path
    as it is) writes result.json and the trajectory, no figure and no replay, and never
    imports meshcat, zmq, Pinocchio's visualisers or matplotlib."""
    out = tmp_path / "o"
    argv = ["run", "quickstart", "--nodes", "40", "--no-refine", "--execution", "stop",
            "--no-replay", "--no-plots", "--quiet", "--out", str(out)]
    proc = subprocess.run([sys.executable, "-c", RUN_SCRIPT.format(
        argv=argv, modules=REPLAY_AND_PLOTS_ONLY)], capture_output=True, text=True,
        timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "", f"the run imported {proc.stdout.strip()}"
    written = sorted(p.name for p in out.iterdir())
    assert written == ["result.json", "trajectory.csv", "trajectory.json"], written
