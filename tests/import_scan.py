"""The imports of a source file, for the layer tests of the packages (tests/*/test_*layers.py)."""

from __future__ import annotations

import ast
from pathlib import Path


def file_imports(path: Path, root: Path) -> list[tuple[int, str]]:
    """(line, module) of every absolute import in ``path``, also those inside functions; ``from pkg
    import sub`` also names ``pkg.sub`` where ``sub`` is a module of the tree under ``root.parent``.

    Raises:
        AssertionError: a relative import (the packages use absolute ones only).
    """
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}:{node.lineno}: relative import"
            module = node.module or ""
            found.append((node.lineno, module))
            base = Path(*module.split("."))
            for alias in node.names:
                sub = root.parent / base / alias.name
                if sub.with_suffix(".py").is_file() or (sub / "__init__.py").is_file():
                    found.append((node.lineno, f"{module}.{alias.name}"))
    return found
