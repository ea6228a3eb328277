"""The README's and the user guide's examples run as written, from any directory, on the
installed package.

Each ```python block of README.md and docs/guide.md is executed in a fresh interpreter
whose working directory is an empty temporary folder (so a relative path such as
``robots/...`` would fail) and whose ``sys.path`` does not start with the repository; their
``mpd-pin`` commands run one after the other. The guide's result.json tables name every
field of the schema; the README stays short and lists every notebook.
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
GUIDE = ROOT / "docs" / "guide.md"
#: The documents whose examples run, in reading order.
DOCUMENTS = (README, GUIDE)


def _blocks(path: Path, language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```$", path.read_text(encoding="utf-8"),
                      re.M | re.S)


BLOCKS = [(path.name, k, code) for path in DOCUMENTS
          for k, code in enumerate(_blocks(path, "python"))]


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: p.name)
def test_documents_have_python_examples(path):
    assert _blocks(path, "python"), f"{path.name} has no ```python block"


@pytest.mark.parametrize("name, index, code", BLOCKS, ids=[f"{n}-{k}" for n, k, _ in BLOCKS])
def test_python_block_runs_in_an_empty_directory(name, index, code, tmp_path):
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
    assert proc.returncode == 0, f"{name} block {index} failed:\n{code}\n{proc.stderr[-3000:]}"
    assert proc.stdout.strip(), f"{name} block {index} printed nothing"
    assert not list(tmp_path.iterdir()), f"{name} example left files in the working directory"


# ------------------------------------------------------------------ the shell commands
BASH = [block for path in DOCUMENTS for block in _blocks(path, "bash")]


def _mpd_pin_commands() -> list[str]:
    """The ``mpd-pin …`` commands of the ```bash blocks of README.md, then docs/guide.md, in
    order, as written (a ``pip install … && mpd-pin …`` line gives its second half;
    comments dropped)."""
    commands = []
    for block in BASH:
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if "mpd-pin " in line:
                commands.append(line[line.index("mpd-pin "):])
    return commands


def test_shell_commands_run_as_written(tmp_path):
    """Every ``mpd-pin`` command of the README and the guide runs, one after the other, in
    an empty folder (``mpd-pin show … > my_scene.toml`` feeds the next one); the first
    prints the line the README (and the guide) shows; every result.json written is checked
    against the schema (tests/conftest.py)."""
    import json

    commands = _mpd_pin_commands()
    assert commands[0] == "mpd-pin run quickstart --out out/", commands
    assert any(c.startswith("mpd-pin show ") for c in commands)
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    outputs = []
    for command in commands:
        proc = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"{command}:\n{proc.stderr[-3000:]}"
        outputs.append(proc.stdout)
    for path in DOCUMENTS:
        shown = re.search(r"prints\n\n```text\n(.*?)\n```", path.read_text(encoding="utf-8"), re.S)
        assert shown, f"{path.name} shows no output of the first command"
        assert outputs[0].strip() == shown.group(1).strip(), path.name
    first = json.loads((tmp_path / "out" / "result.json").read_text())
    assert first["warnings"] == [] and 1.0 < first["total_energy"] < 1000.0  # plausible J
    paper = json.loads((tmp_path / "out" / "case1" / "result.json").read_text())
    case1 = outputs[commands.index("mpd-pin run case1 --out out/case1")]
    assert paper["warnings"] and f"warning: {paper['warnings'][0]}" in case1


# ------------------------------------------------------------------ result.json tables
def _table_fields(heading_text: str) -> set[str]:
    """Backticked names in the first column of the guide's table following ``heading_text``."""
    text = GUIDE.read_text(encoding="utf-8")
    start = text.index(heading_text)
    rows = re.search(r"\n(\|.*?\n)(?!\|)", text[start:], re.S).group(1)
    names = set()
    for row in rows.splitlines()[2:]:
        names |= set(re.findall(r"`(\w+)`", row.split("|")[1]))
    return names


@pytest.mark.parametrize("kind, heading", [
    ("energy", 'An energy scenario (`kind = "energy"`, paper 000):'),
    ("dynamic2link", "files, but the PNG figures listed in `plots`, and:"),
])
def test_guide_tables_name_every_result_field(kind, heading):
    from mpd_pin.app.results import result_schema

    fields = set(result_schema()["$defs"][kind]["properties"])
    assert _table_fields(heading) == fields


# ------------------------------------------------------------------ a short README
def test_readme_stays_short():
    """The README is the overview; details belong in docs/guide.md (issue 23)."""
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines: move details to docs/guide.md"


def test_readme_lists_every_notebook():
    text = README.read_text(encoding="utf-8")
    section = re.search(r"^## Notebooks\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    assert section, "README.md has no '## Notebooks' section"
    listed = set(re.findall(r"^- \*\*(\w+)\*\* \S", section.group(1), re.M))
    expected = {p.stem.split("_")[0] if p.stem[:2].isdigit() else p.stem
                for p in (ROOT / "notebooks").glob("*.ipynb")}
    assert listed == expected, f"README notebooks {sorted(listed)} != {sorted(expected)}"
