"""The README's Python examples run as written, from any directory, on the installed package.

Each ```python block of README.md is executed in a fresh interpreter whose working
directory is an empty temporary folder (so a relative path such as ``robots/...``
would fail) and whose ``sys.path`` does not start with the repository.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

BLOCKS = re.findall(r"^```python\n(.*?)^```$", README.read_text(encoding="utf-8"), re.M | re.S)


def test_readme_has_python_examples():
    assert BLOCKS, "README.md has no ```python block"


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs_in_an_empty_directory(index, tmp_path):
    code = BLOCKS[index]
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    # -P (3.11+): do not put the script's directory (here: the cwd) first on sys.path.
    proc = subprocess.run(
        [sys.executable, "-P", "-c", code],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, f"README block {index} failed:\n{code}\n{proc.stderr[-3000:]}"
    assert proc.stdout.strip(), f"README block {index} printed nothing"
    assert not list(tmp_path.iterdir()), "README example left files in the working directory"
