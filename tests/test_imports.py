"""Import structure (issue 35, "Structure"): no import circles, no private names across modules.

Every module of ``mpd_pin`` is parsed with ``ast`` (nothing is imported). An edge ``a -> b``
is a *module-level* import in ``a`` of the ``mpd_pin`` module ``b``:

* relative imports are resolved against ``a``'s package;
* ``from p import x`` is an edge to ``p.x`` when ``p.x`` is a module, else to ``p`` (a name
  that ``p/__init__.py`` defines or re-exports);
* the implicit import of a parent package (``import p.q`` runs ``p/__init__.py``) is not an
  edge: Python has always started that package before any of its modules;
* imports under ``if TYPE_CHECKING:`` are edges like any other. A type-only circle does
  not fail at run time, but it is still a circle in the layering (neither module can be
  understood, moved or tested without the other), so it fails here too;
* "module level" means anywhere outside a function body (class bodies, ``try`` and ``if``
  blocks run at import). Imports inside functions are *function-level* and kept apart
  (:func:`test_function_level_imports_are_listed` lists those pointing up).

A function-level import pointing *down* the layering is fine (a heavy module loaded when
first needed); one pointing *up* (its target already reaches the importing module) is
the usual way to dodge a circle rather than remove it. So the graph of module- and
function-level imports together must be acyclic too, with no exception.

A private name is one starting with ``_`` that is not a dunder (``__version__``). No module
may import a private name from another ``mpd_pin`` module, nor read one as an attribute
(``roadmap._bus()``, ``table._name(k)``) when the name is defined only in other modules
(a heuristic: defined = a ``def``/``class``/assigned name or a ``self.x =`` attribute in
that module). Private *modules* are allowed (``from . import _impl``), since a module is
not an attribute of another module's API. There are no exceptions.
"""

from __future__ import annotations

import ast
import functools
from dataclasses import dataclass
from pathlib import Path

import networkx as nx

import mpd_pin

ROOT = Path(mpd_pin.__file__).resolve().parent
PACKAGE = "mpd_pin"

@dataclass(frozen=True)
class Import:
    """One import statement's target, as found in the source."""

    source: str  #: importing module
    target: str  #: imported mpd_pin module
    name: str | None  #: attribute imported by ``from target import name`` (None for modules)
    line: int
    function_level: bool


def module_name(path: Path) -> str:
    """Dotted module name of a file under the package root."""
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def all_modules() -> dict[str, Path]:
    """Every module of the package, by dotted name."""
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


@functools.cache
def parsed() -> dict[str, ast.Module]:
    """Every module's syntax tree, by dotted name (parsed once per session)."""
    return {m: ast.parse(p.read_text(), filename=str(p)) for m, p in all_modules().items()}


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    """Absolute name of ``from <level dots><target> import ...`` written in ``module``."""
    if level == 0:
        return target or ""
    package = module.split(".") if is_package else module.split(".")[:-1]
    base = package[: len(package) - (level - 1)]
    return ".".join(base + ([target] if target else []))


class _Collector(ast.NodeVisitor):
    """Collect the mpd_pin imports of one module, noting whether each is inside a function."""

    def __init__(self, module: str, is_package: bool, modules: set[str]):
        self.module, self.is_package, self.modules = module, is_package, modules
        self.depth = 0
        self.found: list[Import] = []

    def _add(self, target: str, name: str | None, node: ast.stmt) -> None:
        if target == PACKAGE or target.startswith(PACKAGE + "."):
            self.found.append(Import(self.module, target, name, node.lineno, self.depth > 0))

    def _function(self, node: ast.AST) -> None:
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = _function

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self._add(alias.name, None, node)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        base = _resolve(self.module, self.is_package, node.level, node.module)
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            if sub in self.modules:
                self._add(sub, None, node)
            else:
                self._add(base, alias.name, node)


def all_imports() -> list[Import]:
    """Every mpd_pin import in the package (module- and function-level)."""
    modules = all_modules()
    found: list[Import] = []
    for name, tree in parsed().items():
        collector = _Collector(name, modules[name].name == "__init__.py", set(modules))
        collector.visit(tree)
        found += collector.found
    return found


def import_graph(imports: list[Import] | None = None) -> nx.DiGraph:
    """Module-level import graph of the package: an edge per importing/imported module pair."""
    graph = nx.DiGraph()
    graph.add_nodes_from(all_modules())
    for imp in all_imports() if imports is None else imports:
        if not imp.function_level and imp.target != imp.source:
            graph.add_edge(imp.source, imp.target)
    return graph


