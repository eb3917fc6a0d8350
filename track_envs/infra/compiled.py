"""Compiled kernels: `numba.njit` with an on-disk cache that cannot go stale across modules.

Every compiled function of the three packages is declared with [`njit`][track_envs.infra.compiled.njit] from
this module (a drop-in for ``numba.njit``). With ``cache=True`` numba keeps the machine code of a function on
disk and reuses it while the *function's own source file* is unchanged. A kernel that calls a
compiled function of another module (the Mahalanobis costs inside the GNN's frame kernel, the one
LSTM cell inside every learned family's roll-out) is inlined or linked into the caller's machine
code, so numba's own check would keep serving the old callee after that callee's module changed.

Here the freshness stamp of every cached function of the project is the sha256 of the sources of
*all* its compiled modules (every ``.py`` file under ``track_envs``, ``predictors`` and ``agents``
that declares a kernel), read once per process. Any change to any kernel invalidates every cached
kernel of the project, which then compiles again on first use; nothing stale is ever loaded.
Functions outside the project keep numba's own locators; ``NUMBA_CACHE_DIR`` is honoured (the
project's caches go below it when it is set, else next to each module in ``__pycache__``).
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba
from numba.core import caching

#: The package folders whose compiled modules share one freshness stamp.
PACKAGE_ROOTS: tuple[Path, ...] = tuple(
    Path(__file__).resolve().parents[2] / name for name in ("track_envs", "predictors", "agents")
)
_MARKER = b"from track_envs.infra.compiled import njit"


@functools.cache
def project_kernel_digest() -> bytes:
    """sha256 over the path and content of every compiled module of the project (sorted by path)."""
    digest = hashlib.sha256()
    for root in PACKAGE_ROOTS:
        if not root.is_dir():
            continue
        for path in sorted(root.rglob("*.py")):
            data = path.read_bytes()
            if _MARKER in data:
                digest.update(str(path.relative_to(root.parent)).encode())
                digest.update(hashlib.sha256(data).digest())
    return digest.digest()


def _in_project(py_file: str) -> bool:
    path = Path(py_file).resolve()
    return any(path.is_relative_to(root) for root in PACKAGE_ROOTS)


def _project_locator(base: type) -> type:
    """A subclass of numba's locator ``base`` whose stamp is the whole project's kernel digest."""

    class ProjectLocator(base):
        def get_source_stamp(self) -> Any:
            return (super().get_source_stamp(), project_kernel_digest())

        @classmethod
        def from_function(cls, py_func: Callable[..., Any], py_file: str) -> Any:
            if not _in_project(py_file):
                return None
            return super().from_function(py_func, py_file)

    ProjectLocator.__name__ = ProjectLocator.__qualname__ = f"Project{base.__name__.lstrip('_')}"
    return ProjectLocator


def _install() -> bool:
    """Put the project's locators first in numba's list (once); False where numba lacks the hook."""
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    user = getattr(caching, "UserProvidedCacheLocator", None) or getattr(
        caching, "_UserProvidedCacheLocator", None
    )
    in_tree = getattr(caching, "InTreeCacheLocator", None) or getattr(caching, "_InTreeCacheLocator", None)
    if impl is None or user is None or in_tree is None or not hasattr(impl, "_locator_classes"):
        return False
    classes = impl._locator_classes
    if any(getattr(c, "_track_envs", False) for c in classes):
        return True
    ours = [_project_locator(user), _project_locator(in_tree)]
    for c in ours:
        c._track_envs = True  # type: ignore[attr-defined]
    classes[:0] = ours
    return True


#: Whether the project's stamp is in use (numba without the locator hook: ``cache`` is turned off
#: for the project's kernels, so they compile on first use in every process but are never stale).
STAMPED_CACHE = _install()


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit`` for the project's kernels: same arguments, the project-wide cache stamp.

    Used bare (``@njit``) or with options (``@njit(cache=True, inline="always")``).
    """
    if not STAMPED_CACHE:
        options.pop("cache", None)
    if args and callable(args[0]) and len(args) == 1 and not options:
        return numba.njit(args[0])
    return numba.njit(*args, **options)


__all__ = ["PACKAGE_ROOTS", "STAMPED_CACHE", "njit", "project_kernel_digest"]
