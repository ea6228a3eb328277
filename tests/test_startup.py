"""Start-up (issue "scale", item 5): the answering commands import nothing heavy.

``mpd-pin scenarios``, ``show`` and ``--help`` read TOML files and argparse only; a fresh
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