def full_graph(imports: list[Import] | None = None) -> nx.DiGraph:
    """Module- and function-level imports together."""
    imports = all_imports() if imports is None else imports
    graph = import_graph(imports)
    for imp in imports:
        if imp.function_level and imp.target != imp.source:
            graph.add_edge(imp.source, imp.target)
    return graph


def _cycles(graph: nx.DiGraph) -> list[list[str]]:
    """The simple cycles, each in import order from its smallest module name."""
    out = []
    for c in nx.simple_cycles(graph):
        k = c.index(min(c))
        out.append(c[k:] + c[:k])
    return sorted(out)


def _show(cycles: list[list[str]]) -> str:
    return f"{len(cycles)} import circle(s):\n" + "\n".join(
        " -> ".join(c + c[:1]) for c in cycles)


def _private_definitions(tree: ast.Module) -> set[str]:
    """Private names a module defines: defs, classes, assigned names, ``self.x =``."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store)
              and isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
            names.add(node.attr)
    return {n for n in names if _is_private(n)}


def private_attribute_uses() -> list[tuple[str, int, str, list[str]]]:
    """(module, line, attribute, defining modules) for every ``x._name`` read or written
    in a module (``x`` not ``self``/``cls``) whose ``_name`` only other modules define."""
    trees = parsed()
    defined = {m: _private_definitions(t) for m, t in trees.items()}
    uses = []
    for module, tree in trees.items():
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and _is_private(node.attr)):
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            if node.attr in defined[module]:
                continue
            owners = sorted(m for m, names in defined.items() if node.attr in names)
            if owners:
                uses.append((module, node.lineno, node.attr, owners))
    return uses


def test_targets_exist():
    """Every resolved import names a real module (guards the resolver itself)."""
    modules = all_modules()
    missing = sorted({f"{i.source}:{i.line} -> {i.target}" for i in all_imports()
                      if i.target not in modules})
    assert not missing, "\n".join(missing)


def test_no_import_cycles():
    """Module-level imports (``TYPE_CHECKING`` ones included) form no circle."""
    cycles = _cycles(import_graph())
    assert not cycles, _show(cycles)


def test_no_function_level_import_closes_a_cycle():
    """Nor do module- and function-level imports together (a function-level import may
    load a heavy module late, but not dodge a circle)."""
    cycles = _cycles(full_graph())
    assert not cycles, _show(cycles)


def test_no_private_names_imported_across_modules():
    found = {(i.source, i.target, i.name): i.line for i in all_imports()
             if i.name is not None and _is_private(i.name) and i.target != i.source}
    bad = sorted(f"{s}:{line} imports {t}.{n}" for (s, t, n), line in found.items())
    assert not bad, "\n".join(bad)


def test_no_private_attributes_across_modules():
    uses = private_attribute_uses()
    bad = sorted({f"{m}:{line} uses .{attr} (defined in {', '.join(owners)})"
                  for m, line, attr, owners in uses})
    assert not bad, "\n".join(bad)


def test_function_level_imports_are_listed(capsys):
    """Function-level imports pointing down are fine (lazy loading of heavy modules); run
    ``pytest -s`` to see the number and any pointing up (which the cycle test fails on)."""
    graph = import_graph()
    rows = []
    for imp in all_imports():
        if imp.function_level and imp.target != imp.source:
            up = nx.has_path(graph, imp.target, imp.source)
            rows.append((f"{imp.source}:{imp.line} -> {imp.target}", up))
    with capsys.disabled():
        print(f"\n{len(rows)} function-level mpd_pin imports; pointing up the layering:")
        for row, up in rows:
            if up:
                print("  " + row)


def test_the_checks_catch_what_they_should():
    """The checkers themselves, on planted input: a type-only circle, a function-level
    one, a private import and a private attribute."""
    planted = [Import("a", "b", None, 1, False), Import("b", "a", None, 1, False)]
    assert _cycles(import_graph(planted))
    dodged = [Import("a", "b", None, 1, False), Import("b", "a", None, 1, True)]
    assert not _cycles(import_graph(dodged)) and _cycles(full_graph(dodged))
    collector = _Collector("mpd_pin.x.y", False, {"mpd_pin.x.z", "mpd_pin.x.y"})
    collector.visit(ast.parse("from typing import TYPE_CHECKING\n"
                              "if TYPE_CHECKING:\n    from .z import _hidden\n"
                              "def f():\n    from . import z\n"))
    assert [(i.target, i.name, i.function_level) for i in collector.found] == [
        ("mpd_pin.x.z", "_hidden", False), ("mpd_pin.x.z", None, True)]
    assert _private_definitions(ast.parse("class A:\n    def _m(self):\n        self._x = 1\n"
                                          "other._y = 2\n")) == {"_m", "_x"}
    assert not _is_private("__version__") and _is_private("_Parts")
