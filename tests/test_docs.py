"""The repository's design notes stand alone (docs/design.md §7).

* docs/design.md has strictly formatted section headings (``## §N Title``,
  ``### §Na Title``), numbered in order;
* every "docs/design.md §X" citation in the package, tests, bench, scripts,
  notebooks, README and user guide (docs/guide.md) names a section that exists
  (ranges ``§1–2``, ``§3-§4`` resolve every section in between), and so does every
  bare "§X" cross-reference inside the notes themselves;
* docs/README.md lists exactly the sections of docs/design.md, with their titles
  (so no section is an orphan: each is cited or at least indexed);
* the user guide's "Layout" block names every folder and module of ``mpd_pin/`` and
  nothing that does not exist;
* every relative link of README.md, docs/guide.md and docs/README.md leads to a file of
  the repository, and every ``#anchor`` to a heading of its target.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "docs" / "design.md"
INDEX = ROOT / "docs" / "README.md"
README = ROOT / "README.md"
GUIDE = ROOT / "docs" / "guide.md"

#: Where citations are looked for, and in which files.
CITING_DIRS = ("mpd_pin", "tests", "bench", "scripts", "notebooks")
CITING_SUFFIXES = {".py", ".ipynb", ".toml", ".md", ".txt"}

SECTION_ID = r"§(?P<num>[1-9][0-9]*)(?P<sub>[a-z]?)"
HEADING_RE = re.compile(rf"^(?P<level>#{{2,3}}) {SECTION_ID} (?P<title>\S.*)$")
# "docs/design.md §3", "docs/design.md §1–2", "docs/design.md §3-§4", across a line break too.
CITATION_RE = re.compile(
    r"docs/design\.md\s+§(?P<a>[0-9]+[a-z]?)(?:\s*[–-]\s*§?(?P<b>[0-9]+[a-z]?))?"
)
# A reference to a section of one of the papers, e.g. "paper 000 §5.1", "(000 §3": not ours.
PAPER_REF_RE = re.compile(r"(?:paper\s+)?\b00[0-9]\s+§[0-9.]+")
BARE_REF_RE = re.compile(r"§(?P<a>[0-9]+[a-z]?)(?:\s*[–-]\s*§?(?P<b>[0-9]+[a-z]?))?")


def design_sections() -> dict[str, str]:
    """Section id ("3", "4a") -> title, parsed strictly from the headings of docs/design.md."""
    sections: dict[str, str] = {}
    last_num = 0
    last_sub = ""
    in_code = False
    for lineno, line in enumerate(DESIGN.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            in_code = not in_code
        if in_code or not line.startswith("#"):
            continue
        where = f"docs/design.md:{lineno}: {line!r}"
        if line.startswith("# "):  # the document title, the only level-1 heading
            assert lineno == 1, f"{where}: only the first line may be a level-1 heading"
            continue
        m = HEADING_RE.match(line)
        assert m, f"{where}: headings must be '## §N Title' or '### §Na Title'"
        num, sub, level = int(m["num"]), m["sub"], len(m["level"])
        assert (level == 2) == (sub == ""), f"{where}: §N is '##', §Na is '###'"
        if level == 2:
            assert num == last_num + 1, f"{where}: sections must be numbered 1, 2, 3, …"
            last_num, last_sub = num, ""
        else:
            assert num == last_num, f"{where}: sub-section of §{num} under §{last_num}"
            expected = chr(ord(last_sub) + 1) if last_sub else "a"
            assert sub == expected, f"{where}: expected §{num}{expected}"
            last_sub = sub
        key = f"{num}{sub}"
        assert key not in sections, f"{where}: duplicate section §{key}"
        sections[key] = m["title"].strip()
    assert not in_code, "docs/design.md: unterminated code block"
    return sections


def _expand(a: str, b: str | None, where: str) -> list[str]:
    """The section ids a citation ``§a`` or ``§a–b`` refers to."""
    if b is None:
        return [a]
    if a.isdigit() and b.isdigit():
        lo, hi = int(a), int(b)
        assert lo < hi, f"{where}: backwards range §{a}–{b}"
        return [str(n) for n in range(lo, hi + 1)]
    return [a, b]  # sub-section ranges: both ends must exist


def _citing_files() -> list[Path]:
    files = [README, GUIDE]
    for d in CITING_DIRS:
        files += [
            p
            for p in sorted((ROOT / d).rglob("*"))
            if p.is_file() and p.suffix in CITING_SUFFIXES and ".ipynb_checkpoints" not in p.parts
        ]
    return files


def citations() -> list[tuple[str, str]]:
    """(where, section id) for every "docs/design.md §X" citation outside docs/."""
    found = []
    for path in _citing_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        if path.suffix == ".ipynb":  # JSON: line breaks inside strings are the two characters \n
            text = text.replace("\\n", "\n")
        for m in CITATION_RE.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            where = f"{path.relative_to(ROOT)}:{line}: {m.group(0)!r}"
            found += [(where, s) for s in _expand(m["a"], m["b"], where)]
    return found


def test_design_notes_exist_with_all_top_level_sections():
    sections = design_sections()
    top = [k for k in sections if k.isdigit()]
    assert top == [str(n) for n in range(1, 11)], top


def test_every_citation_resolves_to_a_heading():
    sections = design_sections()
    found = citations()
    assert len(found) >= 30, f"expected the code's ~30 citations, found {len(found)}"
    missing = [f"{where} -> §{s}" for where, s in found if s not in sections]
    assert not missing, "citations of sections docs/design.md does not have:\n" + "\n".join(missing)


def test_cross_references_inside_the_notes_resolve():
    sections = design_sections()
    text = DESIGN.read_text(encoding="utf-8")
    text = PAPER_REF_RE.sub("", text)
    missing = []
    for m in BARE_REF_RE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        where = f"docs/design.md:{line}: {m.group(0)!r}"
        missing += [f"{where} -> §{s}" for s in _expand(m["a"], m["b"], where) if s not in sections]
    assert not missing, "\n".join(missing)


def test_index_lists_exactly_the_sections():
    sections = design_sections()
    listed: dict[str, str] = {}
    for line in INDEX.read_text(encoding="utf-8").splitlines():
        m = re.match(rf"^(?P<indent> *)- {SECTION_ID} (?P<title>\S.*)$", line)
        if m:
            key = f"{m['num']}{m['sub']}"
            assert (m["indent"] == "") == (m["sub"] == ""), f"docs/README.md: {line!r}"
            assert key not in listed, f"docs/README.md lists §{key} twice"
            listed[key] = m["title"].strip()
    assert list(listed) == list(sections), "docs/README.md and docs/design.md sections differ"
    wrong = {k: (listed[k], sections[k]) for k in sections if listed[k] != sections[k]}
    assert not wrong, f"titles differ (index, design): {wrong}"


def test_every_section_is_cited_or_indexed():
    """No orphan sections: each is cited by the code or at least listed in docs/README.md."""
    cited = {s for _, s in citations()}
    indexed = set(re.findall(r"^ *- §([0-9]+[a-z]?) ", INDEX.read_text(encoding="utf-8"), re.M))
    orphans = [s for s in design_sections() if s not in cited | indexed]
    assert not orphans, orphans


# ------------------------------------------------------------------ the guide's layout
def _layout_block() -> list[str]:
    text = GUIDE.read_text(encoding="utf-8")
    m = re.search(r"^## Layout\n(?P<body>.*?)(?=^## |\Z)", text, re.M | re.S)
    assert m, "docs/guide.md has no '## Layout' section"
    block = re.search(r"^```\n(?P<code>.*?)^```$", m["body"], re.M | re.S)
    assert block, "docs/guide.md's Layout section has no code block"
    return block["code"].splitlines()


def _layout_entries() -> dict[str, set[str]]:
    """'' (the package root) or a folder name -> the module names its entry lists.

    An entry starts at ``mpd_pin/`` or at a line ``  folder/`` and runs over the
    indented continuation lines that follow it.
    """
    entries: dict[str, list[str]] = {}
    current: str | None = None
    for line in _layout_block():
        if line.startswith("mpd_pin/"):
            current = ""
        elif m := re.match(r"^  (\w+)/\s", line + " "):
            current = m[1]
        elif re.match(r"^\S", line):  # another top-level folder of the repository
            current = None
            continue
        if current is None:
            continue
        entries.setdefault(current, []).append(line)
    return {k: set(re.findall(r"\b(\w+)\.py\b", " ".join(v))) for k, v in entries.items()}


def test_guide_layout_matches_the_package_tree():
    pkg = ROOT / "mpd_pin"
    entries = _layout_entries()
    folders = {p.name for p in pkg.iterdir() if p.is_dir() and not p.name.startswith(("_", "."))}
    assert set(entries) - {""} == folders, (
        f"guide layout folders {sorted(set(entries) - {''})} != mpd_pin/ folders {sorted(folders)}"
    )
    for folder, listed in sorted(entries.items()):
        here = pkg / folder
        actual = {p.stem for p in here.glob("*.py")}
        if folder:  # a stage folder's __init__.py goes without saying
            actual.discard("__init__")
        assert listed == actual, (
            f"guide layout of mpd_pin/{folder}: lists {sorted(listed)}, the tree has "
            f"{sorted(actual)}"
        )


def test_readme_points_to_the_design_notes_and_the_guide():
    text = README.read_text(encoding="utf-8")
    assert "docs/design.md" in text and "docs/guide.md" in text
    assert "DESIGN.md" not in text, "the README must not send readers outside the repository"
    assert "guide.md" in INDEX.read_text(encoding="utf-8"), "docs/README.md omits the guide"


# ------------------------------------------------------------------ links
LINK_RE = re.compile(r"!?\[[^\]]*\]\((?P<target>[^)\s]+)\)")


def _anchors(path: Path) -> set[str]:
    """GitHub's anchors of the headings of a Markdown file: lower case, punctuation other
    than hyphens dropped, spaces to hyphens."""
    text = re.sub(r"^```.*?^```$", "", path.read_text(encoding="utf-8"), flags=re.M | re.S)
    headings = re.findall(r"^#{1,6} (.+?)\s*$", text, re.M)
    return {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in headings}


@pytest.mark.parametrize("path", [README, GUIDE, INDEX], ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(path):
    text = re.sub(r"^```.*?^```$", "", path.read_text(encoding="utf-8"), flags=re.M | re.S)
    broken = []
    for m in LINK_RE.finditer(text):
        target = m["target"]
        if re.match(r"^[a-z]+:", target):  # http(s), mailto: not checked here
            continue
        file, _, anchor = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        if not dest.exists():
            broken.append(f"{target}: no file {dest}")
        elif anchor and anchor not in _anchors(dest):
            broken.append(f"{target}: no heading with anchor #{anchor} in {dest.name}")
    assert not broken, f"{path.name}:\n" + "\n".join(broken)


@pytest.mark.parametrize("path", [DESIGN, INDEX, GUIDE])
def test_docs_have_no_overlong_lines_outside_tables_and_code(path):
    in_code = False
    for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            in_code = not in_code
        if not in_code and not line.startswith("|"):
            assert len(line) <= 100, f"{path.name}:{lineno} has {len(line)} characters"
