"""The API reference's public names of a package whose imports declare them.

A package ``__init__`` that ends with ``__getattr__, __dir__, __all__ = lazy_exports(...)``
([`track_envs.infra.lazy`][track_envs.infra.lazy]) has no literal ``__all__`` for griffe to read; this
extension gives griffe the same names, read from the same imports by the same function, so that
the reference shows what ``from package import *`` gives.
"""

from __future__ import annotations

import ast
from typing import Any

import griffe

from track_envs.infra.lazy import declared_exports


def _calls_lazy_exports(tree: ast.Module) -> bool:
    """Whether a module's top level assigns the result of ``lazy_exports(...)``."""
    return any(
        isinstance(node, ast.Assign)
        and isinstance(node.value, ast.Call)
        and isinstance(node.value.func, ast.Name)
        and node.value.func.id == "lazy_exports"
        for node in tree.body
    )


class LazyExports(griffe.Extension):
    """Sets a package's exports from its declaring imports (`declared_exports`)."""

    def on_module_members(self, *, node: Any, mod: griffe.Module, **kwargs: Any) -> None:
        """After griffe has read a module's members: its exports, where ``lazy_exports`` makes them."""
        if isinstance(node, ast.Module) and _calls_lazy_exports(node):
            mod.exports = list(declared_exports(ast.unparse(node), mod.path).names)
