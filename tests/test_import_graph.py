"""The project's import graph: no circles, and the libraries never import the applications.

The graph: a node per module of ``track_envs``, ``predictors``, ``agents`` and ``track_apps``; an
edge per import between two of them, at the top of a module or inside a function (also those
under ``if TYPE_CHECKING:``). ``import a.b.c`` and ``from a.b import c`` (``c`` a module) are an
edge to ``a.b.c``; ``from a.b import name`` (``name`` not a module) an edge to ``a.b``. An edge
goes to the module named, not to the packages above it whose ``__init__`` Python runs first: a
package that re-exports its submodules (``from pkg.sub import name`` in ``pkg/__init__.py``) is
not, by that, a circle with each of them. A package's ``__init__`` importing from its own package
(``from agents import make_agent`` inside ``agents``) is an edge like any other, and would close a
circle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("track_envs", "predictors", "agents", "track_apps")
LIBRARIES = ("track_envs", "predictors", "agents")


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The project module ``name`` names, or the nearest package above it (None: not ours)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def imported(module: str) -> dict[str, int]:
    """The project modules ``module`` imports (module-level and function-level), with a line each."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    edges: dict[str, int] = {}
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package
                for _ in range(node.level - 1):
                    anchor = anchor.rpartition(".")[0]
                base = f"{anchor}.{base}" if base else anchor
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        for name in names:
            target = _resolve(name)
            if target is not None and target != module:
                edges.setdefault(target, node.lineno)
    return edges


GRAPH = {module: imported(module) for module in MODULES}


def circles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    return found


def test_the_graph_sees_every_package():
    assert {m.split(".")[0] for m in GRAPH} == set(PACKAGES)
    assert "agents.files.loop" in GRAPH["agents.sensor_model.estimate"]  # a top-level import
    assert "agents.files.points" in GRAPH["agents.sorting.check"]  # one inside a function


def test_no_import_circles():
    found = circles()
    described = [
        " <-> ".join(c) + ": " + "; ".join(f"{a} -> {b}" for a in c for b in GRAPH[a] if b in c)
        for c in found
    ]
    assert not found, "import circles:\n" + "\n".join(described)


@pytest.mark.parametrize("library", LIBRARIES)
def test_the_libraries_never_import_the_applications(library):
    found = [
        f"{MODULES[m].relative_to(ROOT)}:{line}: {target}"
        for m in GRAPH
        if m.split(".")[0] == library
        for target, line in GRAPH[m].items()
        if target.split(".")[0] == "track_apps"
    ]
    assert not found, f"{library} imports track_apps:\n" + "\n".join(found)
