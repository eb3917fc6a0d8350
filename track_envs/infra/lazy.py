"""Package-level names declared once: the one lazy loader every package ``__init__`` shares.

A package's public names are the names its ``__init__`` imports, and that is the only place they
are written. The names it needs at import (or whose module is light) it imports as usual; the names
whose module is heavy (torch, numba, pymunk, rendering) it imports under ``if TYPE_CHECKING:``, so
that type checkers and the API reference see them while importing the package does not load them::

    from typing import TYPE_CHECKING

    from track_envs.infra.lazy import lazy_exports
    from track_envs.metrics.clear_mot import ClearMot

    if TYPE_CHECKING:
        from track_envs.metrics.track_scoring import score_tracks

    __getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)

[`lazy_exports`][track_envs.infra.lazy.lazy_exports] reads those imports once
([`declared_exports`][track_envs.infra.lazy.declared_exports]): ``__all__`` is every name imported (in the
order written), and the first access of a name imported under ``TYPE_CHECKING`` imports its module, takes the
name from the module's namespace and keeps it in the package's (PEP 562 ``__getattr__`` and ``__dir__``).

The machinery is not public: names imported from ``__future__``, ``typing`` and this module, and
names that start with an underscore.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Callable
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path
from typing import Any

#: Modules whose names an ``__init__`` imports for itself, never as public names.
MACHINERY = frozenset({"__future__", "typing", __name__})


@dataclass(frozen=True)
class Exports:
    """The public names an ``__init__`` declares by its imports.

    Attributes:
        names: Every public name, in the order imported (the package's ``__all__``).
        lazy: Each name imported under ``if TYPE_CHECKING:`` and the dotted module it loads from.
    """

    names: tuple[str, ...]
    lazy: dict[str, str]


def _is_type_checking(test: ast.expr) -> bool:
    """Whether an ``if`` test is ``TYPE_CHECKING`` (or ``typing.TYPE_CHECKING``)."""
    if isinstance(test, ast.Attribute):
        return test.attr == "TYPE_CHECKING"
    return isinstance(test, ast.Name) and test.id == "TYPE_CHECKING"


def _module(node: ast.ImportFrom, package: str) -> str:
    """The absolute dotted name of the module an ``import from`` of ``package``'s ``__init__`` reads."""
    if not node.level:
        return node.module or ""
    base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
    return f"{base}.{node.module}" if node.module else base


def declared_exports(source: str, package: str) -> Exports:
    """The public names of ``package`` declared by the imports of its ``__init__`` ``source``.

    Only ``from MODULE import NAME`` statements at the top level of the module, or in the body of
    a top-level ``if TYPE_CHECKING:``, declare names (those of the ``if`` are the lazy ones).

    Raises:
        ValueError: a name imported twice, or a star import (``from MODULE import *``).
    """
    names: dict[str, None] = {}
    lazy: dict[str, str] = {}

    def read(body: list[ast.stmt], guarded: bool) -> None:
        for node in body:
            if isinstance(node, ast.If) and _is_type_checking(node.test):
                read(node.body, True)
            if not isinstance(node, ast.ImportFrom):
                continue
            module = _module(node, package)
            if module in MACHINERY:
                continue
            for alias in node.names:
                name = alias.asname or alias.name
                if name == "*":
                    raise ValueError(f"{package}: a star import (from {module} import *) declares no names")
                if name.startswith("_"):
                    continue
                if name in names:
                    raise ValueError(f"{package}: {name!r} is imported twice")
                names[name] = None
                if guarded:
                    lazy[name] = module

    read(ast.parse(source).body, False)
    return Exports(tuple(names), lazy)


def lazy_exports(
    package: str, init_file: str | None
) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """The module ``__getattr__``, ``__dir__`` and ``__all__`` of ``package``, from the imports of
    its ``__init__`` ([`declared_exports`][track_envs.infra.lazy.declared_exports]).

    Args:
        package: The package's ``__name__``.
        init_file: The package's ``__file__`` (its ``__init__.py``).

    Raises:
        ValueError: ``init_file`` is not a readable source file, or its imports declare a name twice.
    """
    if init_file is None or not init_file.endswith(".py"):
        raise ValueError(f"{package}: its public names are read from its __init__.py, got {init_file!r}")
    exports = declared_exports(Path(init_file).read_text(encoding="utf-8"), package)
    lazy = exports.lazy

    def __getattr__(name: str) -> Any:
        home = lazy.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = vars(import_module(home))[name]
        vars(sys.modules[package])[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports.names))

    return __getattr__, __dir__, list(exports.names)
