"""Package-level names loaded on first use: the one lazy loader every package ``__init__`` shares.

A package lists its public names in ``__all__``; the names whose module is heavy (torch, numba,
pymunk, rendering) it maps to their modules in a ``_LAZY`` table, and gets its module
``__getattr__`` and ``__dir__`` (PEP 562) from :func:`lazy_exports`::

    _LAZY = {"read_detections": "track_envs.io.detections"}
    __getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)

The first access of such a name imports its module, takes the name from the module's namespace
and keeps it in the package's, so that importing the package stays light.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping, Sequence
from importlib import import_module
from typing import Any


def lazy_exports(
    package: str, lazy: Mapping[str, str], public: Sequence[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` for its ``lazy`` names.

    Args:
        package: The package's ``__name__``.
        lazy: Each lazily loaded name and the dotted module that defines it.
        public: The package's ``__all__`` (listed by ``dir()`` before they are loaded).
    """

    def __getattr__(name: str) -> Any:
        home = lazy.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = vars(import_module(home))[name]
        vars(sys.modules[package])[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__
