"""Trackers are compositions: no class under agents/ subclasses a tracker to change what it does,
and no module calls another object's private (``_``-prefixed) methods."""

from __future__ import annotations

import ast
from pathlib import Path

AGENTS = Path(__file__).resolve().parents[3] / "agents"
#: The tracker classes (the core, and the trackers built from it).
TRACKERS = {"PointTracker", "GnnAgent", "JpdaAgent"}
#: What a class built from the core may define: its constructor (which chooses the components)
#: and the lookup of its components' attributes.
ALLOWED = {"__init__", "__getattr__"}


def _modules() -> list[tuple[Path, ast.Module]]:
    paths = sorted(AGENTS.rglob("*.py"))
    assert len(paths) > 20
    return [(p, ast.parse(p.read_text(), str(p))) for p in paths]


def _core_members() -> set[str]:
    tree = ast.parse((AGENTS / "tracking" / "tracker.py").read_text())
    core = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "PointTracker")
    return {n.name for n in core.body if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)}


def test_no_tracker_subclasses_another_tracker_to_change_its_behaviour():
    core = _core_members()
    assert {"act", "reset", "warm_up", "_associate_frame"} <= core
    built = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if not isinstance(node, ast.ClassDef):
                continue
            bases = {ast.unparse(b).rsplit(".", 1)[-1] for b in node.bases}
            if not bases & TRACKERS:
                continue
            where = f"{path.relative_to(AGENTS.parent)}: {node.name}"
            assert bases & TRACKERS == {"PointTracker"}, f"{where} subclasses {bases & TRACKERS}"
            methods = {n.name for n in node.body if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)}
            assert methods <= ALLOWED, f"{where} defines {sorted(methods - ALLOWED)}"
            assert not methods & core - {"__init__"}, f"{where} overrides {sorted(methods & core)}"
            built.append(node.name)
    assert sorted(built) == ["GnnAgent", "JpdaAgent"]


def test_no_module_calls_private_methods_of_another_object():
    calls = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
                continue
            name, owner = node.func.attr, node.func.value
            if not name.startswith("_") or (name.startswith("__") and name.endswith("__")):
                continue
            if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
                continue
            calls.append(f"{path.relative_to(AGENTS.parent)}:{node.lineno} {ast.unparse(node.func)}")
    assert calls == []
